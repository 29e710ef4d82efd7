//! Scan-pair files (`../shared/data/*.jsonl`, one pair per line): reading,
//! estimating, and the per-line JSON output.
//!
//! Estimation reads only `scan1` and `scan2`; the ground truth (`dx`, `dy`,
//! `dtheta`, `check.overlap_gt`) is read separately, and only for the
//! summary.

use hough_heading::{
    Angle, BeamCheck, BeamFit, BeamFitError, Candidate, Estimate, HalfTurn, Mode, Pose, Prior,
    Raster, Scan, ScanStats, Score, SensorOffset,
};
use serde::{Deserialize, Serialize};

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
            // The check first: it may replace the answer, which is then
            // the one refined. With a prior it only flags (the prior chose).
            let beam_check = options
                .beam_check
                .then(|| raster.check_on_beams(&s1, &s2, &estimate))
                .flatten();
            if let Some(check) = &beam_check {
                match prior {
                    Some(_) => check.flag(&mut estimate),
                    None => check.apply(&mut estimate),
                }
            }
            let beam_fit = estimate
                .translation
                .filter(|_| options.beam_refine)
                .map(|t| raster.refine_on_beams(&s1, &s2, estimate.alpha, &t));
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

/// One output line.
#[derive(Clone, Debug, Serialize)]
pub struct OutputLine {
    /// The pair file, when the command read several.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    /// 0-based index of the input line.
    pub index: usize,
    /// Estimated heading change dθ, degrees in (−180, 180] (null on error).
    pub dtheta_deg: Option<f64>,
    /// `confident`, `ambiguous_direction`, `ambiguous_axis`, `low_overlap`,
    /// `no_structure` or `error`.
    pub status: &'static str,
    /// In [0, 1] (null on error).
    pub confidence: Option<f64>,
    /// Candidate heading changes, strongest first, degrees.
    pub candidates_deg: Vec<f64>,
    /// Each candidate's alignment score in [0, 1] (verification on).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub alignments: Vec<f64>,
    /// Each candidate's support (the decision score: both-way alignment
    /// minus the free-space weight times `free_space`; verification on).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub supports: Vec<f64>,
    /// Each candidate's free-space violation share: the points of either
    /// scan it lays where the other sensor saw through (verification on).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub free_space: Vec<f64>,
    /// The best rotation at least 5° from the answer, whatever its score
    /// (verification on; null when there was none).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub runner_up: Option<RunnerUp>,
    /// Share of scan 2 the chosen pose puts within one cell of scan 1
    /// (verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub overlap: Option<f64>,
    /// Robot displacement x, metres, frame of scan 1 (null when unknown).
    pub dx_m: Option<f64>,
    /// Robot displacement y, metres.
    pub dy_m: Option<f64>,
    /// Pearson correlation of the signatures at the winning shift.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub correlation: Option<f64>,
    /// Correlation of the rival peak (at least 5° away).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rival: Option<f64>,
    /// Metres per cell used for this pair.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub cell_m: Option<f64>,
    /// RMS disagreement of the profile columns with the fitted translation,
    /// metres (`Pose::residual` × the cell size).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_m: Option<f64>,
    /// Profile columns the translation fit kept (`Pose::columns`):
    /// three or more cross-check each other.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub columns: Option<u8>,
    /// Unit vector (frame of scan 1) along which the translation is not
    /// observable (a corridor), when so.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unobservable: Option<[f64; 2]>,
    /// The refinement on the beams, when it ran (`dtheta_deg`, `dx_m` and
    /// `dy_m` are then its pose unless it says `kept`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam_fit: Option<BeamFitLine>,
    /// The candidates judged again on the beams, when that ran
    /// (`Raster::check_on_beams`; `contradicts` or `too_weak` flagged a
    /// confident answer).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam_check: Option<BeamCheckLine>,
    /// Beams of each scan dropped by reason, when any was (so a
    /// `no_structure` from unusable readings says why).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dropped: Option<[DroppedBeams; 2]>,
    /// Why the line failed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// The runner-up of an estimate (`Estimate::runner_up`), in the file's
/// convention.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RunnerUp {
    /// Its heading change, degrees in (−180, 180].
    pub dtheta_deg: f64,
    /// Its alignment (search sample) in [0, 1].
    pub alignment: Option<f64>,
    /// Its support, the decision score.
    pub support: Option<f64>,
    /// Its free-space violation share.
    pub free_space: Option<f64>,
}

