//! A stored scan reference (issue 23): the reference of a scan, its free
//! space and its raster as versioned bytes. Read back, it gives the very
//! estimates the prepared reference and free grid give, and the raster to
//! draw new scans with; bytes of another version, of a plain grid
//! reference, truncated or altered (a raster `Raster` never makes among
//! them) are refused with a typed error.

use host_tests::raycast::{l_room as room, Laser};
use hough_heading::{
    estimator, grid, scan_reference, stages::REFERENCE_FORMAT, stages::SCAN_REFERENCE_FORMAT,
    Angle, Error, FreeSpace, Mode, Raster, Reference, Scan, ScanReference, SensorOffset, Status,
};

type G128 = grid!(128, 128);
type E128 = estimator!(128, 128, 360);
type Stored = scan_reference!(128, 128, 360);

/// The occupied and free cells of a 270° scan taken at `pose` (metres,
/// radians) in [`room`].
fn view(pose: (f64, f64, f64), raster: &Raster) -> (G128, G128) {
    let laser = Laser::centred(270.0, 541, 30.0);
    let ranges = laser.scan(&room(), pose);
    let scan = Scan {
        ranges: &ranges,
        angle_min: laser.angle_min as f32,
        angle_increment: laser.angle_increment as f32,
        max_range: laser.max_range as f32,
        offset: SensorOffset::default(),
    };
    let (mut grid, mut free) = (G128::new(), G128::new());
    raster.rasterize(&scan, &mut grid);
    raster.free_space(&scan, &mut free);
    (grid, free)
}

/// The raster of the stored reference: 9 m radius, segments up to 0.3 m.
fn raster() -> Raster {
    Raster::with_radius(9.0, 128).unwrap().connect(0.3)
}

fn stored() -> (E128, Stored, Vec<u8>) {
    let (grid, free) = view((3.0, 2.5, 0.4), &raster());
    let mut e = E128::new(Mode::Improved);
    let stored = ScanReference::new(e.reference(&grid), free, raster());
    let mut bytes = vec![0u8; Stored::BYTES];
    assert_eq!(stored.to_bytes(&mut bytes), Ok(Stored::BYTES));
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
    assert_eq!(Stored::BYTES, 5_896);
    // The raster comes back: new scans are drawn at the stored scale.
    assert_eq!(back.raster(), raster());
    let raster = back.raster();
    // A small turn, a half turn and a quarter turn from elsewhere in the room.
    for pose in [(3.4, 2.2, 0.6), (4.0, 3.0, 3.4), (2.5, 5.5, 2.0)] {
        let (grid, free) = view(pose, &raster);
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
fn other_versions_and_plain_references_are_refused() {
    let (_, stored, mut bytes) = stored();
    // A later (or earlier) scan reference format: a clear version error.
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
    plain.resize(Stored::BYTES, 0);
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
    for len in [0, 3, 4, 100, Stored::BYTES - 1] {
        assert_eq!(
            Stored::from_bytes(&bytes[..len]),
            Err(Error::BufferTooSmall {
                needed: Stored::BYTES
            }),
            "{len} bytes"
        );
    }
    let mut short = vec![0u8; Stored::BYTES - 1];
    assert_eq!(
        stored.to_bytes(&mut short),
        Err(Error::BufferTooSmall {
            needed: Stored::BYTES
        })
    );
    // Any flipped bit is caught, in the header, the embedded reference, the
    // free grid or the checksums (every 7th byte, each bit position).
    for at in (0..Stored::BYTES).step_by(7) {
        let mut bad = bytes.clone();
        bad[at] ^= 1 << (at % 8);
        let refused = Stored::from_bytes(&bad);
        assert!(
            matches!(
                refused,
                Err(Error::InvalidReference | Error::ReferenceVersion { .. })
            ),
            "byte {at}: {refused:?}"
        );
    }
    // Checksum-valid but impossible free grids: a bit beyond the width (the
    // 128² grid has no such bit; use 100 × 100, whose rows end mid-word),
    // or a cell count that disagrees with the cells.
    type Narrow = scan_reference!(100, 100, 180);
    let mut e = <estimator!(100, 100, 180)>::new(Mode::Improved);
    let mut grid = <grid!(100, 100)>::new();
    let mut free = <grid!(100, 100)>::new();
    for i in 10..90 {
        grid.set(i, 20).unwrap();
        grid.set(30, i).unwrap();
        free.set(i, 50).unwrap();
    }
    let narrow = Narrow::new(e.reference(&grid), free, Raster::with_cell(0.05).unwrap());
    let mut good = vec![0u8; Narrow::BYTES];
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
    );
    clipped.to_bytes(&mut good).unwrap();
    assert_eq!(Narrow::from_bytes(&good).as_ref(), Ok(&clipped));
    narrow.to_bytes(&mut good).unwrap();
    let mut miscounted = good.clone();
    let count_at = Narrow::BYTES - 8;
    miscounted[count_at] ^= 1;
    reseal(&mut miscounted);
    assert_eq!(
        Narrow::from_bytes(&miscounted),
        Err(Error::InvalidReference)
    );
}
