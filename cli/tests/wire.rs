//! `hough-heading wire` and `log --format ld06|rplidar|ydlidar|xv11` on the raw
//! captures of `lidar/tests/data/` (written from the Seattle scans of
//! `cli/data/logs/seattle-excerpt.log` by `tools/lidar_streams.py`, an
//! encoder independent of the parsers).

mod common;

use std::path::{Path, PathBuf};

use common::{json_lines, stderr, tool};
use serde_json::Value;

fn capture(name: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../lidar/tests/data")
        .join(name)
        .display()
        .to_string()
}

fn scratch(name: &str) -> PathBuf {
    common::scratch_file("wire-tests", name)
}

/// The estimate of a line, without where its scans come from.
fn estimate(v: &Value) -> serde_json::Map<String, Value> {
    let mut m = v.as_object().expect("an object").clone();
    // The CARMEN log carries a clock (the revolution index) and a robot
    // pose (0 0 0: unknown) that the raw capture has not.
    for k in ["t1", "t2", "odom"] {
        m.remove(k);
    }
    m
}

const QUICK: [&str; 3] = ["--size", "128", "-q"];

#[test]
fn log_reads_captures_one_scan_per_revolution() {
    for (protocol, revolutions) in [("ld06", 20), ("rplidar", 6), ("ydlidar", 6), ("xv11", 6)] {
        let file = capture(&format!("{protocol}.bin"));
        let out = tool(
            &[
                &["log", &file, "--format", protocol, "--pairs", "consecutive"][..],
                &QUICK,
            ]
            .concat(),
        );
        assert!(out.status.success(), "{protocol}: {}", stderr(&out));
        let lines = json_lines(&out);
        assert_eq!(lines.len(), revolutions - 1, "{protocol}");
        for (i, l) in lines.iter().enumerate() {
            assert_eq!(l["scan1"], i);
            assert_eq!(l["scan2"], i + 1);
            assert_ne!(l["status"], "error");
        }
        let err = stderr(&out);
        assert!(
            err.contains(&format!(
                "{revolutions} revolutions; dropped: 0 bad checksum, 0 bad framing, \
                 0 out of range, 0 bytes skipped"
            )),
            "{protocol}: {err}"
        );
    }
}

#[test]
fn capture_estimates_agree_with_the_source_log() {
    // The LD06 capture carries the 20 scans of the CARMEN excerpt (ranges
    // rounded to the millimetre, beams on a full circle from 0° instead of
    // a half circle from −90°): the heading changes agree.
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/logs/seattle-excerpt.log");
    let a = json_lines(&tool(
        &[&["log", &source.display().to_string()][..], &QUICK].concat(),
    ));
    let b = json_lines(&tool(
        &[
            &[
                "log",
                &capture("ld06.bin"),
                "--format",
                "ld06",
                "--pairs",
                "consecutive",
            ][..],
            &QUICK,
        ]
        .concat(),
    ));
    assert_eq!(a.len(), b.len());
    let close = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| {
            let d = x["dtheta_deg"].as_f64().unwrap() - y["dtheta_deg"].as_f64().unwrap();
            d.abs() < 0.5
        })
        .count();
    assert!(
        close + 1 >= a.len(),
        "{close} of {} pairs within 0.5°",
        a.len()
    );
}

#[test]
fn wire_writes_a_carmen_log_that_log_reads_back_bit_for_bit() {
    for protocol in ["ld06", "rplidar", "ydlidar", "xv11"] {
        let file = capture(&format!("{protocol}.bin"));
        let log = scratch(&format!("{protocol}.log"));
        let log_name = log.display().to_string();
        let out = tool(&["wire", "--protocol", protocol, &file, "--out", &log_name]);
        assert!(out.status.success(), "{protocol}: {}", stderr(&out));
        assert!(stderr(&out).contains("0 bad checksum"), "{}", stderr(&out));
        let text = std::fs::read_to_string(&log).unwrap();
        let lines: Vec<&str> = text
            .lines()
            .filter(|l| l.starts_with("ROBOTLASER1"))
            .collect();
        let fields: Vec<&str> = lines[0].split_whitespace().collect();
        // type start_angle fov resolution max_range accuracy mode n
        assert_eq!(&fields[1..3], ["0", "0"]);
        assert_eq!(fields[3].parse::<f32>().unwrap(), std::f32::consts::TAU);
        assert_eq!(fields[8], "720");
        let direct = json_lines(&tool(
            &[&["log", &file, "--format", protocol][..], &QUICK].concat(),
        ));
        let back = json_lines(&tool(&[&["log", &log_name][..], &QUICK].concat()));
        assert_eq!(direct.len(), lines.len() - 1);
        assert_eq!(
            direct.iter().map(estimate).collect::<Vec<_>>(),
            back.iter().map(estimate).collect::<Vec<_>>(),
            "{protocol}"
        );
    }
}

