//! The real-data summary: errors against the scan-pair files' ground truth.
//!
//! Definitions (all angles over the full circle, degrees):
//!
//! - *error*: `|wrap(dθ_est − dθ_gt)|` ∈ [0, 180].
//! - *≤ 2°*: share of pairs with error ≤ 2°.
//! - *flips*: share with error ≥ 175° (right axis, wrong half-turn).
//! - *flagged*: share with status ≠ `confident`.
//! - *fail unflagged*: among the unflagged pairs, the share with error > 5°
//!   (with the counts).
//! - *t median / p90*: `|d_est − d_gt|` in metres over the pairs whose
//!   rotation is within 2° and whose translation is observable; for the zero
//!   estimate, `|d_gt|` over all pairs.
//! - *median ° ≤ 2°*: median error of the pairs within 2°.
//! - *of which fit better*: among the unflagged pairs more than 5° off, how
//!   many the estimate aligns better than the ground truth does: the share
//!   of scan-2 points within 0.1 m of a scan-1 point is higher under the
//!   estimated pose (an independent f64 check on the raw points; such pairs
//!   are either genuinely ambiguous or wrong in the ground truth). Each
//!   file's table is followed by those pairs' line indices
//!   ([`Summary::fits_better_pairs`]).
//! - *t > 0.3 m*: among the pairs of *t median*, the share more than 0.3 m
//!   off.
//! - *t unobs.*: among the pairs whose rotation is within 2°, the share whose
//!   translation is unobservable along one direction (corridors: the estimate
//!   has no component along it, so its error there is the motion along the
//!   corridor).
//!
//! Subsets: all pairs; `check.overlap_gt ≥ 0.5`; `|dθ_gt| > 90°`; both.

use std::fmt::Write as _;

use hough_heading_recordings::pairs::{wrap_deg, PairEstimate, PairRecord, Truth};
use hough_heading_recordings::stats::{markdown_header, markdown_row, quantile};

/// The columns of [`Summary::table`].
const COLUMNS: [&str; 15] = [
    "subset",
    "method",
    "pairs",
    "median °",
    "p90 °",
    "≤ 2°",
    "median ° ≤ 2°",
    "flips",
    "flagged",
    "fail unflagged (> 5°)",
    "of which fit better",
    "t median m",
    "t p90 m",
    "t > 0.3 m",
    "t unobs.",
];

/// A method compared in the summary.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// The improved pipeline.
    Improved,
    /// The paper as written.
    Paper,
    /// The trivial estimate dθ = 0, d = 0.
    Zero,
}

impl Method {
    fn name(self) -> &'static str {
        match self {
            Method::Improved => "improved",
            Method::Paper => "paper",
            Method::Zero => "zero",
        }
    }
}

/// One pair's outcome under one method.
#[derive(Clone, Copy, Debug)]
struct Outcome {
    error_deg: f64,
    flagged: bool,
    translation_error: Option<f64>,
    unobservable: bool,
    /// Unflagged, more than 5° off, and aligning the raw scans better than
    /// the ground truth.
    fits_better: bool,
}

/// One pair's truth and outcomes.
#[derive(Clone, Debug)]
struct Row {
    /// The pair's line in its file, from 0 (the `index` of the JSON output).
    index: usize,
    overlap: Option<f64>,
    dtheta_deg: f64,
    outcomes: Vec<(Method, Outcome)>,
}

/// Accumulates pairs, then prints the table.
#[derive(Clone, Debug, Default)]
pub struct Summary {
    rows: Vec<Row>,
    errors: usize,
}

impl Summary {
    /// Adds pair `index` (its line in the file, from 0): `estimates` pairs
    /// each method with its estimate.
    pub fn add(
        &mut self,
        index: usize,
        truth: &Truth,
        pair: &PairRecord,
        estimates: &[(Method, &PairEstimate)],
    ) {
        let dtheta_deg = wrap_deg(truth.dtheta.to_degrees());
        let mut outcomes: Vec<(Method, Outcome)> = estimates
            .iter()
            .map(|(m, p)| {
                let error_deg = wrap_deg(p.dtheta_deg - dtheta_deg).abs();
                let unobservable = error_deg <= 2.0
                    && p.estimate
                        .translation
                        .is_some_and(|t| t.unobservable.is_some());
                let translation_error = p
                    .translation
                    .filter(|_| error_deg <= 2.0 && !unobservable)
                    .map(|(x, y)| (x - truth.dx).hypot(y - truth.dy));
                let flagged = p.estimate.status != hough_heading::Status::Confident;
                let fits_better = !flagged
                    && error_deg > 5.0
                    && fits_better_than_truth(pair, truth, p.dtheta_deg, p.translation);
                (
                    *m,
                    Outcome {
                        error_deg,
                        flagged,
                        translation_error,
                        unobservable,
                        fits_better,
                    },
                )
            })
            .collect();
        outcomes.push((
            Method::Zero,
            Outcome {
                error_deg: dtheta_deg.abs(),
                flagged: false,
                translation_error: Some(truth.dx.hypot(truth.dy)),
                unobservable: false,
                fits_better: false,
            },
        ));
        self.rows.push(Row {
            index,
            overlap: truth.check.overlap_gt,
            dtheta_deg,
            outcomes,
        });
    }

