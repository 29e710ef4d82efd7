//! The `accuracy` evaluation prints the same report, byte for byte, on one
//! thread and on several (issue 24 item 4): each trial is seeded by its row
//! and index, and the results are gathered in index order. A small
//! configuration of the `--quick` run (fewer trials, the translation
//! experiment included) keeps the test short; three threads on a 2-core
//! machine are fine, the point is the order.

use std::process::{Command, Output};

fn accuracy(args: &[&str]) -> Output {
    let o = Command::new(env!("CARGO_BIN_EXE_accuracy"))
        .args(args)
        .output()
        .expect("run accuracy");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

#[test]
fn the_report_is_the_same_on_any_number_of_threads() {
    let out = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("accuracy-jobs.md");
    let common = ["--quick", "--trials", "12", "--experiments"];
    let one = accuracy(&[&common[..], &["--jobs", "1"]].concat());
    let out_arg = out.display().to_string();
    let three = accuracy(&[&common[..], &["--jobs", "3", "--out", &out_arg]].concat());
    let report = String::from_utf8_lossy(&one.stdout);
    assert!(report.contains("### Accuracy"), "{report}");
    assert!(report.ends_with("12 trials per row.\n"), "{report}");
    assert!(
        one.stdout == three.stdout,
        "the reports differ:\n--- --jobs 1\n{report}\n--- --jobs 3\n{}",
        String::from_utf8_lossy(&three.stdout)
    );
    assert_eq!(std::fs::read(&out).expect("--out file"), three.stdout);
    // The former option name still works; the threads are named on stderr.
    let old = accuracy(&[&common[..], &["--threads", "2", "--only", "polygon 64"]].concat());
    assert!(
        String::from_utf8_lossy(&old.stderr).contains("2 threads"),
        "{}",
        String::from_utf8_lossy(&old.stderr)
    );
}
