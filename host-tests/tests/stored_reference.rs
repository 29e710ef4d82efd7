//! The reference stored with the firmware (`examples/data/home-128-360.hhr`,
//! read at compile time by `examples/robot_loop.rs` into a `static` in
//! flash) is what the library prepares today from the same room, and the
//! compile-time parse gives the same reference as the run-time one.
//!
//! After a change to how references are prepared or stored, rewrite the file
//! with `UPDATE_STORED_REFERENCE=1 cargo test -p host-tests --test stored_reference`.

#[path = "../../examples/support/room.rs"]
#[allow(dead_code)]
mod room;

use hough_heading::{config::row_words, estimator, reference, Grid, Mode, Reference};
use room::{room_words, Pose};

const SIDE: usize = 128;
const N_THETA: usize = 360;
const RW: usize = row_words(SIDE);
const PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../examples/data/home-128-360.hhr"
);

type Stored = reference!(SIDE, SIDE, N_THETA);

/// Parsed by the compiler, as the firmware does: a `static` that lives in
/// read-only memory.
static STORED: Stored =
    match Reference::from_bytes(include_bytes!("../../examples/data/home-128-360.hhr")) {
        Ok(r) => r,
        Err(_) => panic!("examples/data/home-128-360.hhr is not a 128², N_THETA = 360 reference"),
    };

/// The robot_loop's home view, prepared at run time in improved mode.
fn prepared() -> Stored {
    let home = Grid::<SIDE, SIDE, RW>::from_words(room_words::<SIDE, SIDE, RW>(Pose::ORIGIN));
    let mut estimator = <estimator!(SIDE, SIDE, N_THETA)>::new(Mode::Improved);
    estimator.reference(&home)
}

#[test]
fn stored_file_is_what_the_library_prepares() {
    let reference = prepared();
    let mut bytes = vec![0u8; Stored::BYTES];
    reference.to_bytes(&mut bytes).unwrap();
    if std::env::var_os("UPDATE_STORED_REFERENCE").is_some() {
        std::fs::write(PATH, &bytes).unwrap();
    }
    let stored = std::fs::read(PATH).unwrap();
    assert!(
        stored == bytes,
        "{PATH} is stale: rewrite it with UPDATE_STORED_REFERENCE=1 cargo test -p host-tests --test stored_reference"
    );
}

#[test]
fn compile_time_parse_equals_run_time_parse() {
    let bytes = std::fs::read(PATH).unwrap();
    assert_eq!(Stored::from_bytes(&bytes).as_ref(), Ok(&STORED));
    assert_eq!(STORED, prepared());
    assert!(STORED.profiles().len() >= 2);
}
