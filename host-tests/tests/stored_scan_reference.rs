//! A stored scan reference (issue 23): the reference of a scan, its free
//! space, its raster and the scan itself as versioned bytes. Read back, it
//! gives the very estimates the prepared reference and free grid give, the
//! raster to draw new scans with, and the very check on the beams the pair
//! of scans gives; bytes of another version (format 1 kept no beams), of a
//! plain grid reference, truncated or altered (a raster `Raster` never makes
//! among them), or of a scan longer than the type holds are refused with a
//! typed error.

use host_tests::raycast::{l_room as room, Laser};
use hough_heading::{
    estimator, grid, scan_reference, stages::REFERENCE_FORMAT, stages::SCAN_REFERENCE_FORMAT,
    Angle, Error, FreeSpace, Mode, Raster, Reference, Scan, ScanReference, SensorOffset, Status,
};

type G128 = grid!(128, 128);
type E128 = estimator!(128, 128, 360);
/// Readings of the test's scanner.
const BEAMS: usize = 541;
type Stored = scan_reference!(128, 128, 360, BEAMS);

/// The test's scanner: 270° in 541 beams, 30 m.
fn laser() -> Laser {
    Laser::centred(270.0, BEAMS, 30.0)
}

/// A scan of [`laser`] with these readings.
fn scan_of(ranges: &[f32]) -> Scan<'_> {
    let laser = laser();
    Scan {
        ranges,
        angle_min: laser.angle_min as f32,
        angle_increment: laser.angle_increment as f32,
        max_range: laser.max_range as f32,
        offset: SensorOffset::default(),
    }
}

/// The readings of a scan taken at `pose` (metres, radians) in [`room`].
fn readings(pose: (f64, f64, f64)) -> Vec<f32> {
    laser().scan(&room(), pose)
}

/// The occupied and free cells of a scan.
fn view(ranges: &[f32], raster: &Raster) -> (G128, G128) {
    let scan = scan_of(ranges);
    let (mut grid, mut free) = (G128::new(), G128::new());
    raster.rasterize(&scan, &mut grid);
    raster.free_space(&scan, &mut free);
    (grid, free)
}

/// Where the reference scan is taken.
const HOME: (f64, f64, f64) = (3.0, 2.5, 0.4);

/// The raster of the stored reference: 9 m radius, segments up to 0.3 m.
fn raster() -> Raster {
    Raster::with_radius(9.0, 128).unwrap().connect(0.3)
}

fn stored() -> (E128, Stored, Vec<u8>) {
    let ranges = readings(HOME);
    let (grid, free) = view(&ranges, &raster());
    let mut e = E128::new(Mode::Improved);
    let stored = ScanReference::new(e.reference(&grid), free, raster(), &scan_of(&ranges)).unwrap();
    let mut bytes = vec![0u8; Stored::MAX_BYTES];
    assert_eq!(stored.to_bytes(&mut bytes), Ok(Stored::MAX_BYTES));
    (e, stored, bytes)
}

