//! The JSON line of a scan pair, as `scans` prints it (and `log`, with the
//! scans' indices and times added): the pose, status, candidates, the
//! runner-up, the fit and the check on the beams.

use hough_heading::{BeamCheck, BeamFit, BeamFitError, Candidate, Estimate, ScanStats, Score};
use serde::Serialize;

use crate::pairs::{round, status_name, wrap_deg, FlaggedBy, PairEstimate};

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
    /// Which test flagged a status other than `confident` (absent when
    /// confident or on error): `estimate` (the estimator's own: overlap on
    /// the grid, direction, axis, structure, work budget) or `beam_check`
    /// (the check on the beams, see `beam_check`: the estimator alone
    /// called it confident).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub flagged_by: Option<&'static str>,
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
    /// The work the verification's translation searches spent
    /// (`Estimate::search_rows`, the unit of `--search-budget`;
    /// verification on).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub search_rows: Option<u32>,
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
            flagged_by: p.flagged_by.map(FlaggedBy::name),
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
            search_rows: e
                .candidates
                .iter()
                .any(|c| c.alignment.is_some())
                .then_some(e.search_rows),
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
            flagged_by: None,
            confidence: None,
            candidates_deg: Vec::new(),
            alignments: Vec::new(),
            supports: Vec::new(),
            free_space: Vec::new(),
            runner_up: None,
            overlap: None,
            search_rows: None,
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
