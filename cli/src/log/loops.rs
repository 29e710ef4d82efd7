//! `log --loops`: loop closures over the chain's placed scans, checked
//! before they count, and the pose graph they close (`factrs`: SE(2),
//! Levenberg–Marquardt, a Huber kernel on the closures), solved at the end
//! of the run.
//!
//! 1. **Where to look.** Every [`LoopSettings::stride`]-th placed scan is a
//!    query; the placed scans at least [`LoopSettings::min_gap`] scans and
//!    [`LoopSettings::min_path_m`] of path before it whose chained position
//!    lies within the gate (a few metres plus what the chain's heading σ
//!    since then may have moved it) are the candidates.
//! 2. **Which to try.** The candidates are ranked by the place descriptor
//!    (`hough_heading::place`: the signature correlated over every shift,
//!    on a fixed 10 m window around the sensor) and the first
//!    [`LoopSettings::top`] are estimated prior-free, as a pair of scans
//!    (verification, free space, beam check). Only confident answers are
//!    closures.
//! 3. **Which count.** A closure's heading must lie within 3σ of the
//!    chain's own relative heading (σ from the chain's variances, each
//!    step's at most [`STEP_SIGMA_CAP_DEG`], and the closure's own 2°),
//!    its translation within a metre plus what three such σ allow over
//!    the path between its ends, and it must agree with another closure
//!    that passed (pairwise consistency: two closures measure the same
//!    drift where the chain between their ends is certain). Where the
//!    chain's σ is above [`LoopSettings::trusted_sigma_deg`] it must agree
//!    with two others, one of them elsewhere: at least
//!    [`LoopSettings::elsewhere_nodes`] placed scans away at one end,
//!    through a chain trusted between the two (revisits give 90° and 180°
//!    answers, DESIGN.md §3i, and a symmetric place gives them alike).
//! 4. **The graph.** Each placed scan a node; between consecutive ones the
//!    chain's own step (heading σ from the chain's variances, at most
//!    [`STEP_SIGMA_CAP_DEG`]; translation 5 cm + 5 % of the step); each
//!    accepted closure a factor (heading σ 0.5°, translation 0.5 m) under
//!    a Huber kernel; the first scan fixed.

use std::fmt::Write as _;
use std::path::Path;

use factrs::core::{
    BetweenResidual, GaussianNoise, Graph, Huber, LevenMarquardt, PriorResidual, Values, SE2,
};
use factrs::fac;
use factrs::optimizers::OptError;
use factrs::traits::Optimizer;
use hough_heading::{Mode, Raster};
use hough_heading_recordings::engine::{Engine, View};
use hough_heading_recordings::model::Pose;
use hough_heading_recordings::pairs::{self as scans, PairRecord, RasterOptions};
use hough_heading_recordings::trajectory::Kept;
use hough_heading_recordings::Fatal;

use crate::jobs::Workers;

/// The graph's variable symbols: `X(k)`, the pose of placed scan `k`.
mod symbols {
    #![allow(missing_docs)]
    use factrs::assign_symbols;
    use factrs::core::SE2;
    assign_symbols!(X: SE2);
}
use symbols::X;

/// A placed scan of the chain.
#[derive(Clone)]
pub struct Node {
    /// The scan.
    pub scan: Kept,
    /// Its chained pose.
    pub pose: Pose,
    /// The chain's heading variance at it, degrees².
    pub variance: f64,
}

