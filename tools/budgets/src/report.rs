//! The budget report: builds `examples/bench.rs` per target and configuration
//! (and the real-scan and lidar benches: `real.rs`, `lidar.rs`), runs it
//! under QEMU with the `qemu-icount` plugin, and tabulates instructions,
//! RAM, stack and flash (`table.rs`); or checks them against the committed
//! budget file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Duration;

use serde_json::{json, Map, Value};

use crate::firmware::{build_example, Config, Paths, Target, TARGETS, WITHOUT_TABLES};
use crate::qemu::{self, field, number, Plugin};
use crate::{elf, lidar, real, table, Error};

/// Start of RAM on both QEMU boards: a stack pointer below it after a crash
/// means the stack overflowed the RAM.
const RAM_ORIGIN: u64 = 0x2000_0000;

/// Image sides measured.
const SIDES: [usize; 3] = [64, 128, 256];

/// Allowed growth of any budget before `--check` fails.
pub const TOLERANCE: f64 = 0.10;

/// Budget keys `--check` compares (all "smaller is better"; with
/// [`lidar::CHECKED`]).
const CHECKED: [&str; 23] = [
    "instructions_estimate",
    "instructions_unverified",
    "instructions_verification",
    "instructions_scale_search",
    "stack_scaled",
    "stack_unverified",
    "state_verification",
    "ram_verification",
    "instructions_reference",
    "instructions_per_vote",
    "vote_loop_per_vote",
    "stack_estimate",
    "ram_estimator",
    "ram_unverified",
    "ram_flash_reference",
    "ram_verified_flash_reference",
    "static_ram",
    "flash_library",
    "flash_total",
    "instructions_per_budget_row",
    "real_pair_median",
    "real_pair_max",
    "real_ram",
];

/// Measured regions of one bench run: overhead, reference, estimate, votes,
/// unverified, scaled, and the two estimates cut by a work budget.
const BENCHES: usize = 8;

/// Time limit of one firmware run.
const RUN_TIMEOUT: Duration = Duration::from_secs(60);

/// The configurations: each side with `N_THETA` = 360 and the two ends of the
/// paper's recommended range (`hough_heading::config::recommended_n_theta`; the upper
/// end is exclusive, so the largest even value below it), and 128², 360
/// with [`WITHOUT_TABLES`].
pub fn configs() -> Vec<Config> {
    let mut out = Vec::new();
    for side in SIDES {
        let (min, max_exclusive) = hough_heading::config::recommended_n_theta(side, side);
        let max = (max_exclusive - 1) & !1;
        for (n_theta, choice) in [(min, "min"), (360, "360"), (max, "max")] {
            if !out
                .iter()
                .any(|c: &Config| c.side == side && c.n_theta == n_theta)
            {
                out.push(Config {
                    side,
                    n_theta,
                    choice,
                    features: "",
                });
            }
        }
    }
    out.push(Config {
        side: 128,
        n_theta: 360,
        choice: "360",
        features: WITHOUT_TABLES,
    });
    out
}

/// The configurations `target` measures: [`configs`] with the target's
/// features, each key once; with `only` (a key such as `128x128/360`), just
/// that one.
fn configs_on(target: &Target, only: Option<&str>) -> Vec<Config> {
    let mut out: Vec<Config> = Vec::new();
    for config in configs().into_iter().map(|c| c.on(target)) {
        let key = config.key();
        if only.is_none_or(|only| only == key) && out.iter().all(|c| c.key() != key) {
            out.push(config);
        }
    }
    out
}

/// Builds the bench example for `target` and returns a copy of its ELF under
/// `target/budgets/`.
fn build(paths: &Paths, target: &Target, config: Option<&Config>) -> Result<PathBuf, Error> {
    build_example(
        paths,
        target,
        "bench",
        config,
        config.map_or("", |c| c.features),
    )
}

/// The measured values of one run of the bench firmware.
struct RunResult {
    /// `Some(state bytes)` when the estimator's state does not fit the RAM.
    does_not_fit: Option<u64>,
    /// Entries for the budget file.
    values: Map<String, Value>,
    /// Why the run failed (wrong estimate, crash, timeout), if it did.
    failure: Option<String>,
}

