//! What the budget report and the real-scans measure share: the targets,
//! the configurations, the paths, the firmware builds, and the tables'
//! labels and numbers.

use std::path::PathBuf;
use std::process::Command;

use serde_json::Value;

use crate::Error;

/// A target the budgets cover.
pub struct Target {
    /// Rust target triple.
    pub triple: &'static str,
    /// Short name in the table.
    pub name: &'static str,
    /// The QEMU machine that runs it, if any (RISC-V is only built).
    pub machine: Option<&'static str>,
    /// RAM of that machine, bytes (for the "does not fit" note).
    pub ram: u64,
    /// The library's features its firmware is built with (`""`: the
    /// library's defaults).
    pub features: &'static str,
}

/// The `features` of a build without the library's default features, so
/// without the reach tables (`cargo build --no-default-features`).
pub const WITHOUT_TABLES: &str = "no-default-features";

/// The targets, in table order.
pub const TARGETS: [Target; 3] = [
    Target {
        triple: "thumbv7em-none-eabihf",
        name: "Cortex-M4F",
        machine: Some("mps2-an386"),
        ram: 4 << 20,
        features: "",
    },
    Target {
        triple: "thumbv6m-none-eabi",
        name: "Cortex-M0",
        machine: Some("microbit"),
        ram: 16 << 10,
        // 16 KiB: the references its benches build at run time cannot keep
        // their reach tables, as on a board with that little RAM.
        features: WITHOUT_TABLES,
    },
    Target {
        triple: "riscv32imac-unknown-none-elf",
        name: "RV32IMAC",
        machine: None,
        ram: 0,
        features: "",
    },
];

/// One configuration: image side and θ steps, with how `N_THETA` was chosen.
#[derive(Clone, Copy, Debug)]
pub struct Config {
    /// Image side (square images).
    pub side: usize,
    /// θ steps over the full circle.
    pub n_theta: usize,
    /// `"360"`, or the paper's range: `"min"` / `"max"`.
    pub choice: &'static str,
    /// Library features the bench is built with (`""`: the default).
    pub features: &'static str,
}

impl Config {
    /// The configuration as `target` builds it: with the target's own
    /// features where it asks for the defaults.
    pub fn on(self, target: &Target) -> Self {
        match self.features {
            "" => Self {
                features: target.features,
                ..self
            },
            _ => self,
        }
    }

    /// The key in the budget file.
    pub fn key(&self) -> String {
        format!(
            "{0}x{0}/{1}{2}",
            self.side,
            self.n_theta,
            suffix(self.features)
        )
    }

    /// The grid cell of the tables: the side, and the features if any.
    pub fn grid(&self) -> String {
        labelled(format!("{}²", self.side), self.features)
    }
}

/// A table's label followed by the features, if any.
pub fn labelled(label: String, features: &str) -> String {
    match features {
        "" => label,
        features => format!("{label}, {features}"),
    }
}

/// The key suffix of a feature set: `""`, or `+features`.
pub fn suffix(features: &str) -> String {
    match features {
        "" => String::new(),
        features => format!("+{features}"),
    }
}

/// Paths the report uses.
pub struct Paths {
    /// Repository root (where `Cargo.toml` is).
    pub root: PathBuf,
    /// The built `qemu-icount` plugin.
    pub plugin: PathBuf,
}

/// Builds `example` for `target` (the bench with `config`'s environment)
/// with the library's `features` and returns a copy of its ELF under
/// `target/budgets/`.
pub fn build_example(
    paths: &Paths,
    target: &Target,
    example: &str,
    config: Option<&Config>,
    features: &str,
) -> Result<PathBuf, Error> {
    let mut command = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    command
        .current_dir(&paths.root)
        .args([
            "build",
            "-q",
            "--release",
            // The firmware's features only: the workspace's host crates
            // would switch on `std` features of shared dependencies.
            "-p",
            "hough-heading",
            "--example",
            example,
            "--message-format=json",
        ])
        .args(["--target", target.triple]);
    match features {
        "" => {}
        WITHOUT_TABLES => {
            command.arg("--no-default-features");
        }
        features => {
            command.args(["--features", features]);
        }
    }
    let name = match config {
        _ if example != "bench" => format!("{example}{}.elf", suffix(features)),
        Some(c) => {
            command
                .env("HH_BENCH_SIDE", c.side.to_string())
                .env("HH_BENCH_N_THETA", c.n_theta.to_string())
                .env("HH_BENCH_BASELINE", "0");
            format!("bench-{}-{}{}.elf", c.side, c.n_theta, suffix(features))
        }
        None => {
            command.env("HH_BENCH_BASELINE", "1");
            "bench-baseline.elf".into()
        }
    };
    let output = command.output().map_err(|e| format!("run cargo: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "cargo build of {example} for {} failed:\n{}",
            target.triple,
            String::from_utf8_lossy(&output.stderr)
        )
        .into());
    }
    let executable = String::from_utf8_lossy(&output.stdout)
        .lines()
        .filter_map(|line| serde_json::from_str::<Value>(line).ok())
        .filter(|m| m["reason"] == "compiler-artifact" && m["target"]["name"] == example)
        .find_map(|m| m["executable"].as_str().map(PathBuf::from))
        .ok_or_else(|| format!("cargo reported no {example} executable"))?;
    let dir = paths.root.join("target/budgets").join(target.triple);
    std::fs::create_dir_all(&dir).map_err(|e| format!("create {}: {e}", dir.display()))?;
    let copy = dir.join(name);
    std::fs::copy(&executable, &copy).map_err(|e| format!("copy {}: {e}", executable.display()))?;
    Ok(copy)
}

/// Thousands separated by thin spaces.
pub fn group(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push('\u{202f}');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::group;

    #[test]
    fn groups_thousands() {
        assert_eq!(group(1234567), "1\u{202f}234\u{202f}567");
        assert_eq!(group(12), "12");
    }
}
