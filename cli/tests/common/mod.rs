//! What the tool's tests share: running the built binary, reading its
//! output, the bundled data and scratch places. Each test file takes what
//! it needs (`mod common;`), hence `dead_code` allowed.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use serde_json::Value;

/// The bundled data (`cli/data`).
pub fn data_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// The bundled recordings (`cli/data/logs`).
pub fn logs() -> PathBuf {
    data_dir().join("logs")
}

/// A bundled recording's path.
pub fn log_path(name: &str) -> String {
    logs().join(name).display().to_string()
}

/// Runs the built tool with `args`.
pub fn tool(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hough-heading"))
        .args(args)
        .output()
        .expect("the tool runs")
}

/// Its standard output, as text.
pub fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// Its standard error, as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Its standard output, one JSON value a line.
pub fn json_lines(o: &Output) -> Vec<Value> {
    stdout(o)
        .lines()
        .map(|l| serde_json::from_str(l).expect("a JSON line"))
        .collect()
}

/// A scratch directory for one test (created).
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hough-heading-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// A scratch file `name` among those of the tests `group` (its directory
/// created).
pub fn scratch_file(group: &str, name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(group);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir.join(name)
}

/// Whether the environment variable `CI` is set to something other than
/// empty, `0` or `false` (CI services set `CI=true`; `.ci/run` sets `CI=1`).
pub fn on_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim(), "" | "0" | "false"))
}

/// The path of `../shared/data/<name>` (next to the clone), or `None` after
/// printing `SKIPPED: …` to stderr when it is absent (a user's clone). On CI
/// ([`on_ci`]) the data must be there: a missing file fails the test.
pub fn shared_data(name: &str) -> Option<PathBuf> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../shared/data")
        .join(name);
    if path.exists() {
        return Some(path);
    }
    assert!(
        !on_ci(),
        "CI is set but the real data {} is absent: CI must run this test",
        path.display()
    );
    eprintln!(
        "SKIPPED: real-data test: {} is absent; set CI=1 to make this a failure",
        path.display()
    );
    None
}
