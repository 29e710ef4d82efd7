//! Trajectories in the formats `evo` reads, and the absolute and relative
//! pose errors of `log --summary` with `evo`'s definitions.
//!
//! `--trajectory FILE.tum` writes the chained estimates as a TUM trajectory
//! (`t x y z qx qy qz qw`, one pose a line, the time of the scan from the
//! recording, z = 0, the heading as a unit quaternion about z), and beside it
//! `FILE-reference.tum` (the log's own poses: corrected in a Radish
//! `-corrected` log) and `FILE-odometry.tum` when the log has them, so that
//! `evo_ape tum FILE-reference.tum FILE.tum` and `evo_rpe …` score it.
//! `FILE.kitti` writes the same poses as KITTI rows (the 3 × 4 matrix
//! `[R | t]`, row-major; evo pairs KITTI files line by line). Any other
//! extension keeps the CSV of [`Trajectory::write_csv`]. All tracks start at
//! the first scan's pose (the origin, facing +x).
//!
//! The errors follow `evo`'s defaults (`evo_ape` / `evo_rpe` with
//! `--pose_relation trans_part`, no alignment, `--delta 1 --delta_unit f`):
//! with `P_i` the estimated and `Q_i` the reference pose (as 3-D rigid
//! transforms),
//!
//! - APE_i = ‖trans(Q_i⁻¹·P_i)‖ = ‖t(P_i) − t(Q_i)‖;
//! - RPE_i = ‖trans((Q_i⁻¹·Q_{i+1})⁻¹ · (P_i⁻¹·P_{i+1}))‖ over consecutive
//!   poses, and its rotation angle in degrees (`--pose_relation angle_deg`);
//!
//! each reported as `evo` does (RMSE, mean, median, standard deviation with
//! divisor n, min, max). Poses without a reference are skipped (evo
//! associates by time stamp; these files share theirs).

use std::fmt::Write as _;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::error::Fatal;
use crate::model::{wrap_rad, Pose};
use crate::stats::{markdown_header, markdown_row};
use crate::trajectory::{Step, Trajectory};

/// The file format of `--trajectory`, by the file's extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TrajectoryFormat {
    /// `.tum`: `t x y z qx qy qz qw`.
    Tum,
    /// `.kitti`: 12 numbers a line, `[R | t]` row-major.
    Kitti,
    /// Anything else: the CSV with the odometry's and the log's poses.
    Csv,
}

impl TrajectoryFormat {
    /// The format of `path` (its extension, any case).
    pub fn of(path: &Path) -> Self {
        match path
            .extension()
            .map(|e| e.to_string_lossy().to_ascii_lowercase())
            .as_deref()
        {
            Some("tum") => Self::Tum,
            Some("kitti") => Self::Kitti,
            _ => Self::Csv,
        }
    }
}

/// `path` with `-suffix` added to its stem: `out.tum` → `out-reference.tum`.
pub fn companion(path: &Path, suffix: &str) -> PathBuf {
    let stem = path
        .file_stem()
        .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{suffix}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{suffix}"),
    };
    path.with_file_name(name)
}

/// The unit quaternion `(qx, qy, qz, qw)` of a turn by `theta` about z.
pub fn quaternion(theta: f64) -> [f64; 4] {
    let (s, c) = (theta / 2.0).sin_cos();
    [0.0, 0.0, s, c]
}

/// One TUM line.
pub fn tum_line(time: f64, p: &Pose) -> String {
    let [qx, qy, qz, qw] = quaternion(p.theta);
    format!(
        "{time:.6} {:.6} {:.6} 0 {qx:.9} {qy:.9} {qz:.9} {qw:.9}",
        p.x, p.y
    )
}

/// One KITTI line: `r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz`.
pub fn kitti_line(p: &Pose) -> String {
    let (s, c) = p.theta.sin_cos();
    format!(
        "{c:.9} {:.9} 0 {:.6} {s:.9} {c:.9} 0 {:.6} 0 0 1 0",
        -s, p.x, p.y
    )
}

/// The time stamp of a step: the scan's, or its index when the recording
/// has none (evo needs one; [`write`] says so on stderr).
fn stamp(s: &Step) -> f64 {
    s.time.unwrap_or(s.scan as f64)
}