fn fnv1a(bytes: &[u8]) -> u32 {
    bytes.iter().fold(0x811c_9dc5u32, |h, &b| {
        (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
    })
}

/// Recomputes the outer checksum after an edit, so that only the check
/// under test can refuse the bytes.
fn reseal(bytes: &mut [u8]) {
    let body = bytes.len() - 4;
    let sum = fnv1a(&bytes[..body]);
    bytes[body..].copy_from_slice(&sum.to_le_bytes());
}

#[test]
fn read_back_it_gives_the_same_estimates() {
    let (mut e, stored, bytes) = stored();
    let back = Stored::from_bytes(&bytes).unwrap();
    assert_eq!(back, stored);
    // 5 924 bytes and four per reading: 541 of them.
    assert_eq!(Stored::MAX_BYTES, 5_924 + 4 * 541);
    assert_eq!(back.byte_len(), Stored::MAX_BYTES);
    // The raster comes back: new scans are drawn at the stored scale.
    assert_eq!(back.raster(), raster());
    let raster = back.raster();
    // A small turn, a half turn and a quarter turn from elsewhere in the room.
    for pose in [(3.4, 2.2, 0.6), (4.0, 3.0, 3.4), (2.5, 5.5, 2.0)] {
        let (grid, free) = view(&readings(pose), &raster);
        let direct = e.estimate_scans(
            stored.reference(),
            &grid,
            &FreeSpace {
                reference: stored.free(),
                current: &free,
            },
            None,
        );
        let read = e.estimate_scans(back.reference(), &grid, &back.free_space(&free), None);
        assert_eq!(read, direct, "{pose:?}");
        // And it is right: α = −dθ, the reference taken at heading 0.4.
        let alpha = Angle::from_degrees(-(pose.2 - 0.4).to_degrees() as f32);
        assert!(
            read.alpha.distance(alpha).to_degrees() < 2.0 && read.status == Status::Confident,
            "{pose:?}: {read:?}"
        );
        // The free space is used: without it the verification has less to
        // go on, and a pose that violates it would score alike.
        assert!(
            read.candidates.iter().all(|c| c.free_space.is_some()),
            "{read:?}"
        );
    }
}

#[test]
fn the_stored_scan_checks_the_answer_as_the_pair_does() {
    let (mut e, _, bytes) = stored();
    let back = Stored::from_bytes(&bytes).unwrap();
    let home = readings(HOME);
    // The scan comes back bit for bit.
    let scan = back.scan();
    assert_eq!(scan.ranges.len(), BEAMS);
    assert!(scan
        .ranges
        .iter()
        .zip(&home)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert_eq!(
        scan_of(&home),
        Scan {
            ranges: &home,
            ..scan
        }
    );
    let raster = back.raster();
    for pose in [(3.4, 2.2, 0.6), (4.0, 3.0, 3.4), (2.5, 5.5, 2.0)] {
        let ranges = readings(pose);
        let current = scan_of(&ranges);
        let (grid, free) = view(&ranges, &raster);
        let estimate = e.estimate_scans(back.reference(), &grid, &back.free_space(&free), None);
        // The check on the stored scan is the check on the original pair.
        let stored_check = raster.check_on_beams(&back.scan(), &current, &estimate);
        let pair_check = raster.check_on_beams(&scan_of(&home), &current, &estimate);
        assert_eq!(stored_check, pair_check, "{pose:?}");
        // And it confirms the right answer.
        let check = stored_check.unwrap();
        assert!(
            !check.too_weak() && !check.contradicts(),
            "{pose:?}: {check:?}"
        );
    }
}

#[test]
fn a_scan_longer_than_the_type_holds_is_refused() {
    let (_, stored, bytes) = stored();
    let mut longer = readings(HOME);
    longer.push(1.0);
    let scan = scan_of(&longer);
    assert_eq!(
        Stored::new(
            stored.reference().clone(),
            stored.free().clone(),
            raster(),
            &scan
        ),
        Err(Error::TooManyBeams {
            beams: BEAMS + 1,
            capacity: BEAMS
        })
    );
    // Bytes of 541 readings: too many for 540, read as written by 1 081.
    assert_eq!(
        <scan_reference!(128, 128, 360, 540)>::from_bytes(&bytes),
        Err(Error::TooManyBeams {
            beams: BEAMS,
            capacity: BEAMS - 1
        })
    );
    let wide = <scan_reference!(128, 128, 360, 1081)>::from_bytes(&bytes).unwrap();
    assert_eq!(wide.scan(), stored.scan());
    assert_eq!(wide.reference(), stored.reference());
    assert_eq!(wide.byte_len(), bytes.len());
    let mut again = vec![0u8; wide.byte_len()];
    wide.to_bytes(&mut again).unwrap();
    assert_eq!(again, bytes);
    // No beams stored: the free space is kept, the check has nothing to
    // score.
    let bare = <scan_reference!(128, 128, 360, 0)>::new(
        stored.reference().clone(),
        stored.free().clone(),
        raster(),
        &scan_of(&[]),
    )
    .unwrap();
    assert_eq!(bare.byte_len(), 5_924);
    assert!(bare.scan().ranges.is_empty());
}

#[test]
fn other_versions_and_plain_references_are_refused() {
    let (_, stored, mut bytes) = stored();
    // Format 1 kept no beams: a clear version error.
    assert_eq!(SCAN_REFERENCE_FORMAT, 2);
    let mut first = bytes.clone();
    first[3] = b'1';
    assert_eq!(
        Stored::from_bytes(&first),
        Err(Error::ReferenceVersion {
            found: 1,
            expected: 2
        })
    );
    // A later scan reference format: a clear version error too.
    bytes[3] = b'0' + SCAN_REFERENCE_FORMAT + 1;
    assert_eq!(
        Stored::from_bytes(&bytes),
        Err(Error::ReferenceVersion {
            found: SCAN_REFERENCE_FORMAT + 1,
            expected: SCAN_REFERENCE_FORMAT
        })
    );
    // A plain grid reference has no free space: refused, and readable as
    // what it is.
    let mut plain = vec![0u8; <hough_heading::reference!(128, 128, 360)>::BYTES];
    stored.reference().to_bytes(&mut plain).unwrap();
    plain.resize(Stored::MAX_BYTES, 0);
    assert_eq!(Stored::from_bytes(&plain), Err(Error::InvalidReference));
    assert_eq!(
        Reference::from_bytes(&plain).as_ref(),
        Ok(stored.reference())
    );
    // The embedded reference's reserved header bytes (14–15) must be zero,
    // even with both checksums right.
    for at in [4 + 14, 4 + 15] {
        let (_, _, mut bytes) = self::stored();
        bytes[at] = 1;
        let inner = 4 + <hough_heading::reference!(128, 128, 360)>::BYTES - 4;
        let sum = fnv1a(&bytes[4..inner]);
        bytes[inner..inner + 4].copy_from_slice(&sum.to_le_bytes());
        reseal(&mut bytes);
        assert_eq!(Stored::from_bytes(&bytes), Err(Error::InvalidReference));
    }
    // The embedded reference's own version check is passed on.
    let (_, _, mut bytes) = self::stored();
    bytes[4 + 3] = b'0' + REFERENCE_FORMAT - 1;
    reseal(&mut bytes);
    assert_eq!(
        Stored::from_bytes(&bytes),
        Err(Error::ReferenceVersion {
            found: REFERENCE_FORMAT - 1,
            expected: REFERENCE_FORMAT
        })
    );
}

#[test]
fn truncated_or_altered_bytes_are_refused() {
    let (_, stored, bytes) = stored();
    // Cut before the beam count, the bytes are too short for even an
    // empty scan; cut after it, for the count they hold.
    let head = 5_924 - 4;
    for len in [0, 3, 4, 100, head - 4] {
        assert_eq!(
            Stored::from_bytes(&bytes[..len]),
            Err(Error::BufferTooSmall { needed: head + 4 }),
            "{len} bytes"
        );
    }
    for len in [head, head + 4, Stored::MAX_BYTES - 1] {
        assert_eq!(
            Stored::from_bytes(&bytes[..len]),
            Err(Error::BufferTooSmall {
                needed: Stored::MAX_BYTES
            }),
            "{len} bytes"
        );
    }
    let mut short = vec![0u8; Stored::MAX_BYTES - 1];
    assert_eq!(
        stored.to_bytes(&mut short),
        Err(Error::BufferTooSmall {
            needed: Stored::MAX_BYTES
        })
    );
    // Any flipped bit is caught, in the header, the embedded reference, the
    // free grid, the scan or the checksums (every 7th byte, each bit
    // position); a beam count raised past the bytes makes them too short.
    for at in (0..Stored::MAX_BYTES).step_by(7) {
        let mut bad = bytes.clone();
        bad[at] ^= 1 << (at % 8);
        let refused = Stored::from_bytes(&bad);
        let count = (head - 4..head).contains(&at);
        assert!(
            matches!(
                refused,
                Err(Error::InvalidReference | Error::ReferenceVersion { .. })
            ) || (count && matches!(refused, Err(Error::BufferTooSmall { .. }))),
            "byte {at}: {refused:?}"
        );
    }
    // Checksum-valid but impossible free grids: a bit beyond the width (the
    // 128² grid has no such bit; use 100 × 100, whose rows end mid-word),
    // or a cell count that disagrees with the cells.
    type Narrow = scan_reference!(100, 100, 180, 0);
    let mut e = <estimator!(100, 100, 180)>::new(Mode::Improved);
    let mut grid = <grid!(100, 100)>::new();
    let mut free = <grid!(100, 100)>::new();
    for i in 10..90 {
        grid.set(i, 20).unwrap();
        grid.set(30, i).unwrap();
        free.set(i, 50).unwrap();
    }
    let narrow = Narrow::new(
        e.reference(&grid),
        free,
        Raster::with_cell(0.05).unwrap(),
        &scan_of(&[]),
    )
    .unwrap();
    let mut good = vec![0u8; Narrow::MAX_BYTES];
    narrow.to_bytes(&mut good).unwrap();
    assert_eq!(Narrow::from_bytes(&good).as_ref(), Ok(&narrow));
    let raster_at = 4 + <hough_heading::reference!(100, 100, 180)>::BYTES;
    let free_at = raster_at + 12;
    let mut beyond = good.clone();
    // Row 0's last word holds columns 96–127: bit 31 is column 127.
    beyond[free_at + 4 * 3 + 3] |= 0x80;
    reseal(&mut beyond);
    assert_eq!(Narrow::from_bytes(&beyond), Err(Error::InvalidReference));
    // A raster no `Raster` makes: a cell of 0, a NaN or negative gap, a
    // clip byte of 2, a reserved byte set.
    for (at, value) in [
        (raster_at, 0.0f32.to_bits()),
        (raster_at + 4, f32::NAN.to_bits()),
        (raster_at + 4, (-0.3f32).to_bits()),
        (raster_at + 8, 2),
        (raster_at + 8, 1 << 8),
    ] {
        let mut bad = good.clone();
        bad[at..at + 4].copy_from_slice(&value.to_le_bytes());
        reseal(&mut bad);
        assert_eq!(
            Narrow::from_bytes(&bad),
            Err(Error::InvalidReference),
            "{at}: {value:#x}"
        );
    }
    // A clipped raster with a gap is one it makes: read back as written.
    let clipped = Narrow::new(
        narrow.reference().clone(),
        narrow.free().clone(),
        Raster::with_cell(0.05)
            .unwrap()
            .connect(0.2)
            .clip_to_disc(true),
        &scan_of(&[]),
    )
    .unwrap();
    clipped.to_bytes(&mut good).unwrap();
    assert_eq!(Narrow::from_bytes(&good).as_ref(), Ok(&clipped));
    narrow.to_bytes(&mut good).unwrap();
    let mut miscounted = good.clone();
    // The free grid's cell count, before the scan's geometry and count.
    let count_at = Narrow::MAX_BYTES - 4 - 4 - 24 - 4;
    miscounted[count_at] ^= 1;
    reseal(&mut miscounted);
    assert_eq!(
        Narrow::from_bytes(&miscounted),
        Err(Error::InvalidReference)
    );
}
