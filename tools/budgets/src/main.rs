//! `budgets`: the firmware side of hough-heading's CI.
//!
//! ```text
//! budgets run --machine MACHINE [--timeout SECONDS] ELF
//! budgets report [--check] [--only SIDExSIDE/N|real-scans/…|lidar] [--root DIR] [--plugin LIB]
//! budgets profile --machine MACHINE [--region NAME] [--minus NAME] [--cycle N [--floats]] [--top N] [--root DIR] [--plugin LIB] ELF
//! budgets floats [--root DIR] [--target-dir DIR] TRIPLE...
//! ```
//!
//! `run` starts a firmware ELF on a `qemu-system-arm` machine with semihosting,
//! prints its `defmt` log decoded with the ELF's table (what `defmt-print -e ELF`
//! does) and QEMU's standard error, and exits with the firmware's exit status
//! (124 on timeout).
//!
//! `report` builds `examples/bench.rs` for every target and configuration
//! (and `examples/real_scans.rs`, run on the bundled real scan pairs: see
//! `real.rs`; and `examples/lidar_bench.rs`, the lidar drivers over their
//! captures: see `lidar.rs`),
//! runs it under QEMU with the `qemu-icount` plugin, prints the budget table
//! and writes `budgets/budgets.json` and `budgets/TABLE.md`, and the table
//! into `README.md` between `<!-- budgets:start -->` and
//! `<!-- budgets:end -->` when both markers are there. With `--only KEY` it
//! measures one entry (`128x128/360`, `real-scans/128x128/360`, or `lidar`
//! for the lidar rows) and prints it, writing nothing in `budgets/` (its
//! values go to `target/budgets/measured.json`). With `--check` it
//! writes nothing in `budgets/` (the measurement goes to
//! `target/budgets/measured.json`) and fails when a value grew by more than
//! 10 % over `budgets/budgets.json` or a metric of `budgets/budgets.json` is
//! missing from the measurement. Both fail on a wrong estimate, and when a
//! bench ELF (the estimator without the rasterizer) links a software
//! floating-point routine (`elf::is_float_routine`): the estimate is
//! integer-only on every core.
//! `bash tools/budgets.sh` builds the tools and runs `report`.
//!
//! `profile` runs a bench ELF (as `report` leaves them in
//! `target/budgets/<triple>/bench-<side>-<n>.elf`) with the plugin's flat
//! profile and prints where the instructions of one region (default
//! `estimate`) go, optionally minus another region, by function, inlined
//! function, library source line and calls (see `profile.rs`). E.g. the
//! verification's cost: `--region estimate --minus unverified`. With
//! `--cycle N` the regions are numbered, not named: `--region K` sums region
//! `K` of every round of `N` after the overhead (the real-scan firmware
//! measures 7 a pair: `--cycle 7 --region 4` is the estimate, 5 the check on
//! the beams). `--cycle N --floats` prints instead, for every region of the
//! round, its instructions and those inside the software floating-point
//! routines (`tools/float_cost.sh`).
//!
//! `floats` reads every firmware example's release ELF for each target
//! triple given and fails when one links a software floating-point routine
//! beyond the class the README's allow-list gives it (`floats.rs`).

mod elf;
mod firmware;
mod floats;
mod lidar;
mod profile;
mod qemu;
mod real;
mod report;
mod table;

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use serde_json::{json, Value};

/// Errors are reported as text.
pub type Error = Box<dyn std::error::Error>;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("run") => run(&args[1..]),
        Some("report") => report(&args[1..]),
        Some("profile") => profile(&args[1..]),
        Some("floats") => floats(&args[1..]),
        _ => Err(
            "usage: budgets run --machine M [--timeout S] ELF | budgets report [--check] [--only SIDExSIDE/N|lidar] \
             | budgets profile --machine M [--region NAME] [--minus NAME] [--top N] ELF \
             | budgets floats [--root DIR] [--target-dir DIR] TRIPLE..."
                .into(),
        ),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("budgets: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The value following `--name` in `args`, if present.
fn option<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
}