/// Where and how hard to look for closures.
#[derive(Clone, Copy, Debug)]
pub struct LoopSettings {
    /// Scans between the two ends of a closure, at least.
    pub min_gap: usize,
    /// Chained path between the two ends of a closure, metres, at least:
    /// a robot standing still sees the same view 50 scans on, and the chain
    /// between such scans is already exact (on the dense real streams 34,
    /// 85 and 51 of the 231, 156 and 128 closures accepted were such).
    pub min_path_m: f64,
    /// Every this many placed scans is a query.
    pub stride: usize,
    /// Candidates estimated per query.
    pub top: usize,
    /// The position gate's fixed part, metres.
    pub gate_m: f64,
    /// The position gate at most, metres: farther pairs share too little
    /// (DESIGN.md §3g gated at 5 m).
    pub max_gate_m: f64,
    /// Below this relative heading σ (degrees) the chain's gate alone
    /// decides.
    pub trusted_sigma_deg: f64,
    /// Placed scans between two closures' ends (at one end at least) for
    /// them to count as revisits of different places: a symmetric place
    /// gives the same wrong answer to every scan of a revisit (the shared
    /// freiburg-campus RPLIDAR capture: five closures 89–91° off, from scans
    /// 63–73 to 140–150, all consistent with each other).
    pub elsewhere_nodes: usize,
}

impl Default for LoopSettings {
    fn default() -> Self {
        Self {
            min_gap: 50,
            min_path_m: 2.0,
            stride: 5,
            top: 3,
            gate_m: 2.0,
            max_gate_m: 5.0,
            trusted_sigma_deg: 10.0,
            elsewhere_nodes: 10,
        }
    }
}

/// The heading σ a closure is checked with, degrees (wide: a check must
/// not reject a right closure for the chain's own error).
const CLOSURE_SIGMA_DEG: f64 = 2.0;
/// The heading σ of an accepted closure in the graph, degrees: on the
/// shared dense streams the accepted closures were 0.15° off the truth at
/// the median, 0.7° at the 90th percentile (`docs/drift.md`).
/// Chosen on those streams (0.5°: 369, 302 and 486 of the 378, 312 and 497
/// accepted closures within 1° of the optimized trajectory; 2°: 355, 281,
/// 460).
const GRAPH_CLOSURE_SIGMA_DEG: f64 = 0.5;
/// The translation σ of a closure's own estimate, metres (a revisit's
/// translation is weaker than its heading).
const CLOSURE_SIGMA_M: f64 = 0.5;
/// The translation σ of a closure whose estimate did not observe its
/// translation (a corridor): metres, so wide it does not bind.
const UNOBSERVED_SIGMA_M: f64 = 1000.0;
/// The most heading σ one chain step brings to the closures' check and to
/// the graph, degrees. A step the chain carried states 30° and more: its
/// answer is one of a few candidates, right or tens of degrees off, not a
/// Gaussian. Summed over a sparse log's carried steps that σ let 90° and
/// 180° revisit answers through the check (DESIGN.md §3i: on the shared
/// logs 12 of 78 accepted closures were more than 5° off, none at 3°), and
/// in the graph it let one closure bend a carried step by any amount (with
/// only the right closures, the steps uncapped: aces 23.3° largest error,
/// seattle 8.3°; capped at 3°: 8.5°, 2.1°). Chosen on the shared logs and
/// dense streams (5°: two wrong closures in on orebro; `docs/drift.md`).
const STEP_SIGMA_CAP_DEG: f64 = 3.0;
/// The window of the place descriptors, metres from the sensor.
const PLACE_RADIUS_M: f32 = 10.0;

/// A closure tried: the two nodes, the estimate's motion, and what became
/// of it.
#[derive(Clone, Debug)]
pub struct Closure {
    /// The earlier node.
    pub from: usize,
    /// The later node.
    pub to: usize,
    /// The robot's motion from `from` to `to` by the estimate.
    pub delta: Pose,
    /// Its heading minus the chain's, degrees.
    pub residual_deg: f64,
    /// The chain's relative heading σ between the two, degrees.
    pub sigma_deg: f64,
    /// Its translation minus the chain's, metres (0 when it holds the
    /// heading only).
    pub offset_m: f64,
    /// One standard deviation of its translation in the graph, metres:
    /// [`CLOSURE_SIGMA_M`], or [`UNOBSERVED_SIGMA_M`] where the estimate
    /// did not observe it.
    pub translation_sigma_m: f64,
    /// How far the chain may have moved the later end: a metre, plus three
    /// relative σ (radians) of the path between them, metres.
    pub offset_gate_m: f64,
    /// It entered the graph.
    pub accepted: bool,
}