impl RunnerUp {
    fn of(c: &Candidate) -> Self {
        let value = |v: Option<Score>| v.map(|v| round(v.to_num::<f64>(), 4));
        Self {
            dtheta_deg: round(wrap_deg(-f64::from(c.alpha.to_degrees())), 4),
            alignment: value(c.alignment),
            support: value(c.support),
            free_space: value(c.free_space),
        }
    }
}

/// What the refinement on the beams did.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BeamFitLine {
    /// End points matched to a reference segment within the trim.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub pairs: Option<u16>,
    /// Their RMS distance to the segments, metres.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub residual_m: Option<f64>,
    /// Gauss–Newton steps taken.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations: Option<u8>,
    /// Why the grid's pose was kept: `unsupported`, `too_few_pairs`,
    /// `singular` or `moved_too_far`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub kept: Option<&'static str>,
}

impl BeamFitLine {
    fn of(fit: &Result<BeamFit, BeamFitError>, cell: f32) -> Self {
        match fit {
            Ok(f) => Self {
                pairs: Some(f.pairs),
                residual_m: Some(round(f.residual.to_num::<f64>() * f64::from(cell), 4)),
                iterations: Some(f.iterations),
                kept: None,
            },
            Err(e) => Self {
                pairs: None,
                residual_m: None,
                iterations: None,
                kept: Some(crate::mcu_pairs::beam_fit_kept_name(*e)),
            },
        }
    }
}

/// What the beams said of the chosen pose and its best rival.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BeamCheckLine {
    /// The grid's answer's explained share (`BeamAgreement::explained`).
    pub explained: f64,
    /// Its seen-through share (`BeamAgreement::seen_through`).
    pub seen_through: f64,
    /// Its share of end points in the other sensor's field of view
    /// (`BeamAgreement::in_view`).
    pub in_view: f64,
    /// The best scored other rotation, when there was one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rival: Option<BeamRival>,
    /// The rival scores higher than the grid's answer (a confident answer
    /// is then flagged).
    pub contradicts: bool,
    /// The rival leads by `BEAM_SWITCH_LEAD` or more, and per end point in
    /// view too: it is the answer (unless a prior was given).
    pub switches: bool,
    /// The grid's answer scores below `BEAM_MIN_SCORE` on the beams (a
    /// confident answer is then `low_overlap`).
    pub too_weak: bool,
}

/// The best other rotation on the beams.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BeamRival {
    /// Its heading change, degrees in (−180, 180].
    pub dtheta_deg: f64,
    /// Its explained share.
    pub explained: f64,
    /// Its seen-through share.
    pub seen_through: f64,
    /// Its share of end points in the other sensor's field of view.
    pub in_view: f64,
}

impl BeamCheckLine {
    fn of(check: &BeamCheck) -> Self {
        let share = |v: Score| round(v.to_num::<f64>(), 4);
        Self {
            explained: share(check.chosen.agreement.explained),
            seen_through: share(check.chosen.agreement.seen_through),
            in_view: share(check.chosen.agreement.in_view),
            rival: check.rival.map(|r| BeamRival {
                dtheta_deg: round(wrap_deg(-f64::from(r.alpha.to_degrees())), 4),
                explained: share(r.agreement.explained),
                seen_through: share(r.agreement.seen_through),
                in_view: share(r.agreement.in_view),
            }),
            contradicts: check.contradicts(),
            switches: check.switches(),
            too_weak: check.too_weak(),
        }
    }
}

