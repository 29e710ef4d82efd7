//! Accuracy evaluation (issue 4 item 6, issue 8): synthetic scene pairs with
//! known rotation, translation and scale, estimated in paper mode and in
//! improved mode; prints one markdown table.
//!
//! ```text
//! cargo run --release -p host-tests --bin accuracy            # full run (< 10 min, 2 cores)
//! cargo run --release -p host-tests --bin accuracy -- --quick # smoke run (< 1 min)
//! ```
//!
//! Every trial is seeded by its row and index ([`trial_seed`]); paper and
//! improved mode see the same image pairs. `N_THETA` = 360 throughout.

use std::io::Write;
use std::time::Instant;

use clap::Parser;
use host_tests::eval::{
    parallel_map, run_pair, trial_pair, trial_pair_independent, trial_seed, Outcome, Summary,
};
use host_tests::scene::{Damage, SceneKind};
use hough_heading::{
    half_turn_steps, rho_bins, row_words, Estimator, Mode, Score, Status, Thresholds,
};

const N_THETA: usize = 360;

#[derive(Parser, Debug)]
#[command(about = "Accuracy of hough-heading on synthetic scene pairs (markdown table)")]
struct Args {
    /// Smoke run: 100 trials per row, 64² and 128² only.
    #[arg(long)]
    quick: bool,
    /// Trials per row (default 1000, or 100 with --quick).
    #[arg(long)]
    trials: Option<usize>,
    /// Worker threads (default: available parallelism).
    #[arg(long)]
    threads: Option<usize>,
    /// Also write the table to this file.
    #[arg(long)]
    out: Option<std::path::PathBuf>,
    /// Print a sweep of the status thresholds (improved mode) after the table.
    #[arg(long)]
    sweep: bool,
    /// Only rows whose label contains this text (e.g. "polygon 128").
    #[arg(long)]
    only: Option<String>,
    /// Write every outcome as CSV lines to this file (for analysis).
    #[arg(long)]
    dump: Option<std::path::PathBuf>,
}

/// One row of the evaluation.
#[derive(Clone, Copy, Debug)]
struct Row {
    kind: SceneKind,
    size: usize,
    damage: (&'static str, Damage),
    with_scale: bool,
    /// Independent missing stretches in the two views (see
    /// [`trial_pair_independent`]).
    independent: bool,
}

impl Row {
    fn label(&self) -> String {
        format!(
            "{} {}² {}{}{}",
            self.kind.name(),
            self.size,
            self.damage.0,
            if self.independent { " indep." } else { "" },
            if self.with_scale { "" } else { " (s = 1)" }
        )
    }

