//! Bad input at the command-line tool's edge (issue 7): the built binary
//! (`CARGO_BIN_EXE_hough-heading`) on damaged images and scan-pair files.
//!
//! What must hold:
//!
//! * an unusable image (missing, empty, truncated or malformed PBM/PNG,
//!   absurd declared size, no occupied pixel, wrong dimensions) exits with
//!   status 2 and a one-line message on stderr naming the file;
//! * a bad option value exits with status 2 and names the option;
//! * in a scan-pair batch, every bad line (malformed JSON, `NaN`/`1e999`
//!   numbers, missing fields, a 0-beam scan, garbage, an empty line) gets an
//!   output line with `"status":"error"` and a stderr message naming the line
//!   and the problem; every other line, including an enormous one, is still
//!   estimated; the exit status is 1 when some pairs failed, 0 otherwise;
//! * nothing panics.
//!
//! And at the library's edge, stored references (`Reference::from_bytes`):
//!
//! * bytes of another format version (version 2, written before the
//!   reference kept its grid for the verification by alignment, or any other
//!   version digit after the "HHR" magic) are refused with
//!   `Error::ReferenceVersion { found, expected: REFERENCE_FORMAT }`,
//!   whatever their length and checksum;
//! * a version-3 reference whose stored grid disagrees with its stored
//!   occupied count, or has cells beyond `W`, is refused with
//!   `Error::InvalidReference` even when its checksum is right.

use std::path::PathBuf;
use std::process::{Command, Output, Stdio};

const BIN: &str = env!("CARGO_BIN_EXE_hough-heading");