impl Closure {
    /// How far, degrees, the closure's heading change lies from that of
    /// `poses` (the optimized trajectory, one pose per placed scan).
    pub fn disagreement_deg(&self, poses: &[Pose]) -> f64 {
        match (poses.get(self.from), poses.get(self.to)) {
            (Some(a), Some(b)) => {
                scans::wrap_deg((self.delta.theta - a.between(b).theta).to_degrees()).abs()
            }
            _ => f64::INFINITY,
        }
    }
}

/// The run's closures and the corrected poses of its nodes.
pub struct Solved {
    /// Every confident closure tried.
    pub closures: Vec<Closure>,
    /// Each node's pose after the graph (the chain's without closures).
    pub poses: Vec<Pose>,
}

/// Finds, checks and applies the loop closures of `nodes`.
///
/// # Errors
/// A [`Fatal`] error when the solver fails.
pub fn close(
    nodes: &[Node],
    workers: &mut Workers<Box<dyn Engine>>,
    options: &RasterOptions,
    mode: Mode,
    settings: &LoopSettings,
) -> Result<Solved, Fatal> {
    let signatures = workers.map(nodes, |engine, _, node| {
        signature(engine.as_mut(), &node.scan)
    });
    let variances = capped_variances(nodes.iter().map(|n| n.variance));
    let path = path_lengths(nodes);
    let queries = candidates(nodes, &path, &signatures, workers, settings);
    let estimated = workers.map(&queries, |engine, _, &(i, j)| {
        let pair = PairRecord {
            scan1: nodes[i].scan.1.record.clone(),
            scan2: nodes[j].scan.1.record.clone(),
        };
        scans::estimate_with_prior(engine.as_mut(), &pair, options, &[mode], None)
    });
    let mut closures = Vec::new();
    for (&(i, j), result) in queries.iter().zip(estimated) {
        let Ok(estimates) = result else { continue };
        let e = &estimates[0];
        if e.estimate.status != hough_heading::Status::Confident {
            continue;
        }
        // The estimate's own translation: the odometry between a revisit's
        // two scans has drifted for the whole loop (on the shared dense
        // streams, metres). Where the estimate cannot observe it (a
        // corridor), or has none, the closure holds the heading only.
        let observed = e
            .estimate
            .translation
            .is_some_and(|t| t.unobservable.is_none())
            && e.translation.is_some();
        let (x, y) = e.translation.filter(|_| observed).unwrap_or((0.0, 0.0));
        let delta = Pose {
            x,
            y,
            theta: e.dtheta_deg.to_radians(),
        };
        let chain = nodes[i].pose.between(&nodes[j].pose);
        let residual_deg = scans::wrap_deg((delta.theta - chain.theta).to_degrees());
        let sigma_deg =
            ((variances[j] - variances[i]).abs() + CLOSURE_SIGMA_DEG * CLOSURE_SIGMA_DEG).sqrt();
        let path = path[j] - path[i];
        closures.push(Closure {
            from: i,
            to: j,
            delta,
            residual_deg,
            sigma_deg,
            offset_m: if observed {
                (delta.x - chain.x).hypot(delta.y - chain.y)
            } else {
                0.0
            },
            translation_sigma_m: if observed {
                CLOSURE_SIGMA_M
            } else {
                UNOBSERVED_SIGMA_M
            },
            offset_gate_m: 1.0 + 3.0 * sigma_deg.to_radians().min(1.0) * path,
            accepted: false,
        });
    }
    let chain: Vec<Pose> = nodes.iter().map(|n| n.pose).collect();
    accept(&mut closures, &variances, settings);
    let poses = solve(&chain, &variances, &closures)?;
    Ok(Solved { closures, poses })
}

/// The chain's heading variance at each node (`chained`, degrees²) with
/// each step's share capped at [`STEP_SIGMA_CAP_DEG`]².
fn capped_variances(chained: impl IntoIterator<Item = f64>) -> Vec<f64> {
    let cap = STEP_SIGMA_CAP_DEG * STEP_SIGMA_CAP_DEG;
    let mut before = None;
    let mut sum = 0.0;
    chained
        .into_iter()
        .map(|v| {
            if let Some(b) = before.replace(v) {
                sum += (v - b).clamp(0.0, cap);
            }
            sum
        })
        .collect()
}

