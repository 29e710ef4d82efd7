//! The drivers over `embedded-io` readers (features `io`, `async`) give the
//! same revolutions as feeding the bytes by hand, whatever the chunking,
//! and survive a reader error; the `scan` glue hands them to the
//! estimator. The crate's tests enable the three features (a dev-dependency
//! on itself), so `cargo test --workspace` runs these.
#![cfg(all(feature = "io", feature = "async", feature = "scan"))]

mod common;

use common::{Fixture, Rng};
use hough_lidar::{Ld06, Lidar};

const BINS: usize = 720;
type Ld06Lidar = Lidar<hough_lidar::ld06::Ld06Layout, { Ld06::CAPACITY }, BINS>;

fn lidar() -> Ld06Lidar {
    Lidar::new(Ld06::new(), 100.0)
}

/// The revolutions of `bytes`, fed one byte at a time.
fn by_hand(bytes: &[u8]) -> Vec<Vec<f32>> {
    let mut l = lidar();
    let mut out = Vec::new();
    for &b in bytes {
        if l.push(b) {
            out.push(l.revolution().unwrap().ranges.to_vec());
        }
    }
    out
}

/// A reader handing out 1 to 100 bytes a call, and failing every
/// `fail_every`-th call (if any).
struct Chunky<'a> {
    data: &'a [u8],
    rng: Rng,
    calls: usize,
    fail_every: Option<usize>,
}

#[derive(Debug, PartialEq)]
struct Glitch;

impl embedded_io::Error for Glitch {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

impl embedded_io::ErrorType for Chunky<'_> {
    type Error = Glitch;
}

impl Chunky<'_> {
    fn chunk(&mut self, buf: &mut [u8]) -> Result<usize, Glitch> {
        self.calls += 1;
        if self.fail_every.is_some_and(|n| self.calls % n == 0) {
            return Err(Glitch);
        }
        let n = (1 + self.rng.below(100))
            .min(buf.len())
            .min(self.data.len());
        buf[..n].copy_from_slice(&self.data[..n]);
        self.data = &self.data[n..];
        Ok(n)
    }
}

impl embedded_io::Read for Chunky<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Glitch> {
        self.chunk(buf)
    }
}

impl embedded_io_async::Read for Chunky<'_> {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Glitch> {
        self.chunk(buf)
    }
}

/// Runs a future that never waits (the reader is always ready).
fn block_on<F: std::future::Future>(f: F) -> F::Output {
    let mut f = std::pin::pin!(f);
    let mut cx = std::task::Context::from_waker(std::task::Waker::noop());
    loop {
        if let std::task::Poll::Ready(v) = f.as_mut().poll(&mut cx) {
            return v;
        }
    }
}

#[test]
fn blocking_driver_matches_feeding_by_hand_and_survives_errors() {
    let f = Fixture::load("ld06");
    let want = by_hand(&f.bytes);
    assert_eq!(want.len(), 20);
    for fail_every in [None, Some(7)] {
        let reader = Chunky {
            data: &f.bytes,
            rng: Rng(42),
            calls: 0,
            fail_every,
        };
        let mut driver = hough_lidar::Driver::new(reader, lidar());
        let (mut got, mut errors) = (Vec::new(), 0);
        loop {
            match driver.next_revolution() {
                Ok(Some(r)) => got.push(r.ranges.to_vec()),
                Ok(None) => break,
                Err(Glitch) => errors += 1,
            }
        }
        assert_eq!(got, want);
        assert_eq!(errors > 0, fail_every.is_some());
        assert_eq!(driver.lidar().parser().counters().dropped_packets(), 0);
    }
}

#[test]
fn async_driver_matches_feeding_by_hand() {
    let f = Fixture::load("ld06");
    let want = by_hand(&f.bytes);
    let reader = Chunky {
        data: &f.bytes,
        rng: Rng(7),
        calls: 0,
        fail_every: None,
    };
    let mut driver = hough_lidar::Driver::new(reader, lidar());
    let got = block_on(async {
        let mut got = Vec::new();
        while let Some(r) = driver.next_revolution_async().await.unwrap() {
            got.push(r.ranges.to_vec());
        }
        got
    });
    assert_eq!(got, want);
}

