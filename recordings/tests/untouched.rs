//! Reading a recording leaves it as it was: after `open_recording` has read
//! every event of a copy of each bundled recording (a ROS 2 bag directory
//! in SQLite and in MCAP, a ROS 1 bag, a gzip CARMEN log), the copy's
//! directory lists the same files with the same bytes; and the same with
//! the copy made read-only (SQLite opened without `immutable` writes its
//! `-shm` and `-wal` files beside the database, and fails to open it where
//! it cannot).

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use hough_heading_recordings::{open_recording, Format, Opened, Source};
use indicatif::ProgressBar;

/// The bundled recordings (`cli/data/logs`, by relative path).
fn logs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../cli/data/logs")
}

/// Every file under `dir`, by its path relative to `dir`, with its bytes.
fn snapshot(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut pending = vec![dir.to_path_buf()];
    while let Some(d) = pending.pop() {
        for entry in fs::read_dir(&d).expect("a listing") {
            let path = entry.expect("an entry").path();
            if path.is_dir() {
                pending.push(path);
            } else {
                let bytes = fs::read(&path).expect("a file");
                out.insert(path.strip_prefix(dir).unwrap().to_path_buf(), bytes);
            }
        }
    }
    out
}

/// Sets `dir` and everything in it read-only (or writable again).
fn set_read_only(dir: &Path, read_only: bool) {
    for path in fs::read_dir(dir)
        .expect("a listing")
        .map(|e| e.unwrap().path())
    {
        let mut p = fs::metadata(&path).unwrap().permissions();
        p.set_readonly(read_only);
        fs::set_permissions(&path, p).unwrap();
    }
    let mut p = fs::metadata(dir).unwrap().permissions();
    p.set_readonly(read_only);
    fs::set_permissions(dir, p).unwrap();
}

/// The scans of `file` as the tool reads them (every event read).
fn scans(file: &Path) -> usize {
    let source = Source {
        file: file.to_path_buf(),
        format: Format::Auto,
        topic: Some("/scan".into()),
        odom_topic: None,
        max_range: 50.0,
        laser_offset: None,
    };
    let Opened::Recording(recording) = open_recording(&source, &ProgressBar::hidden())
        .unwrap_or_else(|e| panic!("{}: {e}", file.display()))
    else {
        panic!("not a capture")
    };
    let mut scans = 0;
    for event in recording.events {
        let event = event.expect("no fatal error").expect("no failed record");
        scans += usize::from(matches!(event, hough_heading_recordings::Event::Scan(_)));
    }
    scans
}

#[test]
fn reading_leaves_the_recording_as_it_was() {
    let scratch = Path::new(env!("CARGO_TARGET_TMPDIR")).join("untouched");
    for (name, expected_scans) in [
        ("seattle-bag-db3", 12),
        // The same in write-ahead-log mode, as rosbag2 writes its bags
        // (the mode that makes a plain read-only SQLite reader write).
        ("seattle-bag-db3 (WAL)", 12),
        ("seattle-bag-dir", 12),
        ("seattle-bag.bag", 12),
        ("seattle-excerpt.log.gz", 20),
    ] {
        for read_only in [false, true] {
            let dir = scratch.join(format!("{name}-{read_only}").replace([' ', '(', ')'], ""));
            if dir.exists() {
                set_read_only(&dir, false);
                fs::remove_dir_all(&dir).unwrap();
            }
            fs::create_dir_all(&dir).unwrap();
            let wal = name.strip_suffix(" (WAL)");
            let name = wal.unwrap_or(name);
            let source = logs().join(name);
            let copy = dir.join(name);
            if source.is_dir() {
                fs::create_dir(&copy).unwrap();
                for entry in fs::read_dir(&source).unwrap() {
                    let path = entry.unwrap().path();
                    fs::copy(&path, copy.join(path.file_name().unwrap())).unwrap();
                }
            } else {
                fs::copy(&source, &copy).unwrap();
            }
            if wal.is_some() {
                let db = rusqlite::Connection::open(copy.join("seattle-bag-db3.db3")).unwrap();
                let mode: String = db
                    .query_row("PRAGMA journal_mode=WAL", [], |r| r.get(0))
                    .unwrap();
                assert_eq!(mode, "wal");
            }
            if read_only {
                if copy.is_dir() {
                    set_read_only(&copy, true);
                }
                set_read_only(&dir, true);
            }
            let before = snapshot(&dir);
            let read = scans(&copy);
            let after = snapshot(&dir);
            set_read_only(&dir, false);
            if copy.is_dir() {
                set_read_only(&copy, false);
            }
            assert_eq!(read, expected_scans, "{name}");
            assert_eq!(
                before.keys().collect::<Vec<_>>(),
                after.keys().collect::<Vec<_>>(),
                "{name} (read-only: {read_only}): the listing changed"
            );
            assert!(
                before == after,
                "{name} (read-only: {read_only}): bytes changed"
            );
        }
    }
}
