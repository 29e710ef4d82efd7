//! The translation fit (`stages::fit_translation`, integer arithmetic: Q16
//! shifts, Q15 normals, a Q24 normal matrix) against an `f64` statement of
//! the same fit, written here from its documentation: the weighted least
//! squares over the best shifts; when a best shift is more than 2 px from
//! that fit, the consensus over the translations that pairs of columns (or,
//! with all normals nearly parallel, single columns) determine, scored by
//! the summed weight of the columns with a candidate within 2 px; the final
//! least squares over the supporting candidates; one direction
//! unobservable when the normal matrix's eigenvalues are more than 20 : 1
//! apart.
//!
//! Both see the same quantized inputs, so they differ only by the integer
//! arithmetic's rounding, except where a decision sits on its threshold
//! (a residual within 0.01 px of 2 px, an eigenvalue ratio within 10⁻³ of
//! 0.05, two consensus translations whose supports the rounding could
//! reorder): such cases are counted, not compared, and their share bounded.

use hough_heading::stages::{fit_translation, ColumnShift, Shift, RUNNERS_UP};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const OUTLIER_PX: f64 = 2.0;
/// A residual this close to [`OUTLIER_PX`] makes a case fragile.
const EDGE_PX: f64 = 0.01;
const OBSERVABILITY: f64 = 0.05;
const MIN_PAIR_SINE: f64 = 0.34;

/// One column as the fit sees it: its normal and its candidates (best
/// first), each `(shift px, weight)`, `None` for weight 0.
struct Column {
    n: (f64, f64),
    candidates: Vec<Option<(f64, f64)>>,
}

fn decode(c: &ColumnShift) -> Column {
    let shift = |s: &Shift| {
        (s.score_q16 > 0).then(|| (f64::from(s.shift_q16) / 65536.0, f64::from(s.score_q16)))
    };
    let mut candidates = vec![shift(&c.best)];
    candidates.extend(c.runners_up.iter().map(shift));
    Column {
        n: (
            f64::from(c.normal_q15.0) / 32768.0,
            f64::from(c.normal_q15.1) / 32768.0,
        ),
        candidates,
    }
}

/// The reference's answer and whether a decision sat on its threshold.
struct Fit {
    t: (f64, f64),
    unobservable: Option<(f64, f64)>,
    residual: f64,
    columns: usize,
    fragile: bool,
}

/// `t`, the unobservable direction, and the eigenvalue ratio small / large.
type Solved = ((f64, f64), Option<(f64, f64)>, f64);