#[test]
fn revolutions_estimate_like_the_original_scans() {
    use hough_heading::{estimator, grid, Mode, Raster, Scan, SensorOffset};
    type Grid = grid!(128, 128);
    type Estimator = estimator!(128, 128, 360);

    // The source scans: Seattle FLASER lines, 361 beams from −90° by 0.5°.
    let log = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../cli/data/logs/seattle-excerpt.log"
    ))
    .unwrap();
    let originals: Vec<Vec<f32>> = log
        .lines()
        .filter(|l| l.starts_with("FLASER"))
        .map(|l| {
            l.split_whitespace()
                .skip(2)
                .take(361)
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    let f = Fixture::load("ld06");
    let revolutions = by_hand(&f.bytes);
    assert_eq!(revolutions.len(), originals.len());

    let offset = SensorOffset::default();
    let alpha = |a: Scan<'_>, b: Scan<'_>| {
        let raster = Raster::auto(&[a, b], 128).unwrap().connect(0.3);
        let (mut ga, mut gb) = (Grid::new(), Grid::new());
        raster.rasterize(&a, &mut ga);
        raster.rasterize(&b, &mut gb);
        Estimator::new(Mode::Improved).estimate_pair(&ga, &gb).alpha
    };
    let mut lidar = lidar();
    let mut glue: Vec<Vec<f32>> = Vec::new();
    for &b in &f.bytes {
        if lidar.push(b) {
            let r = lidar.revolution().unwrap();
            // The glue: a revolution is a Scan (bin i at i·0.5° ccw).
            let scan = r.scan(offset);
            assert_eq!(scan.ranges, &r.ranges[..]);
            assert_eq!(scan.angle_increment, std::f32::consts::TAU / 720.0);
            glue.push(scan.ranges.to_vec());
        }
    }
    assert_eq!(glue, revolutions);
    fn orig(r: &[f32]) -> Scan<'_> {
        Scan {
            ranges: r,
            angle_min: -std::f32::consts::FRAC_PI_2,
            angle_increment: 0.5f32.to_radians(),
            max_range: 81.9,
            offset: SensorOffset::default(),
        }
    }
    fn rev(r: &[f32]) -> Scan<'_> {
        Scan {
            ranges: r,
            angle_min: 0.0,
            angle_increment: std::f32::consts::TAU / 720.0,
            max_range: 100.0,
            offset: SensorOffset::default(),
        }
    }
    let mut close = 0;
    for i in 1..originals.len() {
        let a = alpha(orig(&originals[i - 1]), orig(&originals[i]));
        let b = alpha(rev(&revolutions[i - 1]), rev(&revolutions[i]));
        if a.distance(b).to_degrees() < 0.5 {
            close += 1;
        }
    }
    // Same scans, a different beam layout (0.5 mm rounding, the revolution
    // starting at 0° instead of −90°): 18 of the 19 estimates agree.
    assert!(
        close >= originals.len() - 2,
        "{close} of {} pairs agree",
        originals.len() - 1
    );
}

/// The README's "On a robot" firmware loop, verbatim but for the UART (the
/// LD06 capture) and the loop's end.
#[test]
fn on_a_robot() {
    let uart = &Fixture::load("ld06").bytes[..];
    let mut confident = 0;
    // --- README "On a robot" begins
    use hough_heading::{estimator, grid, Mode, Raster, SensorOffset, Status};
    use hough_lidar::{Driver, Ld06, Lidar};

    type Grid = grid!(128, 128);
    type Estimator = estimator!(128, 128, 360);

    // LD06 on the UART (230400 8N1), 720 beams a turn, returns beyond 12 m ignored.
    let mut lidar = Driver::new(
        uart,
        Lidar::<_, { Ld06::CAPACITY }, 720>::new(Ld06::new(), 12.0),
    );
    // Mounted 10 cm ahead of the wheel axle, its zero to the robot's front.
    let mount = SensorOffset {
        x: 0.10,
        y: 0.0,
        theta: 0.0,
    };
    let raster = Raster::with_radius(6.0, 128).unwrap().connect(0.3); // ±6 m window
    let mut estimator = Estimator::new(Mode::Improved);
    let mut previous = None;
    let mut heading_deg = 0.0f32;
    while let Ok(Some(turn)) = lidar.next_revolution() {
        let mut grid = Grid::new();
        raster.rasterize(&turn.scan(mount), &mut grid);
        if let Some(reference) = &previous {
            let estimate = estimator.estimate(reference, &grid);
            if estimate.status == Status::Confident {
                heading_deg -= estimate.alpha.to_degrees(); // the scene turns the other way
                confident += 1;
            }
        }
        previous = Some(estimator.reference(&grid));
    }
    let dropped = lidar.lidar().parser().counters().dropped_packets(); // log it
                                                                       // --- README "On a robot" ends
    assert_eq!(dropped, 0);
    assert!(confident >= 15, "{confident} confident of 19");
    assert!(heading_deg.is_finite());
}
