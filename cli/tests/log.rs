//! `hough-heading log` on the bundled recordings (`cli/data/logs/`,
//! written by `tools/make_test_logs.py` with Python's own writers): the
//! estimates equal `scans` on the same scans in the pair format, the log's
//! deltas equal the pair files' values, and bad input is a clear error.

mod common;

use std::path::{Path, PathBuf};

use common::{json_lines, log_path as data, logs, stderr, stdout, tool};
use serde_json::Value;

fn scratch(name: &str) -> PathBuf {
    common::scratch_file("log-tests", name)
}

/// The fields `scans` and `log` both print, without the line index.
fn estimate_fields(v: &Value) -> serde_json::Map<String, Value> {
    let mut m = v.as_object().expect("an object").clone();
    for k in [
        "index", "file", "scan1", "scan2", "t1", "t2", "odom", "log_pose",
    ] {
        m.remove(k);
    }
    m
}

fn pair_lines(name: &str) -> Vec<Value> {
    std::fs::read_to_string(logs().join(name))
        .expect("pair file")
        .lines()
        .map(|l| serde_json::from_str(l).expect("pair JSON"))
        .collect()
}

/// `log` on `args` equals `scans` on `pairs`, pair by pair (the pairs
/// alone: `--prior none`, no chain).
fn assert_same_as_scans(log_args: &[&str], pairs: &str) -> Vec<Value> {
    let log = tool(&[log_args, &["--prior", "none"]].concat());
    assert_eq!(log.status.code(), Some(0), "{}", stderr(&log));
    let scans = tool(&["scans", "-q", &data(pairs)]);
    assert_eq!(scans.status.code(), Some(0), "{}", stderr(&scans));
    let (from_log, from_pairs) = (json_lines(&log), json_lines(&scans));
    assert_eq!(from_log.len(), from_pairs.len());
    assert!(from_log.len() >= 10);
    for (k, (a, b)) in from_log.iter().zip(&from_pairs).enumerate() {
        assert_eq!(a["scan1"], k, "{a}");
        assert_eq!(a["scan2"], k + 1, "{a}");
        assert_eq!(estimate_fields(a), estimate_fields(b), "pair {k}");
    }
    from_log
}

#[test]
fn carmen_log_estimates_equal_scans_on_the_same_pairs() {
    let lines = assert_same_as_scans(
        &["log", "-q", &data("seattle-excerpt.log")],
        "seattle-excerpt.pairs.jsonl",
    );
    // Most of these real sequential pairs are resolved (a sanity check that
    // the comparison is not between two empty outputs).
    let confident = lines.iter().filter(|l| l["status"] == "confident").count();
    assert!(confident >= 15, "{confident} confident");
}

#[test]
fn gzip_log_reads_like_the_plain_one() {
    let plain = tool(&["log", "-q", &data("seattle-excerpt.log")]);
    let gz = tool(&["log", "-q", &data("seattle-excerpt.log.gz")]);
    assert_eq!(gz.status.code(), Some(0), "{}", stderr(&gz));
    assert_eq!(stdout(&plain), stdout(&gz));
}

#[test]
fn mcap_bag_estimates_equal_scans_on_the_same_pairs() {
    assert_same_as_scans(
        &["log", "-q", &data("seattle-bag.mcap"), "--topic", "/scan"],
        "seattle-bag.pairs.jsonl",
    );
}

