//! `hough-heading mcu`: real scan pairs for the firmware, and the check that
//! the firmware's estimates are the host's, bit for bit (issue 16, item 4).
//!
//! - `mcu export PAIRS.jsonl... --out pairs.bin [--limit N]` writes the first
//!   `N` pairs of each pair file in the compact binary form the firmware
//!   example `examples/real_scans.rs` reads (format: [`pairs`], i.e.
//!   `recordings/src/mcu_pairs.rs`, which the firmware compiles too).
//! - `mcu check pairs.bin LOG...` estimates every pair of `pairs.bin` as
//!   `hough-heading scans --size 128 --n-theta 360` does (same engine, same
//!   [`scans::estimate`], from the ranges as the firmware decodes them) and
//!   compares each result line with the one in each firmware log (the output
//!   of `budgets run`): exit status 1 when a pair is missing or differs,
//!   naming the fields that differ.
//!
//! `bash .ci/firmware.sh` runs both around the firmware on the Cortex-M4F and
//! the Cortex-M0.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use clap::{Args, Subcommand};
use hough_heading::{Mode, Thresholds};

use hough_heading_recordings::engine::View;
use hough_heading_recordings::mcu_pairs::{self as pairs, ScanHeader};
use hough_heading_recordings::options::engine_for;
use hough_heading_recordings::pairs::{self as scans, PairRecord, RasterOptions, ScanRecord};
use hough_heading_recordings::Fatal;

use crate::input::{lines, read_input};

/// `mcu`.
#[derive(Clone, Debug, Args)]
pub struct McuArgs {
    /// What to do.
    #[command(subcommand)]
    pub what: McuCommand,
}

/// `mcu export` or `mcu check`.
#[derive(Clone, Debug, Subcommand)]
pub enum McuCommand {
    /// Writes scan pairs in the firmware's binary form (u16 millimetres).
    Export {
        /// Pair files (format of ../shared/data/README.md).
        #[arg(required = true, num_args = 1..)]
        pairs: Vec<PathBuf>,
        /// Output file.
        #[arg(long)]
        out: PathBuf,
        /// N pairs of each file, evenly spaced (lines ⌊i·lines/N⌋, i < N);
        /// all without this option.
        #[arg(long, value_name = "N")]
        per_file: Option<usize>,
    },
    /// Compares the firmware's result lines with the host's estimates.
    Check {
        /// The binary pair file the firmware read.
        pairs: PathBuf,
        /// Firmware logs (`budgets run` output), one per core.
        #[arg(required = true, num_args = 1..)]
        logs: Vec<PathBuf>,
    },
}

/// Runs `mcu`; the number of pairs that differ or are missing.
///
/// # Errors
/// Unreadable or malformed files.
pub fn run(args: &McuArgs) -> Result<usize, Fatal> {
    match &args.what {
        McuCommand::Export {
            pairs,
            out,
            per_file,
        } => export(pairs, out, *per_file).map(|()| 0),
        McuCommand::Check { pairs, logs } => check(pairs, logs),
    }
}

/// The range code of a reading (see [`pairs`]); whether a valid range was
/// clamped to [`pairs::MAX_MM`].
pub fn range_code(range: Option<f32>, max_range: f32) -> (u16, bool) {
    match range {
        Some(r) if r.is_finite() => {
            if r >= max_range {
                (pairs::NO_RETURN, false)
            } else {
                let mm = (f64::from(r) * 1000.0).round().max(0.0);
                let clamped = mm > f64::from(pairs::MAX_MM);
                (mm.min(f64::from(pairs::MAX_MM)) as u16, clamped)
            }
        }
        _ => (pairs::NO_READING, false),
    }
}

/// Appends one scan (header and range codes) to `out`; the clamped ranges.
fn encode_scan(scan: &ScanRecord, out: &mut Vec<u8>) -> Result<usize, String> {
    let beams = u16::try_from(scan.ranges.len())
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| format!("{} beams: need 1 to 65535", scan.ranges.len()))?;
    let header = ScanHeader {
        beams,
        angle_min: scan.angle_min,
        angle_increment: scan.angle_increment,
        max_range: scan.max_range,
        offset: scan.laser_offset,
    };
    out.extend_from_slice(&header.bytes());
    let mut clamped = 0;
    for &r in &scan.ranges {
        let (code, c) = range_code(r, scan.max_range);
        clamped += usize::from(c);
        out.extend_from_slice(&code.to_le_bytes());
    }
    Ok(clamped)
}