/// `budgets run`.
fn run(args: &[String]) -> Result<ExitCode, Error> {
    let machine = option(args, "--machine").ok_or("--machine is required")?;
    let timeout = option(args, "--timeout").map_or(Ok(30), str::parse)?;
    let elf = args
        .last()
        .filter(|a| !a.starts_with("--"))
        .ok_or("ELF path missing")?;
    let outcome = qemu::run(Path::new(elf), machine, None, Duration::from_secs(timeout))?;
    for line in &outcome.log {
        println!("  {line}");
    }
    eprint!("{}", outcome.stderr);
    Ok(match outcome.status {
        _ if outcome.timed_out => {
            eprintln!("budgets: {elf} timed out after {timeout} s");
            ExitCode::from(124)
        }
        Some(0) => ExitCode::SUCCESS,
        Some(code) => {
            eprintln!("budgets: {elf} exited with status {code}");
            ExitCode::from(u8::try_from(code).unwrap_or(1).max(1))
        }
        None => ExitCode::FAILURE,
    })
}

/// `budgets profile --machine M [--region NAME] [--minus NAME] [--top N] ELF`.
fn profile(args: &[String]) -> Result<ExitCode, Error> {
    let machine = option(args, "--machine").ok_or("--machine is required")?;
    let elf = args
        .last()
        .filter(|a| !a.starts_with("--"))
        .ok_or("ELF path missing")?;
    let root = PathBuf::from(option(args, "--root").unwrap_or("."));
    let root = root.canonicalize().unwrap_or(root);
    let plugin = option(args, "--plugin")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/tools/debug/libqemu_icount.so"));
    if !plugin.exists() {
        return Err(format!("plugin {} not built", plugin.display()).into());
    }
    profile::run(&profile::Request {
        elf: Path::new(elf),
        machine,
        plugin,
        region: option(args, "--region").unwrap_or("estimate"),
        minus: option(args, "--minus"),
        cycle: option(args, "--cycle").map(str::parse).transpose()?,
        top: option(args, "--top").map_or(Ok(25), str::parse)?,
        scratch: root.join("target/budgets"),
        root: root.clone(),
        floats: args.iter().any(|a| a == "--floats"),
    })?;
    Ok(ExitCode::SUCCESS)
}

/// `budgets floats [--root DIR] [--target-dir DIR] TRIPLE...`: every
/// firmware example's software floating point (release builds under
/// `--target-dir`, default `<root>/target`) against the README's allow-list
/// (`floats.rs`); fails when one links more than its class.
fn floats(args: &[String]) -> Result<ExitCode, Error> {
    let root = PathBuf::from(option(args, "--root").unwrap_or("."));
    let target_dir =
        option(args, "--target-dir").map_or_else(|| root.join("target"), PathBuf::from);
    let mut triples = Vec::new();
    let mut rest = args.iter();
    while let Some(arg) = rest.next() {
        match arg.as_str() {
            "--root" | "--target-dir" => {
                rest.next();
            }
            triple => triples.push(triple),
        }
    }
    if triples.is_empty() {
        return Err("floats: no target triple given".into());
    }
    let ok = floats::check(
        &root.join("README.md"),
        &root.join("examples"),
        &target_dir,
        &triples,
    )?;
    Ok(if ok {
        ExitCode::SUCCESS
    } else {
        eprintln!(
            "budgets: a firmware example links floating point its README class does not allow"
        );
        ExitCode::FAILURE
    })
}

