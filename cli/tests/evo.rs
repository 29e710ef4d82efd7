//! `log --trajectory FILE.tum|.kitti` and the APE / RPE of `log --summary`
//! on the bundled Seattle excerpt, re-computed here from the written files
//! (positions and headings read back from the TUM quaternions), with
//! `evo`'s definitions: APE = ‖t(P_i) − t(Q_i)‖, RPE = ‖trans((Q_i⁻¹Q_{i+1})⁻¹
//! (P_i⁻¹P_{i+1}))‖. The Python tests run `evo` itself on the same files.

mod common;

use std::path::Path;

use common::{scratch, tool};

fn log_file() -> String {
    common::log_path("seattle-excerpt.log.gz")
}

/// `(t, x, y, θ)` rows of a TUM file (θ from the quaternion, checked to be
/// a unit turn about z).
fn read_tum(path: &Path) -> Vec<[f64; 4]> {
    std::fs::read_to_string(path)
        .expect("a TUM file")
        .lines()
        .map(|l| {
            let f: Vec<f64> = l.split(' ').map(|v| v.parse().expect("a number")).collect();
            assert_eq!(f.len(), 8, "{l}");
            let (qx, qy, qz, qw) = (f[4], f[5], f[6], f[7]);
            assert_eq!((f[3], qx, qy), (0.0, 0.0, 0.0));
            assert!((qz * qz + qw * qw - 1.0).abs() < 1e-8);
            [f[0], f[1], f[2], 2.0 * qz.atan2(qw)]
        })
        .collect()
}

/// `p⁻¹·q` of planar poses `(x, y, θ)`.
fn between(p: [f64; 3], q: [f64; 3]) -> [f64; 3] {
    let (s, c) = p[2].sin_cos();
    let (ex, ey) = (q[0] - p[0], q[1] - p[1]);
    [c * ex + s * ey, -s * ex + c * ey, q[2] - p[2]]
}

fn rmse(v: &[f64]) -> f64 {
    (v.iter().map(|e| e * e).sum::<f64>() / v.len() as f64).sqrt()
}

/// The value of column `column` in the table row starting `| name |`.
fn table_value(text: &str, name: &str, column: usize) -> f64 {
    let row = text
        .lines()
        .find(|l| l.starts_with(&format!("| {name} |")))
        .unwrap_or_else(|| panic!("no row {name} in {text}"));
    row.split('|')
        .nth(column + 1)
        .expect("a cell")
        .trim()
        .parse()
        .expect("a number")
}

#[test]
fn tum_trajectories_carry_the_recording_s_times_and_the_summary_s_errors() {
    let dir = scratch("tum");
    let out = dir.join("seattle.tum");
    let o = tool(&[
        "log",
        &log_file(),
        "--summary",
        "--trajectory",
        &out.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(0));
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    let est = read_tum(&out);
    let reference = read_tum(&dir.join("seattle-reference.tum"));
    let odometry = read_tum(&dir.join("seattle-odometry.tum"));
    assert_eq!((est.len(), reference.len(), odometry.len()), (20, 20, 20));
    // The times are the scans' (t1, t2 of the JSON lines), increasing.
    let lines: Vec<serde_json::Value> = String::from_utf8_lossy(&o.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON"))
        .collect();
    let mut times = vec![lines[0]["t1"].as_f64().expect("t1")];
    times.extend(lines.iter().map(|l| l["t2"].as_f64().expect("t2")));
    for (row, t) in est.iter().zip(&times) {
        assert!((row[0] - t).abs() < 1e-6, "{} vs {t}", row[0]);
    }
    assert!(est.windows(2).all(|w| w[1][0] > w[0][0]));
    assert_eq!(est[0][1..], [0.0; 3]);
    // APE and RPE of the files, against the summary's table.
    let pose = |r: &[f64; 4]| [r[1], r[2], r[3]];
    let ape: Vec<f64> = est
        .iter()
        .zip(&reference)
        .map(|(p, q)| (p[1] - q[1]).hypot(p[2] - q[2]))
        .collect();
    let mut rpe = Vec::new();
    let mut rpe_deg = Vec::new();
    for i in 0..est.len() - 1 {
        let dp = between(pose(&est[i]), pose(&est[i + 1]));
        let dq = between(pose(&reference[i]), pose(&reference[i + 1]));
        let e = between(dq, dp);
        rpe.push(e[0].hypot(e[1]));
        let a = e[2].sin().atan2(e[2].cos());
        rpe_deg.push(a.abs().to_degrees());
    }
    let near = |a: f64, b: f64| (a - b).abs() < 6e-5;
    assert!(
        near(table_value(&stderr, "estimates", 1), rmse(&ape)),
        "{stderr}"
    );
    let max = ape.iter().copied().fold(0.0, f64::max);
    assert!(near(table_value(&stderr, "estimates", 5), max));
    assert!(near(table_value(&stderr, "estimates", 6), rmse(&rpe)));
    assert!((table_value(&stderr, "estimates", 9) - rmse(&rpe_deg)).abs() < 1e-3);
    // The estimates follow the corrected poses far better than the
    // (synthetic, drifting) odometry does.
    let odom_ape: Vec<f64> = odometry
        .iter()
        .zip(&reference)
        .map(|(p, q)| (p[1] - q[1]).hypot(p[2] - q[2]))
        .collect();
    assert!(near(table_value(&stderr, "odometry", 1), rmse(&odom_ape)));
    assert!(rmse(&ape) < 0.1 && rmse(&odom_ape) > 3.0 * rmse(&ape));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn kitti_rows_are_the_tum_poses() {
    let dir = scratch("kitti");
    let (tum, kitti) = (dir.join("a.tum"), dir.join("a.kitti"));
    for path in [&tum, &kitti] {
        let o = tool(&[
            "log",
            "-q",
            &log_file(),
            "--trajectory",
            &path.display().to_string(),
        ]);
        assert_eq!(o.status.code(), Some(0));
    }
    for (t, k) in [
        ("a.tum", "a.kitti"),
        ("a-reference.tum", "a-reference.kitti"),
    ] {
        let tum = read_tum(&dir.join(t));
        let rows = std::fs::read_to_string(dir.join(k)).expect("a KITTI file");
        let rows: Vec<Vec<f64>> = rows
            .lines()
            .map(|l| l.split(' ').map(|v| v.parse().expect("a number")).collect())
            .collect();
        assert_eq!(rows.len(), tum.len());
        for (r, p) in rows.iter().zip(&tum) {
            assert_eq!(r.len(), 12);
            let (s, c) = p[3].sin_cos();
            let want = [c, -s, 0.0, p[1], s, c, 0.0, p[2], 0.0, 0.0, 1.0, 0.0];
            for (a, b) in r.iter().zip(want) {
                assert!((a - b).abs() < 2e-6, "{r:?} vs {want:?}");
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