/// The line indices `--per-file n` picks out of `lines`: evenly spaced, all
/// when `n` is absent or at least `lines`.
pub fn spread(lines: usize, n: Option<usize>) -> Vec<usize> {
    match n {
        Some(n) if n < lines => (0..n).map(|i| i * lines / n).collect(),
        _ => (0..lines).collect(),
    }
}

fn export(files: &[PathBuf], out: &Path, per_file: Option<usize>) -> Result<(), Fatal> {
    let mut body = Vec::new();
    let (mut count, mut most_beams, mut clamped, mut skipped) = (0u32, 0usize, 0usize, 0usize);
    for path in files {
        let bytes = read_input(path)?;
        let lines = lines(&bytes);
        for i in spread(lines.len(), per_file) {
            let line = lines[i];
            let pair = match serde_json::from_slice::<PairRecord>(line) {
                Ok(pair) => pair,
                Err(e) => {
                    eprintln!(
                        "hough-heading: {} line {}: skipped: {e}",
                        path.display(),
                        i + 1
                    );
                    skipped += 1;
                    continue;
                }
            };
            let mut record = count.to_le_bytes().to_vec();
            let encoded = encode_scan(&pair.scan1, &mut record)
                .and_then(|a| encode_scan(&pair.scan2, &mut record).map(|b| a + b));
            match encoded {
                Ok(c) => {
                    clamped += c;
                    most_beams = most_beams
                        .max(pair.scan1.ranges.len())
                        .max(pair.scan2.ranges.len());
                    body.extend_from_slice(&record);
                    count += 1;
                }
                Err(e) => {
                    eprintln!(
                        "hough-heading: {} line {}: skipped: {e}",
                        path.display(),
                        i + 1
                    );
                    skipped += 1;
                }
            }
        }
    }
    let mut file = Vec::with_capacity(pairs::HEADER_LEN + body.len());
    file.extend_from_slice(&pairs::MAGIC);
    file.extend_from_slice(&pairs::VERSION.to_le_bytes());
    file.extend_from_slice(&(pairs::HEADER_LEN as u16).to_le_bytes());
    file.extend_from_slice(&count.to_le_bytes());
    file.extend_from_slice(&(most_beams as u32).to_le_bytes());
    file.extend_from_slice(&body);
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .map_err(|e| Fatal::io(format!("{}: cannot create: {e}", dir.display())))?;
    }
    std::fs::write(out, &file)
        .map_err(|e| Fatal::io(format!("{}: cannot write: {e}", out.display())))?;
    eprintln!(
        "hough-heading: {}: {count} pairs, {} bytes, up to {most_beams} beams per scan \
         ({clamped} ranges clamped to {} mm, {skipped} lines skipped)",
        out.display(),
        file.len(),
        pairs::MAX_MM
    );
    Ok(())
}

/// Decodes a binary pair file: `(index, pair)` with the ranges as the
/// firmware decodes them.
///
/// # Errors
/// A message when the file is malformed.
pub fn decode(bytes: &[u8]) -> Result<Vec<(u32, PairRecord)>, String> {
    let mut at = 0;
    let mut take = |n: usize| -> Result<&[u8], String> {
        let part = bytes
            .get(at..at + n)
            .ok_or_else(|| format!("truncated at byte {at}"))?;
        at += n;
        Ok(part)
    };
    let header: &[u8; pairs::HEADER_LEN] = take(pairs::HEADER_LEN)?
        .try_into()
        .map_err(|_| "short header")?;
    let (count, _) = pairs::header(header).ok_or("wrong magic, version or header size")?;
    let mut out = Vec::new();
    for _ in 0..count {
        let index = u32::from_le_bytes(take(4)?.try_into().map_err(|_| "short index")?);
        let mut scan = || -> Result<ScanRecord, String> {
            let h: &[u8; pairs::SCAN_HEADER_LEN] = take(pairs::SCAN_HEADER_LEN)?
                .try_into()
                .map_err(|_| "short scan header")?;
            let h = ScanHeader::read(h);
            let codes = take(2 * usize::from(h.beams))?;
            let ranges = codes
                .chunks_exact(2)
                .map(|c| {
                    let r = pairs::range(u16::from_le_bytes([c[0], c[1]]), h.max_range);
                    (!r.is_nan()).then_some(r)
                })
                .collect();
            Ok(ScanRecord {
                ranges,
                angle_min: h.angle_min,
                angle_increment: h.angle_increment,
                max_range: h.max_range,
                laser_offset: h.offset,
            })
        };
        let scan1 = scan()?;
        let scan2 = scan()?;
        out.push((index, PairRecord { scan1, scan2 }));
    }
    Ok(out)
}

