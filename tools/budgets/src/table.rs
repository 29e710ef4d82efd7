//! The Markdown tables of the bench rows (`examples/bench.rs`): the budget
//! table and the verification's share; and the table layout every table of
//! the report uses (the real-scan and lidar rows render in `real.rs` and
//! `lidar.rs`).

use std::fmt::Write as _;

use serde_json::{Map, Value};

use crate::firmware::{group, Config, Target};

/// One row of the budget table.
pub fn row(target: &Target, config: &Config, v: &Map<String, Value>) -> Vec<String> {
    let int = |k: &str| v.get(k).and_then(Value::as_u64);
    let bytes = |k: &str| int(k).map_or("–".into(), |n| format!("{n} B"));
    let count = |k: &str| int(k).map_or("–".into(), group);
    let ratio = |k: &str| {
        v.get(k)
            .and_then(Value::as_f64)
            .map_or("–".into(), |r| format!("{r:.2}"))
    };
    let n = match config.choice {
        "360" => "360".to_string(),
        choice => format!("{} ({choice})", config.n_theta),
    };
    let mut cells = vec![target.name.to_string(), config.grid(), n];
    if v.get("fits") == Some(&Value::Bool(false)) {
        let state = int("state").unwrap_or(0);
        let note = format!(
            "does not fit: state {state} B + stack > {} KiB RAM",
            target.ram >> 10
        );
        cells.extend([note, "".into(), "".into(), "".into(), "".into(), "".into()]);
    } else {
        // The estimate's peak stack, and how much more the scale search
        // needs.
        let ram = match (int("state"), int("stack_estimate")) {
            (Some(state), Some(stack)) => {
                let extra = int("stack_scaled").map_or(0, |s| s.saturating_sub(stack));
                format!(
                    "{} B ({state} + {stack}; scale search +{extra})",
                    state + stack
                )
            }
            _ => "–".into(),
        };
        cells.extend([
            count("instructions_estimate"),
            ratio("instructions_per_vote"),
            ratio("vote_loop_per_vote"),
            count("instructions_reference"),
            count("instructions_scale_search"),
            ram,
        ]);
    }
    cells.extend([count("votes"), bytes("static_ram"), bytes("flash_library")]);
    cells
}

/// One row of the verification table: the estimate with and without the
/// verification by alignment, and the difference.
pub fn verification_row(target: &Target, config: &Config, v: &Map<String, Value>) -> Vec<String> {
    let int = |k: &str| v.get(k).and_then(Value::as_u64);
    let count = |k: &str| int(k).map_or("–".into(), group);
    let n = match config.choice {
        "360" => "360".to_string(),
        choice => format!("{} ({choice})", config.n_theta),
    };
    let mut cells = vec![target.name.to_string(), config.grid(), n];
    if v.get("fits") == Some(&Value::Bool(false)) {
        let state = int("state").unwrap_or(0);
        cells.push(format!(
            "does not fit: state {state} B (verification {} B) + stack > {} KiB RAM",
            int("state_verification").unwrap_or(0),
            target.ram >> 10
        ));
        cells.extend(std::iter::repeat_n(
            String::new(),
            VERIFICATION_HEADER.len() - 4,
        ));
        return cells;
    }
    let pair = |a: &str, b: &str| match (int(a), int(b)) {
        (Some(a), Some(b)) => format!("{a} B / {b} B"),
        _ => "–".into(),
    };
    let state = match (int("state_verification"), int("state")) {
        (Some(part), Some(state)) => format!("{part} B (of {state} B)"),
        _ => "–".into(),
    };
    let ram = match (int("ram_verification"), int("state_verification")) {
        (Some(ram), Some(state)) => format!("{ram} B ({state} + {})", ram - state),
        _ => "–".into(),
    };
    let overlap =
        int("overlap_permille").map_or("–".into(), |p| format!("{}.{} %", p / 10, p % 10));
    cells.extend([
        count("instructions_estimate"),
        count("instructions_unverified"),
        count("instructions_verification"),
        pair("stack_estimate", "stack_unverified"),
        state,
        ram,
        overlap,
        match (int("ram_flash_reference"), int("stack_unverified")) {
            (Some(ram), Some(stack)) => format!("{ram} B ({} + {stack})", ram - stack),
            _ => "–".into(),
        },
        match (int("ram_verified_flash_reference"), int("stack_estimate")) {
            (Some(ram), Some(stack)) => format!("{ram} B ({} + {stack})", ram - stack),
            _ => "–".into(),
        },
        v.get("instructions_per_budget_row")
            .and_then(Value::as_f64)
            .map_or("–".into(), |c| format!("{c:.2}")),
        match (int("instructions_cut_large"), int("budget_rows_cut_large")) {
            (Some(count), Some(rows)) => format!("{} ({} rows)", group(count), group(rows)),
            _ => "–".into(),
        },
    ]);
    cells
}

/// Columns of the budget table.
pub const HEADER: [&str; 12] = [
    "target",
    "grid",
    "N_θ",
    "instr. / estimate",
    "instr. / vote",
    "vote loop instr. / vote",
    "instr. / reference",
    "scale search, extra instr.",
    "estimator RAM (state + stack)",
    "votes",
    "static RAM",
    "library flash",
];

/// Columns of the verification table.
pub const VERIFICATION_HEADER: [&str; 14] = [
    "target",
    "grid",
    "N_θ",
    "instr. / estimate, verification on",
    "verification off",
    "verification, extra instr.",
    "peak stack on / off",
    "verification state (reference grid)",
    "verification, extra RAM (state + stack)",
    "overlap",
    "verification off, reference in flash: RAM (estimator + stack)",
    "verified, reference in flash (grid too): RAM (estimator + stack)",
    "searches, instr. per budget row",
    "estimate cut by the larger work budget",
];

/// A Markdown table.
pub fn markdown(header: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = String::new();
    let _ = writeln!(out, "| {} |", header.join(" | "));
    let _ = writeln!(out, "|{}", "---|".repeat(header.len()));
    for r in rows {
        let _ = writeln!(out, "| {} |", r.join(" | "));
    }
    out
}
