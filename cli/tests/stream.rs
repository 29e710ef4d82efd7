//! A robot's stream (issue 39): raw lidar captures are judged like the
//! log they were made from, the motion prior carries consecutive pairs, and
//! keyframe odometry chains the scans. On the bundled Seattle excerpt and
//! its LD06 / RPLIDAR captures (`cli/data/logs/`), and, when
//! `../shared/data/logs` is there, on the whole shared logs (skipped
//! without them unless `CI` is set). Truth: the logs' corrected poses.

use std::path::Path;

use serde_json::Value;

mod common;
use common::{json_lines, log_path as data, stderr, tool};

/// `log -q ARGS`: its lines (exit status 0 checked).
fn log(args: &[&str]) -> Vec<Value> {
    let o = tool(&[&["log", "-q"], args].concat());
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    json_lines(&o)
}

fn f(v: &Value) -> f64 {
    v.as_f64().expect("a number")
}

fn wrap(d: f64) -> f64 {
    (d + 540.0).rem_euclid(360.0) - 180.0
}

/// The log's corrected heading of each scan, degrees (scan 0 at 0).
fn headings(carmen: &[Value]) -> Vec<f64> {
    let mut h = vec![0.0];
    for line in carmen {
        assert_eq!(line["scan2"], h.len(), "consecutive pairs");
        h.push(h[h.len() - 1] + f(&line["log_pose"]["dtheta_deg"]));
    }
    h
}

/// Within 2°, flagged, confident and more than 5° off: counts.
fn score(lines: &[Value], heading: &[f64]) -> (usize, usize, usize) {
    let (mut within, mut flagged, mut wrong) = (0, 0, 0);
    for l in lines {
        let (a, b) = (
            l["scan1"].as_u64().unwrap() as usize,
            l["scan2"].as_u64().unwrap() as usize,
        );
        let error = wrap(f(&l["dtheta_deg"]) - (heading[b] - heading[a])).abs();
        within += usize::from(error <= 2.0);
        if l["status"] != "confident" {
            flagged += 1;
        } else if error > 5.0 {
            wrong += 1;
        }
    }
    (within, flagged, wrong)
}

#[test]
fn lidar_captures_are_judged_on_their_beams_like_the_log() {
    let carmen = log(&[&data("seattle-excerpt.log"), "--prior", "none"]);
    let lidar_720 = Path::new(env!("CARGO_MANIFEST_DIR")).join("../lidar/tests/data/ld06.bin");
    let captures = [
        (data("seattle-excerpt-360.ld06"), "ld06", 1.0),
        (data("seattle-excerpt-360.rplidar"), "rplidar", 1.0),
        // 720 points 0.5° apart: every beam of the log.
        (lidar_720.display().to_string(), "ld06", 0.2),
    ];
    for (file, format, tolerance) in captures {
        let lines = log(&[&file, "--format", format, "--prior", "none"]);
        assert_eq!(lines.len(), carmen.len(), "{file}");
        for (c, l) in carmen.iter().zip(&lines) {
            let check = &l["beam_check"];
            // Before issue 39 every such pair said 0 and `too_few_pairs`.
            assert!(f(&check["explained"]) > 0.3, "{file} {l}");
            assert!(
                l["beam_fit"]["pairs"].as_u64().unwrap_or(0) >= 20,
                "{file} {l}"
            );
            if c["status"] == "confident" {
                assert_eq!(l["status"], "confident", "{file}: {l}");
                let d = wrap(f(&l["dtheta_deg"]) - f(&c["dtheta_deg"])).abs();
                assert!(d <= tolerance, "{file}: {d}° from the log's estimate");
            }
        }
    }
}

