//! Scan-pair files (`../shared/data/*.jsonl`, one pair per line): reading,
//! estimating, and the per-line JSON output.
//!
//! Estimation reads only `scan1` and `scan2`; the ground truth (`dx`, `dy`,
//! `dtheta`, `check.overlap_gt`) is read separately, and only for the
//! summary.

use hough_heading::{
    Angle, BeamCheck, BeamFit, BeamFitError, Estimate, HalfTurn, Mode, Pose, Prior, Raster, Scan,
    ScanStats, SensorOffset, Status,
};
use serde::Deserialize;

use crate::engine::{Engine, View};

/// One scan as stored in a pair file.
#[derive(Clone, Debug, Deserialize)]
pub struct ScanRecord {
    /// Ranges in metres; `null` reads as NaN (dropped).
    pub ranges: Vec<Option<f32>>,
    /// Direction of beam 0, radians.
    pub angle_min: f32,
    /// Angle between beams, radians.
    pub angle_increment: f32,
    /// "No return" at or beyond this, metres.
    pub max_range: f32,
    /// Laser pose `[x, y, θ]` in the robot frame (default: at the origin).
    #[serde(default)]
    pub laser_offset: [f32; 3],
}

impl ScanRecord {
    /// The valid returns as points `(x, y)` in the robot frame, metres (f64,
    /// for the summary's independent checks).
    pub fn points(&self) -> Vec<(f64, f64)> {
        let [ox, oy, oth] = self.laser_offset.map(f64::from);
        self.ranges
            .iter()
            .enumerate()
            .filter_map(|(i, r)| {
                let r = f64::from((*r)?);
                (r.is_finite() && r > 0.0 && r < f64::from(self.max_range)).then(|| {
                    let a = f64::from(self.angle_min)
                        + i as f64 * f64::from(self.angle_increment)
                        + oth;
                    (ox + r * a.cos(), oy + r * a.sin())
                })
            })
            .collect()
    }

    /// The ranges with `null` as NaN.
    pub fn ranges(&self) -> Vec<f32> {
        self.ranges.iter().map(|r| r.unwrap_or(f32::NAN)).collect()
    }

    /// The library's view of this scan over `ranges` (from [`Self::ranges`]).
    pub fn scan<'a>(&self, ranges: &'a [f32]) -> Scan<'a> {
        Scan {
            ranges,
            angle_min: self.angle_min,
            angle_increment: self.angle_increment,
            max_range: self.max_range,
            offset: SensorOffset {
                x: self.laser_offset[0],
                y: self.laser_offset[1],
                theta: self.laser_offset[2],
            },
        }
    }
}

/// The part of a line the estimator reads.
#[derive(Clone, Debug, Deserialize)]
pub struct PairRecord {
    /// The reference scan.
    pub scan1: ScanRecord,
    /// The new scan.
    pub scan2: ScanRecord,
}

/// The ground truth of a line (summary only).
#[derive(Clone, Copy, Debug, Deserialize)]
pub struct Truth {
    /// Robot x at scan 2 in the robot frame at scan 1, metres.
    pub dx: f64,
    /// Robot y, metres.
    pub dy: f64,
    /// Heading change, radians (positive = left turn).
    pub dtheta: f64,
    /// Quality checks.
    #[serde(default)]
    pub check: Check,
}

/// The `check` object of a line.
#[derive(Clone, Copy, Debug, Default, Deserialize)]
pub struct Check {
    /// Fraction of scan-2 points within 0.1 m of a scan-1 point under the
    /// ground truth.
    pub overlap_gt: Option<f64>,
}

/// Default largest gap between neighbouring beams drawn as a segment,
/// metres (`--connect`; measured best on the real scan pairs, README).
pub const DEFAULT_CONNECT_M: f32 = 0.3;

/// How scans become grids.
#[derive(Clone, Copy, Debug)]
pub struct RasterOptions {
    /// Fixed metres per cell; `None`: [`Raster::auto`] per pair.
    pub cell: Option<f32>,
    /// Draw segments between neighbouring beams closer than this (metres).
    pub connect: Option<f32>,
    /// Keep only the disc inscribed in the grid.
    pub disc: bool,
    /// Refine the chosen pose on the beams' end points
    /// ([`Raster::refine_on_beams`]).
    pub beam_refine: bool,
    /// Judge the candidates again on the beams and flag an answer they
    /// contradict ([`Raster::check_on_beams`]).
    pub beam_check: bool,
}

impl RasterOptions {
    /// The raster for one pair on a grid `size` cells wide.
    pub fn raster(&self, scans: &[Scan<'_>], size: usize) -> Option<Raster> {
        let raster = match self.cell {
            Some(cell) => Raster::with_cell(cell),
            None => Raster::auto(scans, size),
        }?
        .clip_to_disc(self.disc);
        Some(match self.connect {
            Some(gap) => raster.connect(gap),
            None => raster,
        })
    }
}

/// The result of one pair in one mode, in the file's convention.
#[derive(Clone, Debug)]
pub struct PairEstimate {
    /// The estimate on the two grids.
    pub estimate: Estimate,
    /// Metres per cell used.
    pub cell: f32,
    /// Heading change dθ = −α, degrees in (−180, 180].
    pub dtheta_deg: f64,
    /// `(dx, dy)` metres, when the translation was found.
    pub translation: Option<(f64, f64)>,
    /// Rasterization counts of both scans.
    pub stats: [ScanStats; 2],
    /// The refinement on the beams, when it ran: the fit (whose pose
    /// `dtheta_deg` and `translation` then are) or why the grid's pose was
    /// kept.
    pub beam_fit: Option<Result<BeamFit, BeamFitError>>,
    /// The candidates judged again on the beams, when that ran.
    pub beam_check: Option<BeamCheck>,
    /// Which test flagged the answer, when its status is not confident.
    pub flagged_by: Option<FlaggedBy>,
}

/// The test that made an answer's status other than confident.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FlaggedBy {
    /// The estimator's own: overlap on the grid, the direction or axis
    /// test, too little structure, the work budget.
    Estimate,
    /// The check on the beams ([`BeamCheck::flag`]): a rival that
    /// contradicts the answer, an answer too weak on the beams, or a
    /// confidence cap below ½. The estimator alone called it confident.
    BeamCheck,
}