/// `budgets report [--check] [--only SIDExSIDE/N|real-scans/…|lidar]`.
fn report(args: &[String]) -> Result<ExitCode, Error> {
    let check = args.iter().any(|a| a == "--check");
    let only = option(args, "--only");
    let root = PathBuf::from(option(args, "--root").unwrap_or("."));
    let plugin = option(args, "--plugin")
        .map(PathBuf::from)
        .unwrap_or_else(|| root.join("target/tools/debug/libqemu_icount.so"));
    if !plugin.exists() {
        return Err(format!("plugin {} not built", plugin.display()).into());
    }
    let paths = firmware::Paths {
        root: root.clone(),
        plugin,
    };
    let measured = report::measure(&paths, only)?;
    let body = json!({
        "generated_by": "bash tools/budgets.sh",
        "tolerance": report::TOLERANCE,
        "units": "instructions: guest instructions counted by the qemu-icount plugin; \
                  per vote: divided by occupied cells × N_THETA/2; lidar per packet, per point: \
                  divided by the capture's packets, points; bytes otherwise",
        "toolchain": command_line("rustc", &["--version"]),
        "qemu": command_line("qemu-system-arm", &["--version"]),
        "targets": measured.targets,
    });
    println!("{}", measured.table);

    let budget_path = root.join("budgets/budgets.json");
    let mut failed = false;
    if only.is_some() || check {
        write(&root.join("target/budgets/measured.json"), &pretty(&body)?)?;
    }
    if only.is_some() {
        eprintln!(
            "budgets: --only measures one entry; nothing written in budgets/ or checked \
             (its values: target/budgets/measured.json)"
        );
    } else if check {
        let text = std::fs::read_to_string(&budget_path)
            .map_err(|e| format!("read {}: {e}", budget_path.display()))?;
        let budget: Value = serde_json::from_str(&text)?;
        let now = body["targets"].as_object().ok_or("no targets measured")?;
        let regressions = report::check(&budget, now);
        for r in &regressions {
            eprintln!("budgets: REGRESSION {r}");
        }
        if regressions.is_empty() {
            eprintln!(
                "budgets: every budget within {:.0} %",
                report::TOLERANCE * 100.0
            );
        }
        failed |= !regressions.is_empty();
    } else {
        write(&budget_path, &pretty(&body)?)?;
        write(&root.join("budgets/TABLE.md"), &table_page(&measured.table))?;
        eprintln!("budgets: wrote budgets/budgets.json and budgets/TABLE.md");
        update_readme(&root.join("README.md"), &measured.table)?;
    }
    for f in &measured.failures {
        eprintln!("budgets: FAILED {f}");
    }
    failed |= !measured.failures.is_empty();
    Ok(if failed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// The first line a command prints, or `"unknown"`.
fn command_line(program: &str, args: &[&str]) -> String {
    std::process::Command::new(program)
        .args(args)
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.lines().next().map(str::to_owned))
        .unwrap_or_else(|| "unknown".into())
}

fn pretty(value: &Value) -> Result<String, Error> {
    Ok(serde_json::to_string_pretty(value)? + "\n")
}

fn write(path: &Path, text: &str) -> Result<(), Error> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir)?;
    }
    std::fs::write(path, text).map_err(|e| format!("write {}: {e}", path.display()).into())
}

/// Markers around the budget table in `README.md`.
const README_MARKERS: (&str, &str) = ("<!-- budgets:start -->", "<!-- budgets:end -->");

/// Replaces the text between [`README_MARKERS`] in the README with `table`,
/// when the README has both markers.
fn update_readme(path: &Path, table: &str) -> Result<(), Error> {
    let Ok(text) = std::fs::read_to_string(path) else {
        return Ok(());
    };
    let (start, end) = README_MARKERS;
    let (Some(a), Some(b)) = (text.find(start), text.find(end)) else {
        eprintln!("budgets: README.md has no {start} … {end} markers; table not copied there");
        return Ok(());
    };
    if b < a {
        return Err("README.md: budgets markers out of order".into());
    }
    let updated = format!("{}{start}\n{table}{}", &text[..a], &text[b..]);
    if updated != text {
        write(path, &updated)?;
        eprintln!("budgets: updated the table in README.md");
    }
    Ok(())
}