#[test]
fn wire_says_the_pose_is_unknown_and_gives_the_revolutions_own_times() {
    // LD06 packets carry a time stamp: the bundled capture's are 2 ms a
    // packet apart, 60 packets a revolution. RPLIDAR packets carry none.
    for (protocol, period) in [("ld06", Some(0.12)), ("rplidar", None)] {
        let file = capture(&format!("{protocol}.bin"));
        let log = scratch(&format!("timed-{protocol}.log"));
        let log_name = log.display().to_string();
        let out = tool(&["wire", "--protocol", protocol, &file, "--out", &log_name]);
        assert!(out.status.success(), "{protocol}: {}", stderr(&out));
        let text = std::fs::read_to_string(&log).unwrap();
        assert!(text.contains("\nPARAM hough_heading_odometry none\n"));
        assert_eq!(
            text.contains("\nPARAM hough_heading_clock none\n"),
            period.is_none(),
            "{protocol}"
        );
        // The timestamp field (after the 720 ranges, 720 remissions and
        // the 11 fields from laser_x to turn_axis).
        let times: Vec<f64> = text
            .lines()
            .filter(|l| l.starts_with("ROBOTLASER1"))
            .map(|l| {
                l.split(' ')
                    .nth(9 + 720 + 1 + 720 + 11)
                    .unwrap()
                    .parse()
                    .unwrap()
            })
            .collect();
        for w in times.windows(2) {
            assert!(
                (w[1] - w[0] - period.unwrap_or(1.0)).abs() < 1e-9,
                "{times:?}"
            );
        }
        // Read back: no odometry to agree with, and a 10 Hz-class stream
        // is chained on keyframes by its times.
        let back = tool(&["log", &log_name, "--size", "128", "--summary"]);
        assert!(back.status.success(), "{}", stderr(&back));
        let err = stderr(&back);
        assert!(!err.contains("odometry's turn"), "{err}");
        assert!(!err.contains("against the odometry"), "{err}");
        let chained_on = if period.is_some() {
            "keyframe"
        } else {
            "consecutive"
        };
        assert!(
            err.contains(&format!(" {chained_on} pairs (")),
            "{protocol}: {err}"
        );
    }
}