/// Least squares over the chosen candidates.
fn solve(columns: &[Column], choices: &[Option<usize>]) -> Option<Solved> {
    let (mut a, mut b, mut c, mut u, mut v) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (col, k) in columns.iter().zip(choices) {
        let Some((s, w)) = k.and_then(|k| col.candidates[k]) else {
            continue;
        };
        let (nx, ny) = col.n;
        a += w * nx * nx;
        b += w * nx * ny;
        c += w * ny * ny;
        u += w * nx * s;
        v += w * ny * s;
    }
    let spread = (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let (large, small) = (0.5 * (a + c) + spread, 0.5 * (a + c) - spread);
    if large <= 0.0 {
        return None;
    }
    let ratio = small / large;
    if ratio < OBSERVABILITY {
        let (ex, ey) = if b != 0.0 {
            let (x, y) = (large - c, b);
            let n = x.hypot(y);
            (x / n, y / n)
        } else if a >= c {
            (1.0, 0.0)
        } else {
            (0.0, 1.0)
        };
        let along = (ex * u + ey * v) / large;
        return Some(((along * ex, along * ey), Some((-ey, ex)), ratio));
    }
    let det = a * c - b * b;
    Some((((c * u - b * v) / det, (a * v - b * u) / det), None, ratio))
}

fn residual(col: &Column, k: usize, t: (f64, f64)) -> Option<f64> {
    col.candidates[k].map(|(s, _)| col.n.0 * t.0 + col.n.1 * t.1 - s)
}

/// The heaviest candidate within `limit` px of `t`'s prediction (first of
/// equals).
fn supporting(col: &Column, t: (f64, f64), limit: f64) -> Option<(usize, f64)> {
    let mut best: Option<(usize, f64)> = None;
    for k in 0..col.candidates.len() {
        if let (Some((_, w)), Some(r)) = (col.candidates[k], residual(col, k, t)) {
            if r.abs() <= limit && best.is_none_or(|(_, bw)| w > bw) {
                best = Some((k, w));
            }
        }
    }
    best
}

fn support(columns: &[Column], t: (f64, f64), limit: f64) -> f64 {
    columns
        .iter()
        .filter_map(|c| supporting(c, t, limit))
        .map(|(_, w)| w)
        .sum()
}

/// The translations the consensus considers, in the library's order.
fn considered(columns: &[Column]) -> Vec<(f64, f64)> {
    let mut out = Vec::new();
    for (i, a) in columns.iter().enumerate() {
        for b in &columns[i + 1..] {
            let det = a.n.0 * b.n.1 - a.n.1 * b.n.0;
            if det.abs() < MIN_PAIR_SINE {
                continue;
            }
            for ka in 0..a.candidates.len() {
                for kb in (0..b.candidates.len()).filter(|&kb| ka == 0 || kb == 0) {
                    if let (Some((sa, _)), Some((sb, _))) = (a.candidates[ka], b.candidates[kb]) {
                        out.push((
                            (sa * b.n.1 - a.n.1 * sb) / det,
                            (a.n.0 * sb - sa * b.n.0) / det,
                        ));
                    }
                }
            }
        }
    }
    if out.is_empty() {
        for c in columns {
            out.extend(
                c.candidates
                    .iter()
                    .flatten()
                    .map(|&(s, _)| (s * c.n.0, s * c.n.1)),
            );
        }
    }
    out
}

fn reference_fit(columns: &[Column]) -> Option<Fit> {
    let mut fragile = false;
    let mut choices: Vec<Option<usize>> = vec![Some(0); columns.len()];
    let (mut t, mut unobservable, ratio) = solve(columns, &choices)?;
    fragile |= (ratio - OBSERVABILITY).abs() < 1e-3;
    let mut agree = true;
    for col in columns {
        if let Some(r) = residual(col, 0, t) {
            fragile |= (r.abs() - OUTLIER_PX).abs() < EDGE_PX;
            agree &= r.abs() <= OUTLIER_PX;
        }
    }
    if !agree {
        let scored: Vec<((f64, f64), f64, f64, f64)> = considered(columns)
            .into_iter()
            .map(|t| {
                let strict = support(columns, t, OUTLIER_PX - EDGE_PX);
                let nominal = support(columns, t, OUTLIER_PX);
                let lenient = support(columns, t, OUTLIER_PX + EDGE_PX);
                (t, strict, nominal, lenient)
            })
            .collect();
        let mut best: Option<usize> = None;
        for (j, s) in scored.iter().enumerate() {
            if best.is_none_or(|b| s.2 > scored[b].2) {
                best = Some(j);
            }
        }
        if let Some(b) = best {
            let (tb, strict_b, _, lenient_b) = scored[b];
            fragile |= strict_b != lenient_b;
            for (j, &(tj, _, _, lenient_j)) in scored.iter().enumerate() {
                let apart = (tj.0 - tb.0).hypot(tj.1 - tb.1) > 1e-3;
                let rival = if j < b {
                    lenient_j >= strict_b
                } else {
                    lenient_j > strict_b
                };
                fragile |= apart && j != b && rival;
            }
            choices = columns
                .iter()
                .map(|c| supporting(c, tb, OUTLIER_PX).map(|(k, _)| k))
                .collect();
            let (t2, u2, ratio2) = solve(columns, &choices)?;
            fragile |= (ratio2 - OBSERVABILITY).abs() < 1e-3;
            (t, unobservable) = (t2, u2);
        }
    }
    let (mut sum_w, mut sum_r2, mut kept) = (0.0, 0.0, 0);
    for (col, k) in columns.iter().zip(&choices) {
        if let Some(k) = *k {
            if let (Some((_, w)), Some(r)) = (col.candidates[k], residual(col, k, t)) {
                sum_w += w;
                sum_r2 += w * r * r;
                kept += 1;
            }
        }
    }
    Some(Fit {
        t,
        unobservable,
        residual: if sum_w > 0.0 {
            (sum_r2 / sum_w).sqrt()
        } else {
            0.0
        },
        columns: kept,
        fragile,
    })
}

/// A random case: 1–6 columns (sometimes all within a few degrees of one
/// direction: a corridor), shifts of a random translation with noise, some
/// columns locked on a wrong wall (best shift 4–20 px off) with the right
/// one or another wrong one among their runners-up, weights from 1/64 to 1
/// (scaled by a random power of two up to 2¹⁵, or 2⁻¹⁰, for some cases).
fn random_case(rng: &mut ChaCha8Rng) -> Vec<ColumnShift> {
    let count = rng.gen_range(1..=6);
    let corridor = rng.gen_bool(0.15);
    let base = rng.gen_range(0.0..std::f64::consts::PI);
    let t = (rng.gen_range(-40.0..40.0), rng.gen_range(-40.0..40.0));
    let weight_scale = match rng.gen_range(0..6) {
        0 => 2f64.powi(rng.gen_range(1..=15)),
        1 => 2f64.powi(-10),
        _ => 1.0,
    };
    let weight = |rng: &mut ChaCha8Rng| {
        ((rng.gen_range(1.0 / 64.0..=1.0) * weight_scale * 65536.0) as u32).max(1)
    };
    (0..count)
        .map(|_| {
            let psi = if corridor {
                base + rng.gen_range(-0.08..0.08)
            } else {
                rng.gen_range(0.0..std::f64::consts::PI)
            };
            let (s, c) = psi.sin_cos();
            let normal_q15 = ((c * 32768.0).round() as i32, (s * 32768.0).round() as i32);
            let truth = c * t.0 + s * t.1;
            let noisy = |rng: &mut ChaCha8Rng| truth + rng.gen_range(-0.4..0.4);
            let wrong = |rng: &mut ChaCha8Rng| {
                truth + rng.gen_range(4.0..20.0) * if rng.gen_bool(0.5) { 1.0 } else { -1.0 }
            };
            let q16 = |v: f64| (v * 65536.0).round() as i32;
            let locked = rng.gen_bool(0.3);
            let best = Shift {
                shift_q16: q16(if locked { wrong(rng) } else { noisy(rng) }),
                score_q16: weight(rng),
            };
            let mut runners_up = [Shift::default(); RUNNERS_UP];
            for (i, r) in runners_up.iter_mut().enumerate() {
                if rng.gen_bool(0.6) {
                    let right = locked && i == 0 && rng.gen_bool(0.8);
                    *r = Shift {
                        shift_q16: q16(if right { noisy(rng) } else { wrong(rng) }),
                        score_q16: weight(rng),
                    };
                }
            }
            ColumnShift {
                normal_q15,
                best,
                runners_up,
            }
        })
        .collect()
}

/// 20 000 seeded cases; the fit's unobservable direction also has the
/// documented sign. Measured (2026-12-02): 359 fragile (1.8 %), the
/// other 19 641 identical in columns kept and observability; translation
/// error max 4.6·10⁻⁴ px (|t| up to 57 px), residual error max
/// 8.3·10⁻⁴ px, unobservable direction error max 1.1·10⁻⁵. Bounds:
/// fragile ≤ 4 %, translation ≤ 2⁻¹² px + 2⁻¹⁶ of |t|, residual
/// ≤ 2·10⁻³ px, direction ≤ 10⁻⁴ (up to sign).
#[test]
fn integer_fit_agrees_with_the_f64_fit() {
    let mut rng = ChaCha8Rng::seed_from_u64(20_261_202);
    let (mut compared, mut fragile, mut none) = (0usize, 0usize, 0usize);
    let (mut worst_t, mut worst_r, mut worst_u) = (0.0f64, 0.0f64, 0.0f64);
    const CASES: usize = 20_000;
    for case in 0..CASES {
        let shifts = random_case(&mut rng);
        let columns: Vec<Column> = shifts.iter().map(decode).collect();
        let reference = reference_fit(&columns);
        let fit = fit_translation(&shifts);
        let (Some(r), Some(f)) = (&reference, &fit) else {
            assert_eq!(
                reference.is_some(),
                fit.is_some(),
                "case {case}: {shifts:?}"
            );
            none += 1;
            continue;
        };
        if r.fragile {
            fragile += 1;
            continue;
        }
        compared += 1;
        assert_eq!(usize::from(f.columns), r.columns, "case {case}: {shifts:?}");
        assert_eq!(
            f.unobservable.is_some(),
            r.unobservable.is_some(),
            "case {case}: {shifts:?}"
        );
        let (x, y) = (f.x.to_num::<f64>(), f.y.to_num::<f64>());
        let dt = (x - r.t.0).hypot(y - r.t.1);
        let bound = 2f64.powi(-12) + 2f64.powi(-16) * r.t.0.hypot(r.t.1);
        assert!(
            dt <= bound,
            "case {case}: t ({x}, {y}) vs {:?}, {dt} px: {shifts:?}",
            r.t
        );
        worst_t = worst_t.max(dt);
        let dr = (f.residual.to_num::<f64>() - r.residual).abs();
        assert!(
            dr <= 1e-3,
            "case {case}: residual {} vs {}",
            f.residual,
            r.residual
        );
        worst_r = worst_r.max(dr);
        if let (Some((ux, uy)), Some((rx, ry))) = (f.unobservable, r.unobservable) {
            assert!(
                uy > 0 || (uy == 0 && ux < 0),
                "case {case}: sign of ({ux}, {uy})"
            );
            let (ux, uy) = (ux.to_num::<f64>(), uy.to_num::<f64>());
            let du = (ux - rx).hypot(uy - ry).min((ux + rx).hypot(uy + ry));
            assert!(
                du <= 1e-4,
                "case {case}: direction ({ux}, {uy}) vs ({rx}, {ry})"
            );
            worst_u = worst_u.max(du);
        }
    }
    eprintln!(
        "{CASES} cases: {compared} compared, {fragile} fragile, {none} without a fit; \
         max error: t {worst_t:.2e} px, residual {worst_r:.2e} px, direction {worst_u:.2e}"
    );
    assert!(fragile * 25 <= CASES, "{fragile} fragile cases of {CASES}");
    assert!(
        compared * 10 >= CASES * 9,
        "only {compared} of {CASES} compared"
    );
}

/// Hostile inputs: any `i32` normals and shifts and any `u32` weights give
/// a fit or `None`, never a panic (debug overflow checks included), and a
/// fit's translation is within the fixed-point range by construction.
#[test]
fn extreme_inputs_never_panic() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let pick = |rng: &mut ChaCha8Rng| -> i32 {
        match rng.gen_range(0..4) {
            0 => i32::MIN,
            1 => i32::MAX,
            2 => rng.gen_range(-3..=3),
            _ => rng.gen(),
        }
    };
    for _ in 0..20_000 {
        let count = rng.gen_range(0..=10);
        let shifts: Vec<ColumnShift> = (0..count)
            .map(|_| ColumnShift {
                normal_q15: (pick(&mut rng), pick(&mut rng)),
                best: Shift {
                    shift_q16: pick(&mut rng),
                    score_q16: pick(&mut rng) as u32,
                },
                runners_up: [Shift {
                    shift_q16: pick(&mut rng),
                    score_q16: pick(&mut rng) as u32,
                }; RUNNERS_UP],
            })
            .collect();
        if let Some(f) = fit_translation(&shifts) {
            assert!(f.residual >= 0);
            assert!(usize::from(f.columns) <= count);
        }
    }
}