/// Runs one bench ELF and pairs the firmware's `bench` lines with the
/// plugin's counts.
fn measure_run(
    paths: &Paths,
    target: &Target,
    elf_path: &Path,
    image: &elf::Image,
) -> Result<RunResult, Error> {
    let machine = target.machine.ok_or("not runnable")?;
    let plugin = Plugin::for_image(paths.plugin.clone(), image, None)?;
    let run = qemu::run(elf_path, machine, Some(&plugin), RUN_TIMEOUT)?;
    let mut values = Map::new();
    let config = run
        .log
        .iter()
        .find(|l| l.starts_with("config "))
        .ok_or("no config line")?;
    let state = ["estimator", "reference"]
        .iter()
        .map(|k| field(config, k).and_then(number).unwrap_or(0))
        .sum::<u64>();
    values.insert("state".into(), json!(state));
    // The state only the verification needs: the grid the reference keeps
    // (the verification builds its pyramid on its own stack).
    let state_verification = field(config, "reference_grid")
        .and_then(number)
        .unwrap_or(0);
    let state_estimator = field(config, "estimator").and_then(number).unwrap_or(0);
    values.insert("state_verification".into(), json!(state_verification));

    if run.status == Some(3) || run.log.iter().any(|l| l.starts_with("does-not-fit")) {
        return Ok(RunResult {
            does_not_fit: Some(state),
            values,
            failure: None,
        });
    }
    let counts: Vec<(u64, Option<u64>)> = run
        .stderr
        .lines()
        .filter_map(|l| l.strip_prefix("hh-icount "))
        .map(|rest| {
            let count = rest.split_whitespace().next().and_then(number).unwrap_or(0);
            (count, field(rest, "stack_low").and_then(number))
        })
        .collect();
    let benches: Vec<&String> = run.log.iter().filter(|l| l.starts_with("bench ")).collect();
    if run.status != Some(0) || counts.len() != benches.len() || benches.len() != BENCHES {
        let why = if run.timed_out {
            "timed out (crash or stack overflow)".to_string()
        } else if run.status == Some(1) {
            format!(
                "wrong estimate: {}",
                run.log.last().map_or("", String::as_str)
            )
        } else {
            format!("exit status {:?}", run.status)
        };
        // QEMU's dump of a locked-up core shows the stack pointer (R13): below
        // the RAM, the stack overflowed, and the configuration does not fit.
        if crashed_stack_pointer(&run.stderr).is_some_and(|sp| sp < RAM_ORIGIN) {
            return Ok(RunResult {
                does_not_fit: Some(state),
                values,
                failure: None,
            });
        }
        return Ok(RunResult {
            does_not_fit: None,
            values,
            failure: Some(format!("{why}\n{}\n{}", run.log.join("\n"), run.stderr)),
        });
    }

    let overhead = counts[0].0;
    let mut per = BTreeMap::new();
    for (line, &(count, low)) in benches.iter().zip(&counts) {
        let what = line.split_whitespace().nth(1).unwrap_or("?");
        let sp = field(line, "sp").and_then(number).unwrap_or(0);
        let votes = field(line, "votes").and_then(number).unwrap_or(0);
        let stack = low.map_or(0, |low| sp.saturating_sub(low));
        per.insert(
            what.to_string(),
            (count.saturating_sub(overhead), votes, stack),
        );
    }
    let get = |what: &str| per.get(what).copied().unwrap_or((0, 0, 0));
    let (reference, _, stack_reference) = get("reference");
    let (estimate, votes, stack_estimate) = get("estimate");
    let (vote_loop, _, _) = get("votes");
    let (unverified, _, stack_unverified) = get("unverified");
    let (scaled, _, stack_scaled) = get("scaled");
    let (cut_small, _, _) = get("cut-small");
    let (cut_large, _, _) = get("cut-large");
    // The work budget of each cut estimate, as the bench logged it
    // (`budget <what> rows=<rows>`).
    let budget_rows = |what: &str| {
        run.log
            .iter()
            .filter_map(|l| l.strip_prefix("budget "))
            .find(|l| l.split_whitespace().next() == Some(what))
            .and_then(|l| field(l, "rows"))
            .and_then(number)
    };
    let ratio = |n: u64| {
        if votes == 0 {
            0.0
        } else {
            (n as f64 / votes as f64 * 100.0).round() / 100.0
        }
    };
    let result = run
        .log
        .iter()
        .find(|l| l.starts_with("result "))
        .ok_or("no result line")?;
    values.insert("votes".into(), json!(votes));
    values.insert("instructions_reference".into(), json!(reference));
    values.insert("instructions_estimate".into(), json!(estimate));
    values.insert("instructions_unverified".into(), json!(unverified));
    values.insert(
        "instructions_verification".into(),
        json!(estimate.saturating_sub(unverified)),
    );
    values.insert("instructions_vote_loop".into(), json!(vote_loop));
    // Both estimates verify (as built): the difference is the scale search.
    values.insert(
        "instructions_scale_search".into(),
        json!(scaled.saturating_sub(estimate)),
    );
    // Two estimates on a pair that defeats the pruning, cut by work budgets
    // of 2¹⁹ and 2²⁰ grid rows (`examples/bench.rs`): the searches' cost of
    // one budget row.
    values.insert("instructions_cut_small".into(), json!(cut_small));
    values.insert("instructions_cut_large".into(), json!(cut_large));
    if let (Some(small), Some(large)) = (budget_rows("cut-small"), budget_rows("cut-large")) {
        let rows = large.saturating_sub(small).max(1) as f64;
        values.insert(
            "instructions_per_budget_row".into(),
            json!((cut_large.saturating_sub(cut_small) as f64 / rows * 100.0).round() / 100.0),
        );
        values.insert("budget_rows_cut_large".into(), json!(large));
    }
    values.insert("instructions_per_vote".into(), json!(ratio(estimate)));
    values.insert("vote_loop_per_vote".into(), json!(ratio(vote_loop)));
    values.insert("stack_reference".into(), json!(stack_reference));
    values.insert("stack_estimate".into(), json!(stack_estimate));
    values.insert("stack_unverified".into(), json!(stack_unverified));
    values.insert("stack_scaled".into(), json!(stack_scaled));
    values.insert(
        "ram_estimator".into(),
        json!(state + stack_estimate.max(stack_reference)),
    );
    values.insert(
        "ram_unverified".into(),
        json!(state + stack_unverified.max(stack_reference)),
    );
    // Without the verification and with the reference in flash (a `static`
    // parsed at compile time by `Reference::from_bytes`): the estimator and
    // the unverified estimate's peak stack are all the RAM.
    values.insert(
        "ram_flash_reference".into(),
        json!(state_estimator + stack_unverified),
    );
    // The verified estimate with the reference in flash (its grid too):
    // the estimator and the verified estimate's peak stack.
    values.insert(
        "ram_verified_flash_reference".into(),
        json!(state_estimator + stack_estimate),
    );
    // The verification's RAM: its state plus the extra peak stack of the
    // verified estimate over the unverified one.
    values.insert(
        "stack_verification".into(),
        json!(stack_estimate.saturating_sub(stack_unverified)),
    );
    values.insert(
        "ram_verification".into(),
        json!(state_verification + stack_estimate.saturating_sub(stack_unverified)),
    );
    let alpha = field(result, "alpha_mdeg")
        .and_then(|v| v.parse::<i64>().ok())
        .unwrap_or(0);
    values.insert("alpha_mdeg".into(), json!(alpha));
    values.insert(
        "status".into(),
        json!(field(result, "status").unwrap_or("?")),
    );
    if let Some(overlap) = run
        .log
        .iter()
        .find(|l| l.starts_with("checks "))
        .and_then(|l| field(l, "overlap_permille"))
        .and_then(number)
    {
        values.insert("overlap_permille".into(), json!(overlap));
    }
    Ok(RunResult {
        does_not_fit: None,
        values,
        failure: None,
    })
}