#[test]
fn the_logs_own_deltas_equal_the_pair_files_values() {
    // FLASER x y θ are the corrected poses: their deltas are the pairs'
    // ground truth. The odometry was written as 5 % more translation and
    // 0.02 rad more turn per step (tools/make_test_logs.py).
    let carmen = json_lines(&tool(&["log", "-q", &data("seattle-excerpt.log")]));
    let bag = json_lines(&tool(&[
        "log",
        "-q",
        &data("seattle-bag.mcap"),
        "--topic",
        "/scan",
    ]));
    for (lines, pairs, has_truth) in [
        (&carmen, pair_lines("seattle-excerpt.pairs.jsonl"), true),
        (&bag, pair_lines("seattle-bag.pairs.jsonl"), false),
    ] {
        for (line, pair) in lines.iter().zip(&pairs) {
            let f = |v: &Value| v.as_f64().expect("a number");
            let odom = &line["odom"];
            assert!(
                (f(&odom["dx_m"]) - 1.05 * f(&pair["dx"])).abs() < 2e-4,
                "{line}"
            );
            assert!(
                (f(&odom["dy_m"]) - 1.05 * f(&pair["dy"])).abs() < 2e-4,
                "{line}"
            );
            let turn = (f(&pair["dtheta"]) + 0.02).to_degrees();
            assert!((f(&odom["dtheta_deg"]) - turn).abs() < 2e-3, "{line}");
            assert_eq!(f(&line["t1"]), f(&pair["t1"]));
            if has_truth {
                let log = &line["log_pose"];
                assert!((f(&log["dx_m"]) - f(&pair["dx"])).abs() < 2e-4, "{line}");
                assert!((f(&log["dy_m"]) - f(&pair["dy"])).abs() < 2e-4, "{line}");
                let turn = f(&pair["dtheta"]).to_degrees();
                assert!((f(&log["dtheta_deg"]) - turn).abs() < 2e-3, "{line}");
            } else {
                assert!(line.get("log_pose").is_none(), "{line}");
            }
        }
    }
}

#[test]
fn summary_scores_against_the_corrected_poses_like_scans() {
    let log = tool(&["log", "-q", "--summary", &data("seattle-excerpt.log")]);
    assert_eq!(log.status.code(), Some(0), "{}", stderr(&log));
    let scans = tool(&[
        "scans",
        "-q",
        "--summary",
        &data("seattle-excerpt.pairs.jsonl"),
    ]);
    let row = |text: &str, method: &str| {
        text.lines()
            .find(|l| l.starts_with(&format!("| all | {method} |")))
            .map(str::to_owned)
            .unwrap_or_else(|| panic!("no {method} row in:\n{text}"))
    };
    let (a, b) = (stderr(&log), stderr(&scans));
    assert!(row(&a, "improved").starts_with("| all | improved | 19 |"));
    assert_eq!(row(&a, "improved"), row(&b, "improved"));
    assert_eq!(row(&a, "zero"), row(&b, "zero"));
}

#[test]
fn pair_modes_every_reference_and_window() {
    let file = data("seattle-excerpt.log");
    let pairs = |extra: &[&str]| -> Vec<(u64, u64)> {
        let mut args = vec!["log", "-q", &file];
        args.extend_from_slice(extra);
        let o = tool(&args);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        json_lines(&o)
            .iter()
            .map(|l| (l["scan1"].as_u64().unwrap(), l["scan2"].as_u64().unwrap()))
            .collect()
    };
    let every = pairs(&["--every", "4"]);
    assert_eq!(every, vec![(0, 4), (4, 8), (8, 12), (12, 16)]);
    let reference = pairs(&["--pairs", "reference", "--reference", "17"]);
    assert_eq!(reference, vec![(17, 18), (17, 19)]);
    let window = pairs(&["--pairs", "window", "--window", "2", "--limit", "5"]);
    assert_eq!(
        window,
        vec![(0, 1), (0, 2), (1, 2), (1, 3), (2, 3), (2, 4), (3, 4)]
    );
    // A 3 s window: the first scans are at 1244.18, 1246.18, 1247.38 and
    // 1250.18 s, so (0, 2) and (1, 3) are too far apart.
    let timed = pairs(&[
        "--pairs",
        "window",
        "--window",
        "5",
        "--window-s",
        "3",
        "--limit",
        "4",
    ]);
    assert_eq!(timed, vec![(0, 1), (1, 2), (2, 3)]);
}