    /// Adds every pair of `other` (pooling files).
    pub fn extend(&mut self, other: Summary) {
        self.rows.extend(other.rows);
        self.errors += other.errors;
    }

    /// Whether no pair was scored (a recording without reference poses).
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// Counts a line that failed.
    pub fn add_error(&mut self) {
        self.errors += 1;
    }

    /// The table (Markdown), one row per subset × method.
    pub fn table(&self) -> String {
        let mut out = markdown_header(&COLUMNS);
        type Filter = fn(&Row) -> bool;
        let subsets: [(&str, Filter); 4] = [
            ("all", |_| true),
            ("overlap ≥ 0.5", |r| r.overlap.is_some_and(|o| o >= 0.5)),
            ("\\|dθ\\| > 90°", |r| r.dtheta_deg.abs() > 90.0),
            ("\\|dθ\\| > 90°, overlap ≥ 0.5", |r| {
                r.dtheta_deg.abs() > 90.0 && r.overlap.is_some_and(|o| o >= 0.5)
            }),
        ];
        let methods: Vec<Method> = self
            .rows
            .first()
            .map(|r| r.outcomes.iter().map(|(m, _)| *m).collect())
            .unwrap_or_default();
        for (name, keep) in subsets {
            let rows: Vec<&Row> = self.rows.iter().filter(|r| keep(r)).collect();
            for &method in &methods {
                let outcomes: Vec<Outcome> = rows
                    .iter()
                    .filter_map(|r| r.outcomes.iter().find(|(m, _)| *m == method))
                    .map(|(_, o)| *o)
                    .collect();
                out.push_str(&line(name, method, &outcomes));
            }
        }
        if self.errors > 0 {
            let _ = writeln!(out, "\n{} line(s) failed and are not counted.", self.errors);
        }
        out
    }
}

impl Summary {
    /// The pairs behind the table's "of which fit better" column, by line
    /// index (one file's summary: pooled files would mix their indices):
    /// for each method, those at overlap ≥ 0.5, then the others.
    pub fn fits_better_pairs(&self) -> String {
        let mut out = String::new();
        let methods = self
            .rows
            .first()
            .map(|r| r.outcomes.iter().map(|(m, _)| *m));
        for method in methods.into_iter().flatten() {
            let (mut overlapping, mut others) = (Vec::new(), Vec::new());
            for row in &self.rows {
                if row
                    .outcomes
                    .iter()
                    .any(|(m, o)| *m == method && o.fits_better)
                {
                    let list = if row.overlap.is_some_and(|o| o >= 0.5) {
                        &mut overlapping
                    } else {
                        &mut others
                    };
                    list.push(row.index.to_string());
                }
            }
            if !overlapping.is_empty() || !others.is_empty() {
                let _ = writeln!(
                    out,
                    "{}: wrong unflagged pairs that fit the scans better than the truth (line index): overlap ≥ 0.5: {}; lower: {}",
                    method.name(),
                    list_or_none(&overlapping),
                    list_or_none(&others)
                );
            }
        }
        out
    }
}

fn list_or_none(items: &[String]) -> String {
    if items.is_empty() {
        "none".into()
    } else {
        items.join(", ")
    }
}

