use hough_heading::{estimator, grid, Angle, Mode};

type G = grid!(128, 128);
type E = estimator!(128, 128, 360);

fn draw(poly: &[(f64, f64)], alpha: f64, t: (f64, f64)) -> G {
    let mut g = G::new();
    let (s, c) = alpha.sin_cos();
    let tr = |p: (f64, f64)| (c * p.0 - s * p.1 + t.0, s * p.0 + c * p.1 + t.1);
    for i in 0..poly.len() {
        let a = tr(poly[i]);
        let b = tr(poly[(i + 1) % poly.len()]);
        let n = 400;
        for j in 0..=n {
            let f = j as f64 / n as f64;
            let _ = g.set_point(
                (a.0 + f * (b.0 - a.0)) as f32,
                (a.1 + f * (b.1 - a.1)) as f32,
            );
        }
    }
    g
}

#[test]
fn smoke() {
    let poly = [
        (-40.0, -30.0),
        (35.0, -35.0),
        (45.0, 10.0),
        (0.0, 20.0),
        (-10.0, 45.0),
        (-45.0, 30.0),
    ];
    let g1 = draw(&poly, 0.0, (0.0, 0.0));
    for deg in [0.0f64, 17.3, 95.0, 181.0, 250.5, 333.3] {
        for mode in [Mode::Paper, Mode::Improved] {
            let g2 = draw(&poly, deg.to_radians(), (3.0, -2.0));
            let mut e = E::new(mode);
            let r = e.estimate_pair(&g1, &g2);
            let err = r
                .alpha
                .distance(Angle::from_degrees(deg as f32))
                .to_degrees();
            println!("{mode:?} {deg}: got {:.3} err {:.3} status {:?} conf {} corr {} rival {} ht {:?} tr {:?}", r.alpha.to_degrees(), err, r.status, r.confidence, r.correlation, r.rival, r.half_turn, r.translation);
        }
    }
}