#[test]
fn the_motion_prior_carries_the_stream_and_keyframes_chain_it() {
    let carmen = log(&[&data("seattle-excerpt.log"), "--prior", "none"]);
    let heading = headings(&carmen);
    // Consecutive pairs on the log (scans 2 s apart: `--pairs auto` takes
    // consecutive pairs), keyframes on request, and keyframes on the LD06
    // capture (timed by its packets, a revolution every 0.12 s).
    for (args, every_pair_a_keyframe) in [
        (vec![data("seattle-excerpt.log")], true),
        (
            vec![data("seattle-excerpt.log"), "--keyframes".into()],
            false,
        ),
        (
            vec![
                data("seattle-excerpt-360.ld06"),
                "--format".into(),
                "ld06".into(),
            ],
            false,
        ),
    ] {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let lines = log(&args);
        let (within, flagged, wrong) = score(&lines, &heading);
        assert!(
            within >= lines.len() - 1,
            "{args:?}: {within} of {} within 2°",
            lines.len()
        );
        assert!(
            flagged <= 1 && wrong == 0,
            "{args:?}: {flagged} flagged, {wrong} wrong"
        );
        // Every line carries the chain; its heading follows the log's.
        let mut keyframe = 0;
        for l in &lines {
            let chain = &l["chain"];
            assert_eq!(
                l["scan1"], keyframe,
                "{args:?}: pairs start at the keyframe"
            );
            if chain["keyframe"] == true {
                keyframe = l["scan2"].as_u64().unwrap();
            }
            let b = l["scan2"].as_u64().unwrap() as usize;
            let drift = wrap(f(&chain["theta_deg"]) - heading[b]).abs();
            assert!(drift < 2.0, "{args:?}: heading {drift}° off at scan {b}");
        }
        if every_pair_a_keyframe {
            assert!(lines.iter().all(|l| l["chain"]["keyframe"] == true));
        }
    }
}

/// On the shared whole logs, consecutive pairs with the motion prior (the
/// default): the figures of `docs/stream.md` as floors (per cent within 2°,
/// per cent flagged at most, confident and > 5° off at most), and the
/// chain's heading σ honest (`docs/drift.md`).
#[test]
fn shared_logs_consecutive_pairs() {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data/logs");
    let cases = [
        ("aces", 97.0, 5.0, 0),
        ("orebro", 95.0, 15.0, 0),
        ("seattle", 99.0, 3.0, 0),
        ("freiburg-campus", 92.0, 23.0, 3),
    ];
    if !shared.join("aces-corrected.log.gz").exists() {
        let ci = std::env::var("CI").is_ok_and(|v| !v.is_empty() && v != "0" && v != "false");
        assert!(!ci, "CI is set but {} is missing", shared.display());
        eprintln!("skipped: {} not found", shared.display());
        return;
    }
    for (name, within_min, flagged_max, wrong_max) in cases {
        let file = shared
            .join(format!("{name}-corrected.log.gz"))
            .display()
            .to_string();
        let alone = log(&[&file, "--prior", "none"]);
        let heading = headings(&alone);
        let lines = log(&[&file]);
        let (within, flagged, wrong) = score(&lines, &heading);
        let n = lines.len() as f64;
        let (within_pc, flagged_pc) = (100.0 * within as f64 / n, 100.0 * flagged as f64 / n);
        assert!(
            within_pc >= within_min,
            "{name}: {within_pc:.1} % within 2°"
        );
        assert!(
            flagged_pc <= flagged_max,
            "{name}: {flagged_pc:.1} % flagged"
        );
        assert!(wrong <= wrong_max, "{name}: {wrong} confident and wrong");
        // The chain's stated heading σ is honest: the truth lies within 2σ
        // of the chained heading for at least 90 % of the scans (issue 46).
        let covered = lines
            .iter()
            .filter(|l| {
                let chain = &l["chain"];
                let b = l["scan2"].as_u64().unwrap() as usize;
                let error = wrap(f(&chain["theta_deg"]) - heading[b]).abs();
                error <= 2.0 * f(&chain["heading_sigma_deg"])
            })
            .count();
        assert!(
            covered as f64 >= 0.9 * n,
            "{name}: the truth within 2σ for {covered} of {n} scans"
        );
        // A step is never a guess that left no trace: every line says how
        // the chain made it.
        for l in &lines {
            let source = l["chain"]["source"].as_str().unwrap();
            assert!(
                ["estimate", "prior", "unplaced", "carried"].contains(&source),
                "{name}: source {source}"
            );
        }
        // The pairs alone are worse: the prior is what carries the stream.
        let (within_alone, _, _) = score(&alone, &heading);
        assert!(
            within > within_alone,
            "{name}: {within} vs {within_alone} alone"
        );
    }
}

/// The trajectory file's chained heading against the log's, degrees: the
/// largest difference and the last.
fn trajectory_drift(csv: &Path) -> (f64, f64) {
    let text = std::fs::read_to_string(csv).expect("the trajectory file");
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().expect("a header").split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).expect(name);
    let (theta, truth) = (column("theta"), column("log_theta"));
    let (mut largest, mut last) = (0.0f64, 0.0);
    for row in rows {
        let cells: Vec<&str> = row.split(',').collect();
        let value = |k: usize| cells[k].parse::<f64>().expect("a number");
        last = wrap((value(theta) - value(truth)).to_degrees());
        largest = largest.max(last.abs());
    }
    (largest, last)
}