    /// A stable row id for the seeds: kind, size, damage, scale.
    fn id(&self) -> u64 {
        let kind = SceneKind::ALL
            .iter()
            .position(|&k| k == self.kind)
            .unwrap_or(0) as u64;
        let damage = Damage::PRESETS
            .iter()
            .position(|(n, _)| *n == self.damage.0)
            .unwrap_or(0) as u64;
        (((kind * 1000 + self.size as u64) * 10 + damage) * 2 + u64::from(self.with_scale)) * 2
            + u64::from(self.independent)
    }
}

/// The rows of the run: every kind × damage × size (64², 128², 256²; the
/// quick run skips 256²), then the half-turn-symmetric kinds with independent
/// damage in the two views, and scale-free rows for the translation.
fn rows(quick: bool) -> Vec<Row> {
    let mut rows = Vec::new();
    let sizes: &[usize] = if quick { &[64, 128] } else { &[64, 128, 256] };
    let row = |kind, size, damage, with_scale, independent| Row {
        kind,
        size,
        damage,
        with_scale,
        independent,
    };
    for &size in sizes {
        for kind in SceneKind::ALL {
            for damage in Damage::PRESETS {
                rows.push(row(kind, size, damage, true, false));
            }
        }
    }
    for &size in sizes {
        for kind in [SceneKind::Corridor, SceneKind::CentrallySymmetric] {
            for damage in &Damage::PRESETS[1..] {
                rows.push(row(kind, size, *damage, true, true));
            }
        }
    }
    // Translation without scale change (laser scans of one sensor, issue 8).
    for &size in sizes {
        for kind in [SceneKind::RandomPolygon, SceneKind::ManhattanRoom] {
            rows.push(row(kind, size, Damage::PRESETS[1], false, false));
        }
    }
    rows
}

/// Both modes on `trials` seeded pairs of `row`, for one configuration.
fn run_row<
    const W: usize,
    const H: usize,
    const RW: usize,
    const N: usize,
    const HALF: usize,
    const RHO: usize,
>(
    row: &Row,
    trials: usize,
    threads: usize,
) -> (Vec<Outcome>, Vec<Outcome>) {
    let symmetric = row.kind.is_centrally_symmetric();
    let both = parallel_map(trials, threads, |i| {
        let seed = trial_seed(row.id(), i as u64);
        let render = if row.independent {
            trial_pair_independent
        } else {
            trial_pair
        };
        let (truth, pair) = render(row.kind, &row.damage.1, W, H, row.with_scale, seed);
        let mut paper = Estimator::<W, H, RW, N, HALF, RHO>::new(Mode::Paper);
        let mut improved = Estimator::<W, H, RW, N, HALF, RHO>::new(Mode::Improved);
        (
            run_pair(&mut paper, &pair, &truth, symmetric),
            run_pair(&mut improved, &pair, &truth, symmetric),
        )
    });
    both.into_iter().unzip()
}

fn dispatch(row: &Row, trials: usize, threads: usize) -> (Vec<Outcome>, Vec<Outcome>) {
    const H: usize = half_turn_steps(N_THETA);
    match row.size {
        64 => run_row::<64, 64, { row_words(64) }, N_THETA, H, { rho_bins(64, 64) }>(
            row, trials, threads,
        ),
        128 => run_row::<128, 128, { row_words(128) }, N_THETA, H, { rho_bins(128, 128) }>(
            row, trials, threads,
        ),
        256 => run_row::<256, 256, { row_words(256) }, N_THETA, H, { rho_bins(256, 256) }>(
            row, trials, threads,
        ),
        other => panic!("no configuration for {other}²"),
    }
}

fn pct(v: f64) -> String {
    if v.is_nan() {
        "–".into()
    } else {
        format!("{:.1} %", 100.0 * v)
    }
}

fn num(v: f64, digits: usize) -> String {
    if v.is_nan() {
        "–".into()
    } else {
        format!("{v:.digits$}")
    }
}

fn table_header() -> String {
    "| scene | size | damage | scale | mode | trials | median ° | p90 ° | fail > 5° | wrong half-turn | flagged | fail among unflagged | t median px | t p90 px |\n\
     |---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
        .into()
}

fn table_line(row: &Row, mode: &str, s: &Summary, translation: bool) -> String {
    let symmetric = row.kind.is_centrally_symmetric();
    format!(
        "| {} | {}² | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
        row.kind.name(),
        row.size,
        row.damage.0,
        if row.with_scale { "0.9–1.1" } else { "1" },
        mode,
        s.trials,
        num(s.median_deg, 3),
        num(s.p90_deg, 3),
        pct(s.failures),
        if symmetric {
            "–".into()
        } else {
            pct(s.wrong_half_turns)
        },
        pct(s.flagged),
        pct(s.failures_unflagged),
        if translation {
            num(s.translation_median_px, 2)
        } else {
            "–".into()
        },
        if translation {
            num(s.translation_p90_px, 2)
        } else {
            "–".into()
        },
    )
}

/// Threshold sweep over the improved mode's recorded scores.
fn sweep(results: &[(Row, Vec<Outcome>)]) -> String {
    let mut out = String::from(
        "\n### Status thresholds (improved mode): share flagged / failures among unflagged\n\n",
    );
    let ratios = [0.85, 0.88, 0.9, 0.92, 0.95];
    let margins = [0.02, 0.03, 0.05, 0.08, 0.1];
    out.push_str("| rival_ratio | direction_margin | worst fail among unflagged (row) | symmetric flagged (min) | polygon 128² moderate flagged | manhattan 128² moderate flagged | mean flagged (asymmetric rows) |\n|---|---|---|---|---|---|---|\n");
    for &r in &ratios {
        for &m in &margins {
            let t = Thresholds {
                rival_ratio: Score::from_num(r),
                direction_margin: Score::from_num(m),
                ..Thresholds::DEFAULT
            };
            let mut worst = (0.0f64, String::new());
            let mut sym_min = 1.0f64;
            let (mut poly, mut manh) = (f64::NAN, f64::NAN);
            let (mut flag_sum, mut flag_n) = (0.0, 0);
            for (row, outcomes) in results {
                let s = Summary::with_status(outcomes, |o| o.status_with(&t));
                if s.failures_unflagged > worst.0 {
                    worst = (s.failures_unflagged, row.label());
                }
                if row.kind.is_centrally_symmetric() {
                    sym_min = sym_min.min(s.flagged);
                } else {
                    flag_sum += s.flagged;
                    flag_n += 1;
                }
                if row.size == 128 && row.damage.0 == "moderate" && row.with_scale {
                    match row.kind {
                        SceneKind::RandomPolygon => poly = s.flagged,
                        SceneKind::ManhattanRoom => manh = s.flagged,
                        _ => {}
                    }
                }
            }
            out.push_str(&format!(
                "| {r} | {m} | {} ({}) | {} | {} | {} | {} |\n",
                pct(worst.0),
                worst.1,
                pct(sym_min),
                pct(poly),
                pct(manh),
                pct(flag_sum / flag_n.max(1) as f64),
            ));
        }
    }
    out
}

fn main() {
    let args = Args::parse();
    let trials = args.trials.unwrap_or(if args.quick { 100 } else { 1000 });
    let threads = args
        .threads
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get()));
    let start = Instant::now();
    let mut table = table_header();
    let mut improved_results = Vec::new();
    let mut stderr = std::io::stderr();
    let mut dump = args.dump.as_ref().map(|path| {
        let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("create the dump"));
        let _ = writeln!(
            f,
            "row,mode,trial,error,axis_error,full_error,wrong_half_turn,status,correlation,rival,margin,t_error,t_unobservable,direct,flipped"
        );
        f
    });
    for row in rows(args.quick) {
        if let Some(filter) = &args.only {
            if !row.label().contains(filter.as_str()) {
                continue;
            }
        }
        let t0 = Instant::now();
        let (paper, improved) = dispatch(&row, trials, threads);
        let sp = Summary::of(&paper);
        let si = Summary::of(&improved);
        table.push_str(&table_line(&row, "paper", &sp, false));
        table.push_str(&table_line(&row, "improved", &si, true));
        let _ = writeln!(
            stderr,
            "{:<32} {:>6.1} s  improved: median {:.3}° p90 {:.3}° fail {:.1} % flagged {:.1} %",
            row.label(),
            t0.elapsed().as_secs_f64(),
            si.median_deg,
            si.p90_deg,
            100.0 * si.failures,
            100.0 * si.flagged
        );
        if let Some(dump) = dump.as_mut() {
            for (mode, outcomes) in [("paper", &paper), ("improved", &improved)] {
                for (i, o) in outcomes.iter().enumerate() {
                    let _ = writeln!(
                        dump,
                        "{},{mode},{i},{:.4},{:.4},{:.4},{},{:?},{:.4},{:.4},{:.4},{},{},{:.4},{:.4}",
                        row.label(),
                        o.error_deg,
                        o.axis_error_deg,
                        o.full_error_deg,
                        o.wrong_half_turn,
                        o.status,
                        o.correlation,
                        o.rival,
                        o.margin,
                        o.translation_error_px.map_or(f64::NAN, |t| t),
                        o.translation_unobservable,
                        o.direct,
                        o.flipped,
                    );
                }
            }
        }
        improved_results.push((row, improved));
    }
    let mut report = table;
    let statuses = status_breakdown(&improved_results);
    report.push_str(&statuses);
    if args.sweep {
        report.push_str(&sweep(&improved_results));
    }
    report.push_str(&format!(
        "\n{} trials per row, N_THETA = {N_THETA}, {threads} threads, {:.0} s.\n",
        trials,
        start.elapsed().as_secs_f64()
    ));
    print!("{report}");
    if let Some(path) = args.out {
        std::fs::write(&path, &report).expect("write the table");
    }
}

/// Improved mode: share of each status per row.
fn status_breakdown(results: &[(Row, Vec<Outcome>)]) -> String {
    let mut out = String::from(
        "\n### Statuses (improved mode)\n\n| row | confident | ambiguous axis | ambiguous direction | no structure | t unobservable |\n|---|---|---|---|---|---|\n",
    );
    for (row, outcomes) in results {
        let n = outcomes.len().max(1) as f64;
        let share = |s: Status| outcomes.iter().filter(|o| o.status == s).count() as f64 / n;
        let unobs = outcomes
            .iter()
            .filter(|o| o.translation_unobservable)
            .count() as f64
            / n;
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            row.label(),
            pct(share(Status::Confident)),
            pct(share(Status::AmbiguousAxis)),
            pct(share(Status::AmbiguousDirection)),
            pct(share(Status::NoStructure)),
            pct(unobs),
        ));
    }
    out
}