/// The beams of one scan that set no cell, by reason.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct DroppedBeams {
    /// At or beyond `max_range` (no return).
    pub no_return: u32,
    /// NaN or infinite.
    pub not_finite: u32,
    /// Zero or negative.
    pub non_positive: u32,
    /// Outside the grid's window.
    pub outside: u32,
}

impl DroppedBeams {
    fn of(stats: &ScanStats) -> Self {
        Self {
            no_return: stats.no_return,
            not_finite: stats.not_finite,
            non_positive: stats.non_positive,
            outside: stats.outside,
        }
    }
}

impl OutputLine {
    /// The line for a successful estimate.
    pub fn of(index: usize, p: &PairEstimate) -> Self {
        let e = &p.estimate;
        let dtheta = -f64::from(e.alpha.to_degrees());
        let unobservable = e.translation.and_then(|t| t.unobservable).map(|(ux, uy)| {
            // The direction lives in image 2; frame 1 is R(dθ) of it.
            let (ux, uy) = (ux.to_num::<f64>(), uy.to_num::<f64>());
            let (s, c) = dtheta.to_radians().sin_cos();
            [round(c * ux - s * uy, 4), round(s * ux + c * uy, 4)]
        });
        Self {
            file: None,
            index,
            dtheta_deg: Some(round(p.dtheta_deg, 4)),
            status: status_name(e.status),
            confidence: Some(round(e.confidence.to_num::<f64>(), 4)),
            candidates_deg: e
                .candidates
                .iter()
                .map(|c| round(wrap_deg(-f64::from(c.alpha.to_degrees())), 4))
                .collect(),
            alignments: candidate_values(e, |c| c.alignment),
            supports: candidate_values(e, |c| c.support),
            free_space: candidate_values(e, |c| c.free_space),
            runner_up: e.runner_up.as_ref().map(RunnerUp::of),
            overlap: e
                .candidates
                .iter()
                .any(|c| c.alignment.is_some())
                .then(|| round(e.overlap.to_num::<f64>(), 4)),
            dx_m: p.translation.map(|t| round(t.0, 4)),
            dy_m: p.translation.map(|t| round(t.1, 4)),
            correlation: Some(round(e.correlation.to_num::<f64>(), 4)),
            rival: Some(round(e.rival.to_num::<f64>(), 4)),
            cell_m: Some(round(f64::from(p.cell), 6)),
            residual_m: e
                .translation
                .map(|t| round(t.residual.to_num::<f64>() * f64::from(p.cell), 4)),
            columns: e.translation.map(|t| t.columns),
            unobservable,
            beam_fit: p.beam_fit.as_ref().map(|f| BeamFitLine::of(f, p.cell)),
            beam_check: p.beam_check.as_ref().map(BeamCheckLine::of),
            dropped: p
                .stats
                .iter()
                .any(|s| s.dropped() > 0)
                .then(|| p.stats.each_ref().map(DroppedBeams::of)),
            error: None,
        }
    }

    /// The line for a failed input line.
    pub fn error(index: usize, message: String) -> Self {
        Self {
            file: None,
            index,
            dtheta_deg: None,
            status: "error",
            confidence: None,
            candidates_deg: Vec::new(),
            alignments: Vec::new(),
            supports: Vec::new(),
            free_space: Vec::new(),
            runner_up: None,
            overlap: None,
            dx_m: None,
            dy_m: None,
            correlation: None,
            rival: None,
            cell_m: None,
            residual_m: None,
            columns: None,
            unobservable: None,
            beam_fit: None,
            beam_check: None,
            dropped: None,
            error: Some(message),
        }
    }
}

/// One score of each candidate that has it, rounded to 4 decimals.
fn candidate_values(e: &Estimate, value: impl Fn(&Candidate) -> Option<Score>) -> Vec<f64> {
    e.candidates
        .iter()
        .filter_map(value)
        .map(|v| round(v.to_num::<f64>(), 4))
        .collect()
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