/// `log -q --summary FILE --trajectory CSV EXTRA…` (exit status 0
/// checked): its stderr, and the trajectory's heading error against the
/// log's (largest, last; [`trajectory_drift`]).
fn chained_run(file: &str, csv: &Path, extra: &[&str]) -> (String, (f64, f64)) {
    let mut args = vec!["log", "-q", "--summary", file, "--trajectory"];
    args.push(csv.to_str().unwrap());
    args.extend_from_slice(extra);
    let o = tool(&args);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    (stderr(&o), trajectory_drift(csv))
}

/// The loop closure report of a run's stderr: closures accepted, accepted
/// and within 1° of the optimized trajectory, accepted and more than 5°
/// off the recording's poses.
fn closure_counts(err: &str) -> (usize, usize, usize) {
    let report = err
        .lines()
        .find(|l| l.contains("loop closures:"))
        .unwrap_or_else(|| panic!("no loop closure report: {err}"));
    // "… N confident tried, A accepted into the pose graph of P placed
    // scans, W of them within 1° …; … X of the accepted, …"
    let number_before = |marker: &str| -> usize {
        let head = &report[..report
            .find(marker)
            .unwrap_or_else(|| panic!("{marker}: {report}"))];
        let word = head.split_whitespace().last().expect("a number");
        word.trim_start_matches(": ").parse().expect(word)
    };
    let wrong = if report.contains(" of the accepted") {
        number_before(" of the accepted")
    } else {
        0
    };
    (
        number_before(" accepted into"),
        number_before(" of them within 1°"),
        wrong,
    )
}

/// On the shared whole logs (consecutive pairs, kept about every metre),
/// `log` closes loops by default: no closure more than 5° off the log's
/// poses gets in, the closures never make the largest heading error
/// larger, and on Seattle the corrected heading meets issue 46's targets
/// (≤ 5° all along, ≤ 2° at the end; measured 2.1° and −1.8°, 3.5° and
/// −1.1° without closures; `docs/drift.md`).
#[test]
fn shared_logs_close_their_loops_without_a_wrong_one() {
    let Some(logs) = common::shared_data("logs") else {
        return;
    };
    for name in ["aces", "orebro", "seattle", "freiburg-campus"] {
        let file = logs.join(format!("{name}-corrected.log.gz"));
        let file = file.to_str().unwrap();
        let csv = common::scratch_file("stream", &format!("{name}-loops.csv"));
        let run = |extra: &[&str]| chained_run(file, &csv, extra);
        let (err, (largest, last)) = run(&[]);
        assert!(err.contains("consecutive pairs scored"), "{name}: {err}");
        let (_, _, wrong) = closure_counts(&err);
        assert_eq!(wrong, 0, "{name}: {err}");
        let (_, (largest_alone, _)) = run(&["--no-loops"]);
        assert!(
            largest <= largest_alone + 0.5,
            "{name}: {largest:.1}° with closures, {largest_alone:.1}° without"
        );
        if name == "seattle" {
            assert!(
                largest <= 5.0 && last.abs() <= 2.0,
                "{largest:.2}° / {last:.2}°"
            );
        }
    }
}

/// A dense stream (the bundled 10 Hz excerpt of the semi-synthetic Seattle
/// stream, exact truth): by default `log` takes keyframes and closes its
/// loops; every closure it accepts is right (within 5° of the truth), most
/// agree with the optimized trajectory within 1°, and the corrected
/// heading stays within 2° of the truth all along (1.4° measured; 2.0°
/// without the closures).
#[test]
fn a_dense_stream_takes_keyframes_and_closes_its_loops() {
    let file = data("seattle-dense-excerpt.log.gz");
    let csv = common::scratch_file("stream", "dense-loops.csv");
    let (err, (largest, _)) = chained_run(&file, &csv, &[]);
    assert!(err.contains("keyframe pairs scored"), "{err}");
    let (accepted, within, wrong) = closure_counts(&err);
    assert!(accepted >= 10, "{err}");
    assert_eq!(wrong, 0, "{err}");
    assert!(4 * within >= 3 * accepted, "{err}");
    assert!(largest <= 2.0, "corrected heading {largest:.2}° off");
    // Without them: no closure, the chain's own trajectory.
    let (err, _) = chained_run(&file, &csv, &["--no-loops"]);
    assert!(!err.contains("loop closures"), "{err}");
}