/// The place descriptor of a scan: its signature on a fixed window.
fn signature(engine: &mut dyn Engine, scan: &Kept) -> Vec<u16> {
    let ranges = scan.1.record.ranges();
    let Some(raster) = Raster::with_radius(PLACE_RADIUS_M, engine.size()) else {
        return Vec::new();
    };
    engine.rasterize(View::First, &scan.1.record.scan(&ranges), &raster);
    engine.place_signature(View::First)
}

/// The chain's path length from the first node to each node, metres.
fn path_lengths(nodes: &[Node]) -> Vec<f64> {
    let mut path = vec![0.0; nodes.len()];
    for k in 1..nodes.len() {
        let step = nodes[k - 1].pose.between(&nodes[k].pose);
        path[k] = path[k - 1] + step.x.hypot(step.y);
    }
    path
}

/// The pairs to estimate: for each query, the most alike candidates within
/// the gate.
fn candidates(
    nodes: &[Node],
    path: &[f64],
    signatures: &[Vec<u16>],
    workers: &mut Workers<Box<dyn Engine>>,
    settings: &LoopSettings,
) -> Vec<(usize, usize)> {
    let queries: Vec<usize> = (0..nodes.len()).step_by(settings.stride.max(1)).collect();
    let ranked = workers.map(&queries, |engine, _, &j| {
        let mut near: Vec<(usize, f64)> = nodes[..j]
            .iter()
            .enumerate()
            .filter(|(i, n)| {
                *i < j
                    && n.scan.0 + settings.min_gap <= nodes[j].scan.0
                    && path[j] - path[*i] >= settings.min_path_m
            })
            .filter(|(i, n)| {
                let sigma = (nodes[j].variance - n.variance).abs().sqrt().to_radians();
                let gate = settings.gate_m + (path[j] - path[*i]) * sigma.min(1.0);
                let d = n.pose.between(&nodes[j].pose);
                d.x.hypot(d.y) <= gate.min(settings.max_gate_m)
            })
            .map(|(i, _)| (i, engine.place_similarity(&signatures[i], &signatures[j])))
            .collect();
        near.sort_by(|a, b| b.1.total_cmp(&a.1));
        near.into_iter()
            .take(settings.top)
            .map(|(i, _)| (i, j))
            .collect::<Vec<_>>()
    });
    ranked.into_iter().flatten().collect()
}

/// Marks the closures that pass the chain's gate and agree with another
/// (where the chain is uncertain, with two, one of them elsewhere).
fn accept(closures: &mut [Closure], variances: &[f64], settings: &LoopSettings) {
    let gated: Vec<bool> = closures
        .iter()
        .map(|c| c.residual_deg.abs() <= 3.0 * c.sigma_deg && c.offset_m <= c.offset_gate_m)
        .collect();
    // The chain's heading variance between two closures' ends, degrees².
    let between = |a: &Closure, b: &Closure| {
        (variances[a.from] - variances[b.from]).abs() + (variances[a.to] - variances[b.to]).abs()
    };
    let consistent = |a: &Closure, b: &Closure| {
        let v = between(a, b) + 2.0 * CLOSURE_SIGMA_DEG * CLOSURE_SIGMA_DEG;
        scans::wrap_deg(a.residual_deg - b.residual_deg).abs() <= 3.0 * v.sqrt()
    };
    let trusted = settings.trusted_sigma_deg;
    let elsewhere = |a: &Closure, b: &Closure| {
        let apart = a.from.abs_diff(b.from).max(a.to.abs_diff(b.to)) >= settings.elsewhere_nodes;
        apart && between(a, b) <= trusted * trusted
    };
    let accepted: Vec<bool> = (0..closures.len())
        .map(|a| {
            let closure = &closures[a];
            if !gated[a] {
                return false;
            }
            let supporters: Vec<&Closure> = (0..closures.len())
                .filter(|&b| b != a && gated[b] && consistent(closure, &closures[b]))
                .map(|b| &closures[b])
                .collect();
            if closure.sigma_deg <= trusted {
                !supporters.is_empty()
            } else {
                supporters.len() >= 2 && supporters.iter().any(|b| elsewhere(closure, b))
            }
        })
        .collect();
    for (c, a) in closures.iter_mut().zip(accepted) {
        c.accepted = a;
    }
}