fn line(subset: &str, method: Method, outcomes: &[Outcome]) -> String {
    let n = outcomes.len();
    if n == 0 {
        let mut cells = vec![subset, method.name(), "0"];
        cells.resize(COLUMNS.len(), "–");
        return markdown_row(&cells);
    }
    let errors: Vec<f64> = outcomes.iter().map(|o| o.error_deg).collect();
    let share = |count: usize| format!("{:.1} %", 100.0 * count as f64 / n as f64);
    let within = outcomes.iter().filter(|o| o.error_deg <= 2.0).count();
    let flips = outcomes.iter().filter(|o| o.error_deg >= 175.0).count();
    let close: Vec<f64> = errors.iter().copied().filter(|&e| e <= 2.0).collect();
    let close_median = if close.is_empty() {
        "–".to_string()
    } else {
        format!("{:.3}", quantile(&close, 0.5))
    };
    let (flagged, unflagged_fail, fit_better) = if method == Method::Zero {
        ("–".to_string(), "–".to_string(), "–".to_string())
    } else {
        let flagged = outcomes.iter().filter(|o| o.flagged).count();
        let unflagged = n - flagged;
        let fails = outcomes
            .iter()
            .filter(|o| !o.flagged && o.error_deg > 5.0)
            .count();
        let fail = if unflagged == 0 {
            "–".to_string()
        } else {
            format!(
                "{:.1} % ({fails}/{unflagged})",
                100.0 * fails as f64 / unflagged as f64
            )
        };
        let better = outcomes.iter().filter(|o| o.fits_better).count();
        (share(flagged), fail, format!("{better}/{fails}"))
    };
    let t: Vec<f64> = outcomes
        .iter()
        .filter_map(|o| o.translation_error)
        .collect();
    let unobservable_count = outcomes.iter().filter(|o| o.unobservable).count();
    let has_translation = !t.is_empty() || unobservable_count > 0;
    let unobservable = if method == Method::Zero || within == 0 || !has_translation {
        "–".to_string()
    } else {
        format!("{:.1} %", 100.0 * unobservable_count as f64 / within as f64)
    };
    let (t_median, t_p90) = if t.is_empty() {
        ("–".to_string(), "–".to_string())
    } else {
        (
            format!("{:.3}", quantile(&t, 0.5)),
            format!("{:.3}", quantile(&t, 0.9)),
        )
    };
    let t_off = if method == Method::Zero || t.is_empty() {
        "–".to_string()
    } else {
        let far = t.iter().filter(|&&e| e > 0.3).count();
        format!(
            "{:.1} % ({far}/{})",
            100.0 * far as f64 / t.len() as f64,
            t.len()
        )
    };
    markdown_row(&[
        subset.to_string(),
        method.name().to_string(),
        n.to_string(),
        format!("{:.2}", quantile(&errors, 0.5)),
        format!("{:.2}", quantile(&errors, 0.9)),
        share(within),
        close_median,
        share(flips),
        flagged,
        unflagged_fail,
        fit_better,
        t_median,
        t_p90,
        t_off,
        unobservable,
    ])
}

/// Share of scan-2 points within 0.1 m of a scan-1 point when mapped by the
/// pose `p₁ = R(dθ)·p₂ + d` (brute force, f64).
fn aligned_share(pair: &PairRecord, dtheta_rad: f64, d: (f64, f64)) -> f64 {
    let (p1, p2) = (pair.scan1.points(), pair.scan2.points());
    if p2.is_empty() {
        return 0.0;
    }
    let (s, c) = dtheta_rad.sin_cos();
    let near = p2
        .iter()
        .filter(|&&(x, y)| {
            let (qx, qy) = (c * x - s * y + d.0, s * x + c * y + d.1);
            p1.iter()
                .any(|&(ax, ay)| (ax - qx).powi(2) + (ay - qy).powi(2) < 0.01)
        })
        .count();
    near as f64 / p2.len() as f64
}

/// Whether the estimated pose aligns the raw scans better than the truth.
fn fits_better_than_truth(
    pair: &PairRecord,
    truth: &Truth,
    dtheta_deg: f64,
    translation: Option<(f64, f64)>,
) -> bool {
    let Some(d) = translation else {
        return false;
    };
    aligned_share(pair, dtheta_deg.to_radians(), d)
        > aligned_share(pair, truth.dtheta, (truth.dx, truth.dy))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(index: usize, overlap: f64, fits_better: bool) -> Row {
        let outcome = Outcome {
            error_deg: if fits_better { 170.0 } else { 0.3 },
            flagged: false,
            translation_error: None,
            unobservable: false,
            fits_better,
        };
        Row {
            index,
            overlap: Some(overlap),
            dtheta_deg: 10.0,
            outcomes: vec![(Method::Improved, outcome)],
        }
    }

    #[test]
    fn fits_better_pairs_are_listed_by_overlap() {
        let summary = Summary {
            rows: vec![
                row(3, 0.7, true),
                row(4, 0.9, false),
                row(8, 0.2, true),
                row(11, 0.5, true),
            ],
            errors: 0,
        };
        assert_eq!(
            summary.fits_better_pairs(),
            "improved: wrong unflagged pairs that fit the scans better than the truth (line index): overlap ≥ 0.5: 3, 11; lower: 8\n"
        );
        let none = Summary {
            rows: vec![row(0, 0.9, false)],
            errors: 0,
        };
        assert_eq!(none.fits_better_pairs(), "");
    }
}
