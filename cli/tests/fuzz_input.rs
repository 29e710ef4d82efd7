//! Fuzz-style checks of the tool's inputs (issue 7, targets 5 and 6 of
//! `host-tests/tests/fuzz_harness.rs`, with its driver and checks from the
//! test kit, `host_tests::fuzz`):
//!
//! 5. the image decoder (`images::read` + `place`) on arbitrary and mutated
//!    PBM (`P1`, `P4`) and PNG files;
//! 6. the scan-pair parser and pipeline (`serde_json` into
//!    `scans::PairRecord`, then `scans::estimate`) on arbitrary and mutated
//!    JSON lines.
//!
//! Every case must return (no panic, in the test profile's overflow-checked
//! arithmetic) with a result in its documented range; `FUZZ_SCALE`
//! multiplies the case counts, as for the harness.

use std::io::Write;

use host_tests::fuzz::{check, fuzz, wild_f32};
use hough_heading::Mode;
use proptest::prelude::*;

/// A binary image as `P1`, `P4` or PNG bytes.
fn encode(width: usize, height: usize, cells: &[bool], format: u8) -> Vec<u8> {
    match format {
        0 => {
            let mut s = format!("P1\n# fuzz\n{width} {height}\n");
            for row in cells.chunks(width) {
                for &c in row {
                    s.push(if c { '1' } else { '0' });
                    s.push(' ');
                }
                s.push('\n');
            }
            s.into_bytes()
        }
        1 => {
            let mut out = format!("P4\n{width} {height}\n").into_bytes();
            for row in cells.chunks(width) {
                for byte in row.chunks(8) {
                    let mut b = 0u8;
                    for (i, &c) in byte.iter().enumerate() {
                        if c {
                            b |= 0x80 >> i;
                        }
                    }
                    out.push(b);
                }
            }
            out
        }
        _ => {
            let img = image::GrayImage::from_fn(width as u32, height as u32, |c, r| {
                image::Luma([if cells[r as usize * width + c as usize] {
                    0
                } else {
                    255
                }])
            });
            let mut out = std::io::Cursor::new(Vec::new());
            img.write_to(&mut out, image::ImageFormat::Png).unwrap();
            out.into_inner()
        }
    }
}

/// How a valid file is damaged.
#[derive(Clone, Debug)]
enum Damage {
    None,
    Truncate(usize),
    Overwrite(Vec<(usize, u8)>),
    Insert(usize, Vec<u8>),
    /// Replace the whole file with arbitrary bytes behind a magic number.
    Arbitrary(&'static [u8], Vec<u8>),
}

fn damage() -> impl Strategy<Value = Damage> {
    prop_oneof![
        1 => Just(Damage::None),
        2 => any::<usize>().prop_map(Damage::Truncate),
        3 => proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8).prop_map(Damage::Overwrite),
        1 => (any::<usize>(), proptest::collection::vec(any::<u8>(), 1..16)).prop_map(|(a, b)| Damage::Insert(a, b)),
        2 => (
            prop_oneof![
                Just(&b"P1\n"[..]),
                Just(&b"P4\n"[..]),
                Just(&b"P4\n99999 99999\n"[..]),
                Just(&b"P1\n3 2\n"[..]),
                Just(&b"\x89PNG\r\n\x1a\n"[..]),
                Just(&b""[..]),
            ],
            proptest::collection::vec(any::<u8>(), 0..200)
        )
            .prop_map(|(m, b)| Damage::Arbitrary(m, b)),
    ]
}

fn apply(mut bytes: Vec<u8>, d: &Damage) -> Vec<u8> {
    match d {
        Damage::None => bytes,
        Damage::Truncate(at) => {
            bytes.truncate(at % (bytes.len() + 1));
            bytes
        }
        Damage::Overwrite(edits) => {
            if !bytes.is_empty() {
                let len = bytes.len();
                for &(at, v) in edits {
                    bytes[at % len] = v;
                }
            }
            bytes
        }
        Damage::Insert(at, extra) => {
            let at = at % (bytes.len() + 1);
            bytes.splice(at..at, extra.iter().copied());
            bytes
        }
        Damage::Arbitrary(magic, rest) => magic.iter().chain(rest).copied().collect(),
    }
}

