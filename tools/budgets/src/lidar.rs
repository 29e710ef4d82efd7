//! The lidar rows of the budget report (issue 25): `examples/lidar_bench.rs`
//! over the four captures of `lidar/tests/data/`, under QEMU with the
//! `qemu-icount` plugin.
//!
//! The firmware measures, after one empty region (the markers' overhead),
//! two regions per capture: the parser over every byte (each point
//! decoded), then a `Lidar` (parser and 720-beam assembler) over every
//! byte. Its log gives each capture's counts and the types' sizes:
//!
//! ```text
//! ld06: 57857 bytes, 1231 packets, 14772 points, 20 revolutions, 0 dropped, parser 88 B, lidar 3752 B
//! assembler 3656 B (720 beams)
//! ```

use serde_json::{json, Map, Value};

use crate::firmware::{build_example, group, Paths, Target};
use crate::qemu::{self, number, Plugin};
use crate::{elf, Error};

/// What `--only` takes to measure just the lidar rows.
pub const ONLY: &str = "lidar";

/// Key of a protocol's entry in the budget file.
pub fn key(protocol: &str) -> String {
    format!("{ONLY}/{protocol}")
}

/// The lidar metrics `--check` compares (all "smaller is better"): the
/// instructions per packet and per point, and the RAM of each type.
pub const CHECKED: [&str; 7] = [
    "instructions_parser_per_packet",
    "instructions_parser_per_point",
    "instructions_lidar_per_packet",
    "instructions_lidar_per_point",
    "ram_parser",
    "ram_lidar",
    "ram_assembler",
];

/// Time limit of the run (a few seconds on either core with the plugin).
const TIMEOUT: std::time::Duration = std::time::Duration::from_secs(120);

/// The counts and sizes of one capture's log line (`ld06: 57857 bytes, …,
/// parser 88 B, lidar 3752 B`): the protocol and, by name, `bytes`,
/// `packets`, `points`, `revolutions`, `dropped`, `parser`, `lidar`.
fn capture(line: &str) -> Option<(&str, Map<String, Value>)> {
    let (protocol, rest) = line.split_once(": ")?;
    let mut values = Map::new();
    for part in rest.split(", ") {
        let words: Vec<&str> = part.split_whitespace().collect();
        let (name, n) = match words[..] {
            [n, name] => (name, n),
            [name, n, "B"] => (name, n),
            _ => return None,
        };
        values.insert(name.into(), json!(number(n)?));
    }
    values.contains_key("packets").then_some((protocol, values))
}

/// The entries of one run: per protocol, its key and budget values.
pub type Entries = Vec<(String, Map<String, Value>)>;

/// Builds and runs the lidar bench on `target`: its entries, or why the run
/// failed.
pub fn measure(paths: &Paths, target: &Target) -> Result<Result<Entries, String>, Error> {
    let machine = target.machine.ok_or("not runnable")?;
    let path = build_example(paths, target, "lidar_bench", None, target.features)?;
    let image = elf::read(&path)?;
    let plugin = Plugin::for_image(paths.plugin.clone(), &image, None)?;
    let run = qemu::run(&path, machine, Some(&plugin), TIMEOUT)?;
    let counts: Vec<u64> = run
        .stderr
        .lines()
        .filter_map(|l| l.strip_prefix("hh-icount "))
        .map(|rest| rest.split_whitespace().next().and_then(number).unwrap_or(0))
        .collect();
    let captures: Vec<(&str, Map<String, Value>)> =
        run.log.iter().filter_map(|l| capture(l)).collect();
    let assembler = run
        .log
        .iter()
        .filter_map(|l| l.strip_prefix("assembler "))
        .find_map(|l| l.split_whitespace().next().and_then(number));
    let complete =
        run.status == Some(0) && !captures.is_empty() && counts.len() == 1 + 2 * captures.len();
    let Some(assembler) = assembler.filter(|_| complete) else {
        return Ok(Err(format!(
            "lidar_bench exited with {:?} (timed out: {}; it fails on a dropped packet or a \
             skipped byte), {} counts for {} captures:\n{}\n{}",
            run.status,
            run.timed_out,
            counts.len(),
            captures.len(),
            run.log.join("\n"),
            run.stderr
        )));
    };
    let net = |i: usize| counts[i].saturating_sub(counts[0]);
    let mut entries = Vec::new();
    for (i, (protocol, logged)) in captures.into_iter().enumerate() {
        let int = |k: &str| logged.get(k).and_then(Value::as_u64).unwrap_or(0);
        let (packets, points) = (int("packets"), int("points"));
        let (parser, lidar) = (net(1 + 2 * i), net(2 + 2 * i));
        let per = |n: u64, d: u64| (n as f64 / d.max(1) as f64 * 100.0).round() / 100.0;
        let mut values = Map::new();
        for k in ["bytes", "packets", "points", "revolutions"] {
            values.insert(k.into(), json!(int(k)));
        }
        values.insert("instructions_parser".into(), json!(parser));
        values.insert("instructions_lidar".into(), json!(lidar));
        values.insert(
            "instructions_parser_per_packet".into(),
            json!(per(parser, packets)),
        );
        values.insert(
            "instructions_parser_per_point".into(),
            json!(per(parser, points)),
        );
        values.insert(
            "instructions_lidar_per_packet".into(),
            json!(per(lidar, packets)),
        );
        values.insert(
            "instructions_lidar_per_point".into(),
            json!(per(lidar, points)),
        );
        values.insert("ram_parser".into(), json!(int("parser")));
        values.insert("ram_lidar".into(), json!(int("lidar")));
        values.insert("ram_assembler".into(), json!(assembler));
        entries.push((key(protocol), values));
    }
    Ok(Ok(entries))
}