impl FlaggedBy {
    /// The name in the JSON lines' `flagged_by`.
    pub fn name(self) -> &'static str {
        match self {
            FlaggedBy::Estimate => "estimate",
            FlaggedBy::BeamCheck => "beam_check",
        }
    }
}

/// Rasterizes both scans of `pair` into `engine` and estimates in each of
/// `modes` (the grids are drawn once).
///
/// # Errors
/// A message when a scan has no beam, or the cell size is unusable.
pub fn estimate(
    engine: &mut dyn Engine,
    pair: &PairRecord,
    options: &RasterOptions,
    modes: &[Mode],
) -> Result<Vec<PairEstimate>, String> {
    estimate_with_prior(engine, pair, options, modes, None)
}

/// Like [`estimate`], with an optional prior on α (e.g. from odometry) that
/// picks among the candidates; `None` gives exactly [`estimate`]'s result.
///
/// # Errors
/// As [`estimate`].
pub fn estimate_with_prior(
    engine: &mut dyn Engine,
    pair: &PairRecord,
    options: &RasterOptions,
    modes: &[Mode],
    prior: Option<Prior>,
) -> Result<Vec<PairEstimate>, String> {
    let (r1, r2) = (pair.scan1.ranges(), pair.scan2.ranges());
    if r1.is_empty() || r2.is_empty() {
        return Err("a scan has no beams".into());
    }
    let (s1, s2) = (pair.scan1.scan(&r1), pair.scan2.scan(&r2));
    let raster = options
        .raster(&[s1, s2], engine.size())
        .ok_or("the cell size must be finite and positive")?;
    let stats = [
        engine.rasterize(View::First, &s1, &raster),
        engine.rasterize(View::Second, &s2, &raster),
    ];
    Ok(modes
        .iter()
        .map(|&mode| {
            let mut estimate = engine.estimate_with_prior(mode, prior);
            let estimator_status = estimate.status;
            // The check first: it may replace the answer, which is then
            // the one refined. With a prior it only flags (the prior chose),
            // and a rival the prior rules out contradicts nothing.
            let beam_check = options
                .beam_check
                .then(|| raster.check_on_beams(&s1, &s2, &estimate))
                .flatten();
            if let Some(check) = &beam_check {
                match prior {
                    Some(_) => check.given(prior).flag(&mut estimate),
                    None => check.apply(&mut estimate),
                }
            }
            let beam_fit = estimate
                .translation
                .filter(|_| options.beam_refine)
                .map(|t| raster.refine_on_beams(&s1, &s2, estimate.alpha, &t));
            let flagged_by = match (estimator_status, estimate.status) {
                (_, Status::Confident) => None,
                (Status::Confident, _) => Some(FlaggedBy::BeamCheck),
                _ => Some(FlaggedBy::Estimate),
            };
            let (alpha, translation) = reported_pose(&estimate, beam_fit.as_ref());
            let motion = raster.motion(alpha, translation.as_ref());
            PairEstimate {
                cell: raster.cell(),
                dtheta_deg: f64::from(motion.dtheta).to_degrees(),
                translation: motion
                    .translation
                    .map(|(x, y)| (f64::from(x), f64::from(y))),
                stats,
                estimate,
                beam_fit,
                beam_check,
                flagged_by,
            }
        })
        .collect())
}

/// The pose the tool reports for `estimate`: the fit on the beams when it
/// succeeded, else the grid estimate's.
pub fn reported_pose(
    estimate: &Estimate,
    fit: Option<&Result<BeamFit, BeamFitError>>,
) -> (Angle, Option<Pose>) {
    match fit {
        Some(Ok(fit)) => (fit.alpha, Some(fit.translation)),
        _ => (estimate.alpha, estimate.translation),
    }
}

/// The status as a lower-case word: the names of the firmware's result
/// lines (`hough-heading mcu check` compares them with these).
pub use crate::mcu_pairs::status_name;

/// Which half-turn the direction test chose.
pub fn half_turn_name(h: HalfTurn) -> &'static str {
    match h {
        HalfTurn::Direct => "direct",
        HalfTurn::Flipped => "flipped",
    }
}

/// Rounds to `digits` decimals (keeps the output short and stable).
pub fn round(v: f64, digits: i32) -> f64 {
    let f = 10f64.powi(digits);
    (v * f).round() / f
}

/// Wraps degrees to (−180, 180].
pub fn wrap_deg(d: f64) -> f64 {
    let r = d.rem_euclid(360.0);
    if r > 180.0 {
        r - 360.0
    } else {
        r
    }
}