#[test]
fn fuzz_cli_image_decoder() {
    let dir = std::env::temp_dir().join(format!("hough-fuzz-images-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let counter = std::cell::Cell::new(0u32);
    let decoded = std::cell::Cell::new(0u32);
    fuzz(
        "cli::images::read + place",
        3000,
        40,
        (
            (1usize..80, 1usize..80).prop_flat_map(|(w, h)| {
                (
                    Just(w),
                    Just(h),
                    proptest::collection::vec(any::<bool>(), w * h),
                )
            }),
            0u8..3,
            damage(),
            any::<u8>(),
            any::<bool>(),
        ),
        |((w, h, cells), format, d, level, invert)| {
            let bytes = apply(encode(w, h, &cells, format), &d);
            counter.set(counter.get() + 1);
            let path = dir.join(format!("case-{}.img", counter.get()));
            std::fs::File::create(&path)
                .and_then(|mut f| f.write_all(&bytes))
                .unwrap();
            let threshold = hough_heading_recordings::image::Threshold { level, invert };
            match hough_heading_recordings::image::read(&path, threshold) {
                Ok(image) => {
                    decoded.set(decoded.get() + 1);
                    prop_assert!(image.count() > 0);
                    for fit in [
                        hough_heading_recordings::image::Fit::Centre,
                        hough_heading_recordings::image::Fit::None,
                    ] {
                        if let Err(e) =
                            hough_heading_recordings::image::place(&image, "x.pbm", 64, fit)
                        {
                            prop_assert!(e.to_string().contains("x.pbm"), "{e}");
                        }
                    }
                }
                Err(e) => {
                    let name = path.display().to_string();
                    prop_assert!(
                        e.to_string().contains(&name),
                        "message without the file: {e}"
                    );
                }
            }
            let _ = std::fs::remove_file(&path);
            Ok(())
        },
    );
    println!("  of which decoded: {}", decoded.get());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A valid scan-pair line with `beams` beams per scan.
fn pair_line(beams: usize, ranges: &[Option<f32>]) -> String {
    let r: Vec<String> = (0..beams)
        .map(|i| match ranges.get(i).copied().flatten() {
            Some(v) if v.is_finite() => format!("{v}"),
            _ => "null".into(),
        })
        .collect();
    let scan = format!(
        "{{\"ranges\":[{}],\"angle_min\":-1.57,\"angle_increment\":{},\"max_range\":30.0,\"laser_offset\":[0.1,0.0,0.0]}}",
        r.join(","),
        std::f32::consts::PI / beams.max(1) as f32
    );
    format!("{{\"scan1\":{scan},\"scan2\":{scan},\"dx\":0.1,\"dy\":0.0,\"dtheta\":0.05}}")
}

#[test]
fn fuzz_cli_scan_pairs() {
    let mut engine = hough_heading_recordings::options::engine_for(64, 180)
        .expect("64²/180 is compiled into the tool");
    let engine = std::cell::RefCell::new(&mut engine);
    let parsed = std::cell::Cell::new(0u32);
    let options = hough_heading_recordings::pairs::RasterOptions {
        cell: None,
        connect: None,
        disc: false,
        beam_refine: true,
        beam_check: true,
    };
    fuzz(
        "cli scan-pair lines",
        3000,
        50,
        (
            0usize..200,
            proptest::collection::vec(proptest::option::of(wild_f32()), 0..200),
            prop_oneof![3 => Just(Damage::None), 2 => damage()],
            proptest::bool::weighted(0.2),
        ),
        |(beams, ranges, d, both)| {
            let line = apply(pair_line(beams, &ranges).into_bytes(), &d);
            // Also non-finite numbers spelled out (not JSON, must be refused).
            let line = if both {
                String::from_utf8_lossy(&line)
                    .replace("30.0", "NaN")
                    .into_bytes()
            } else {
                line
            };
            if let Ok(pair) =
                serde_json::from_slice::<hough_heading_recordings::pairs::PairRecord>(&line)
            {
                parsed.set(parsed.get() + 1);
                let mut engine = engine.borrow_mut();
                match hough_heading_recordings::pairs::estimate(
                    engine.as_mut(),
                    &pair,
                    &options,
                    &[Mode::Improved, Mode::Paper],
                ) {
                    Ok(estimates) => {
                        for e in &estimates {
                            check(&e.estimate, false, None, None)?;
                            prop_assert!(e.dtheta_deg.abs() <= 180.0 + 1e-3);
                        }
                    }
                    Err(message) => prop_assert!(!message.is_empty()),
                }
            }
            Ok(())
        },
    );
    println!("  of which parsed and estimated: {}", parsed.get());
}