fn write_lines(path: &Path, lines: impl Iterator<Item = String>) -> Result<(), Fatal> {
    let fail = |e: std::io::Error| Fatal::io(format!("{}: cannot write: {e}", path.display()));
    let mut out = BufWriter::new(File::create(path).map_err(fail)?);
    for line in lines {
        writeln!(out, "{line}").map_err(fail)?;
    }
    out.flush().map_err(fail)
}

/// The three tracks of a chain: estimates, the log's poses, odometry.
type Track = fn(&Step) -> Option<Pose>;
const TRACKS: [(&str, Track); 3] = [
    ("estimates", |s| Some(s.pose)),
    ("reference", |s| s.log_pose),
    ("odometry", |s| s.odom),
];

/// Writes `--trajectory` in the format of its extension (TUM and KITTI with
/// their companion files); the files written, for the message.
///
/// # Errors
/// An unwritable file.
pub fn write(t: &Trajectory, path: &Path) -> Result<Vec<PathBuf>, Fatal> {
    let format = TrajectoryFormat::of(path);
    if format == TrajectoryFormat::Csv {
        t.write_csv(path)?;
        return Ok(vec![path.to_path_buf()]);
    }
    if format == TrajectoryFormat::Tum && t.steps.iter().any(|s| s.time.is_none()) {
        eprintln!(
            "hough-heading: {}: some scans have no time in the recording: their TUM time is \
             the scan's index",
            path.display()
        );
    }
    let mut written = Vec::new();
    for (name, track) in TRACKS {
        let target = match name {
            "estimates" => path.to_path_buf(),
            other => companion(path, other),
        };
        let poses: Vec<(f64, Pose)> = t
            .steps
            .iter()
            .filter_map(|s| track(s).map(|p| (stamp(s), p)))
            .collect();
        // KITTI rows pair by line: a track with gaps would shift them.
        let complete = poses.len() == t.steps.len();
        if poses.is_empty() || (format == TrajectoryFormat::Kitti && !complete) {
            continue;
        }
        match format {
            TrajectoryFormat::Tum => {
                write_lines(&target, poses.iter().map(|(time, p)| tum_line(*time, p)))?
            }
            _ => write_lines(&target, poses.iter().map(|(_, p)| kitti_line(p)))?,
        }
        written.push(target);
    }
    Ok(written)
}

/// `evo`'s statistics of one error series.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorStats {
    /// Values.
    pub n: usize,
    /// Root mean square.
    pub rmse: f64,
    /// Mean.
    pub mean: f64,
    /// Median (the mean of the two middle values for even `n`).
    pub median: f64,
    /// Standard deviation, divisor `n`.
    pub std: f64,
    /// Smallest.
    pub min: f64,
    /// Largest.
    pub max: f64,
}

impl ErrorStats {
    /// The statistics of `values` (`None` when empty).
    pub fn of(values: &[f64]) -> Option<Self> {
        if values.is_empty() {
            return None;
        }
        let n = values.len();
        let nf = n as f64;
        let mean = values.iter().sum::<f64>() / nf;
        let sse: f64 = values.iter().map(|v| v * v).sum();
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / nf;
        let mut sorted = values.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median = if n % 2 == 1 {
            sorted[n / 2]
        } else {
            (sorted[n / 2 - 1] + sorted[n / 2]) / 2.0
        };
        Some(Self {
            n,
            rmse: (sse / nf).sqrt(),
            mean,
            median,
            std: var.sqrt(),
            min: sorted[0],
            max: sorted[n - 1],
        })
    }
}

/// APE and RPE of one track against the reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseErrors {
    /// APE, translation part, metres.
    pub ape: ErrorStats,
    /// RPE over one frame, translation part, metres.
    pub rpe: Option<ErrorStats>,
    /// RPE over one frame, rotation angle, degrees.
    pub rpe_deg: Option<ErrorStats>,
}