/// The stack pointer in QEMU's register dump after a fatal error
/// (`R13=1ffffd18`), if there is one.
fn crashed_stack_pointer(stderr: &str) -> Option<u64> {
    let at = stderr.find("R13=")? + 4;
    u64::from_str_radix(stderr.get(at..at + 8)?, 16).ok()
}

/// Everything measured: `target triple → config key → values`, plus the
/// failures seen.
pub struct Measured {
    /// The budget-file body.
    pub targets: Map<String, Value>,
    /// The Markdown tables: the budgets, the verification's share, the real
    /// scans and the lidar drivers (those with rows).
    pub table: String,
    /// Wrong estimates, crashes.
    pub failures: Vec<String>,
}

/// Builds and measures every target and configuration (with `only`, the
/// configuration, real-scan entry or [`lidar::ONLY`] named).
pub fn measure(paths: &Paths, only: Option<&str>) -> Result<Measured, Error> {
    let mut targets = Map::new();
    let mut failures = Vec::new();
    let mut rows = Vec::new();
    let mut verification_rows = Vec::new();
    let mut real_rows = Vec::new();
    let mut lidar_rows = Vec::new();
    for target in &TARGETS {
        eprintln!("budgets: {} ({})", target.name, target.triple);
        let configs = configs_on(target, only);
        // The firmware without the library (the library's flash), for each configuration.
        let baseline = if configs.is_empty() {
            None
        } else {
            Some(elf::read(&build(paths, target, None)?)?)
        };
        let mut entries = Map::new();
        for (config, baseline) in configs.iter().zip(baseline.iter().cycle()) {
            let path = build(paths, target, Some(config))?;
            let image = elf::read(&path)?;
            // The estimate is integer arithmetic only: no core may need the
            // runtime's floating-point routines for it.
            if !image.float_routines.is_empty() {
                failures.push(format!(
                    "{} {}: the bench links floating-point routines ({}); the estimate must stay integer-only",
                    target.triple,
                    config.key(),
                    image.float_routines.join(", ")
                ));
            }
            let mut values = Map::new();
            let flash_library = image.flash.saturating_sub(baseline.flash + image.grids);
            values.insert("flash_total".into(), json!(image.flash));
            values.insert("flash_library".into(), json!(flash_library));
            values.insert("static_ram".into(), json!(image.static_ram));
            values.insert(
                "static_ram_library".into(),
                json!(image.static_ram.saturating_sub(baseline.static_ram)),
            );
            let mut fits = true;
            if target.machine.is_some() {
                let run = measure_run(paths, target, &path, &image)?;
                values.extend(run.values);
                if let Some(failure) = run.failure {
                    failures.push(format!("{} {}: {failure}", target.triple, config.key()));
                }
                fits = run.does_not_fit.is_none();
            }
            values.insert("fits".into(), json!(fits));
            rows.push(table::row(target, config, &values));
            if target.machine.is_some() {
                verification_rows.push(table::verification_row(target, config, &values));
            }
            entries.insert(config.key(), Value::Object(values));
        }
        // The real scan pairs (`examples/real_scans.rs`): with the target's
        // features, and without the reach tables where RAM would hold them.
        let mut real_features = vec![target.features];
        if target.ram >= 1 << 20 && target.features != WITHOUT_TABLES {
            real_features.push(WITHOUT_TABLES);
        }
        for features in real_features {
            let key = real::key(features);
            let runnable = target.machine.is_some();
            let wanted = only.is_none_or(|only| only == key);
            if !runnable || !wanted {
                continue;
            }
            match real::measure(paths, target, features)? {
                Ok(values) => {
                    real_rows.push(real::row(target, features, &values));
                    entries.insert(key, Value::Object(values));
                }
                Err(failure) => failures.push(format!("{} {key}: {failure}", target.triple)),
            }
        }
        // The lidar drivers (`examples/lidar_bench.rs`), one entry a protocol.
        if target.machine.is_some() && only.is_none_or(|only| only == lidar::ONLY) {
            match lidar::measure(paths, target)? {
                Ok(measured) => {
                    for (key, values) in measured {
                        lidar_rows.push(lidar::row(target, &key, &values));
                        entries.insert(key, Value::Object(values));
                    }
                }
                Err(failure) => failures.push(format!("{} lidar: {failure}", target.triple)),
            }
        }
        targets.insert(target.triple.into(), Value::Object(entries));
    }
    if let Some(only) = only.filter(|_| targets.values().all(|t| t == &json!({}))) {
        return Err(format!("--only {only}: no entry of that name").into());
    }
    let tables = [
        (&table::HEADER[..], rows),
        (&table::VERIFICATION_HEADER[..], verification_rows),
        (&real::HEADER[..], real_rows),
        (&lidar::HEADER[..], lidar_rows),
    ];
    Ok(Measured {
        targets,
        table: tables
            .iter()
            .filter(|(_, rows)| !rows.is_empty())
            .map(|(header, rows)| table::markdown(header, rows))
            .collect::<Vec<_>>()
            .join("\n"),
        failures,
    })
}