#[test]
fn a_failed_wire_leaves_no_output_file() {
    let empty = scratch("nothing.bin");
    std::fs::write(&empty, b"").unwrap();
    let log = scratch("nothing.log");
    let _ = std::fs::remove_file(&log);
    let out = tool(&[
        "wire",
        "--protocol",
        "ld06",
        &empty.display().to_string(),
        "--out",
        &log.display().to_string(),
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(!log.exists());
    let dir: Vec<_> = std::fs::read_dir(log.parent().unwrap())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("nothing.log"))
        .collect();
    assert!(dir.is_empty(), "{dir:?}");
}

#[test]
fn damaged_captures_are_counted_on_stderr() {
    let mut bytes = std::fs::read(capture("ld06.bin")).unwrap();
    // Packet 100's distance bytes (offset 10 in the packet), packet 200's
    // header, and a run of noise after packet 300.
    bytes[100 * 47 + 10] ^= 0x10;
    bytes[200 * 47] = 0x00;
    let noise: Vec<u8> = (0..500u32).map(|i| (i * 97 + 13) as u8).collect();
    bytes.splice(301 * 47..301 * 47, noise);
    let file = scratch("damaged-ld06.bin");
    std::fs::write(&file, &bytes).unwrap();
    let out = tool(
        &[
            &["log", &file.display().to_string(), "--format", "ld06"][..],
            &QUICK,
        ]
        .concat(),
    );
    assert!(out.status.success());
    assert_eq!(json_lines(&out).len(), 19);
    let err = stderr(&out);
    // 1231 intact packets less the two damaged ones.
    assert!(err.contains("ld06: 1229 packets"), "{err}");
    assert!(err.contains("dropped: 1 bad checksum"), "{err}");
}

#[test]
fn unusable_captures_are_errors() {
    let empty = scratch("empty.bin");
    std::fs::write(&empty, b"").unwrap();
    let name = empty.display().to_string();
    let out = tool(&["log", &name, "--format", "ydlidar", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no usable laser scan"),
        "{}",
        stderr(&out)
    );
    let out = tool(&["wire", "--protocol", "ld06", &name, "--out", "-"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no complete revolution"),
        "{}",
        stderr(&out)
    );
    let out = tool(&[
        "wire",
        "--protocol",
        "ld06",
        "/nonexistent/capture.bin",
        "--out",
        "-",
    ]);
    assert_eq!(out.status.code(), Some(2));
    let out = tool(&[
        "wire",
        "--protocol",
        "ld06",
        &capture("ld06.bin"),
        "--out",
        "-",
        "--max-range",
        "-1",
    ]);
    assert_eq!(out.status.code(), Some(2));
}

/// The bundled LD06 capture as an ESP32 logger prints it: one 47-byte
/// packet a line, upper-case hex bytes separated by spaces.
fn hex_text_capture(name: &str) -> PathBuf {
    let bytes = std::fs::read(capture("ld06.bin")).unwrap();
    let text: String = bytes
        .chunks(47)
        .map(|packet| {
            let hex: Vec<String> = packet.iter().map(|b| format!("{b:02X}")).collect();
            hex.join(" ") + "\r\n"
        })
        .collect();
    let file = scratch(name);
    std::fs::write(&file, text).unwrap();
    file
}

#[test]
fn hex_text_captures_are_read_as_the_bytes_they_spell() {
    let binary = capture("ld06.bin");
    let hex = hex_text_capture("ld06-hex.txt").display().to_string();
    let args = ["--format", "ld06", "--pairs", "consecutive"];
    let from_binary = tool(&[&["log", &binary][..], &args, &QUICK].concat());
    let from_hex = tool(&[&["log", &hex][..], &args, &QUICK].concat());
    assert!(from_hex.status.success(), "{}", stderr(&from_hex));
    assert_eq!(json_lines(&from_hex), json_lines(&from_binary));
    let err = stderr(&from_hex);
    assert!(
        err.contains("hex text, read as the bytes it spells"),
        "{err}"
    );
    assert!(
        err.contains("20 revolutions; dropped: 0 bad checksum"),
        "{err}"
    );
    // `wire` writes the same CARMEN log from either.
    let logs: Vec<Vec<u8>> = [&binary, &hex]
        .iter()
        .map(|file| {
            let out = tool(&["wire", "--protocol", "ld06", file, "--out", "-"]);
            assert!(out.status.success(), "{}", stderr(&out));
            out.stdout
        })
        .collect();
    // The header names the capture read; the lines after it are the same.
    let body = |log: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(log)
            .lines()
            .filter(|l| !l.starts_with('#'))
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(body(&logs[0]), body(&logs[1]));
    assert!(body(&logs[0]).iter().any(|l| l.starts_with("ROBOTLASER1")));
}

#[test]
fn a_damaged_hex_text_capture_reads_up_to_the_damage_and_says_where() {
    let file = hex_text_capture("ld06-hex-damaged.txt");
    let mut text = std::fs::read_to_string(&file).unwrap();
    // Line 901 (packet 900) gets a character that is not a hex digit.
    let at = text.match_indices('\n').nth(899).unwrap().0 + 4;
    text.replace_range(at..at + 1, "Q");
    std::fs::write(&file, text).unwrap();
    let out = tool(
        &[
            &["log", &file.display().to_string(), "--format", "ld06"][..],
            &["--pairs", "consecutive"],
            &QUICK,
        ]
        .concat(),
    );
    let err = stderr(&out);
    assert!(out.status.success(), "{err}");
    assert!(
        err.contains("read error: hex text, line 901: 'Q' is not a hex digit"),
        "{err}"
    );
    // Every packet before the damage is read (none after it), and the 900
    // of 1231 hold 14 whole revolutions of the 20: 13 consecutive pairs.
    assert!(err.contains("ld06: 900 packets"), "{err}");
    assert!(
        err.contains("14 revolutions; dropped: 0 bad checksum"),
        "{err}"
    );
    assert_eq!(json_lines(&out).len(), 13, "{err}");
}

#[test]
fn a_capture_without_its_format_is_refused_in_one_line_naming_it() {
    let hex = hex_text_capture("ld06-hex-unnamed.txt")
        .display()
        .to_string();
    for (file, what) in [(capture("ld06.bin"), "binary"), (hex, "hex text")] {
        let out = tool(&["log", &file, "-q"]);
        assert_eq!(out.status.code(), Some(2), "{file}");
        let err = stderr(&out);
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(err.contains(&format!("{what}, not a CARMEN log")), "{err}");
        assert!(err.contains("`--format ld06`"), "{err}");
    }
    // A CARMEN log given a capture's format is told so, not read as noise.
    let log = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/logs/seattle-excerpt.log");
    let out = tool(&["log", &log.display().to_string(), "--format", "ld06", "-q"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("text but not hex text, not a raw ld06 capture"),
        "{}",
        stderr(&out)
    );
}