/// The graph's factor for the chain's step into node `k` (of the chain's
/// poses, its heading `variances` in degrees², capped): the motion, its
/// heading σ in degrees and its translation σ in metres (5 cm + 5 % of the
/// step). [`solve`] and [`write_g2o`] write the same graph.
fn chain_step(chain: &[Pose], variances: &[f64], k: usize) -> (Pose, f64, f64) {
    let step = chain[k - 1].between(&chain[k]);
    let heading_deg = (variances[k] - variances[k - 1]).max(0.01).sqrt();
    (step, heading_deg, 0.05 + 0.05 * step.x.hypot(step.y))
}

/// The pose graph of the chain (`initial` poses, heading `variances` in
/// degrees²) and the accepted closures, solved.
fn solve(initial: &[Pose], variances: &[f64], closures: &[Closure]) -> Result<Vec<Pose>, Fatal> {
    let initial = initial.to_vec();
    if initial.len() < 2 || !closures.iter().any(|c| c.accepted) {
        return Ok(initial);
    }
    let se2 = |p: &Pose| SE2::new(p.theta, p.x, p.y);
    let mut values = Values::new();
    for (k, p) in initial.iter().enumerate() {
        values.insert(X(k as u32), se2(p));
    }
    let mut graph = Graph::new();
    graph.add_factor(fac![
        PriorResidual::new(se2(&initial[0])),
        X(0),
        GaussianNoise::<3>::from_diag_sigmas(1e-4, 1e-4, 1e-4)
    ]);
    for k in 1..initial.len() {
        let (step, heading_deg, xy) = chain_step(&initial, variances, k);
        graph.add_factor(fac![
            BetweenResidual::new(se2(&step)),
            (X(k as u32 - 1), X(k as u32)),
            GaussianNoise::<3>::from_diag_sigmas(heading_deg.to_radians(), xy, xy)
        ]);
    }
    for c in closures.iter().filter(|c| c.accepted) {
        graph.add_factor(fac![
            BetweenResidual::new(se2(&c.delta)),
            (X(c.from as u32), X(c.to as u32)),
            GaussianNoise::<3>::from_diag_sigmas(
                GRAPH_CLOSURE_SIGMA_DEG.to_radians(),
                c.translation_sigma_m,
                c.translation_sigma_m
            ),
            Huber::default()
        ]);
    }
    let mut optimizer: LevenMarquardt = LevenMarquardt::new_default(graph);
    // Out of iterations, the solver's last values stand (each iteration
    // lowered the cost); a system it cannot solve is an error.
    let solved = match optimizer.optimize(values) {
        Ok(v) | Err(OptError::MaxIterations(v)) => v,
        Err(OptError::InvalidSystem) => return Err(Fatal::io("pose graph: invalid system")),
        Err(OptError::FailedToStep) => return Err(Fatal::io("pose graph: failed to step")),
    };
    Ok((0..initial.len())
        .map(|k| {
            solved.get(X(k as u32)).map_or(initial[k], |p: &SE2| Pose {
                x: p.x(),
                y: p.y(),
                theta: p.theta(),
            })
        })
        .collect())
}

