//! The real-scan rows of the budget report: `examples/real_scans.rs` on the
//! bundled real scan pairs (`host-tests/data/real-pairs.bin`), under QEMU with
//! the `qemu-icount` plugin.
//!
//! The firmware measures, after one empty region (the markers' overhead),
//! seven regions per pair in order: the window (`Raster::auto` over both
//! scans), rasterizing scan 1, preparing the reference, rasterizing scan 2,
//! the estimate, its check on the beams (empty on the Cortex-M0) and the
//! refinement on the beams; its result lines (`pair=… scan1=beams/… scan2=beams/…`)
//! give each scan's beam count.

use serde_json::{json, Map, Value};

use crate::firmware::{build_example, group, labelled, suffix, Paths, Target};
use crate::qemu::{self, field, number, Plugin};
use crate::{elf, Error};

/// Key of the real-scan entry in the budget file, for the library built
/// with `features`.
pub fn key(features: &str) -> String {
    format!("real-scans/128x128/360{}", suffix(features))
}

/// Regions per pair.
const REGIONS: usize = 7;

/// Time limit of the run (120 pairs take about 10 s on the Cortex-M0 without
/// the plugin).
const TIMEOUT: std::time::Duration = std::time::Duration::from_secs(600);

/// Builds and runs the real-scan firmware on `target`; its budget values, or
/// why it failed.
pub fn measure(
    paths: &Paths,
    target: &Target,
    features: &str,
) -> Result<Result<Map<String, Value>, String>, Error> {
    let machine = target.machine.ok_or("not runnable")?;
    let path = build_example(paths, target, "real_scans", None, features)?;
    let image = elf::read(&path)?;
    let plugin = Plugin::for_image(paths.plugin.clone(), &image, None)?;
    // QEMU opens the pair file relative to its working directory: the
    // repository root, where `tools/budgets.sh` runs this.
    let run = qemu::run(&path, machine, Some(&plugin), TIMEOUT)?;
    let counts: Vec<(u64, Option<u64>)> = run
        .stderr
        .lines()
        .filter_map(|l| l.strip_prefix("hh-icount "))
        .map(|rest| {
            let count = rest.split_whitespace().next().and_then(number).unwrap_or(0);
            (count, field(rest, "stack_low").and_then(number))
        })
        .collect();
    let beams: Vec<[u64; 2]> = run
        .log
        .iter()
        .filter(|l| l.starts_with("pair="))
        .map(|l| {
            let beams = |k| {
                field(l, k)
                    .and_then(|v| v.split('/').next())
                    .and_then(number)
                    .unwrap_or(0)
            };
            [beams("scan1"), beams("scan2")]
        })
        .collect();
    if run.status != Some(0) || beams.is_empty() || counts.len() != 1 + REGIONS * beams.len() {
        return Ok(Err(format!(
            "real_scans exited with {:?} (timed out: {}), {} counts for {} pairs:\n{}\n{}",
            run.status,
            run.timed_out,
            counts.len(),
            beams.len(),
            run.log.join("\n"),
            run.stderr
        )));
    }
    let overhead = counts[0].0;
    let net = |i: usize| counts[i].0.saturating_sub(overhead);
    let (mut pair, mut estimate, mut reference, mut window) = (vec![], vec![], vec![], vec![]);
    let (mut check, mut refine) = (vec![], vec![]);
    let (mut per_beam, mut scans_360, mut scans_180) = (vec![], vec![], vec![]);
    for (p, beams) in beams.iter().enumerate() {
        let at = 1 + REGIONS * p;
        let regions: Vec<u64> = (at..at + REGIONS).map(net).collect();
        pair.push(regions.iter().sum::<u64>());
        window.push(regions[0]);
        reference.push(regions[2]);
        estimate.push(regions[4]);
        check.push(regions[5]);
        refine.push(regions[6]);
        for (&n, &b) in [regions[1], regions[3]].iter().zip(beams) {
            per_beam.push(n as f64 / b.max(1) as f64);
            match b {
                360 => scans_360.push(n),
                180 => scans_180.push(n),
                _ => {}
            }
        }
    }
    let (lo, hi) = image.stack.unwrap_or((0, 0));
    let lowest = counts
        .iter()
        .filter_map(|c| c.1)
        .min()
        .unwrap_or(hi)
        .max(lo);
    let stack = hi - lowest;
    let mut per_beam_sorted = per_beam;
    per_beam_sorted.sort_by(f64::total_cmp);
    let mut values = Map::new();
    values.insert("pairs".into(), json!(beams.len()));
    values.insert("real_pair_median".into(), json!(median(&mut pair)));
    values.insert("real_pair_max".into(), json!(pair.iter().max()));
    values.insert("real_estimate_median".into(), json!(median(&mut estimate)));
    values.insert("real_estimate_max".into(), json!(estimate.iter().max()));
    values.insert("real_check_median".into(), json!(median(&mut check)));
    values.insert("real_check_max".into(), json!(check.iter().max()));
    values.insert("real_refine_median".into(), json!(median(&mut refine)));
    values.insert("real_refine_max".into(), json!(refine.iter().max()));
    values.insert(
        "real_reference_median".into(),
        json!(median(&mut reference)),
    );
    values.insert("real_window_median".into(), json!(median(&mut window)));
    values.insert(
        "real_rasterize_per_beam".into(),
        json!((per_beam_sorted[per_beam_sorted.len() / 2] * 10.0).round() / 10.0),
    );
    values.insert("real_rasterize_360".into(), json!(median(&mut scans_360)));
    values.insert("real_rasterize_180".into(), json!(median(&mut scans_180)));
    values.insert("real_stack".into(), json!(stack));
    values.insert("real_ram".into(), json!(image.static_ram + stack));
    values.insert("static_ram".into(), json!(image.static_ram));
    values.insert("flash_total".into(), json!(image.flash));
    Ok(Ok(values))
}