/// The host's result lines for the pairs of a binary pair file.
///
/// # Errors
/// A malformed pair file, or a pair the CLI cannot estimate.
pub fn host_lines(bytes: &[u8], free_space: bool) -> Result<Vec<(u32, String)>, String> {
    let mut engine = engine_for(pairs::SIDE, pairs::N_THETA).map_err(|e| e.to_string())?;
    // As `EstimatorArgs::engine` with no tuning options (and
    // `--no-free-space` when the firmware estimated without it).
    engine.set_thresholds(Thresholds::DEFAULT);
    engine.set_verification(true);
    engine.set_free_space(free_space);
    let options = RasterOptions {
        cell: None,
        connect: Some(scans::DEFAULT_CONNECT_M),
        disc: false,
        beam_refine: true,
        // The firmware checks on the beams where it has the free space too
        // (the Cortex-M4F; the M0's 16 KiB have no room for either).
        beam_check: free_space,
    };
    let mut out = Vec::new();
    for (index, pair) in decode(bytes)? {
        let estimates = scans::estimate(engine.as_mut(), &pair, &options, &[Mode::Improved])
            .map_err(|e| format!("pair {index}: {e}"))?;
        let p = &estimates[0];
        let occupied = [View::First, View::Second].map(|v| engine.image(v).count() as u32);
        let mut line = String::new();
        pairs::write_result(
            &mut line,
            index,
            p.cell,
            occupied,
            &p.stats,
            &p.estimate,
            p.beam_fit.as_ref(),
        )
        .map_err(|e| e.to_string())?;
        out.push((index, line));
    }
    Ok(out)
}

/// The fields of a result line that differ, as `key: host ≠ firmware`.
pub fn differences(host: &str, firmware: &str) -> Vec<String> {
    let fields = |line: &str| -> BTreeMap<String, String> {
        line.split_whitespace()
            .filter_map(|w| w.split_once('='))
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect()
    };
    let (a, b) = (fields(host), fields(firmware));
    let mut keys: Vec<&String> = a.keys().chain(b.keys()).collect();
    keys.sort();
    keys.dedup();
    keys.into_iter()
        .filter(|k| a.get(*k) != b.get(*k))
        .map(|k| {
            let show = |v: Option<&String>| v.map_or("(absent)", String::as_str).to_string();
            format!("{k}: host {} ≠ firmware {}", show(a.get(k)), show(b.get(k)))
        })
        .collect()
}

/// Differing pairs printed per log.
const SHOWN: usize = 10;