/// Every closure tried as CSV (`--closures`): the scans of its ends (the
/// recording's indices), its heading change, the chain's and the optimized
/// trajectory's between the same scans, the closure's difference to each
/// (degrees), accepted or not.
///
/// # Errors
/// A [`Fatal`] error when the file cannot be written.
pub fn write_closures(path: &Path, nodes: &[Node], solved: &Solved) -> Result<(), Fatal> {
    let mut out = String::from(
        "scan1,scan2,closure_dtheta_deg,chain_dtheta_deg,optimized_dtheta_deg,before_deg,after_deg,accepted\n",
    );
    for c in &solved.closures {
        let chain = nodes[c.from].pose.between(&nodes[c.to].pose);
        let optimized = solved.poses[c.from].between(&solved.poses[c.to]);
        let _ = writeln!(
            out,
            "{},{},{:.4},{:.4},{:.4},{:.4},{:.4},{}",
            nodes[c.from].scan.0,
            nodes[c.to].scan.0,
            c.delta.theta.to_degrees(),
            chain.theta.to_degrees(),
            optimized.theta.to_degrees(),
            c.residual_deg,
            scans::wrap_deg((c.delta.theta - optimized.theta).to_degrees()),
            c.accepted
        );
    }
    std::fs::write(path, out).map_err(|e| Fatal::io(format!("{}: {e}", path.display())))
}

