//! The `hough-heading` tool (the built binary) on the bundled data and on
//! bad input, and a check on the real scan pairs (skipped when
//! `../shared/data` is absent, except on CI).

mod common;

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;
use std::sync::{Arc, Mutex, OnceLock};

use common::{data_dir, scratch, stderr, stdout, tool};
use hough_heading::Mode;
use hough_heading_recordings::pairs::wrap_deg;

// ---------------------------------------------------------------------------
// The command-line tool.

fn image_file(name: &str) -> String {
    data_dir().join("images").join(name).display().to_string()
}

#[test]
fn demo_runs_on_the_bundled_data() {
    let o = tool(&["demo"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    assert!(out.contains("4/4 image pairs"), "{out}");
    // fr079 #630 (a 160° loop closure) comes out within 2° of the truth,
    // flagged `low_overlap` (README, demo).
    assert!(out.contains("7/7 scan pairs"), "{out}");
}

/// The rows of a demo report (pairs and verdict, without the timing).
fn demo_rows(out: &str) -> Vec<String> {
    out.lines()
        .filter(|l| l.starts_with("  ✓") || l.starts_with("  ✗"))
        .map(String::from)
        .collect()
}

#[test]
fn demo_writes_its_bundled_data_and_reads_a_directory() {
    let dir = scratch("demo-data");
    let o = tool(&["demo", "--write-data", &dir.display().to_string()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // Byte-identical to the source tree's data directory.
    for file in [
        "images/truth.json",
        "images/polygon-a.pbm",
        "images/room-b.pbm",
        "images/l-shape-a.png",
        "scans.jsonl",
        "scans.notes.json",
        "README.md",
    ] {
        let written = std::fs::read(dir.join(file)).unwrap();
        assert!(
            written == std::fs::read(data_dir().join(file)).unwrap(),
            "{file}"
        );
    }
    let bundled = tool(&["demo"]);
    let from_dir = tool(&["demo", "--data", &dir.display().to_string()]);
    assert!(from_dir.status.success(), "{}", stderr(&from_dir));
    assert!(stdout(&from_dir).contains(&dir.display().to_string()));
    assert_eq!(demo_rows(&stdout(&bundled)).len(), 11);
    assert_eq!(demo_rows(&stdout(&bundled)), demo_rows(&stdout(&from_dir)));
    // A directory without the files is an unreadable-file error.
    let empty = scratch("demo-empty");
    let o = tool(&["demo", "--data", &empty.display().to_string()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("truth.json"), "{}", stderr(&o));
}

#[test]
fn images_prints_the_rotation_as_text_and_json() {
    let (a, b) = (image_file("polygon-a.pbm"), image_file("polygon-b.pbm"));
    let o = tool(&["images", &a, &b]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("+37.0"), "{}", stdout(&o));
    let o = tool(&["images", &a, &b, "--json"]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    let alpha = v["alpha_deg"].as_f64().unwrap();
    assert!((alpha - 37.0).abs() < 1.0, "{v}");
    assert_eq!(v["status"], "confident");
    assert!(v["confidence"].as_f64().unwrap() > 0.5);
    let candidates = v["candidates"].as_array().unwrap();
    assert!(candidates[0]["alpha_deg"].is_number() && candidates[0]["score"].is_number());
    assert!((v["tx_px"].as_f64().unwrap() - 4.0).abs() < 1.0, "{v}");
    assert!((v["ty_px"].as_f64().unwrap() + 3.0).abs() < 1.0, "{v}");
    // PNG and ASCII PBM.
    let o = tool(&[
        "images",
        &image_file("l-shape-a.png"),
        &image_file("l-shape-b.png"),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert!(
        (v["alpha_deg"].as_f64().unwrap() + 160.0).abs() < 1.0,
        "{v}"
    );
    let o = tool(&[
        "images",
        &image_file("room-a.pbm"),
        &image_file("room-b.pbm"),
        "--json",
        "--mode",
        "paper",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert!(v["tx_px"].is_null(), "paper mode has no translation: {v}");
}

#[test]
fn images_fit_centre_pads_and_keeps_the_translation() {
    // Crop the bundled 128² polygon pair to 100 × 90 (top-left kept) and
    // estimate on a padded grid: same rotation, translation unchanged.
    let dir = scratch("fit");
    let crop = |name: &str| {
        let img = image::open(image_file(name)).unwrap().to_luma8();
        let cropped = image::imageops::crop_imm(&img, 14, 19, 100, 90).to_image();
        let path = dir.join(name.replace(".pbm", ".png"));
        cropped.save(&path).unwrap();
        path.display().to_string()
    };
    let (a, b) = (crop("polygon-a.pbm"), crop("polygon-b.pbm"));
    let o = tool(&["images", &a, &b]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("100×90") && stderr(&o).contains("--fit"),
        "{}",
        stderr(&o)
    );
    let o = tool(&["images", &a, &b, "--fit", "centre", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_str(stdout(&o).trim()).unwrap();
    assert_eq!(v["size"], 128);
    assert!((v["alpha_deg"].as_f64().unwrap() - 37.0).abs() < 1.0, "{v}");
    // The crop moves both centres by the same amount: t changes by (I − R)c,
    // which the tool undoes; allow for pixels lost at the crop border.
    assert!((v["tx_px"].as_f64().unwrap() - 4.0).abs() < 1.5, "{v}");
    assert!((v["ty_px"].as_f64().unwrap() + 3.0).abs() < 1.5, "{v}");
}

#[test]
fn bad_images_are_clear_errors_with_exit_status_2() {
    let dir = scratch("bad-images");
    let good = image_file("polygon-a.pbm");
    // Truncated P4.
    let bytes = std::fs::read(&good).unwrap();
    let truncated = dir.join("truncated.pbm");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    // Truncated P1 header.
    let header_only = dir.join("header.pbm");
    std::fs::write(&header_only, b"P1\n128 12").unwrap();
    // Empty (all white) 128² image.
    let empty = dir.join("empty.pbm");
    let mut blank = b"P4\n128 128\n".to_vec();
    blank.extend(std::iter::repeat_n(0u8, 16 * 128));
    std::fs::write(&empty, blank).unwrap();
    // Wrong size: 100 × 100.
    let small = dir.join("small.pbm");
    let mut s = b"P4\n100 100\n".to_vec();
    s.extend(std::iter::repeat_n(0xffu8, 13 * 100));
    std::fs::write(&small, s).unwrap();
    let text = dir.join("text.pbm");
    std::fs::write(&text, b"hello").unwrap();
    let missing = dir.join("missing.pbm");
    for (bad, expect) in [
        (&truncated, "truncated.pbm"),
        (&header_only, "header.pbm"),
        (&empty, "no occupied pixel"),
        (&small, "100×100"),
        (&text, "text.pbm"),
        (&missing, "missing.pbm"),
    ] {
        let o = tool(&["images", &good, &bad.display().to_string()]);
        assert_eq!(
            o.status.code(),
            Some(2),
            "{}: {}",
            bad.display(),
            stderr(&o)
        );
        assert!(
            stderr(&o).contains(expect),
            "{}: {}",
            bad.display(),
            stderr(&o)
        );
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
    // Unknown configuration.
    let o = tool(&["images", &good, &good, "--n-theta", "100"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("available"), "{}", stderr(&o));
}

/// A valid pair line from the bundled data, with its scans replaced.
fn pair_line(edit: impl FnOnce(&mut serde_json::Value)) -> String {
    let text = std::fs::read_to_string(data_dir().join("scans.jsonl")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(text.lines().next().unwrap()).unwrap();
    edit(&mut v);
    v.to_string()
}

#[test]
fn scans_reports_bad_lines_and_goes_on() {
    let dir = scratch("bad-scans");
    let good = pair_line(|_| {});
    let no_beams = pair_line(|v| v["scan2"]["ranges"] = serde_json::json!([]));
    let junk_ranges = pair_line(|v| {
        let n = v["scan1"]["ranges"].as_array().unwrap().len();
        let bad: Vec<serde_json::Value> = (0..n)
            .map(|i| match i % 4 {
                0 => serde_json::Value::Null,
                1 => serde_json::json!(-1.0),
                2 => serde_json::json!(0.0),
                _ => serde_json::json!(1e9),
            })
            .collect();
        v["scan1"]["ranges"] = serde_json::Value::Array(bad);
    });
    let nan_geometry = pair_line(|v| v["scan2"]["angle_increment"] = serde_json::json!("NaN"));
    let lines = [
        good.as_str(),
        "{\"scan1\": {",
        no_beams.as_str(),
        "",
        junk_ranges.as_str(),
        nan_geometry.as_str(),
        good.as_str(),
    ];
    let file = dir.join("pairs.jsonl");
    std::fs::write(&file, lines.join("\n") + "\n").unwrap();
    let o = tool(&["scans", &file.display().to_string(), "--summary", "-q"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let out: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(out.len(), lines.len());
    let status: Vec<&str> = out.iter().map(|v| v["status"].as_str().unwrap()).collect();
    assert_eq!(status[0], "confident");
    assert_eq!(status[1], "error");
    assert!(
        out[1]["error"].as_str().unwrap().contains("line 2"),
        "{}",
        out[1]
    );
    assert_eq!(status[2], "error");
    assert!(
        out[2]["error"].as_str().unwrap().contains("no beams"),
        "{}",
        out[2]
    );
    assert_eq!(status[3], "error");
    assert!(
        out[3]["error"].as_str().unwrap().contains("line 4"),
        "{}",
        out[3]
    );
    // All readings of scan 1 invalid: an answer without structure, not an error.
    assert_eq!(status[4], "no_structure", "{}", out[4]);
    assert_eq!(status[5], "error", "{}", out[5]);
    assert_eq!(status[6], "confident");
    for (i, v) in out.iter().enumerate() {
        assert_eq!(v["index"], i);
    }
    let keys = [
        "index",
        "dtheta_deg",
        "status",
        "confidence",
        "candidates_deg",
        "dx_m",
        "dy_m",
        "residual_m",
        "columns",
    ];
    for key in keys {
        assert!(out[0].get(key).is_some(), "{key} missing: {}", out[0]);
    }
    let err = stderr(&o);
    assert!(err.contains("| overlap ≥ 0.5 | improved |"), "{err}");
    assert!(err.contains("line(s) failed"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn scans_never_reads_the_ground_truth_to_estimate() {
    let dir = scratch("no-truth");
    let good = pair_line(|_| {});
    let scrubbed = pair_line(|v| {
        let o = v.as_object_mut().unwrap();
        for key in ["dx", "dy", "dtheta", "check", "log_delta"] {
            o.remove(key);
        }
    });
    let file = dir.join("pairs.jsonl");
    std::fs::write(&file, format!("{good}\n{scrubbed}\n")).unwrap();
    let o = tool(&["scans", &file.display().to_string(), "-q"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    let out: Vec<&str> = text.lines().collect();
    assert_eq!(out[0], out[1].replace("\"index\":1", "\"index\":0"));
}

#[test]
fn scans_input_errors_exit_with_status_2() {
    let o = tool(&["scans", "/nonexistent/pairs.jsonl"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("/nonexistent/pairs.jsonl"),
        "{}",
        stderr(&o)
    );
    let file = data_dir().join("scans.jsonl").display().to_string();
    let o = tool(&["scans", &file, "--cell", "-1"]);
    assert_eq!(o.status.code(), Some(2));
    let o = tool(&["scans", &file, "--size", "100"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("available"), "{}", stderr(&o));
    let o = tool(&["scans"]);
    assert_eq!(o.status.code(), Some(2));
}

/// Output piped into a reader that stops after one line (`demo | head -1`):
/// the tool ends (by SIGPIPE on Unix) without a panic message.
#[test]
fn a_closed_output_pipe_is_not_a_panic() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_hough-heading"))
        .arg("demo")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run hough-heading");
    let mut first = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .unwrap();
    // The reader is dropped here: the pipe is closed after one line.
    assert!(!first.is_empty());
    let out = child.wait_with_output().unwrap();
    let err = stderr(&out);
    assert!(!err.contains("panicked"), "{err}");
    assert_ne!(out.status.code(), Some(101), "{err}");
}

/// `reference` writes one scan of a pair as the bytes a firmware stores:
/// read back by the library, they are the reference, free space, raster and
/// scan the library prepares from the same scan on its own, an estimate of
/// the pair's other scan against them is the pair's ground truth, and the
/// stored scan confirms it on the beams.
#[test]
fn reference_writes_a_scan_reference_the_library_reads() {
    use hough_heading::{estimator, grid, scan_reference, Raster};
    use hough_heading_recordings::pairs::{PairRecord, Truth};
    type Stored = scan_reference!(128, 128, 360, 2048);
    let pairs = data_dir().join("scans.jsonl");
    let out = scratch("reference").join("dock.hhs");
    let (pairs_arg, out_arg) = (pairs.display().to_string(), out.display().to_string());
    // `reference --scans PAIRS --out OUT` and `extra`.
    let reference = |extra: &[&str]| {
        let base = ["reference", "--scans", &pairs_arg, "--out", &out_arg];
        tool(&[&base[..], extra].concat())
    };
    let o = reference(&["--line", "2", "--size", "128"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&out).unwrap();
    let stored = Stored::from_bytes(&bytes).unwrap();
    let text = std::fs::read_to_string(&pairs).unwrap();
    let line = text.lines().nth(2).unwrap();
    let pair: PairRecord = serde_json::from_str(line).unwrap();
    let truth: Truth = serde_json::from_str(line).unwrap();
    let (r1, r2) = (pair.scan1.ranges(), pair.scan2.ranges());
    let (s1, s2) = (pair.scan1.scan(&r1), pair.scan2.scan(&r2));
    // The raster of this scan alone, with the tool's default segments.
    let raster = Raster::auto(&[s1], 128).unwrap().connect(0.3);
    assert_eq!(stored.raster(), raster);
    let draw = |scan| {
        let (mut occupied, mut free) = (<grid!(128, 128)>::new(), <grid!(128, 128)>::new());
        raster.rasterize(scan, &mut occupied);
        raster.free_space(scan, &mut free);
        (occupied, free)
    };
    let mut e = <estimator!(128, 128, 360)>::new(Mode::Improved);
    let (g1, f1) = draw(&s1);
    assert_eq!(
        stored,
        Stored::new(e.reference(&g1), f1, raster, &s1).unwrap()
    );
    assert_eq!(bytes.len(), stored.byte_len());
    let (g2, f2) = draw(&s2);
    let estimate = e.estimate_scans(stored.reference(), &g2, &stored.free_space(&f2), None);
    let motion = raster.motion(estimate.alpha, estimate.translation.as_ref());
    let error = wrap_deg(f64::from(motion.dtheta).to_degrees() - truth.dtheta.to_degrees());
    assert!(error.abs() < 2.0, "{error}° off: {estimate:?}");
    let check = raster.check_on_beams(&stored.scan(), &s2, &estimate);
    assert_eq!(check, raster.check_on_beams(&s1, &s2, &estimate));
    let check = check.unwrap();
    assert!(!check.too_weak() && !check.contradicts(), "{check:?}");
    // A line the file does not have, and a third scan: clear errors.
    let missing = reference(&["--line", "99"]);
    assert_eq!(missing.status.code(), Some(2));
    assert!(
        stderr(&missing).contains("no line 99"),
        "{}",
        stderr(&missing)
    );
    let third = reference(&["--scan", "3"]);
    assert_eq!(third.status.code(), Some(2));
    // The beams' options belong to the commands that estimate: storing a
    // scan refuses them rather than ignoring them.
    let estimating_option = reference(&["--no-beam-check"]);
    assert_eq!(estimating_option.status.code(), Some(2));
    assert!(stderr(&estimating_option).contains("--no-beam-check"));
}

#[test]
fn plot_writes_a_png_sheet() {
    let dir = scratch("plot");
    let file = data_dir().join("scans.jsonl").display().to_string();
    let o = tool(&[
        "plot",
        "scans",
        &file,
        "--index",
        "1",
        "--size",
        "128",
        "--out",
        &dir.display().to_string(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = std::fs::read(dir.join("scans-1.png")).unwrap();
    assert_eq!(&png[..4], b"\x89PNG");
    let o = tool(&[
        "plot",
        "scans",
        &file,
        "--index",
        "99",
        "--out",
        &dir.display().to_string(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("index 99"), "{}", stderr(&o));
}

// ---------------------------------------------------------------------------
// Real data (skipped when ../shared/data is absent, except on CI).

/// Whether the environment variable `CI` is set to something other than
/// empty, `0` or `false` (CI services set `CI=true`; `.ci/run` sets `CI=1`
/// unless told otherwise).
fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"))
}

/// The text of `../shared/data/<name>` (next to the clone), or `None` after
/// printing `SKIPPED: …` to stderr when it is absent (a user's clone). On CI
/// (`CI` set, see [`on_ci`]) the data must be there: a missing file fails the
/// test instead of skipping it.
fn real_data(name: &str) -> Option<String> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(name);
    match std::fs::read_to_string(&path) {
        Ok(text) => Some(text),
        Err(e) if on_ci() => panic!(
            "CI is set but the real data {} cannot be read ({e}): CI must run this test",
            path.display()
        ),
        Err(e) => {
            eprintln!(
                "SKIPPED: real-data test: {} cannot be read ({e}); set CI=1 to make this a failure",
                path.display()
            );
            None
        }
    }
}

/// The tool's JSON lines for `args`, which must succeed.
fn scan_lines(args: &[&str]) -> Vec<serde_json::Value> {
    let o = tool(args);
    assert!(o.status.success(), "{}", stderr(&o));
    stdout(&o)
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .collect()
}

/// The tool's default answers at 128² (`scans -q --size 128 [--limit N]
/// FILE`) on a shared pair file, run once per test binary: the work
/// budget's, the refinement's and the check's tests share them (each test
/// runs its own variants).
fn default_answers(path: &str, limit: Option<usize>) -> Arc<Vec<serde_json::Value>> {
    /// A run's key (file, limit) and its answers, once computed.
    type Runs = HashMap<(String, Option<usize>), Arc<OnceLock<Arc<Vec<serde_json::Value>>>>>;
    static RUNS: OnceLock<Mutex<Runs>> = OnceLock::new();
    let run = RUNS
        .get_or_init(Mutex::default)
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .entry((path.to_string(), limit))
        .or_default()
        .clone();
    run.get_or_init(|| {
        let limit = limit.map(|n| n.to_string());
        let mut args = vec!["scans", "-q", "--size", "128"];
        if let Some(n) = &limit {
            args.extend(["--limit", n]);
        }
        args.push(path);
        Arc::new(scan_lines(&args))
    })
    .clone()
}

/// The default work budget (`Thresholds::search_budget`, 2²⁶ grid rows)
/// cuts none of the first 150 pairs of each FLIRT file at 128² (the most
/// any shared pair spends there is 10.0 M rows), and a budget of 2²⁰ rows
/// cuts some, which then say so and are not confident.
#[test]
fn the_default_work_budget_cuts_no_real_pair() {
    let files = ["fr079-flirt_pairs.jsonl", "intel-flirt_pairs.jsonl"];
    if files.iter().any(|f| real_data(f).is_none()) {
        return;
    }
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let paths: Vec<String> = files
        .iter()
        .map(|f| dir.join(f).display().to_string())
        .collect();
    let status = |v: &serde_json::Value| v["status"].as_str().unwrap_or("").to_string();
    // The first 150 pairs of each: fr079's whole run (the check's test) and
    // intel's first 200 (the refinement's).
    let (fr079, intel) = (
        default_answers(&paths[0], None),
        default_answers(&paths[1], Some(200)),
    );
    let default: Vec<_> = fr079
        .iter()
        .take(150)
        .chain(intel.iter().take(150))
        .collect();
    assert_eq!(default.len(), 300);
    assert!(default.iter().all(|v| status(v) != "search_cut"));
    let mut args = vec!["scans", "-q", "--size", "128", "--limit", "150"];
    args.extend(["--search-budget", "1048576"]);
    args.extend(paths.iter().map(String::as_str));
    let tight = scan_lines(&args);
    let cut: Vec<_> = tight.iter().filter(|v| status(v) == "search_cut").collect();
    assert!(!cut.is_empty(), "2^20 rows cut nothing");
    // Below ½ (the JSON's four decimals round the cap, ½ − 2⁻¹⁶, to 0.5).
    assert!(cut.iter().all(|v| v["confidence"].as_f64().unwrap() <= 0.5));
}

/// The refinement on the beams (`Raster::refine_on_beams`, on by
/// default) against the files' ground truth at 128², the microcontroller
/// size, on the first 400 pairs of two buildings: among the pairs whose
/// views overlap (`overlap_gt` ≥ 0.5) and whose grid estimate is within
/// 2°, the median rotation and translation errors fall (here 391 pairs:
/// 0.241° → 0.167°, 2.3 → 1.9 cm; pooled over all shared pairs 0.321° →
/// 0.231°, 3.4 → 2.4 cm); `--no-beam-refine` gives the grid's pose and no
/// `beam_fit`.
#[test]
fn the_refinement_on_the_beams_brings_real_pairs_closer_to_the_truth() {
    let files = ["intel-flirt_pairs.jsonl", "seattle-corrected_pairs.jsonl"];
    let Some(texts) = files
        .iter()
        .map(|f| real_data(f))
        .collect::<Option<Vec<_>>>()
    else {
        return;
    };
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/data");
    let (mut rotation, mut translation) = ([vec![], vec![]], [vec![], vec![]]);
    for (file, text) in files.iter().zip(&texts) {
        let path = dir.join(file).display().to_string();
        let grid = scan_lines(&[
            "scans",
            "-q",
            "--size",
            "128",
            "--limit",
            "200",
            &path,
            "--no-beam-refine",
        ]);
        let beams = default_answers(&path, Some(200));
        assert!(grid.iter().all(|v| v.get("beam_fit").is_none()));
        assert!(beams
            .iter()
            .any(|v| v["beam_fit"]["pairs"].as_u64() > Some(10)));
        for ((line, g), b) in text.lines().zip(&grid).zip(beams.iter()) {
            let truth: serde_json::Value = serde_json::from_str(line).unwrap();
            if truth["check"]["overlap_gt"]
                .as_f64()
                .is_none_or(|o| o < 0.5)
            {
                continue;
            }
            let dtheta = truth["dtheta"].as_f64().unwrap().to_degrees();
            let (dx, dy) = (truth["dx"].as_f64().unwrap(), truth["dy"].as_f64().unwrap());
            let err =
                |v: &serde_json::Value| wrap_deg(v["dtheta_deg"].as_f64().unwrap() - dtheta).abs();
            let moved = |v: &serde_json::Value| {
                let (x, y) = (v["dx_m"].as_f64()?, v["dy_m"].as_f64()?);
                v.get("unobservable")
                    .is_none()
                    .then(|| (x - dx).hypot(y - dy))
            };
            if err(g) > 2.0 {
                continue;
            }
            for (k, v) in [g, b].into_iter().enumerate() {
                rotation[k].push(err(v));
                if let Some(m) = moved(v) {
                    translation[k].push(m);
                }
            }
        }
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    assert!(rotation[0].len() > 150, "{}", rotation[0].len());
    let (r_grid, r_beams) = (median(&mut rotation[0]), median(&mut rotation[1]));
    let (t_grid, t_beams) = (median(&mut translation[0]), median(&mut translation[1]));
    assert!(
        r_beams < 0.85 * r_grid,
        "rotation: grid {r_grid}°, beams {r_beams}°"
    );
    assert!(
        t_beams < 0.9 * t_grid,
        "translation: grid {t_grid} m, beams {t_beams} m"
    );
}

/// The check on the beams (`Raster::check_on_beams`, on by default)
/// against the file's ground truth on all 1 210 `fr079-flirt` pairs at
/// 128²: the wrong share (> 5°) among the confident answers falls (here
/// 35 of 957 → 3 of 875), and where the beams replace the grid's answer
/// they bring far more pairs within 2° than they take out (52 against 9);
/// `--no-beam-check` gives no `beam_check`.
#[test]
fn the_check_on_the_beams_flags_and_fixes_wrong_answers() {
    let file = "fr079-flirt_pairs.jsonl";
    let Some(text) = real_data(file) else {
        return;
    };
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(file)
        .display()
        .to_string();
    let unchecked = scan_lines(&["scans", "-q", "--size", "128", &path, "--no-beam-check"]);
    let checked = default_answers(&path, None);
    assert!(unchecked.iter().all(|v| v.get("beam_check").is_none()));
    // [right, wrong] among the confident answers, before and after;
    // pairs the switches bring within 2° and take out.
    let (mut before, mut after) = ([0u32; 2], [0u32; 2]);
    let (mut fixed, mut broken) = (0, 0);
    for ((line, u), c) in text.lines().zip(&unchecked).zip(checked.iter()) {
        let truth: serde_json::Value = serde_json::from_str(line).unwrap();
        let dtheta = truth["dtheta"].as_f64().unwrap().to_degrees();
        let err =
            |v: &serde_json::Value| wrap_deg(v["dtheta_deg"].as_f64().unwrap() - dtheta).abs();
        for (v, tally) in [(u, &mut before), (c, &mut after)] {
            if v["status"] == "confident" {
                tally[usize::from(err(v) > 5.0)] += 1;
            }
        }
        if c["beam_check"]["switches"] == true {
            assert_ne!(c["status"], "confident");
            fixed += u32::from(err(u) > 2.0 && err(c) <= 2.0);
            broken += u32::from(err(u) <= 2.0 && err(c) > 2.0);
        } else {
            assert_eq!(u["dtheta_deg"], c["dtheta_deg"]);
        }
    }
    let share = |t: [u32; 2]| f64::from(t[1]) / f64::from((t[0] + t[1]).max(1));
    assert!(
        share(after) < 0.6 * share(before),
        "wrong among confident: before {before:?}, after {after:?}"
    );
    assert!(
        fixed >= 20 && fixed >= 4 * broken,
        "switches: {fixed} fixed, {broken} broken"
    );
}

#[test]
fn real_fr079_pairs_with_overlap_are_mostly_within_two_degrees() {
    let Some(text) = real_data("fr079-flirt_pairs.jsonl") else {
        return;
    };
    use hough_heading_recordings::pairs::{estimate, PairRecord, RasterOptions, Truth};
    let mut engine = hough_heading_recordings::engine::engine(256, 360).unwrap();
    let options = RasterOptions {
        cell: None,
        connect: None,
        disc: false,
        beam_refine: true,
        beam_check: true,
    };
    let (mut pairs, mut within) = (0, 0);
    for line in text.lines() {
        let truth: Truth = serde_json::from_str(line).unwrap();
        if truth.check.overlap_gt.is_none_or(|o| o < 0.5) {
            continue;
        }
        let pair: PairRecord = serde_json::from_str(line).unwrap();
        let p = estimate(engine.as_mut(), &pair, &options, &[Mode::Improved]).unwrap();
        let error = wrap_deg(p[0].dtheta_deg - truth.dtheta.to_degrees()).abs();
        pairs += 1;
        within += usize::from(error <= 2.0);
        if pairs == 100 {
            break;
        }
    }
    assert_eq!(pairs, 100);
    assert!(within >= 80, "{within}/100 within 2°");
}

#[test]
fn images_scale_search_recovers_a_known_scale_and_translation() {
    use host_tests::scene::{render_pair, write_pbm, Damage, PbmFormat, SceneKind, Transform};
    use rand::SeedableRng;
    // A random polygon, turned 25°, moved (3.25, −1.5) px and scaled by 1.07
    // about the image centre.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let scene = SceneKind::RandomPolygon.generate(&mut rng);
    let truth = Transform {
        alpha_rad: 25f64.to_radians(),
        tx: 3.25,
        ty: -1.5,
        scale: 1.07,
    };
    let pair = render_pair(&scene, &truth, &Damage::CLEAN, 128, 128, 7);
    let dir = scratch("scale");
    let (a, b) = (dir.join("a.pbm"), dir.join("b.pbm"));
    write_pbm(&pair.i1.image, &a, PbmFormat::Binary).unwrap();
    write_pbm(&pair.i2.image, &b, PbmFormat::Binary).unwrap();
    let (a, b) = (a.display().to_string(), b.display().to_string());
    let run = |extra: &[&str]| {
        let mut args = vec!["images", a.as_str(), b.as_str(), "--json"];
        args.extend_from_slice(extra);
        let o = tool(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        serde_json::from_str::<serde_json::Value>(stdout(&o).trim()).unwrap()
    };
    let f = |v: &serde_json::Value, key: &str| v[key].as_f64().unwrap();
    let v = run(&["--scale-search"]);
    assert!((f(&v, "alpha_deg") - 25.0).abs() < 0.5, "{v}");
    assert!((f(&v, "scale") - 1.07).abs() < 0.01, "{v}");
    assert!((f(&v, "tx_px") - 3.25).abs() < 0.75, "{v}");
    assert!((f(&v, "ty_px") + 1.5).abs() < 0.75, "{v}");
    assert!(f(&v, "residual_px") >= 0.0, "{v}");
    let columns = v["columns"].as_u64().unwrap();
    assert!((1..=4).contains(&columns), "{v}");
    // Without the search the scale is reported as exactly 1.
    assert_eq!(f(&run(&[]), "scale"), 1.0);
    // A range outside 0.5–2, or not MIN:MAX, is a usage error.
    for bad in ["0.3:1.2", "1.2:1.1", "x", "0.9"] {
        let o = tool(&["images", &a, &b, &format!("--scale-search={bad}")]);
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--scale-search"), "{}", stderr(&o));
    }
}

/// Every verified answer on the bundled scan pairs names its runner-up (the
/// best rotation at least 5° away, whatever its lead), with its rotation,
/// alignment, support and free-space share, and the winner's support is at
/// least the runner-up's; `confident` exactly when the lead reaches the
/// default decision gap (0.08) and the confidence is at least ½.
#[test]
fn scans_json_reports_the_runner_up() {
    let scans = data_dir().join("scans.jsonl").display().to_string();
    let o = tool(&["scans", "-q", &scans]);
    assert!(o.status.success(), "{}", stderr(&o));
    let mut named = 0;
    for line in stdout(&o).lines() {
        let v: serde_json::Value = serde_json::from_str(line).unwrap();
        let status = v["status"].as_str().unwrap();
        if matches!(status, "no_structure" | "error") {
            continue;
        }
        let supports = v["supports"].as_array().expect("supports");
        assert_eq!(
            supports.len(),
            v["candidates_deg"].as_array().unwrap().len(),
            "{line}"
        );
        assert_eq!(
            v["free_space"].as_array().map(Vec::len),
            Some(supports.len()),
            "{line}"
        );
        let Some(r) = v.get("runner_up") else {
            // Only an answer with nothing else to compare has none.
            assert_eq!(supports.len(), 1, "runner-up missing: {line}");
            continue;
        };
        named += 1;
        for key in ["dtheta_deg", "alignment", "support", "free_space"] {
            assert!(r[key].is_number(), "runner_up.{key} missing: {line}");
        }
        let lead = supports[0].as_f64().unwrap() - r["support"].as_f64().unwrap();
        assert!(lead >= -1e-4, "{line}");
        // (Printed to 4 decimals: a lead within 10⁻³ of the gap is not read.)
        if status != "low_overlap" && (lead - 0.08).abs() > 1e-3 {
            assert_eq!(status == "confident", lead >= 0.08, "{line}");
            assert_eq!(
                status == "confident",
                v["confidence"].as_f64().unwrap() >= 0.5,
                "{line}"
            );
        }
    }
    assert!(named >= 1, "{named} runner-ups");
}
