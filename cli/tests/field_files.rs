//! Recordings from the field read whole and summarised without reference
//! poses: `log` on the `laser_scan_matcher` demo bag (a ROS 1 bag in the
//! layout older rosbag wrote) and the Olin ROS 2 SQLite bag (real data,
//! skipped when `../shared/data` is absent, except on CI), and `--summary`
//! on the bundled bags, which have odometry but no poses to score against.

mod common;

use common::{json_lines, log_path, scratch_file, shared_data, stderr, stdout, tool};

/// The CSV trajectory's rows: `theta` and `odom_theta` (radians) a row.
fn headings(csv: &str) -> Vec<(f64, Option<f64>)> {
    csv.lines()
        .skip(1)
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            (cells[4].parse().unwrap(), cells[8].parse().ok())
        })
        .collect()
}

fn wrap_deg(d: f64) -> f64 {
    let w = d.rem_euclid(360.0);
    if w > 180.0 {
        w - 360.0
    } else {
        w
    }
}

/// The demo bag's index data records state a wrong data length (20 bytes
/// an entry for 12): read by their count, all 360 scans are read.
#[test]
fn the_laser_scan_matcher_demo_bag_reads_whole() {
    let Some(bag) = shared_data("dense/laser-scan-matcher-demo.bag") else {
        return;
    };
    let o = tool(&["log", bag.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(stdout(&o).lines().count(), 359);
    assert!(
        stderr(&o).contains(": 360 scans, 359 keyframe pairs (0 failed record(s) or pair(s))"),
        "{}",
        stderr(&o)
    );
}

/// `--summary` without reference poses: no empty table, no failed lines,
/// and the chain's figures, which the trajectory file gives independently.
#[test]
fn summary_without_reference_poses_reports_the_chain_and_its_odometry() {
    for bag in ["seattle-bag-db3", "seattle-bag.bag", "seattle-bag.mcap"] {
        let csv = scratch_file("field-files", &format!("{bag}.csv"));
        let o = tool(&[
            "log",
            &log_path(bag),
            "--topic",
            "/scan",
            "--summary",
            "--trajectory",
            csv.to_str().unwrap(),
            "-q",
        ]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let err = stderr(&o);
        assert!(err.contains("no reference poses to score against"), "{err}");
        assert!(!err.contains("failed and are not counted"), "{err}");
        assert!(!err.contains("| subset |"), "{err}");
        // The flags by kind, as the JSON lines give them.
        let mut statuses = std::collections::BTreeMap::new();
        for line in json_lines(&o) {
            *statuses
                .entry(line["status"].as_str().unwrap().to_string())
                .or_insert(0) += 1;
        }
        let by_status: Vec<String> = statuses.iter().map(|(s, n)| format!("{s} {n}")).collect();
        assert!(
            err.contains(&format!(
                "pairs by their estimate's status (the JSON lines' `status`): {}\n",
                by_status.join(", ")
            )),
            "{err}"
        );
        let rows = headings(&std::fs::read_to_string(&csv).unwrap());
        assert_eq!(rows.len(), 12);
        assert!(
            rows.iter().all(|r| r.1.is_some()),
            "{bag}: odometry in every row"
        );
        assert!(
            err.contains("| chain steps (one a scan after the first) | 11 |"),
            "{err}"
        );
        let turn: f64 = rows
            .windows(2)
            .map(|w| wrap_deg((w[1].0 - w[0].0).to_degrees()))
            .sum();
        assert!(
            err.contains(&format!("| chained turn | {turn:.1}° |")),
            "{err}"
        );
        let within = rows
            .windows(2)
            .filter(|w| {
                let chain = w[1].0 - w[0].0;
                let odom = w[1].1.unwrap() - w[0].1.unwrap();
                wrap_deg((chain - odom).to_degrees()).abs() <= 2.0
            })
            .count();
        let line = format!(
            "| steps within 2° of the odometry's turn | {:.1} % ({within}/11) |",
            100.0 * within as f64 / 11.0
        );
        assert!(err.contains(&line), "{err}");
    }
}

/// The Olin bag's first odometry message (1663967375.866 s) comes after its
/// first three scans: the trajectory's odometry columns are filled from the
/// fourth scan on, and the summary compares the chain with them.
#[test]
fn the_olin_bags_trajectory_carries_its_odometry() {
    let Some(bag) = shared_data("dense/olin-rplidar-macfirst-floor") else {
        return;
    };
    let csv = scratch_file("field-files", "olin.csv");
    let o = tool(&[
        "log",
        bag.to_str().unwrap(),
        "--summary",
        "--trajectory",
        csv.to_str().unwrap(),
        "-q",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let rows = headings(&std::fs::read_to_string(&csv).unwrap());
    assert_eq!(rows.len(), 357);
    assert!(rows[..3].iter().all(|r| r.1.is_none()));
    assert!(rows[3..].iter().all(|r| r.1.is_some()));
    let err = stderr(&o);
    assert!(err.contains("no reference poses to score against"), "{err}");
    assert!(
        err.contains("| chain steps (one a scan after the first) | 356 |"),
        "{err}"
    );
    assert!(
        err.contains("steps within 2° of the odometry's turn"),
        "{err}"
    );
}