/// A scratch directory removed at the end of the test.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("hough-bad-input-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        Self(dir)
    }

    fn file(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let path = self.0.join(name);
        std::fs::write(&path, bytes).unwrap();
        path
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn run(args: &[&str], stdin: Option<&[u8]>) -> Output {
    let mut child = Command::new(BIN)
        .args(args)
        .stdin(if stdin.is_some() {
            Stdio::piped()
        } else {
            Stdio::null()
        })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the hough-heading binary runs");
    if let Some(bytes) = stdin {
        use std::io::Write;
        child.stdin.take().unwrap().write_all(bytes).unwrap();
    }
    child.wait_with_output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Asserts the run failed cleanly: `code`, a message containing every
/// `needle`, and no panic.
fn assert_fails(out: &Output, code: i32, needles: &[&str], what: &str) {
    let stderr = text(&out.stderr);
    assert!(!stderr.contains("panicked"), "{what}: panic: {stderr}");
    assert_eq!(out.status.code(), Some(code), "{what}: stderr {stderr}");
    for needle in needles {
        assert!(
            stderr.contains(needle),
            "{what}: message lacks {needle:?}: {stderr}"
        );
    }
}

/// A 64×64 P1 image of an irregular polygon outline (pixels, centred),
/// turned `rotate_deg` counter-clockwise: drawn by the test kit's scene
/// renderer, undamaged.
fn polygon_pbm(rotate_deg: f64) -> Vec<u8> {
    use host_tests::scene::{self, Damage, PbmFormat, Point, Scene, Transform};
    use rand::SeedableRng;
    let v = [
        (-20.0, -15.0),
        (18.0, -19.0),
        (24.0, 3.0),
        (0.0, 9.0),
        (-6.0, 25.0),
        (-24.0, 15.0),
    ]
    .map(|(x, y)| Point::new(x, y));
    let turn = Transform {
        alpha_rad: rotate_deg.to_radians(),
        tx: 0.0,
        ty: 0.0,
        scale: 1.0,
    };
    let polygon = Scene::polygon(&v).transformed(&turn);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
    let rendered = scene::render(&polygon, &Damage::CLEAN, 64, 64, &mut rng);
    scene::to_pbm(&rendered.image, PbmFormat::Ascii)
}

/// A PNG of `width × height` with grey levels from `f(col, row)`.
fn png(width: u32, height: u32, f: impl Fn(u32, u32) -> u8) -> Vec<u8> {
    let img = image::GrayImage::from_fn(width, height, |c, r| image::Luma([f(c, r)]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

#[test]
fn good_images_work() {
    let dir = Scratch::new("good");
    let a = dir.file("a.pbm", &polygon_pbm(0.0));
    let b = dir.file("b.pbm", &polygon_pbm(30.0));
    let out = run(
        &["images", a.to_str().unwrap(), b.to_str().unwrap(), "--json"],
        None,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(
        text(&out.stdout).contains("confident"),
        "{}",
        text(&out.stdout)
    );
}

#[test]
fn bad_images_name_the_file_and_exit_2() {
    let dir = Scratch::new("images");
    let good = dir.file("good.pbm", &polygon_pbm(0.0));
    let valid_png = png(
        64,
        64,
        |c, r| if c == 10 || r == 50 || c == r { 0 } else { 255 },
    );
    let mut corrupt_png = valid_png.clone();
    let n = corrupt_png.len();
    for b in &mut corrupt_png[n / 2..n / 2 + 8] {
        *b ^= 0x5a;
    }
    let mut p4 = b"P4\n64 64\n".to_vec();
    p4.extend(std::iter::repeat_n(0x81u8, 8 * 64));
    let cases: Vec<(&str, Vec<u8>, &[&str])> = vec![
        ("empty.pbm", vec![], &[]),
        ("truncated-p4.pbm", p4[..p4.len() - 100].to_vec(), &[]),
        ("truncated-p1.pbm", polygon_pbm(0.0)[..2000].to_vec(), &[]),
        (
            "bad-header.pbm",
            b"P1\nsixty-four 64\n0 1 0\n".to_vec(),
            &[],
        ),
        ("zero-size.pbm", b"P4\n0 0\n".to_vec(), &[]),
        (
            "huge-declared.pbm",
            b"P4\n99999 99999\n\x00\x01".to_vec(),
            &[],
        ),
        ("p1-digit-2.pbm", b"P1\n2 2\n0 2\n1 1\n".to_vec(), &[]),
        ("truncated.png", valid_png[..40].to_vec(), &[]),
        ("corrupt.png", corrupt_png, &[]),
        ("text.png", b"this is not an image\n".to_vec(), &[]),
        ("white.png", png(64, 64, |_, _| 255), &["no occupied pixel"]),
        (
            "wrong-size.png",
            png(48, 64, |c, _| if c == 5 { 0 } else { 255 }),
            &["48"],
        ),
        (
            "other-size.pbm",
            {
                let mut s = String::from("P1\n128 128\n");
                for r in 0..128 {
                    for c in 0..128 {
                        s.push(if c == r { '1' } else { '0' });
                    }
                    s.push('\n');
                }
                s.into_bytes()
            },
            &["128"],
        ),
    ];
    for (name, bytes, extra) in &cases {
        let bad = dir.file(name, bytes);
        for (a, b) in [(&good, &bad), (&bad, &good)] {
            let out = run(&["images", a.to_str().unwrap(), b.to_str().unwrap()], None);
            // Two valid images of different sizes: the grid takes A's size
            // and the message names B, the image that does not fit it.
            let second = b.file_name().unwrap().to_str().unwrap();
            let mut needles = if *name == "other-size.pbm" {
                vec![second]
            } else {
                vec![*name]
            };
            needles.extend(extra.iter());
            assert_fails(&out, 2, &needles, name);
            assert!(
                out.stdout.is_empty(),
                "{name}: stdout {}",
                text(&out.stdout)
            );
        }
    }
    let missing = dir.0.join("missing.pbm");
    let out = run(
        &["images", good.to_str().unwrap(), missing.to_str().unwrap()],
        None,
    );
    assert_fails(&out, 2, &["missing.pbm"], "missing file");
    println!("bad images: {} cases", 2 * cases.len() + 1);
}

#[test]
fn non_binary_images_are_thresholded() {
    let dir = Scratch::new("grey");
    // A grey ramp with a dark polygon: the threshold decides, colour and
    // alpha are converted first.
    let grey = png(64, 64, |c, r| {
        if c == 12 || r == 40 || c + r == 90 {
            20
        } else {
            200
        }
    });
    let a = dir.file("grey.png", &grey);
    let rgb = {
        let img = image::RgbaImage::from_fn(64, 64, |c, r| {
            if c == 12 || r == 40 || c + r == 90 {
                image::Rgba([200, 0, 0, 255])
            } else {
                image::Rgba([255, 255, 255, (c * 4) as u8])
            }
        });
        let mut out = std::io::Cursor::new(Vec::new());
        img.write_to(&mut out, image::ImageFormat::Png).unwrap();
        out.into_inner()
    };
    let b = dir.file("rgba.png", &rgb);
    let out = run(
        &["images", a.to_str().unwrap(), b.to_str().unwrap(), "--json"],
        None,
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    // A threshold that leaves nothing: a clean error naming the file.
    let out = run(
        &[
            "images",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--threshold",
            "0",
        ],
        None,
    );
    assert_fails(&out, 2, &["grey.png", "no occupied pixel"], "threshold 0");
}

#[test]
fn bad_options_exit_2_and_name_the_option() {
    let dir = Scratch::new("options");
    let a = dir.file("a.pbm", &polygon_pbm(0.0));
    let a = a.to_str().unwrap();
    for (args, needle) in [
        (vec!["--threshold", "300"], "--threshold"),
        (vec!["--rival-ratio", "2"], "--rival-ratio"),
        (vec!["--direction-margin=-1"], "--direction-margin"),
        (vec!["--max-shift", "NaN"], "--max-shift"),
        (vec!["--n-theta", "7"], "7"),
        (vec!["--size", "100"], "100"),
        (vec!["--mode", "fancy"], "fancy"),
    ] {
        let mut all = vec!["images", a, a];
        all.extend(args.iter());
        let out = run(&all, None);
        assert_fails(&out, 2, &[needle], &format!("{args:?}"));
    }
    let out = run(&["scans", "-", "--cell=-1"], Some(b""));
    assert_fails(&out, 2, &["--cell"], "--cell -1");
    let out = run(&["scans", "/nonexistent/pairs.jsonl"], None);
    assert_fails(&out, 2, &["/nonexistent/pairs.jsonl"], "missing pair file");
}

/// A scan with `n` beams over a half circle, ranges from `range(i)`.
fn scan(n: usize, range: impl Fn(usize) -> String) -> String {
    let ranges: Vec<String> = (0..n).map(range).collect();
    format!(
        "{{\"ranges\":[{}],\"angle_min\":-1.5708,\"angle_increment\":{},\"max_range\":30.0}}",
        ranges.join(","),
        std::f64::consts::PI / n.max(1) as f64
    )
}

fn room(i: usize) -> String {
    // A rectangular room seen from off its centre: distinct wall distances.
    let phi = -std::f64::consts::FRAC_PI_2 + std::f64::consts::PI * i as f64 / 360.0;
    let (s, c) = phi.sin_cos();
    let tx = if c > 1e-9 { 4.0 / c } else { f64::INFINITY };
    let ty = if s > 1e-9 {
        2.5 / s
    } else if s < -1e-9 {
        1.5 / -s
    } else {
        f64::INFINITY
    };
    format!("{:.3}", tx.min(ty))
}

#[test]
fn scan_pair_batch_keeps_going() {
    let good = format!(
        "{{\"scan1\":{},\"scan2\":{}}}",
        scan(360, room),
        scan(360, room)
    );
    let enormous = format!(
        "{{\"scan1\":{},\"scan2\":{}}}",
        scan(400_000, |i| format!("{:.3}", 2.0 + (i % 97) as f64 / 50.0)),
        scan(360, room)
    );
    let garbage_line = "x".repeat(2_000_000);
    // (line, expected error fragment or None for a result)
    let lines: Vec<(String, Option<&str>)> = vec![
        (good.clone(), None),
        (
            good.replace("\"ranges\":[", "\"ranges\":[NaN,"),
            Some("malformed pair"),
        ),
        (
            good.replace("\"ranges\":[", "\"ranges\":[1e999,"),
            Some("malformed pair"),
        ),
        (
            good.replace("\"angle_increment\"", "\"angle_incr\""),
            Some("angle_increment"),
        ),
        (
            good.replace("\"max_range\":30.0", "\"max_range\":\"far\""),
            Some("malformed pair"),
        ),
        (
            format!(
                "{{\"scan1\":{},\"scan2\":{}}}",
                scan(0, room),
                scan(360, room)
            ),
            Some("no beams"),
        ),
        (format!("{{\"scan1\":{}}}", scan(360, room)), Some("scan2")),
        (String::new(), Some("malformed pair")),
        (garbage_line, Some("malformed pair")),
        ("[1, 2, 3]".into(), Some("malformed pair")),
        (enormous, None),
        // Readings the library drops (null, negative, beyond max_range): a
        // result (no structure when nothing is left), never an error.
        (
            format!(
                "{{\"scan1\":{},\"scan2\":{}}}",
                scan(360, |_| "null".into()),
                scan(360, room)
            ),
            None,
        ),
        (
            format!(
                "{{\"scan1\":{},\"scan2\":{}}}",
                scan(360, |i| format!("-{i}")),
                scan(360, room)
            ),
            None,
        ),
        (good.clone(), None),
    ];
    let mut input = lines
        .iter()
        .map(|(l, _)| l.as_str())
        .collect::<Vec<_>>()
        .join("\n");
    input.push('\n');
    let out = run(
        &["scans", "-", "--size", "64", "--n-theta", "180", "--quiet"],
        Some(input.as_bytes()),
    );
    let stderr = text(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(out.status.code(), Some(1), "some pairs failed: {stderr}");
    let stdout = text(&out.stdout);
    let outputs: Vec<serde_json::Value> = stdout
        .lines()
        .map(|l| serde_json::from_str(l).expect("each output line is JSON"))
        .collect();
    assert_eq!(outputs.len(), lines.len(), "one output line per input line");
    for (i, ((_, expected), output)) in lines.iter().zip(&outputs).enumerate() {
        let line_no = format!("line {}", i + 1);
        assert_eq!(output["index"], i, "{output}");
        match expected {
            Some(fragment) => {
                assert_eq!(output["status"], "error", "{line_no}: {output}");
                let message = output["error"].as_str().unwrap_or_default();
                assert!(
                    message.contains(&line_no) && message.contains(fragment),
                    "{message}"
                );
                assert!(
                    stderr.contains(&format!("{line_no}:")),
                    "stderr lacks {line_no}: {stderr}"
                );
            }
            None => assert_ne!(output["status"], "error", "{line_no}: {output}"),
        }
    }
    // The first and last (identical, valid) pairs: the same answer.
    assert_eq!(outputs[0]["status"], outputs[lines.len() - 1]["status"]);
    // An all-good batch exits 0.
    let out = run(
        &["scans", "-", "--size", "64", "--n-theta", "180", "--quiet"],
        Some(format!("{good}\n{good}\n").as_bytes()),
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    // An empty file: nothing to do, no error.
    let out = run(
        &["scans", "-", "--size", "64", "--n-theta", "180", "--quiet"],
        Some(b""),
    );
    assert_eq!(out.status.code(), Some(0), "{}", text(&out.stderr));
    assert!(out.stdout.is_empty());
}

/// A pair whose readings are all dropped (NaN written as `null`, negative,
/// beyond `max_range`) comes back `no_structure`, and the output says why
/// (the dropped beams by reason).
#[test]
fn dropped_readings_are_reported() {
    let line = format!(
        "{{\"scan1\":{},\"scan2\":{}}}\n",
        scan(360, |i| format!("-{i}")),
        scan(360, room)
    );
    let out = run(
        &["scans", "-", "--size", "64", "--n-theta", "180", "--quiet"],
        Some(line.as_bytes()),
    );
    let all = format!("{}{}", text(&out.stdout), text(&out.stderr));
    assert!(
        all.contains("negative") || all.contains("non_positive") || all.contains("dropped"),
        "{all}"
    );
}

/// `scans --cell 1e-30 --connect 1e30`: the step count of connected segments
/// overflows (`Raster::connect`, finding F9 of `adversarial.rs`): a panic in
/// the test build of the tool.
#[test]
fn connect_with_tiny_cells_does_not_panic() {
    let line = format!(
        "{{\"scan1\":{},\"scan2\":{}}}\n",
        scan(360, room),
        scan(360, room)
    );
    let out = run(
        &[
            "scans",
            "-",
            "--size",
            "64",
            "--n-theta",
            "180",
            "--quiet",
            "--cell",
            "1e-30",
            "--connect",
            "1e30",
        ],
        Some(line.as_bytes()),
    );
    assert!(
        !text(&out.stderr).contains("panicked"),
        "{}",
        text(&out.stderr)
    );
}

// ---------------------------------------------------------------------------
// Stored references.

mod stored_reference {
    use hough_heading::{estimator, grid, reference, stages::REFERENCE_FORMAT, Error, Mode};

    // 80 columns: 3 words a row, the last 16 bits of each row beyond W.
    type G = grid!(80, 64);
    type E = estimator!(80, 64, 180);
    type R = reference!(80, 64, 180);
    const RW: usize = hough_heading::config::row_words(80);

    /// FNV-1a, the stored format's checksum.
    fn fnv1a(bytes: &[u8]) -> u32 {
        bytes.iter().fold(0x811c_9dc5u32, |h, &b| {
            (h ^ u32::from(b)).wrapping_mul(0x0100_0193)
        })
    }

    /// Recomputes the checksum (the last 4 bytes).
    fn reseal(bytes: &mut [u8]) {
        let n = bytes.len();
        let sum = fnv1a(&bytes[..n - 4]);
        bytes[n - 4..].copy_from_slice(&sum.to_le_bytes());
    }

    /// An irregular outline and its stored reference.
    fn stored() -> (G, Vec<u8>) {
        let mut g = G::new();
        for i in 0..50 {
            g.set(10 + i, 12).unwrap();
            g.set(10, 12 + i % 40).unwrap();
            g.set(20 + i / 2, 10 + i).unwrap();
        }
        let mut bytes = vec![0u8; R::BYTES];
        E::new(Mode::Improved)
            .reference(&g)
            .to_bytes(&mut bytes)
            .unwrap();
        (g, bytes)
    }

    /// Offset of the stored grid: it ends just before the checksum.
    const GRID_AT: usize = R::BYTES - 4 - 4 * RW * 64;

    #[test]
    fn the_stored_layout_is_as_documented() {
        assert_eq!(REFERENCE_FORMAT, 3);
        let (g, bytes) = stored();
        assert_eq!(&bytes[..4], b"HHR3");
        // The occupied count at bytes 16..20, the grid words before the
        // checksum, row by row, little-endian.
        let count = u32::from_le_bytes(bytes[16..20].try_into().unwrap());
        assert_eq!(count, g.occupied());
        for (i, word) in g.words().iter().flatten().enumerate() {
            let at = GRID_AT + 4 * i;
            assert_eq!(
                u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()),
                *word
            );
        }
        let back = R::from_bytes(&bytes).unwrap();
        assert_eq!(back.grid(), &g);
    }

    #[test]
    fn other_format_versions_are_refused_with_their_version() {
        let (g, bytes) = stored();
        let v2 = |found| {
            Err(Error::ReferenceVersion {
                found,
                expected: REFERENCE_FORMAT,
            })
        };
        // A version-2 reference: the version-3 layout without the grid, its
        // own checksum.
        let mut old = bytes[..GRID_AT].to_vec();
        old[3] = b'2';
        old.extend_from_slice(&[0; 4]);
        reseal(&mut old);
        assert_eq!(old.len(), R::BYTES - 4 * RW * 64);
        assert_eq!(R::from_bytes(&old), v2(2));
        // The version is read first: any length, any checksum.
        for len in [4, 5, 20, GRID_AT, R::BYTES, R::BYTES + 100] {
            let mut b = vec![0xA5u8; len];
            b[..4].copy_from_slice(b"HHR2");
            assert_eq!(R::from_bytes(&b), v2(2), "{len} bytes");
        }
        // Version 3 bytes relabelled as another version.
        for (digit, found) in [(b'1', 1), (b'2', 2), (b'4', 4), (b'9', 9)] {
            let mut b = bytes.clone();
            b[3] = digit;
            reseal(&mut b);
            assert_eq!(R::from_bytes(&b), v2(found));
        }
        // Not a reference at all: the magic itself differs.
        let mut b = bytes.clone();
        b[0] = b'X';
        reseal(&mut b);
        assert_eq!(R::from_bytes(&b), Err(Error::InvalidReference));
        // The message says what to do.
        let message = Error::ReferenceVersion {
            found: 2,
            expected: 3,
        }
        .to_string();
        assert!(message.contains('2') && message.contains('3') && message.contains("again"));
        // The current version still reads.
        assert_eq!(R::from_bytes(&bytes).unwrap().grid(), &g);
    }

    #[test]
    fn a_grid_that_disagrees_with_its_count_is_refused() {
        let (g, bytes) = stored();
        let count = g.occupied();
        let word_at = |row: usize, w: usize| GRID_AT + 4 * (row * RW + w);
        // One more occupied cell in the grid (row 40, col 70), the count
        // unchanged: checksum right, content inconsistent.
        assert!(!g.get(70, 40));
        let mut more = bytes.clone();
        more[word_at(40, 2)] |= 1 << (70 - 64);
        reseal(&mut more);
        assert_eq!(R::from_bytes(&more), Err(Error::InvalidReference));
        // The count one higher, the grid unchanged.
        let mut counted = bytes.clone();
        counted[16..20].copy_from_slice(&(count + 1).to_le_bytes());
        reseal(&mut counted);
        assert_eq!(R::from_bytes(&counted), Err(Error::InvalidReference));
        // An empty grid with the original count.
        let mut emptied = bytes.clone();
        emptied[GRID_AT..R::BYTES - 4].fill(0);
        reseal(&mut emptied);
        assert_eq!(R::from_bytes(&emptied), Err(Error::InvalidReference));
        // A cell beyond W = 80 (bit 16 of a row's third word), with the
        // count raised to match: refused too.
        let mut beyond = bytes.clone();
        beyond[word_at(5, 2) + 2] |= 1;
        beyond[16..20].copy_from_slice(&(count + 1).to_le_bytes());
        reseal(&mut beyond);
        assert_eq!(R::from_bytes(&beyond), Err(Error::InvalidReference));
        // Both changed consistently: a reference of another grid, accepted
        // (nothing can tell), and usable.
        let mut consistent = more.clone();
        consistent[16..20].copy_from_slice(&(count + 1).to_le_bytes());
        reseal(&mut consistent);
        let other = R::from_bytes(&consistent).expect("consistent grid and count");
        assert!(other.grid().get(70, 40));
        assert_eq!(other.occupied(), count + 1);
        let e = E::new(Mode::Improved).estimate(&other, &g);
        assert!(e.overlap >= hough_heading::Score::ZERO && e.overlap <= hough_heading::Score::ONE);
    }
}