fn check(pairs_path: &Path, logs: &[PathBuf]) -> Result<usize, Fatal> {
    let bytes = read_input(pairs_path)?;
    // The host's lines with and without the scans' free space, as each
    // firmware log's config line says it estimated (`free_space=`).
    let mut host_by_mode: BTreeMap<bool, Vec<(u32, String)>> = BTreeMap::new();
    let mut bad = 0;
    for log in logs {
        let text = read_input(log)?;
        let free_space = !lines(&text).into_iter().any(|l| {
            let l = String::from_utf8_lossy(l);
            l.trim().starts_with("config ") && l.contains("free_space=false")
        });
        let host = match host_by_mode.entry(free_space) {
            std::collections::btree_map::Entry::Occupied(e) => e.into_mut(),
            std::collections::btree_map::Entry::Vacant(e) => e.insert(
                host_lines(&bytes, free_space)
                    .map_err(|e| Fatal::io(format!("{}: {e}", pairs_path.display())))?,
            ),
        };
        let firmware: BTreeMap<u32, String> = lines(&text)
            .into_iter()
            .filter_map(|l| {
                let l = String::from_utf8_lossy(l).trim().to_string();
                let index = l
                    .strip_prefix("pair=")?
                    .split_whitespace()
                    .next()?
                    .parse()
                    .ok()?;
                Some((index, l))
            })
            .collect();
        let mut differ = 0;
        for (index, line) in host.iter() {
            match firmware.get(index) {
                Some(f) if f == line => {}
                Some(f) => {
                    differ += 1;
                    if differ <= SHOWN {
                        eprintln!(
                            "hough-heading: {}: pair {index} differs: {}",
                            log.display(),
                            differences(line, f).join("; ")
                        );
                    }
                }
                None => {
                    differ += 1;
                    if differ <= SHOWN {
                        eprintln!("hough-heading: {}: pair {index} missing", log.display());
                    }
                }
            }
        }
        if differ > SHOWN {
            eprintln!(
                "hough-heading: {}: … and {} more pairs differ or are missing",
                log.display(),
                differ - SHOWN
            );
        }
        println!(
            "{}: {} pairs compared with the host (128², N_θ = 360, verification on): {}",
            log.display(),
            host.len(),
            if differ == 0 {
                "all identical".to_string()
            } else {
                format!("{differ} differ or are missing")
            }
        );
        bad += differ;
    }
    Ok(bad)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn firmware_connect_is_the_cli_default() {
        assert_eq!(pairs::CONNECT_M, scans::DEFAULT_CONNECT_M);
    }

    #[test]
    fn range_codes_round_trip_to_the_millimetre() {
        for r in [0.0f32, 0.001, 1.234, 49.999, 65.533] {
            let (code, clamped) = range_code(Some(r), 81.91);
            assert!(!clamped);
            assert!((pairs::range(code, 81.91) - r).abs() <= 0.0005, "{r}");
        }
        assert_eq!(range_code(Some(70.0), 81.91), (pairs::MAX_MM, true));
        assert_eq!(range_code(Some(50.0), 50.0).0, pairs::NO_RETURN);
        assert_eq!(pairs::range(pairs::NO_RETURN, 50.0), 50.0);
        assert_eq!(range_code(None, 50.0).0, pairs::NO_READING);
        assert_eq!(range_code(Some(f32::NAN), 50.0).0, pairs::NO_READING);
        assert!(pairs::range(pairs::NO_READING, 50.0).is_nan());
    }

    #[test]
    fn export_round_trips_the_bundled_pairs() {
        let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scans.jsonl");
        let out = std::env::temp_dir().join(format!("hh-mcu-{}.bin", std::process::id()));
        export(std::slice::from_ref(&data), &out, None).unwrap();
        let bytes = std::fs::read(&out).unwrap();
        let _ = std::fs::remove_file(&out);
        let decoded = decode(&bytes).unwrap();
        let text = std::fs::read(&data).unwrap();
        let original: Vec<PairRecord> = lines(&text)
            .iter()
            .map(|l| serde_json::from_slice(l).unwrap())
            .collect();
        assert_eq!(decoded.len(), original.len());
        for (i, ((index, d), o)) in decoded.iter().zip(&original).enumerate() {
            assert_eq!(*index as usize, i);
            for (d, o) in [(&d.scan1, &o.scan1), (&d.scan2, &o.scan2)] {
                assert_eq!(d.angle_min.to_bits(), o.angle_min.to_bits());
                assert_eq!(d.angle_increment.to_bits(), o.angle_increment.to_bits());
                assert_eq!(d.max_range.to_bits(), o.max_range.to_bits());
                assert_eq!(
                    d.laser_offset.map(f32::to_bits),
                    o.laser_offset.map(f32::to_bits)
                );
                assert_eq!(d.ranges.len(), o.ranges.len());
                for (a, b) in d.ranges.iter().zip(&o.ranges) {
                    match (a, b) {
                        // Valid ranges to the millimetre, clamped to 0 … MAX_MM.
                        (Some(a), Some(b)) if *b < o.max_range => {
                            assert!((a - b.clamp(0.0, 65.533)).abs() <= 5e-4, "{a} {b}");
                        }
                        (Some(a), Some(_)) => assert_eq!(*a, o.max_range),
                        (a, b) => assert_eq!(a.is_none(), b.is_none()),
                    }
                }
            }
        }
        assert!(decode(&bytes[..bytes.len() - 1]).is_err());
        assert!(decode(b"HHSP").is_err());
    }

    #[test]
    fn spread_picks_evenly_spaced_lines() {
        assert_eq!(spread(10, Some(4)), vec![0, 2, 5, 7]);
        assert_eq!(spread(3, Some(5)), vec![0, 1, 2]);
        assert_eq!(spread(3, None), vec![0, 1, 2]);
    }

    #[test]
    fn differences_name_the_fields() {
        let d = differences("pair=1 a=2 b=3", "pair=1 a=2 b=4 c=5");
        assert_eq!(
            d,
            vec!["b: host 3 ≠ firmware 4", "c: host (absent) ≠ firmware 5"]
        );
    }
}