/// The graph as `.g2o` (`VERTEX_SE2`, `EDGE_SE2` with the information
/// matrix's upper triangle): the chain's steps and the accepted closures,
/// the poses the solver gave.
///
/// # Errors
/// A [`Fatal`] error when the file cannot be written.
pub fn write_g2o(path: &Path, nodes: &[Node], solved: &Solved) -> Result<(), Fatal> {
    let mut out = String::new();
    for (k, p) in solved.poses.iter().enumerate() {
        let _ = writeln!(out, "VERTEX_SE2 {k} {:.6} {:.6} {:.6}", p.x, p.y, p.theta);
    }
    let mut edge = |a: usize, b: usize, d: &Pose, heading_deg: f64, xy: f64| {
        let (ixy, it) = (1.0 / (xy * xy), 1.0 / heading_deg.to_radians().powi(2));
        let _ = writeln!(
            out,
            "EDGE_SE2 {a} {b} {:.6} {:.6} {:.6} {ixy:.3} 0 0 {ixy:.3} 0 {it:.3}",
            d.x, d.y, d.theta
        );
    };
    let chain: Vec<Pose> = nodes.iter().map(|n| n.pose).collect();
    let variances = capped_variances(nodes.iter().map(|n| n.variance));
    for k in 1..nodes.len() {
        let (step, heading_deg, xy) = chain_step(&chain, &variances, k);
        edge(k - 1, k, &step, heading_deg, xy);
    }
    for c in solved.closures.iter().filter(|c| c.accepted) {
        edge(
            c.from,
            c.to,
            &c.delta,
            GRAPH_CLOSURE_SIGMA_DEG,
            c.translation_sigma_m,
        );
    }
    std::fs::write(path, out).map_err(|e| Fatal::io(format!("{}: {e}", path.display())))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn closure(from: usize, to: usize, residual_deg: f64, sigma_deg: f64) -> Closure {
        Closure {
            from,
            to,
            delta: Pose::ZERO,
            residual_deg,
            sigma_deg,
            offset_m: 0.0,
            translation_sigma_m: CLOSURE_SIGMA_M,
            offset_gate_m: 1.0,
            accepted: false,
        }
    }

    /// Which of `ends` (from, to, the closure's heading minus the chain's,
    /// degrees) `accept` takes on a chain of heading `variances`.
    fn verdicts(variances: &[f64], ends: &[(usize, usize, f64)]) -> Vec<bool> {
        let sigma = |a: usize, b: usize| (variances[b] - variances[a] + 4.0).sqrt();
        let mut closures: Vec<Closure> = ends
            .iter()
            .map(|&(a, b, residual)| closure(a, b, residual, sigma(a, b)))
            .collect();
        accept(&mut closures, variances, &LoopSettings::default());
        closures.iter().map(|c| c.accepted).collect()
    }

    /// 100 nodes, 0.25° σ a step, and one carried step of σ 30° at node 30:
    /// the chain's heading variance at each node.
    fn chain_with_a_carried_step() -> Vec<f64> {
        (0..100)
            .map(|k| match k {
                0..30 => k as f64 * 0.0625,
                _ => (k - 1) as f64 * 0.0625 + 900.0,
            })
            .collect()
    }

    #[test]
    fn a_half_turn_closure_is_rejected_and_consistent_ones_kept() {
        // A chain of 100 nodes, 0.25° σ a step.
        let variances: Vec<f64> = (0..100).map(|k| k as f64 * 0.0625).collect();
        let ends = [
            (0, 60, 1.0),
            (2, 62, 1.5),
            (4, 64, 180.0),
            (6, 66, 90.0),
            // Within the gate but alone: nothing agrees with it.
            (50, 99, -9.0),
        ];
        assert_eq!(
            verdicts(&variances, &ends),
            [true, true, false, false, false]
        );
    }

    #[test]
    fn a_carried_step_does_not_open_the_gate_to_quarter_turns() {
        // The carried step's stated variance lets a revisit's quarter-turn
        // answers through; capped, it does not, and the right closures stay.
        let chained = chain_with_a_carried_step();
        let ends = [
            (0, 60, 1.0),
            (2, 62, 1.5),
            (4, 64, 0.5),
            (20, 80, 0.5),
            // A symmetric place, revisited twice: alike wrong answers.
            (6, 66, 88.0),
            (8, 68, 89.0),
            (24, 84, 87.5),
        ];
        assert_eq!(verdicts(&chained, &ends), [true; 7]);
        let capped = capped_variances(chained.iter().copied());
        assert!((capped[99] - (98.0 * 0.0625 + 9.0)).abs() < 1e-9);
        assert_eq!(
            verdicts(&capped, &ends),
            [true, true, true, true, false, false, false]
        );
    }

    #[test]
    fn an_uncertain_chain_takes_a_closure_seen_elsewhere_too() {
        // Every closure across the carried step is beyond the trusted σ.
        let ends = [
            // One revisit, and another 20 scans on: the same drift.
            (0, 60, 1.0),
            (2, 62, 1.5),
            (20, 80, 0.5),
            // A symmetric place: three alike wrong answers, one revisit.
            (6, 66, 88.0),
            (8, 68, 89.0),
            (10, 70, 87.5),
        ];
        assert_eq!(
            verdicts(&chain_with_a_carried_step(), &ends),
            [true, true, true, false, false, false]
        );
    }

    #[test]
    fn a_closure_pulls_a_drifted_square_back() {
        // A robot drives a 10 m square (4 × 10 steps of 1 m, a quarter turn
        // at each corner) and returns to the start; the chain turned 2°
        // too little at each corner.
        let mut truth = vec![Pose::ZERO];
        let mut chain = vec![Pose::ZERO];
        for k in 0..40 {
            let turn = if k % 10 == 9 { 90f64.to_radians() } else { 0.0 };
            let step = |t: f64| Pose {
                x: 1.0,
                y: 0.0,
                theta: t,
            };
            truth.push(truth[k].compose(&step(turn)));
            chain.push(chain[k].compose(&step(
                turn - if turn > 0.0 { 2f64.to_radians() } else { 0.0 },
            )));
        }
        // The corners' steps are uncertain (σ 3°), the others 0.25°.
        let mut variances = vec![0.0];
        for k in 0..40 {
            let v = if k % 10 == 9 { 9.0 } else { 0.0625 };
            variances.push(variances[k] + v);
        }
        let end = truth.len() - 1;
        let mut c = closure(0, end, 0.0, 1.0);
        c.delta = truth[0].between(&truth[end]);
        c.accepted = true;
        let solved = solve(&chain, &variances, &[c]).unwrap();
        let error = |p: &Pose, q: &Pose| scans::wrap_deg((p.theta - q.theta).to_degrees()).abs();
        assert!(error(&chain[end], &truth[end]) > 7.0);
        assert!(
            error(&solved[end], &truth[end]) < 1.0,
            "{}",
            error(&solved[end], &truth[end])
        );
        // No accepted closure: the chain as it was.
        assert_eq!(
            solve(&chain, &variances, &[]).unwrap()[end].theta,
            chain[end].theta
        );
    }
}