/// `evo`'s APE and RPE of `(estimate, reference)` pose pairs, in order.
pub fn pose_errors(pairs: &[(Pose, Pose)]) -> Option<PoseErrors> {
    let ape: Vec<f64> = pairs
        .iter()
        .map(|(p, q)| (p.x - q.x).hypot(p.y - q.y))
        .collect();
    let (mut rpe, mut rpe_deg) = (Vec::new(), Vec::new());
    for w in pairs.windows(2) {
        let ((p0, q0), (p1, q1)) = (w[0], w[1]);
        // E = (Q0⁻¹ Q1)⁻¹ (P0⁻¹ P1): its translation is the estimated
        // relative step, minus the reference's, in the reference step's
        // end frame.
        let (dp, dq) = (p0.between(&p1), q0.between(&q1));
        let e = dq.between(&dp);
        rpe.push(e.x.hypot(e.y));
        rpe_deg.push(wrap_rad(e.theta).abs().to_degrees());
    }
    Some(PoseErrors {
        ape: ErrorStats::of(&ape)?,
        rpe: ErrorStats::of(&rpe),
        rpe_deg: ErrorStats::of(&rpe_deg),
    })
}

/// The `(track, log pose)` pairs of a chain for one track.
fn paired(t: &Trajectory, track: Track) -> Vec<(Pose, Pose)> {
    t.steps
        .iter()
        .filter_map(|s| track(s).zip(s.log_pose))
        .collect()
}