#[test]
fn prior_odom_keeps_the_estimates_near_the_odometry() {
    let o = tool(&["log", "-q", "--prior", "odom", &data("seattle-excerpt.log")]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    for l in json_lines(&o) {
        let (est, odom) = (
            l["dtheta_deg"].as_f64().unwrap(),
            l["odom"]["dtheta_deg"].as_f64().unwrap(),
        );
        assert!((est - odom).abs() < 30.0, "{l}");
    }
}

#[test]
fn trajectory_chains_the_estimates_and_the_plot_is_a_png() {
    let csv = scratch("trajectory.csv");
    let png = scratch("trajectory.png");
    let o = tool(&[
        "log",
        "-q",
        &data("seattle-excerpt.log"),
        "--trajectory",
        &csv.display().to_string(),
        "--plot",
        &png.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let text = std::fs::read_to_string(&csv).expect("csv");
    let rows: Vec<Vec<&str>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 20);
    assert_eq!(
        &rows[0][..6],
        &[
            "0",
            "1244.180000",
            "0.000000",
            "0.000000",
            "0.000000",
            "start"
        ]
    );
    // The chained estimates end near the corrected poses (independent: the
    // gmapping-corrected trajectory), and nearer than the drifting odometry.
    let last = &rows[19];
    let n = |i: usize| last[i].parse::<f64>().expect("a number");
    let (x, y) = (n(2), n(3));
    let (ox, oy) = (n(6), n(7));
    let (lx, ly) = (n(9), n(10));
    let err = (x - lx).hypot(y - ly);
    let odom_err = (ox - lx).hypot(oy - ly);
    assert!(
        err < 0.5 && err < odom_err,
        "estimate {err} m, odometry {odom_err} m"
    );
    let bytes = std::fs::read(&png).expect("png");
    assert!(bytes.starts_with(b"\x89PNG"));
}

/// The bundled bag with its `/scan` messages also on `/scan2` (a second
/// LaserScan topic), written with the `mcap` crate.
fn bag_with_two_scan_topics(path: &Path) {
    use std::sync::Arc;
    let bytes = std::fs::read(data("seattle-bag.mcap")).expect("the bundled bag");
    let mut out = mcap::Writer::new(std::io::BufWriter::new(
        std::fs::File::create(path).expect("a scratch file"),
    ))
    .expect("a writer");
    for message in mcap::MessageStream::new(&bytes).expect("a bag") {
        let message = message.expect("a message");
        out.write(&message).expect("written");
        if message.channel.topic == "/scan" {
            let mut channel = (*message.channel).clone();
            channel.topic = "/scan2".into();
            channel.id += 100;
            let copy = mcap::Message {
                channel: Arc::new(channel),
                ..message.clone()
            };
            out.write(&copy).expect("written");
        }
    }
    out.finish().expect("finished");
}

#[test]
fn a_bag_with_one_scan_topic_needs_no_topic_option() {
    let o = tool(&["log", "-q", &data("seattle-bag.mcap")]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("using /scan, the bag's only sensor_msgs/msg/LaserScan topic"),
        "{}",
        stderr(&o)
    );
    let with_topic = tool(&["log", "-q", &data("seattle-bag.mcap"), "--topic", "/scan"]);
    assert_eq!(stdout(&o), stdout(&with_topic));
    assert_eq!(json_lines(&o).len(), 11);
}

#[test]
fn a_missing_topic_lists_the_bags_topics() {
    let dir = std::env::temp_dir().join(format!("hh-two-topics-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    let bag = dir.join("two.mcap");
    bag_with_two_scan_topics(&bag);
    let o = tool(&["log", &bag.display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    for t in [
        "--topic",
        "/scan  (sensor_msgs/msg/LaserScan, 12 messages)",
        "/scan2  (sensor_msgs/msg/LaserScan, 12 messages)",
        "/odom  (nav_msgs/msg/Odometry",
        "/chatter  (std_msgs/msg/String",
    ] {
        assert!(e.contains(t), "{t} not in {e}");
    }
    // Either topic then reads the same scans.
    let second = tool(&["log", "-q", &bag.display().to_string(), "--topic", "/scan2"]);
    assert_eq!(second.status.code(), Some(0), "{}", stderr(&second));
    assert_eq!(json_lines(&second).len(), 11);
    let _ = std::fs::remove_dir_all(&dir);
    let unknown = tool(&["log", &data("seattle-bag.mcap"), "--topic", "/nope"]);
    assert_eq!(unknown.status.code(), Some(2));
    assert!(stderr(&unknown).contains("no messages on topic /nope"));
}

#[test]
fn a_wrong_message_type_is_an_error_naming_the_topic() {
    let o = tool(&["log", &data("seattle-bag.mcap"), "--topic", "/chatter"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains("seattle-bag.mcap: message"), "{e}");
    assert!(
        e.contains("on topic /chatter is std_msgs/msg/String (cdr encoding); expected sensor_msgs/msg/LaserScan"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    let o = tool(&[
        "log",
        &data("seattle-bag.mcap"),
        "--topic",
        "/scan",
        "--odom-topic",
        "/chatter",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o)
            .contains("topic /chatter carries std_msgs/msg/String, not nav_msgs/msg/Odometry"),
        "{}",
        stderr(&o)
    );
}

/// A copy of the bundled bag `name` cut at 70 %, and one cut at `tiny`
/// bytes: the first gives the pairs before the damage and one failed record
/// (`unreadable`), the second no scan (`unusable`, exit status 2).
fn assert_truncated_bag(name: &str, tiny: usize, unreadable: &str, unusable: &str) {
    let bytes = std::fs::read(logs().join(name)).expect("bag");
    for (cut, copy) in [(bytes.len() * 7 / 10, "cut70"), (tiny, "tiny")] {
        let path = scratch(&format!("{copy}-{name}"));
        std::fs::write(&path, &bytes[..cut]).expect("write");
        let o = tool(&["log", "-q", &path.display().to_string(), "--topic", "/scan"]);
        let e = stderr(&o);
        assert!(!e.contains("panicked"), "{e}");
        assert!(e.contains(&format!("{copy}-{name}")), "{e}");
        if cut > tiny {
            // Whole chunks before the cut are read; the damage is one failed
            // record after them.
            assert_eq!(o.status.code(), Some(1), "{e}");
            assert!(e.contains(unreadable), "{e}");
            let lines = json_lines(&o);
            assert!(
                !lines.is_empty() && lines.len() < 11,
                "{} pairs",
                lines.len()
            );
        } else {
            assert_eq!(o.status.code(), Some(2), "{e}");
            assert!(e.contains(unusable), "{e}");
        }
    }
}

#[test]
fn a_truncated_bag_keeps_the_pairs_before_the_damage() {
    assert_truncated_bag(
        "seattle-bag.mcap",
        40,
        "unreadable MCAP",
        "not a readable MCAP file",
    );
    assert_truncated_bag(
        "seattle-bag.bag",
        20,
        "unreadable ROS 1 bag",
        "not a readable ROS 1 bag",
    );
}

#[test]
fn an_all_nan_scan_fails_alone() {
    let o = tool(&["log", "-q", &data("nan-scan.mcap"), "--topic", "/scan"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("nan-scan.mcap: message"), "{e}");
    assert!(e.contains("all 361 ranges are NaN or infinite"), "{e}");
    // Scans 0 and 2 still pair.
    let lines = json_lines(&o);
    assert_eq!(lines.len(), 1);
    assert_eq!(
        (lines[0]["scan1"].as_u64(), lines[0]["scan2"].as_u64()),
        (Some(0), Some(1))
    );
}

/// The excerpt with its FLASER line `k` (0-based among FLASER lines) edited.
fn edited_excerpt(name: &str, edit: impl Fn(usize, &str) -> Option<String>) -> (PathBuf, usize) {
    let text = std::fs::read_to_string(logs().join("seattle-excerpt.log")).expect("log");
    let mut k = 0;
    let mut edited_line = 0;
    let mut out = String::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with("FLASER ") {
            if let Some(new) = edit(k, line) {
                edited_line = i + 1;
                out.push_str(&new);
                out.push('\n');
                k += 1;
                continue;
            }
            k += 1;
        }
        out.push_str(line);
        out.push('\n');
    }
    let path = scratch(name);
    std::fs::write(&path, out).expect("write");
    (path, edited_line)
}

#[test]
fn carmen_bad_lines_are_reported_with_their_line_number() {
    // Too few fields: the line cut after 100 readings.
    let (short, line) = edited_excerpt("short.log", |k, l| {
        (k == 5).then(|| l.split(' ').take(100).collect::<Vec<_>>().join(" "))
    });
    let o = tool(&["log", "-q", &short.display().to_string()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains(&format!("short.log: line {line}: FLASER: too few fields")),
        "{e}"
    );
    assert_eq!(json_lines(&o).len(), 18);
    // A range that is not a number at all.
    let (word, line) = edited_excerpt("word.log", |k, l| {
        (k == 3).then(|| {
            let mut fields: Vec<&str> = l.split(' ').collect();
            fields[11] = "far";
            fields.join(" ")
        })
    });
    let o = tool(&["log", "-q", &word.display().to_string()]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains(&format!("word.log: line {line}: FLASER:")),
        "{e}"
    );
    assert!(
        e.contains("field 12 (range 9) is \"far\", not a number"),
        "{e}"
    );
}

#[test]
fn carmen_nan_and_inf_ranges_are_beams_without_a_reading() {
    // SICK drivers write `nan`/`inf` for a beam without an echo: the scan
    // is kept (its other beams are read), the beams are counted, and the
    // estimates are the same whichever way the file spells it.
    let blank = |name: &str, word: &'static str| {
        edited_excerpt(name, move |k, l| {
            (k % 4 == 1).then(|| {
                let mut fields: Vec<&str> = l.split(' ').collect();
                for f in &mut fields[10..40] {
                    *f = word;
                }
                fields.join(" ")
            })
        })
        .0
    };
    let run = |path: &Path| {
        let o = tool(&["log", "--summary", "-q", &path.display().to_string()]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        o
    };
    let whole = run(&logs().join("seattle-excerpt.log"));
    let nan = run(&blank("nan.log", "nan"));
    let inf = run(&blank("inf.log", "inf"));
    assert_eq!(json_lines(&nan).len(), json_lines(&whole).len());
    assert!(!stderr(&whole).contains("had no reading"));
    let scans = json_lines(&whole).len().div_ceil(4);
    for o in [&nan, &inf] {
        let e = stderr(o);
        assert!(
            e.contains(&format!(
                "{} beam(s) in {scans} scan(s) had no reading in the file",
                30 * scans
            )),
            "{e}"
        );
    }
    let fields = |o: &std::process::Output| {
        json_lines(o)
            .iter()
            .map(estimate_fields)
            .collect::<Vec<_>>()
    };
    assert_eq!(fields(&nan), fields(&inf));
    // Each pair names the scans' beams without a reading, and only theirs.
    for line in json_lines(&nan) {
        for (side, scan) in ["scan1", "scan2"].iter().enumerate() {
            let k = line[scan].as_u64().unwrap();
            let not_finite = line["dropped"][side]["not_finite"].as_u64();
            assert_eq!(not_finite, Some(if k % 4 == 1 { 30 } else { 0 }), "{line}");
        }
    }
}

#[test]
fn unusable_files_exit_with_status_2() {
    let missing = tool(&["log", "/nonexistent/x.log"]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(stderr(&missing).contains("/nonexistent/x.log: cannot read"));
    // Only bad lines: nothing to estimate from.
    let (bad, _) = edited_excerpt("all-bad.log", |_, _| Some("FLASER 3 1 2".into()));
    let o = tool(&["log", "-q", &bad.display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no usable laser scan"),
        "{}",
        stderr(&o)
    );
    // A binary file that is not MCAP reads as a CARMEN log without scans.
    let png = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/images/l-shape-a.png");
    let o = tool(&["log", "-q", &png.display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(!stderr(&o).contains("panicked"));
    // Options.
    for args in [
        vec!["--every", "0"],
        vec!["--pairs", "reference", "--reference", "99"],
        vec!["--pairs", "window", "--trajectory", "/tmp/x.csv"],
        vec!["--prior-sigma", "-1"],
        // Loop closures need a chained run, and closures to write.
        vec!["--prior", "none", "--closures", "/tmp/x.csv"],
        vec!["--prior", "odom", "--g2o", "/tmp/x.g2o"],
        vec!["--no-loops", "--closures", "/tmp/x.csv"],
    ] {
        let mut all = vec!["log", "-q"];
        let file = data("seattle-excerpt.log");
        all.push(&file);
        all.extend(args.iter().copied());
        let o = tool(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

/// The bundled pairs are lines of the shared Seattle pair file, verbatim
/// (skipped when `../shared/data` is absent).
#[test]
fn bundled_pairs_are_verbatim_lines_of_the_shared_file() {
    let pairs = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data/seattle-corrected_pairs.jsonl");
    if !pairs.exists() {
        eprintln!("skipped: {} absent", pairs.display());
        return;
    }
    // The excerpt's pairs are lines of the shared file, verbatim.
    let shared = std::fs::read_to_string(&pairs).expect("shared pairs");
    let excerpt =
        std::fs::read_to_string(logs().join("seattle-excerpt.pairs.jsonl")).expect("pairs");
    for line in excerpt.lines() {
        assert!(shared.lines().any(|l| l == line));
    }
}

/// `ROBOTLASER1` lines (with their own field of view, resolution, maximum
/// range and a laser offset given by the laser and robot poses) made from
/// the first bundled pair (fr079: 360 beams, laser 4 cm behind the robot's
/// centre) give the pair file's estimate, and the odometry delta is the
/// robot poses' delta.
#[test]
fn robotlaser1_lines_give_the_pair_files_estimate() {
    let pairs = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scans.jsonl");
    let first = std::fs::read_to_string(&pairs).expect("scans.jsonl");
    let first = first.lines().next().expect("a line");
    let pair: Value = serde_json::from_str(first).expect("JSON");
    let f = |v: &Value| v.as_f64().expect("a number");
    let robot = [(1.5, -2.0, 0.4), {
        // The robot pose of scan 2: scan 1's composed with the pair's truth.
        let (c, s) = (0.4f64.cos(), 0.4f64.sin());
        let (dx, dy) = (f(&pair["dx"]), f(&pair["dy"]));
        (
            1.5 + c * dx - s * dy,
            -2.0 + s * dx + c * dy,
            0.4 + f(&pair["dtheta"]),
        )
    }];
    let mut log =
        String::from("# ROBOTLASER1 excerpt\nPARAM robot_frontlaser_offset -0.04 host 0\n");
    for (k, name) in ["scan1", "scan2"].iter().enumerate() {
        let scan = &pair[name];
        let n = scan["ranges"].as_array().expect("ranges").len();
        let fov = f(&scan["angle_increment"]) * (n - 1) as f64;
        let ranges: Vec<String> = scan["ranges"]
            .as_array()
            .expect("ranges")
            .iter()
            .map(|r| r.to_string())
            .collect();
        let (rx, ry, rt) = robot[k];
        let off = &scan["laser_offset"];
        let (ox, oy, ot) = (f(&off[0]), f(&off[1]), f(&off[2]));
        let (lx, ly, lt) = (
            rx + rt.cos() * ox - rt.sin() * oy,
            ry + rt.sin() * ox + rt.cos() * oy,
            rt + ot,
        );
        log.push_str(&format!(
            "ROBOTLASER1 0 {} {fov} {} {} 0.01 0 {n} {} 0 {lx} {ly} {lt} {rx} {ry} {rt} 0 0 0 0 0 {} host {}\n",
            scan["angle_min"],
            scan["angle_increment"],
            scan["max_range"],
            ranges.join(" "),
            scan["t"],
            scan["t"],
        ));
    }
    let path = scratch("robotlaser1.log");
    std::fs::write(&path, log).expect("write");
    let from_log = tool(&["log", "-q", "--prior", "none", &path.display().to_string()]);
    assert_eq!(from_log.status.code(), Some(0), "{}", stderr(&from_log));
    let line_file = scratch("robotlaser1.pairs.jsonl");
    std::fs::write(&line_file, format!("{first}\n")).expect("write");
    let from_pairs = tool(&["scans", "-q", &line_file.display().to_string()]);
    let (a, b) = (json_lines(&from_log), json_lines(&from_pairs));
    assert_eq!(a.len(), 1);
    assert_eq!(estimate_fields(&a[0]), estimate_fields(&b[0]));
    let odom = &a[0]["odom"];
    assert!((f(&odom["dx_m"]) - f(&pair["dx"])).abs() < 1e-4, "{odom}");
    assert!((f(&odom["dy_m"]) - f(&pair["dy"])).abs() < 1e-4, "{odom}");
    assert!((f(&odom["dtheta_deg"]) - f(&pair["dtheta"]).to_degrees()).abs() < 1e-3);
    assert!(a[0].get("log_pose").is_none());
}

/// Damaged recordings never panic the readers: every truncation of the bag
/// (in steps) and single-byte corruptions throughout it, and CARMEN lines
/// with fields dropped, duplicated or replaced, are read to the end in
/// process (errors allowed, panics not).
/// ROS 1 bags of the same messages as the MCAP bag (written by the
/// `rosbags` Python package, bz2 and lz4 chunks) give the same output, line
/// for line: the same scans, times and odometry, read by another container
/// and another serialization; their topic is found without `--topic`.
#[test]
fn ros1_bags_read_like_the_mcap_bag() {
    let mcap = tool(&["log", "-q", &data("seattle-bag.mcap"), "--prior", "odom"]);
    assert_eq!(mcap.status.code(), Some(0), "{}", stderr(&mcap));
    for name in ["seattle-bag.bag", "seattle-bag-lz4.bag"] {
        let ros1 = tool(&["log", "-q", &data(name), "--prior", "odom"]);
        assert_eq!(ros1.status.code(), Some(0), "{name}: {}", stderr(&ros1));
        assert!(
            stderr(&ros1).contains("using /scan, the bag's only sensor_msgs/LaserScan topic"),
            "{}",
            stderr(&ros1)
        );
        assert_eq!(stdout(&ros1), stdout(&mcap), "{name}");
        // `--format ros1` names what auto-detection found.
        let named = tool(&[
            "log",
            "-q",
            &data(name),
            "--format",
            "ros1",
            "--prior",
            "odom",
        ]);
        assert_eq!(stdout(&named), stdout(&mcap), "{name}");
    }
    assert_same_as_scans(
        &["log", "-q", &data("seattle-bag.bag"), "--topic", "/scan"],
        "seattle-bag.pairs.jsonl",
    );
    // The same scans as `MultiEchoLaserScan` (one echo a beam) on `/echoes`.
    let echoes = tool(&[
        "log",
        "-q",
        &data("seattle-bag.bag"),
        "--topic",
        "/echoes",
        "--prior",
        "odom",
    ]);
    assert_eq!(echoes.status.code(), Some(0), "{}", stderr(&echoes));
    assert_eq!(stdout(&echoes), stdout(&mcap));
}

#[test]
fn ros1_bag_topics_and_types_are_checked() {
    let unknown = tool(&["log", &data("seattle-bag.bag"), "--topic", "/nope"]);
    assert_eq!(unknown.status.code(), Some(2));
    let e = stderr(&unknown);
    for t in [
        "no messages on topic /nope",
        "/scan  (sensor_msgs/LaserScan, 12 messages)",
        "/odom  (nav_msgs/Odometry, 12 messages)",
        "/chatter  (std_msgs/String, 3 messages)",
        "/echoes  (sensor_msgs/MultiEchoLaserScan, 12 messages)",
    ] {
        assert!(e.contains(t), "{t} not in {e}");
    }
    let o = tool(&["log", &data("seattle-bag.bag"), "--topic", "/chatter"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("on topic /chatter is std_msgs/String")
            && e.contains("expected sensor_msgs/LaserScan"),
        "{e}"
    );
    let o = tool(&["log", &data("seattle-bag.bag"), "--odom-topic", "/scan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("topic /scan carries sensor_msgs/LaserScan, not nav_msgs/Odometry"),
        "{}",
        stderr(&o)
    );
}

/// A ROS 2 bag in SQLite of the same messages (written by the `rosbags`
/// Python package), given as its directory or its `.db3` file, gives the
/// MCAP bag's output line for line.
#[test]
fn ros2_sqlite_bags_read_like_the_mcap_bag() {
    let mcap = tool(&["log", "-q", &data("seattle-bag.mcap"), "--prior", "odom"]);
    assert_eq!(mcap.status.code(), Some(0), "{}", stderr(&mcap));
    let dir = data("seattle-bag-db3");
    let file = data("seattle-bag-db3/seattle-bag-db3.db3");
    for path in [&dir, &file] {
        let o = tool(&["log", "-q", path, "--prior", "odom"]);
        assert_eq!(o.status.code(), Some(0), "{path}: {}", stderr(&o));
        assert_eq!(stdout(&o), stdout(&mcap), "{path}");
    }
    let named = tool(&["log", "-q", &dir, "--format", "db3", "--topic", "/scan"]);
    assert_eq!(named.status.code(), Some(0), "{}", stderr(&named));
    assert_eq!(json_lines(&named).len(), 11);
}

#[test]
fn ros2_sqlite_bag_errors_are_named() {
    let unknown = tool(&["log", &data("seattle-bag-db3"), "--topic", "/nope"]);
    assert_eq!(unknown.status.code(), Some(2));
    let e = stderr(&unknown);
    for t in [
        "no messages on topic /nope",
        "/scan  (sensor_msgs/msg/LaserScan, 12 messages)",
        "/chatter  (std_msgs/msg/String, 3 messages)",
    ] {
        assert!(e.contains(t), "{t} not in {e}");
    }
    let o = tool(&["log", &data("seattle-bag-db3"), "--topic", "/chatter"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o)
            .contains("seattle-bag-db3: message 2 on topic /chatter is std_msgs/msg/String (cdr encoding); expected"),
        "{}",
        stderr(&o)
    );
    // A directory of several bags, and a truncated database.
    let o = tool(&["log", &logs().display().to_string()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("2 bag files and no metadata.yaml to order them"),
        "{}",
        stderr(&o)
    );
    let bytes = std::fs::read(logs().join("seattle-bag-db3/seattle-bag-db3.db3")).expect("db3");
    let cut = scratch("cut.db3");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).expect("write");
    let o = tool(&["log", &cut.display().to_string(), "--topic", "/scan"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("not a readable ROS 2 bag in SQLite") && !e.contains("panicked"),
        "{e}"
    );
}

/// A ROS 2 bag directory in MCAP (written by `rosbags`' own MCAP writer)
/// reads like the bundled MCAP file; a split bag's files are read in the
/// order `metadata.yaml` lists them, each named in its errors.
#[test]
fn ros2_bag_directories_read_their_files_in_order() {
    let mcap = tool(&["log", "-q", &data("seattle-bag.mcap"), "--prior", "odom"]);
    let dir = tool(&["log", "-q", &data("seattle-bag-dir"), "--prior", "odom"]);
    assert_eq!(dir.status.code(), Some(0), "{}", stderr(&dir));
    assert_eq!(stdout(&dir), stdout(&mcap));
    // A split bag: the NaN-scan bag (3 scans, the second unusable), then
    // the Seattle bag (12 scans), as metadata.yaml lists them.
    let split = scratch("split-bag");
    let _ = std::fs::remove_dir_all(&split);
    std::fs::create_dir_all(&split).expect("scratch dir");
    std::fs::copy(logs().join("nan-scan.mcap"), split.join("part_0.mcap")).expect("copy");
    std::fs::copy(logs().join("seattle-bag.mcap"), split.join("part_1.mcap")).expect("copy");
    std::fs::write(
        split.join("metadata.yaml"),
        "rosbag2_bagfile_information:\n  relative_file_paths:\n  - part_0.mcap\n  - part_1.mcap\n  storage_identifier: mcap\n",
    )
    .expect("metadata");
    let o = tool(&[
        "log",
        "-q",
        &split.display().to_string(),
        "--topic",
        "/scan",
        "--prior",
        "none",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("part_0.mcap: message") && e.contains("all 361 ranges are NaN"),
        "{e}"
    );
    // 2 usable scans, then 12: 13 consecutive pairs, the second file's
    // eleven as in the file alone.
    let lines = json_lines(&o);
    assert_eq!(lines.len(), 13);
    let alone = json_lines(&tool(&[
        "log",
        "-q",
        &data("seattle-bag.mcap"),
        "--topic",
        "/scan",
        "--prior",
        "none",
    ]));
    let f = |v: &Value| estimate_fields(v);
    assert!(lines[2..].iter().map(f).eq(alone.iter().map(f)));
}