/// The median (upper middle) of `values`; 0 when empty.
fn median(values: &mut [u64]) -> u64 {
    values.sort_unstable();
    values.get(values.len() / 2).copied().unwrap_or(0)
}

/// Columns of the real-scan table.
pub const HEADER: [&str; 15] = [
    "target",
    "real pairs",
    "instr. / pair, median",
    "instr. / pair, max",
    "estimate, median",
    "estimate, max",
    "check on the beams, median",
    "check on the beams, max",
    "refinement on the beams, median",
    "refinement on the beams, max",
    "reference, median",
    "window (`Raster::auto`), median",
    "rasterize, instr. / beam (median)",
    "rasterize a 360-beam / 180-beam scan (median)",
    "RAM (static + peak stack)",
];

/// One row of the real-scan table.
pub fn row(target: &Target, features: &str, v: &Map<String, Value>) -> Vec<String> {
    let int = |k: &str| v.get(k).and_then(Value::as_u64);
    let count = |k: &str| int(k).map_or("–".into(), group);
    let per_beam = v
        .get("real_rasterize_per_beam")
        .and_then(Value::as_f64)
        .map_or("–".into(), |r| format!("{r:.1}"));
    let ram = match (int("real_ram"), int("static_ram"), int("real_stack")) {
        (Some(ram), Some(s), Some(stack)) => format!("{ram} B ({s} + {stack})"),
        _ => "–".into(),
    };
    vec![
        labelled(target.name.to_string(), features),
        count("pairs"),
        count("real_pair_median"),
        count("real_pair_max"),
        count("real_estimate_median"),
        count("real_estimate_max"),
        count("real_check_median"),
        count("real_check_max"),
        count("real_refine_median"),
        count("real_refine_max"),
        count("real_reference_median"),
        count("real_window_median"),
        per_beam,
        format!(
            "{} / {}",
            count("real_rasterize_360"),
            count("real_rasterize_180")
        ),
        ram,
    ]
}

#[cfg(test)]
mod tests {
    use super::median;

    #[test]
    fn median_is_the_upper_middle() {
        assert_eq!(median(&mut [5, 1, 3]), 3);
        assert_eq!(median(&mut [4, 1, 3, 2]), 3);
        assert_eq!(median(&mut []), 0);
    }
}