/// The APE / RPE table of `--summary`: the chained estimates and the
/// odometry against the log's poses; `None` when the log has no poses.
pub fn report(t: &Trajectory) -> Option<String> {
    let estimates = pose_errors(&paired(t, TRACKS[0].1))?;
    let mut out = format!(
        "chained estimates vs the log's poses, {} poses (evo_ape / evo_rpe \
         definitions: translation part, no alignment, RPE over 1 frame):\n\n",
        estimates.ape.n
    );
    out.push_str(&markdown_header(&[
        "track",
        "APE RMSE (m)",
        "APE mean",
        "APE median",
        "APE std",
        "APE max",
        "RPE RMSE (m)",
        "RPE mean",
        "RPE max",
        "RPE rot RMSE (°)",
        "RPE rot mean (°)",
    ]));
    let mut rows = vec![("estimates", estimates)];
    if let Some(o) = pose_errors(&paired(t, TRACKS[2].1)) {
        rows.push(("odometry", o));
    }
    let f = |v: Option<f64>| v.map_or("–".to_string(), |v| format!("{v:.4}"));
    for (name, e) in rows {
        let _ = write!(
            out,
            "{}",
            markdown_row(&[
                name.to_string(),
                f(Some(e.ape.rmse)),
                f(Some(e.ape.mean)),
                f(Some(e.ape.median)),
                f(Some(e.ape.std)),
                f(Some(e.ape.max)),
                f(e.rpe.map(|s| s.rmse)),
                f(e.rpe.map(|s| s.mean)),
                f(e.rpe.map(|s| s.max)),
                f(e.rpe_deg.map(|s| s.rmse)),
                f(e.rpe_deg.map(|s| s.mean)),
            ])
        );
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(x: f64, y: f64, theta: f64) -> Pose {
        Pose { x, y, theta }
    }

    /// A 3-D rigid transform of a planar pose, row-major 4 × 4.
    fn se3(p: &Pose) -> [[f64; 4]; 4] {
        let (s, c) = p.theta.sin_cos();
        [
            [c, -s, 0.0, p.x],
            [s, c, 0.0, p.y],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    fn mul(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
        let mut m = [[0.0; 4]; 4];
        for (i, row) in m.iter_mut().enumerate() {
            for (j, v) in row.iter_mut().enumerate() {
                *v = (0..4).map(|k| a[i][k] * b[k][j]).sum();
            }
        }
        m
    }

    /// Inverse of a rigid transform: `[Rᵀ | −Rᵀt]`.
    fn inv(a: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
        let mut m = [[0.0; 4]; 4];
        for i in 0..3 {
            for j in 0..3 {
                m[i][j] = a[j][i];
            }
            m[i][3] = -(0..3).map(|k| a[k][i] * a[k][3]).sum::<f64>();
        }
        m[3][3] = 1.0;
        m
    }

    #[test]
    fn rpe_is_evo_s_matrix_formula() {
        // Independent: the 4 × 4 matrices of evo's RPE, against `pose_errors`.
        let est = [
            pose(0.0, 0.0, 0.0),
            pose(1.0, 0.2, 0.3),
            pose(1.5, 1.1, 1.2),
            pose(0.7, 2.0, 2.9),
        ];
        let reference = [
            pose(0.0, 0.0, 0.0),
            pose(0.9, 0.1, 0.25),
            pose(1.6, 1.0, 1.3),
            pose(0.5, 2.2, -3.0),
        ];
        let pairs: Vec<(Pose, Pose)> = est.iter().copied().zip(reference).collect();
        let e = pose_errors(&pairs).expect("errors");
        let mut trans = Vec::new();
        let mut angles = Vec::new();
        for i in 0..3 {
            let dq = mul(&inv(&se3(&reference[i])), &se3(&reference[i + 1]));
            let dp = mul(&inv(&se3(&est[i])), &se3(&est[i + 1]));
            let m = mul(&inv(&dq), &dp);
            trans.push(m[0][3].hypot(m[1][3]));
            // Rotation angle of a 3-D rotation: acos((trace − 1) / 2).
            let trace = m[0][0] + m[1][1] + m[2][2];
            angles.push(((trace - 1.0) / 2.0).clamp(-1.0, 1.0).acos().to_degrees());
        }
        let want = ErrorStats::of(&trans).unwrap();
        let got = e.rpe.unwrap();
        assert!((want.rmse - got.rmse).abs() < 1e-12, "{want:?} {got:?}");
        assert!((want.max - got.max).abs() < 1e-12);
        let want = ErrorStats::of(&angles).unwrap();
        assert!((want.rmse - e.rpe_deg.unwrap().rmse).abs() < 1e-9);
        // APE: the distance of the positions.
        let ape: Vec<f64> = est
            .iter()
            .zip(&reference)
            .map(|(p, q)| {
                let m = mul(&inv(&se3(q)), &se3(p));
                m[0][3].hypot(m[1][3])
            })
            .collect();
        assert!((ErrorStats::of(&ape).unwrap().rmse - e.ape.rmse).abs() < 1e-12);
    }

    #[test]
    fn stats_are_numpy_s() {
        let s = ErrorStats::of(&[3.0, 1.0, 4.0, 2.0]).unwrap();
        assert_eq!(s.median, 2.5);
        assert_eq!(s.mean, 2.5);
        assert!((s.std - 1.25f64.sqrt()).abs() < 1e-15);
        assert!((s.rmse - 7.5f64.sqrt()).abs() < 1e-15);
        assert_eq!((s.min, s.max, s.n), (1.0, 4.0, 4));
        assert_eq!(ErrorStats::of(&[5.0, 1.0, 3.0]).unwrap().median, 3.0);
        assert!(ErrorStats::of(&[]).is_none());
    }

    #[test]
    fn lines_and_names() {
        let p = pose(1.5, -2.0, std::f64::consts::FRAC_PI_2);
        let tum = tum_line(12.25, &p);
        let f: Vec<f64> = tum.split(' ').map(|v| v.parse().unwrap()).collect();
        assert_eq!(f.len(), 8);
        assert_eq!(&f[..4], &[12.25, 1.5, -2.0, 0.0]);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        assert!((f[6] - h).abs() < 1e-9 && (f[7] - h).abs() < 1e-9);
        let k: Vec<f64> = kitti_line(&p)
            .split(' ')
            .map(|v| v.parse().unwrap())
            .collect();
        assert_eq!(k.len(), 12);
        // [R | t] with R a quarter turn: r11 = 0, r12 = −1, r21 = 1.
        assert!(k[0].abs() < 1e-9 && (k[1] + 1.0).abs() < 1e-9 && (k[4] - 1.0).abs() < 1e-9);
        assert_eq!((k[3], k[7], k[11]), (1.5, -2.0, 0.0));
        assert_eq!(
            companion(Path::new("a/out.tum"), "reference"),
            Path::new("a/out-reference.tum")
        );
        assert_eq!(
            TrajectoryFormat::of(Path::new("x.KITTI")),
            TrajectoryFormat::Kitti
        );
        assert_eq!(
            TrajectoryFormat::of(Path::new("x.csv")),
            TrajectoryFormat::Csv
        );
    }
}