/// Columns of the lidar table.
pub const HEADER: [&str; 9] = [
    "target",
    "protocol",
    "packets",
    "points",
    "parser: instr. / packet",
    "parser: instr. / point",
    "parser + assembler: instr. / packet",
    "parser + assembler: instr. / point",
    "RAM: parser / `Lidar` (assembler)",
];

/// One row of the lidar table, for the entry `entry` (`lidar/<protocol>`).
pub fn row(target: &Target, entry: &str, v: &Map<String, Value>) -> Vec<String> {
    let int = |k: &str| v.get(k).and_then(Value::as_u64);
    let count = |k: &str| int(k).map_or("–".into(), group);
    let per = |k: &str| {
        v.get(k)
            .and_then(Value::as_f64)
            .map_or("–".into(), |r| group(r.round() as u64))
    };
    let ram = match (int("ram_parser"), int("ram_lidar"), int("ram_assembler")) {
        (Some(parser), Some(lidar), Some(assembler)) => {
            format!("{parser} B / {lidar} B ({assembler} B)")
        }
        _ => "–".into(),
    };
    vec![
        target.name.to_string(),
        entry.rsplit('/').next().unwrap_or(entry).to_string(),
        count("packets"),
        count("points"),
        per("instructions_parser_per_packet"),
        per("instructions_parser_per_point"),
        per("instructions_lidar_per_packet"),
        per("instructions_lidar_per_point"),
        ram,
    ]
}

/// The bullet of `budgets/TABLE.md` that explains the lidar table.
pub const NOTE: &str =
    "- Lidar table (issue 25): `examples/lidar_bench.rs` over the four captures of \
     `lidar/tests/data/` (in flash), one row per protocol; every capture must decode without a \
     dropped packet or a skipped byte. *packets*, *points*: what the parser decoded. *parser*: \
     `Parser::append` of every byte and `poll` of every packet, each point decoded, per packet and \
     per point. *parser + assembler*: a `Lidar` with 720 beams a revolution over the same bytes \
     (`Lidar::push`: parsing, binning, revolution detection, clearing the buffer at each turn). \
     *RAM*: `size_of` the parser and the `Lidar` (parser + assembler), and of the assembler alone \
     (5 bytes a beam: `f32` range, `u8` quality, plus its state); the same on both cores.\n";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_a_capture_line() {
        let line = "ld06: 57857 bytes, 1231 packets, 14772 points, 20 revolutions, 0 dropped, \
                    parser 88 B, lidar 3752 B";
        let (protocol, v) = capture(line).unwrap();
        assert_eq!(protocol, "ld06");
        assert_eq!(v["packets"], 1231);
        assert_eq!(v["points"], 14772);
        assert_eq!(v["dropped"], 0);
        assert_eq!(v["parser"], 88);
        assert_eq!(v["lidar"], 3752);
        assert!(capture("assembler 3656 B (720 beams)").is_none());
        assert!(capture("panicked: at src/lib.rs:1").is_none());
    }

    #[test]
    fn rows_per_protocol() {
        let target = &crate::firmware::TARGETS[0];
        let v = json!({"packets": 1231, "points": 14772, "instructions_parser_per_packet": 3880.4,
            "instructions_parser_per_point": 323.37, "instructions_lidar_per_packet": 5141.0,
            "instructions_lidar_per_point": 428.42, "ram_parser": 88, "ram_lidar": 3752,
            "ram_assembler": 3656});
        let cells = row(target, &key("ld06"), v.as_object().unwrap());
        assert_eq!(cells.len(), HEADER.len());
        assert_eq!(cells[1], "ld06");
        assert_eq!(cells[4], "3\u{202f}880");
        assert_eq!(cells[8], "88 B / 3752 B (3656 B)");
    }

    #[test]
    fn check_covers_the_lidar_entries() {
        let budget = json!({"targets": {"t": {"lidar/ld06": {"instructions_lidar_per_point": 400.0, "ram_lidar": 3752}}}});
        let ok = json!({"t": {"lidar/ld06": {"instructions_lidar_per_point": 439.0, "ram_lidar": 3752}}});
        assert!(crate::report::check(&budget, ok.as_object().unwrap()).is_empty());
        let grown = json!({"t": {"lidar/ld06": {"instructions_lidar_per_point": 441.0, "ram_lidar": 3752}}});
        assert_eq!(
            crate::report::check(&budget, grown.as_object().unwrap()).len(),
            1
        );
        let missing = json!({"t": {"lidar/ld06": {"instructions_lidar_per_point": 400.0}}});
        assert_eq!(
            crate::report::check(&budget, missing.as_object().unwrap()).len(),
            1
        );
    }
}
