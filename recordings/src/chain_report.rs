//! What a chained trajectory shows without reference poses (`log --summary`
//! on a recording that has no poses of its own to score against): how the
//! pairs moved the chain, its turn, and how it agrees with the odometry
//! where the recording has one.
//!
//! Definitions (angles in degrees):
//!
//! These count the chain's steps, one a scan after the first; the pairs the
//! run estimated (and their JSON lines' `status`) are counted apart, as
//! `log` prints them before this table.
//!
//! - *chain steps placed by a confident estimate*: the steps whose source
//!   is `estimate` or `estimate+odometry`.
//! - *steps by source*: the chain's steps by what moved them
//!   ([`Step::source`]: `estimate` and `estimate+odometry` are confident
//!   estimates; `prior`, `unplaced`, `carried`, `odometry` and `none` are
//!   flagged or failed pairs, by how the chain went on).
//! - *chained turn*: the sum of the steps' heading changes, each wrapped to
//!   (−180, 180] (the total heading change, whole turns included).
//! - *within 2° of the odometry*: among the steps whose two scans have
//!   odometry, the share whose heading change is within 2° of the
//!   odometry's (`|wrap(Δθ_chain − Δθ_odom)|`), and the median and p90 of
//!   that difference.
//! - *turn difference*: the chained turn minus the odometry's over the
//!   same steps (the end heading difference, whole turns included); *end
//!   distance*: between the chain's last pose and the odometry's, both
//!   starting together ([`crate::trajectory`]).

use crate::model::{wrap_rad, Pose};
use crate::stats::{markdown_header, markdown_row, quantile};
use crate::trajectory::{Step, Trajectory};

/// The sources of a step that are a confident estimate.
const CONFIDENT: [&str; 2] = ["estimate", "estimate+odometry"];
/// Heading agreement with the odometry counted, degrees.
const AGREE_DEG: f64 = 2.0;

/// A step's heading change from the step before, degrees.
fn turn_deg(a: &Pose, b: &Pose) -> f64 {
    wrap_rad(b.theta - a.theta).to_degrees()
}

/// The report of `t` (Markdown): `None` when it has no step beyond its
/// start.
pub fn report(t: &Trajectory) -> Option<String> {
    let steps = t.steps.get(1..).filter(|s| !s.is_empty())?;
    let n = steps.len();
    let share = |k: usize, of: usize| format!("{:.1} % ({k}/{of})", 100.0 * k as f64 / of as f64);
    let mut out = markdown_header(&["", "value"]);
    let mut row = |what: &str, value: String| out.push_str(&markdown_row(&[what, &value]));
    let confident = steps
        .iter()
        .filter(|s| CONFIDENT.contains(&s.source))
        .count();
    row("chain steps (one a scan after the first)", n.to_string());
    row(
        "chain steps placed by a confident estimate",
        share(confident, n),
    );
    let mut sources: Vec<&str> = steps.iter().map(|s| s.source).collect();
    sources.sort_unstable();
    sources.dedup();
    for source in sources.iter().filter(|s| !CONFIDENT.contains(s)) {
        let k = steps.iter().filter(|s| s.source == *source).count();
        row(&format!("steps by `{source}`"), share(k, n));
    }
    let turn: f64 = t
        .steps
        .windows(2)
        .map(|w| turn_deg(&w[0].pose, &w[1].pose))
        .sum();
    row("chained turn", format!("{turn:.1}°"));
    // Consecutive steps that both have odometry.
    let with_odom: Vec<(&Step, &Step, Pose, Pose)> = t
        .steps
        .windows(2)
        .filter_map(|w| Some((&w[0], &w[1], w[0].odom?, w[1].odom?)))
        .collect();
    if with_odom.is_empty() {
        row("odometry", "none in the recording".into());
        return Some(out);
    }
    let differences: Vec<f64> = with_odom
        .iter()
        .map(|(a, b, oa, ob)| {
            (wrap_rad(b.pose.theta - a.pose.theta - (ob.theta - oa.theta))).to_degrees()
        })
        .map(f64::abs)
        .collect();
    let m = differences.len();
    let agree = differences.iter().filter(|&&d| d <= AGREE_DEG).count();
    row(
        &format!("steps within {AGREE_DEG}° of the odometry's turn"),
        share(agree, m),
    );
    row(
        "step heading difference to the odometry, median / p90",
        format!(
            "{:.2}° / {:.2}°",
            quantile(&differences, 0.5),
            quantile(&differences, 0.9)
        ),
    );
    let chain_turn: f64 = with_odom
        .iter()
        .map(|(a, b, ..)| turn_deg(&a.pose, &b.pose))
        .sum();
    let odom_turn: f64 = with_odom
        .iter()
        .map(|(_, _, oa, ob)| turn_deg(oa, ob))
        .sum();
    row(
        "turn over those steps: chain / odometry",
        format!("{chain_turn:.1}° / {odom_turn:.1}°"),
    );
    row(
        "end heading difference, chain − odometry",
        format!("{:.1}°", chain_turn - odom_turn),
    );
    if let Some(last) = t.steps.iter().rev().find(|s| s.odom.is_some()) {
        let o = last.odom.unwrap_or(Pose::ZERO);
        row(
            "end distance, chain to odometry",
            format!("{:.2} m", (last.pose.x - o.x).hypot(last.pose.y - o.y)),
        );
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(scan: usize, theta_deg: f64, source: &'static str, odom_deg: Option<f64>) -> Step {
        let pose = |deg: f64| Pose {
            x: scan as f64,
            y: 0.0,
            theta: wrap_rad(deg.to_radians()),
        };
        Step {
            scan,
            time: None,
            pose: pose(theta_deg),
            source,
            odom: odom_deg.map(pose),
            log_pose: None,
        }
    }

    /// A chain turning a full circle and a half in 10° steps, one flagged,
    /// against odometry that turns 11° a step: hand-checked figures.
    #[test]
    fn a_chain_against_its_odometry() {
        let mut t = Trajectory::default();
        t.steps.push(step(0, 0.0, "start", Some(0.0)));
        for i in 1..=54 {
            let source = if i == 7 { "predicted" } else { "estimate" };
            let odom = (i > 4).then(|| 11.0 * f64::from(i as u32));
            t.steps.push(step(i, 10.0 * i as f64, source, odom));
        }
        let report = report(&t).expect("a report");
        assert!(
            report.contains("| chain steps (one a scan after the first) | 54 |"),
            "{report}"
        );
        assert!(
            report.contains("| chain steps placed by a confident estimate | 98.1 % (53/54) |"),
            "{report}"
        );
        assert!(
            report.contains("| steps by `predicted` | 1.9 % (1/54) |"),
            "{report}"
        );
        // 54 steps of 10°: 540°, whole turns included.
        assert!(report.contains("| chained turn | 540.0° |"), "{report}");
        // Steps 6..=54 have odometry at both ends: 49 steps, each 1° off.
        assert!(
            report.contains("| steps within 2° of the odometry's turn | 100.0 % (49/49) |"),
            "{report}"
        );
        assert!(report.contains("| 1.00° / 1.00° |"), "{report}");
        assert!(report.contains("| 490.0° / 539.0° |"), "{report}");
        assert!(report.contains("| end heading difference, chain − odometry | -49.0° |"));
        // Without odometry the report says so.
        for s in &mut t.steps {
            s.odom = None;
        }
        let report = super::report(&t).expect("a report");
        assert!(report.contains("| odometry | none in the recording |"));
        assert!(super::report(&Trajectory::default()).is_none());
    }
}