/// `budgets/TABLE.md`: the tables with how they were made.
fn table_page(table: &str) -> String {
    format!(
        "# Firmware budgets\n\n\
         Regenerate with `bash tools/budgets.sh` (CI runs `bash tools/budgets.sh --check`, which fails \
         when a value grows by more than 10 % over `budgets/budgets.json`).\n\n\
         {table}\n\
         - Scene: two room outlines (`examples/support/room.rs`) in flash, the second turned by 30° and \
         shifted; `Mode::Improved`. Every estimate above was checked against the 30° (±1°), with and \
         without the verification, and the verified one was checked to carry an overlap and an \
         alignment on every candidate.\n\
         - *instr. / estimate*: guest instructions of `Estimator::estimate` against a prepared reference, \
         as built (`Mode::Improved`: with the verification by alignment), \
         counted exactly by the `qemu-icount` TCG plugin (`tools/qemu-icount`) between two marker \
         functions, minus the markers' own cost. *instr. / vote*: that divided by the votes (occupied \
         cells × N_θ/2). *vote loop*: the estimator's vote primitive alone (`vote_column_pair` over \
         θ ∈ [0, π), no column reductions). *instr. / reference*: \
         `Estimator::reference`. The estimate includes the translation (the column shifts come from \
         the direction test's profile matches, then `fit_translation`; with the verification, the \
         aligned pose). *scale search, extra instr.*: \
         the same estimate with `with_scale_search(ScaleRange::DEFAULT)` (verified as well) minus \
         *instr. / estimate* (its scale is checked to be 1 ± 3 %).\n\
         - *estimator RAM*: `size_of` the estimator and the reference, plus the peak stack of the \
         estimate call (and how much more the estimate with the scale search needs): the lowest \
         stack address written during it (the plugin watches every store), below the \
         stack pointer at the call. The grids are not counted (they are inputs, here in flash).\n\
         - Verification table: the same estimate with the verification (the default) and with \
         `with_verification(false)`; *extra instr.* is the difference. *verification state*: the \
         grid the reference keeps (`size_of` a grid), part of the reference whether the \
         verification runs or not (the verification builds its pyramid, `4 · pyramid_words(W, H)` \
         bytes, on its own stack). *extra RAM*: that state plus the verified estimate's peak stack \
         minus the unverified one's. *overlap*: `Estimate::overlap` of the verified estimate. \
         *reference in flash*: without the verification and with the reference a `static` parsed \
         at compile time (`Reference::from_bytes` is a `const fn`; `examples/robot_loop.rs` runs \
         so), the RAM is `size_of` the estimator plus the unverified estimate's peak stack; \
         *verified, reference in flash*: the same with the verification, whose pyramid is on the \
         stack and which reads the reference's grid where it lies: `size_of` the estimator plus \
         the verified estimate's peak stack (`ram_verified_flash_reference`).\n\
         - *static RAM*: `.data + .bss` of the whole firmware (logger, runtime); the library has none. \
         *library flash*: flash of the firmware minus the same firmware built without calling the \
         library (`HH_BENCH_BASELINE=1`) minus the two grids.\n\
         - Real-scan table: `examples/real_scans.rs` on the 120 real scan pairs of \
         `host-tests/data/real-pairs.bin` (FLIRT fr079, 360 beams, and Intel, 180 beams), at 128², \
         N_θ = 360, as `hough-heading scans --size 128` does (window = p90 of the ranges, segments \
         up to 0.3 m, verification on); `.ci/firmware.sh` checks that every result is the host's, \
         bit for bit (`hough-heading mcu check`). *instr. / pair*: the window (`Raster::auto` over \
         both scans), rasterizing both scans, the reference and the estimate. *rasterize*: \
         `Raster::rasterize` of one scan (fixed point: a table sine and cosine and integer \
         products per beam, segments between neighbours), per beam and per scan. *RAM*: `.data + .bss` plus the lowest stack \
         address written in any measured region below the top of the stack (estimator, reference, \
         one grid, the ranges while a scan is read: all on the stack).\n\
         {lidar}\
         - Cortex-M4F runs on QEMU `mps2-an386`, Cortex-M0 on `microbit` (16 KiB RAM); RISC-V is only \
         built (sizes). Release profile: `opt-level = 3`, LTO, one codegen unit. The library's \
         default features (the reach tables) except where a row says `no-default-features`: every \
         Cortex-M0 row (its benches build the reference in RAM, where 16 KiB cannot hold the \
         tables) and one Cortex-M4F row of each table, to show what the tables save.\n",
        lidar = lidar::NOTE
    )
}
