//! The host's side of the firmware example `examples/lidar_heading.rs`: the
//! same pipeline (`examples/support/lidar_pipeline.rs`) on the same LD06
//! capture, whose results are stored in `tests/data/ld06-headings.bin`. The
//! firmware, under QEMU on the Cortex-M4F and the Cortex-M0
//! (`.ci/firmware.sh`), must reproduce that file bit for bit; this test
//! checks that the host still does (rewrite the file with
//! `UPDATE_LIDAR_HEADINGS=1 cargo test -p hough-lidar --test
//! firmware_reference`; the crate's tests enable the feature `scan`, so
//! `cargo test --workspace` runs this one).
#![cfg(feature = "scan")]

#[path = "../../examples/support/lidar_pipeline.rs"]
#[allow(dead_code)]
mod pipeline;

use pipeline::{BINS, RECORD_LEN};

const CAPTURE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ld06.bin");
const HEADINGS: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/ld06-headings.bin");

#[test]
fn host_results_match_the_stored_reference() {
    let bytes = std::fs::read(CAPTURE).unwrap();
    let mut lidar = pipeline::lidar();
    let mut estimator = pipeline::estimator();
    let mut grids = [pipeline::Grid::new(), pipeline::Grid::new()];
    let mut previous: Option<[f32; BINS]> = None;
    let mut records = Vec::new();
    let mut alphas = Vec::new();
    for &b in &bytes {
        if lidar.push(b) {
            let r = lidar.revolution().unwrap();
            if let Some(p) = &previous {
                let e = pipeline::estimate(&mut estimator, p, &r, &mut grids);
                records.extend(pipeline::record(&e));
                alphas.push(e.alpha.to_degrees());
            }
            previous = Some(*r.ranges);
        }
    }
    assert_eq!(records.len(), 19 * RECORD_LEN);
    // The same turns as the CLI's 720-beam revolutions at 128²: the
    // Seattle robot's heading changes (-29°, -29°, 18°, … degrees of scene
    // rotation): check the first three against `hough-heading log` within 2°.
    for (got, want) in alphas.iter().zip([29.03f32, 28.89, -17.58]) {
        assert!((got - want).abs() < 2.0, "{got} vs {want}");
    }
    if std::env::var_os("UPDATE_LIDAR_HEADINGS").is_some() {
        std::fs::write(HEADINGS, &records).unwrap();
    }
    let stored = std::fs::read(HEADINGS).expect("tests/data/ld06-headings.bin");
    assert_eq!(
        stored, records,
        "the host's results changed: see the module doc"
    );
}