/// Compares `measured` with the committed `budget` body: every checked value
/// may grow by at most [`TOLERANCE`], a configuration that fitted must
/// still fit, and every metric of the budget must be in the measurement.
/// Returns the regressions.
pub fn check(budget: &Value, measured: &Map<String, Value>) -> Vec<String> {
    let mut regressions = Vec::new();
    let Some(budget) = budget["targets"].as_object() else {
        return vec!["budget file has no \"targets\"".into()];
    };
    for (triple, entries) in budget {
        for (key, allowed) in entries.as_object().into_iter().flatten() {
            let Some(now) = measured.get(triple).and_then(|t| t.get(key)) else {
                regressions.push(format!("{triple} {key}: not measured any more"));
                continue;
            };
            if allowed["fits"] == Value::Bool(true) && now["fits"] == Value::Bool(false) {
                regressions.push(format!("{triple} {key}: no longer fits"));
            }
            // A metric of the budget file that the new measurement lacks (or
            // left null) is a failure, not a metric skipped (issue 14 item 5).
            for (metric, value) in allowed.as_object().into_iter().flatten() {
                if !value.is_null() && now.get(metric).is_none_or(Value::is_null) {
                    regressions.push(format!("{triple} {key}: {metric} not measured any more"));
                }
            }
            for &metric in CHECKED.iter().chain(&lidar::CHECKED) {
                let (Some(limit), Some(value)) = (allowed[metric].as_f64(), now[metric].as_f64())
                else {
                    continue;
                };
                if value > limit * (1.0 + TOLERANCE) {
                    regressions.push(format!(
                        "{triple} {key}: {metric} {value} > {limit} + {:.0} %",
                        TOLERANCE * 100.0
                    ));
                }
            }
        }
    }
    regressions
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configs_cover_the_recommended_range() {
        let c = configs();
        assert!(c.iter().any(|c| c.side == 128 && c.n_theta == 360));
        assert!(c
            .iter()
            .any(|c| c.side == 256 && c.n_theta == 256 && c.choice == "min"));
        assert!(c.iter().all(|c| c.n_theta % 2 == 0));
    }

    #[test]
    fn the_cortex_m0_measures_every_configuration_without_the_tables_once() {
        let [m4f, m0, _] = &TARGETS;
        let on_m0 = configs_on(m0, None);
        assert!(on_m0.iter().all(|c| c.features == WITHOUT_TABLES));
        assert_eq!(on_m0.len(), configs().len() - 1);
        let on_m4f = configs_on(m4f, None);
        assert_eq!(on_m4f.len(), configs().len());
        assert_eq!(
            on_m4f
                .iter()
                .filter(|c| c.features == WITHOUT_TABLES)
                .count(),
            1
        );
        let only = configs_on(m0, Some("128x128/360+no-default-features"));
        assert_eq!(only.len(), 1);
    }

    #[test]
    fn check_flags_growth_beyond_tolerance_only() {
        let budget = json!({"targets": {"t": {"k": {"fits": true, "flash_library": 1000, "stack_estimate": 100}}}});
        let ok = json!({"t": {"k": {"fits": true, "flash_library": 1099, "stack_estimate": 50}}});
        assert!(check(&budget, ok.as_object().unwrap()).is_empty());
        let bad =
            json!({"t": {"k": {"fits": false, "flash_library": 1101, "stack_estimate": 100}}});
        assert_eq!(check(&budget, bad.as_object().unwrap()).len(), 2);
    }

    #[test]
    fn check_fails_on_a_metric_missing_from_the_measurement() {
        let budget = json!({"targets": {"t": {"k": {"fits": true, "flash_library": 1000, "stack_estimate": 100}}}});
        let missing = json!({"t": {"k": {"fits": true, "flash_library": 1000}}});
        let found = check(&budget, missing.as_object().unwrap());
        assert_eq!(found, ["t k: stack_estimate not measured any more"]);
        let null =
            json!({"t": {"k": {"fits": true, "flash_library": 1000, "stack_estimate": null}}});
        assert_eq!(check(&budget, null.as_object().unwrap()).len(), 1);
        let no_fits = json!({"t": {"k": {"flash_library": 1000, "stack_estimate": 100}}});
        assert_eq!(check(&budget, no_fits.as_object().unwrap()).len(), 1);
        // Extra metrics in the measurement are fine.
        let more = json!({"t": {"k": {"fits": true, "flash_library": 1000, "stack_estimate": 100, "new": 1}}});
        assert!(check(&budget, more.as_object().unwrap()).is_empty());
    }

    #[test]
    fn reads_the_stack_pointer_of_a_lockup() {
        let dump = "qemu: fatal: Lockup\nR12=00000000 R13=1ffffd18 R14=fffffff9\n";
        assert_eq!(crashed_stack_pointer(dump), Some(0x1fff_fd18));
        assert_eq!(crashed_stack_pointer("nothing"), None);
    }
}
