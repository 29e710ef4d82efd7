//! `budgets profile`: where the instructions of one measured region go.
//!
//! Runs a bench firmware under QEMU with the `qemu-icount` plugin's flat
//! profile (`profile=<file>`: executions of every instruction address between
//! each pair of markers), picks one region by the name the firmware announced
//! (`bench <name> ...`), optionally minus another one (`--minus`: e.g. the
//! verified estimate minus the unverified one), and maps the addresses with
//! `llvm-addr2line -f -i -a -C` (the ELF's DWARF, including inlined frames;
//! the release profile keeps `debug = true`). It prints
//!
//! - *inclusive*: per library function, the instructions executed in it or
//!   in what was inlined into it (closures count with their function), from
//!   the inline chains; calls into functions that were not inlined are
//!   counted in the *callee* only (the plugin records no call stack);
//! - *self*: per innermost inlined function;
//! - *lines*: per innermost source line of the library (`src/`);
//! - *calls*: executions of the first instruction of each function symbol
//!   (the number of calls to functions that were not inlined).
//!
//! Exact and repeatable, like the budget counts.

use std::collections::{HashMap, HashSet};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use object::{Object, ObjectSymbol, SymbolKind};

use crate::qemu::{self, Plugin};
use crate::{elf, Error};

/// What to profile and how to print it.
pub struct Request<'a> {
    /// The bench ELF.
    pub elf: &'a Path,
    /// QEMU machine.
    pub machine: &'a str,
    /// The `qemu-icount` plugin.
    pub plugin: PathBuf,
    /// Region name, e.g. `estimate`.
    pub region: &'a str,
    /// Region subtracted address by address, e.g. `unverified`.
    pub minus: Option<&'a str>,
    /// For a firmware that announces no region names and measures `N`
    /// regions a round after the markers' overhead (`examples/real_scans.rs`:
    /// 7 a pair): `region` and `minus` are then indices in the round, and
    /// each is summed over every round.
    pub cycle: Option<usize>,
    /// Rows per table.
    pub top: usize,
    /// Where the profile file goes.
    pub scratch: PathBuf,
    /// Source root: lines under `<root>/src/` are the library's.
    pub root: PathBuf,
    /// With `cycle`: instead of the tables, one line per region of the
    /// round: its instructions and those inside the software
    /// floating-point routines (`elf::is_float_routine`), per round.
    pub floats: bool,
}

/// One region of the profile file.
struct Region {
    total: i64,
    counts: HashMap<u64, i64>,
}

/// Runs the profile and prints the tables.
pub fn run(request: &Request<'_>) -> Result<(), Error> {
    let image = elf::read(request.elf)?;
    std::fs::create_dir_all(&request.scratch)
        .map_err(|e| format!("create {}: {e}", request.scratch.display()))?;
    let file = request
        .scratch
        .join(format!("profile-{}.txt", std::process::id()));
    let plugin = Plugin::for_image(request.plugin.clone(), &image, Some(file.clone()))?;
    let outcome = qemu::run(
        request.elf,
        request.machine,
        Some(&plugin),
        Duration::from_secs(600),
    )?;
    if outcome.status != Some(0) {
        return Err(format!(
            "the firmware failed (status {:?}):\n{}\n{}",
            outcome.status,
            outcome.log.join("\n"),
            outcome.stderr
        )
        .into());
    }
    let text =
        std::fs::read_to_string(&file).map_err(|e| format!("read {}: {e}", file.display()))?;
    let _ = std::fs::remove_file(&file);
    let regions = parse(&text)?;
    if let (true, Some(n)) = (request.floats, request.cycle) {
        return print_floats(request, &regions, n);
    }
    let (main, other) = match request.cycle {
        Some(n) => (
            in_rounds(&regions, n, request.region)?,
            request
                .minus
                .map(|m| in_rounds(&regions, n, m))
                .transpose()?,
        ),
        None => by_name(&regions, &outcome.log, request.region, request.minus)?,
    };
    let overhead = regions.first().map_or(0, |r| r.total);
    let mut counts = main.counts;
    let mut total = main.total - overhead * main.rounds;
    let mut title = format!("`{}`", request.region);
    if let (Some(other), Some(minus)) = (other, request.minus) {
        for (&addr, &n) in &other.counts {
            *counts.entry(addr).or_insert(0) -= n;
        }
        counts.retain(|_, n| *n != 0);
        total -= other.total - overhead * other.rounds;
        title = format!("`{}` minus `{minus}`", request.region);
    }
    if let Some(n) = request.cycle {
        title = format!("{title} of every {n} regions ({} rounds)", main.rounds);
    }
    print_profile(request, &title, total, &counts)
}

/// The counts of one or more regions added up, and how many.
struct Summed {
    total: i64,
    counts: HashMap<u64, i64>,
    rounds: i64,
}

/// Region `index` (a number) of every round of `n` after the overhead.
fn in_rounds(regions: &[Region], n: usize, index: &str) -> Result<Summed, Error> {
    let k: usize = index
        .parse()
        .map_err(|_| format!("--region {index}: with --cycle, an index"))?;
    if k >= n {
        return Err(format!("--region {k}: beyond the round of {n}").into());
    }
    let mut sum = Summed {
        total: 0,
        counts: HashMap::new(),
        rounds: 0,
    };
    for region in regions.iter().skip(1 + k).step_by(n) {
        sum.total += region.total;
        sum.rounds += 1;
        for (&addr, &c) in &region.counts {
            *sum.counts.entry(addr).or_insert(0) += c;
        }
    }
    Ok(sum)
}

/// The regions named `region` and `minus` by the firmware's
/// `bench <name> …` lines, one each.
fn by_name(
    regions: &[Region],
    log: &[String],
    region: &str,
    minus: Option<&str>,
) -> Result<(Summed, Option<Summed>), Error> {
    let names: Vec<&str> = log
        .iter()
        .filter_map(|l| l.strip_prefix("bench "))
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    if regions.len() != names.len() {
        return Err(format!(
            "{} regions in the profile, {} announced by the firmware",
            regions.len(),
            names.len()
        )
        .into());
    }
    let find = |name: &str| {
        names
            .iter()
            .position(|n| *n == name)
            .and_then(|i| regions.get(i))
            .ok_or_else(|| format!("no region `{name}` (the firmware announced {names:?})"))
    };
    let one = |r: &Region| Summed {
        total: r.total,
        counts: r.counts.clone(),
        rounds: 1,
    };
    let main = one(find(region)?);
    let other = minus.map(|m| find(m).map(one)).transpose()?;
    Ok((main, other))
}

/// Prints the tables of `counts` (addresses of the ELF), `total`
/// instructions under `title`.
fn print_profile(
    request: &Request<'_>,
    title: &str,
    total: i64,
    counts: &HashMap<u64, i64>,
) -> Result<(), Error> {
    let addresses: Vec<u64> = counts.keys().copied().collect();
    let frames = symbolize(request.elf, &addresses)?;
    let library = request.root.join("src");
    let mut inclusive: HashMap<String, i64> = HashMap::new();
    let mut own: HashMap<String, i64> = HashMap::new();
    let mut lines: HashMap<String, i64> = HashMap::new();
    for (addr, n) in counts {
        let chain = frames.get(addr).map_or(&[][..], Vec::as_slice);
        let mut seen = HashSet::new();
        for (function, _) in chain {
            let function = enclosing(function);
            // `core`'s iterator adapters would crowd the table.
            if function.contains("hough_heading::") && seen.insert(function.clone()) {
                *inclusive.entry(function).or_insert(0) += n;
            }
        }
        let innermost = chain
            .first()
            .map_or_else(|| format!("?? {addr:#x}"), |(f, _)| enclosing(f));
        *own.entry(innermost).or_insert(0) += n;
        if let Some((function, line)) = chain
            .iter()
            .find(|(_, line)| Path::new(line).starts_with(&library))
        {
            let short = line
                .strip_prefix(&format!("{}/", request.root.display()))
                .unwrap_or(line);
            *lines
                .entry(format!("{short} ({})", short_name(&enclosing(function))))
                .or_insert(0) += n;
        }
    }
    let calls = calls(request.elf, counts)?;

    println!(
        "Profile of {title} on {} ({}): {} instructions (markers' overhead subtracted; \
         the per-address counts sum to {})",
        request.machine,
        request.elf.display(),
        total,
        counts.values().sum::<i64>()
    );
    print_table(
        "inclusive, library functions (with what was inlined into them)",
        &inclusive,
        total,
        request.top,
    );
    print_table(
        "self (innermost inlined function)",
        &own,
        total,
        request.top,
    );
    print_table(
        "library source lines (innermost in src/)",
        &lines,
        total,
        request.top,
    );
    print_table(
        "calls (executions of a function symbol's first instruction)",
        &calls,
        0,
        request.top,
    );
    Ok(())
}

/// Per region of a round of `n`: instructions and those inside the
/// floating-point routines, per round (markers' overhead subtracted from the
/// former).
fn print_floats(request: &Request<'_>, regions: &[Region], n: usize) -> Result<(), Error> {
    let bytes =
        std::fs::read(request.elf).map_err(|e| format!("read {}: {e}", request.elf.display()))?;
    let file = object::File::parse(&*bytes)?;
    let routines: Vec<(u64, u64)> = file
        .symbols()
        .filter(|s| s.kind() == SymbolKind::Text && s.name().is_ok_and(elf::is_float_routine))
        .map(|s| (s.address() & !1, (s.address() & !1) + s.size()))
        .collect();
    let overhead = regions.first().map_or(0, |r| r.total);
    println!(
        "Software floating point per round of {n} regions on {} ({}):",
        request.machine,
        request.elf.display()
    );
    println!(
        "{:>7} {:>14} {:>12} {:>8}",
        "region", "instructions", "in floats", "share"
    );
    for k in 0..n {
        let sum = in_rounds(regions, n, &k.to_string())?;
        let rounds = sum.rounds.max(1);
        let total = (sum.total - overhead * sum.rounds) / rounds;
        let floats: i64 = sum
            .counts
            .iter()
            .filter(|(&a, _)| routines.iter().any(|&(lo, hi)| (lo..hi).contains(&a)))
            .map(|(_, &c)| c)
            .sum::<i64>()
            / rounds;
        println!(
            "{k:>7} {total:>14} {floats:>12} {:>7.2}%",
            100.0 * floats as f64 / total.max(1) as f64
        );
    }
    Ok(())
}

/// Parses the plugin's profile file.
fn parse(text: &str) -> Result<Vec<Region>, Error> {
    let mut regions: Vec<Region> = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match (words.next(), words.next(), words.next()) {
            (Some("region"), Some(_), Some(total)) => regions.push(Region {
                total: total.parse()?,
                counts: HashMap::new(),
            }),
            (Some(addr), Some(n), None) => {
                let addr = qemu::number(addr).ok_or_else(|| format!("bad address {addr}"))?;
                let region = regions.last_mut().ok_or("profile: count before a region")?;
                *region.counts.entry(addr).or_insert(0) += n.parse::<i64>()?;
            }
            _ => return Err(format!("profile: bad line `{line}`").into()),
        }
    }
    Ok(regions)
}

/// The inline chain (innermost first) of each address: `(function, file:line)`.
fn symbolize(elf: &Path, addresses: &[u64]) -> Result<HashMap<u64, Vec<(String, String)>>, Error> {
    let tool = ["llvm-addr2line", "llvm-addr2line-14"]
        .into_iter()
        .find(|t| Command::new(t).arg("--version").output().is_ok())
        .ok_or("llvm-addr2line not found (Debian: llvm)")?;
    let mut child = Command::new(tool)
        .args(["-f", "-i", "-a", "-C", "-e"])
        .arg(elf)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .spawn()
        .map_err(|e| format!("start {tool}: {e}"))?;
    let mut input = String::new();
    for addr in addresses {
        input.push_str(&format!("{addr:#x}\n"));
    }
    let mut stdin = child.stdin.take().ok_or("no stdin")?;
    let writer = std::thread::spawn(move || stdin.write_all(input.as_bytes()));
    let output = child.wait_with_output()?;
    writer
        .join()
        .map_err(|_| "addr2line writer panicked")?
        .map_err(|e| format!("write to {tool}: {e}"))?;
    let text = String::from_utf8_lossy(&output.stdout);
    let mut frames: HashMap<u64, Vec<(String, String)>> = HashMap::new();
    let mut current: Option<u64> = None;
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if let Some(hex) = line.strip_prefix("0x") {
            current = u64::from_str_radix(hex, 16).ok();
            continue;
        }
        let location = lines.next().unwrap_or("??:0");
        if let Some(addr) = current {
            frames
                .entry(addr)
                .or_default()
                .push((clean(line), location.to_string()));
        }
    }
    Ok(frames)
}

/// Executions of each function symbol's first instruction.
fn calls(elf: &Path, counts: &HashMap<u64, i64>) -> Result<HashMap<String, i64>, Error> {
    let bytes = std::fs::read(elf)?;
    let file = object::File::parse(&*bytes)?;
    let mut out = HashMap::new();
    for symbol in file.symbols() {
        if symbol.kind() != SymbolKind::Text || symbol.size() == 0 {
            continue;
        }
        let Some(&n) = counts.get(&(symbol.address() & !1)) else {
            continue;
        };
        let name = symbol.name().unwrap_or("?");
        let name = demangle(name);
        *out.entry(name).or_insert(0) += n;
    }
    Ok(out)
}

/// A symbol name in Rust's legacy mangling, `_ZN<len><part>...E`, as
/// `part::part` without the hash (other names unchanged).
fn demangle(name: &str) -> String {
    let Some(mut rest) = name.strip_prefix("_ZN") else {
        return name.to_string();
    };
    let mut parts = Vec::new();
    while let Some(len_end) = rest.find(|c: char| !c.is_ascii_digit()) {
        let Ok(len) = rest[..len_end].parse::<usize>() else {
            break;
        };
        let Some(part) = rest.get(len_end..len_end + len) else {
            break;
        };
        parts.push(part);
        rest = &rest[len_end + len..];
    }
    clean(&parts.join("::"))
}

/// A function name with Rust's legacy-mangling escapes (`$LT$`, `..`, …)
/// decoded and the trailing hash (`::h0123456789abcdef`) dropped, as
/// `llvm-addr2line` 14 leaves some of them.
fn clean(name: &str) -> String {
    let mut out = name.to_string();
    if let Some(at) = out.rfind("::h") {
        let hash = &out[at + 3..];
        if hash.len() == 16 && hash.chars().all(|c| c.is_ascii_hexdigit()) {
            out.truncate(at);
        }
    }
    for (escaped, plain) in [
        ("$LT$", "<"),
        ("$GT$", ">"),
        ("$u20$", " "),
        ("$u27$", "'"),
        ("$u5b$", "["),
        ("$u5d$", "]"),
        ("$u7b$", "{"),
        ("$u7d$", "}"),
        ("$C$", ","),
        ("$RF$", "&"),
        ("$BP$", "*"),
        ("$u7e$", "~"),
        ("..", "::"),
    ] {
        out = out.replace(escaped, plain);
    }
    // `_<Type as Trait>::f`: the legacy scheme's leading underscore.
    if out.starts_with("_<") {
        out.remove(0);
    }
    // A legacy closure segment reads `_{{closure}}`.
    out.replace('$', "").replace("::_{{", "::{{")
}

/// A function name without its closure suffixes: a closure counts with the
/// function that defines it.
fn enclosing(function: &str) -> String {
    let mut name = function;
    while let Some(stripped) = name.strip_suffix("::{{closure}}") {
        name = stripped;
    }
    name.to_string()
}

/// The last two path segments of a function name (`Type::method`), generic
/// arguments dropped.
fn short_name(function: &str) -> String {
    let mut depth = 0;
    let mut plain = String::new();
    for c in function.chars() {
        match c {
            '<' => depth += 1,
            '>' => depth -= 1,
            _ if depth == 0 => plain.push(c),
            _ => {}
        }
    }
    let parts: Vec<&str> = plain.split("::").filter(|p| !p.is_empty()).collect();
    parts[parts.len().saturating_sub(2)..].join("::")
}

/// Prints the `top` largest entries of `values`, with their share of `total`
/// (no share when `total` is 0).
fn print_table(title: &str, values: &HashMap<String, i64>, total: i64, top: usize) {
    let mut sorted: Vec<(&String, &i64)> = values.iter().filter(|(_, n)| **n != 0).collect();
    sorted.sort_by(|a, b| b.1.abs().cmp(&a.1.abs()).then(a.0.cmp(b.0)));
    println!("\n{title}:");
    for (name, n) in sorted.into_iter().take(top) {
        if total == 0 {
            println!("  {n:>13}  {}", short(name));
        } else {
            let share = *n as f64 / total as f64 * 100.0;
            println!("  {n:>13}  {share:5.1} %  {}", short(name));
        }
    }
}

/// A long name cut to 150 characters.
fn short(name: &str) -> String {
    if name.chars().count() > 150 {
        let cut: String = name.chars().take(147).collect();
        format!("{cut}...")
    } else {
        name.to_string()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_regions() {
        let text = "region 0 5\n0x10 2\n0x12 3\nregion 1 7\n0x10 7\n";
        let regions = parse(text).unwrap();
        assert_eq!(regions.len(), 2);
        assert_eq!(regions[0].total, 5);
        assert_eq!(regions[0].counts[&0x12], 3);
        assert_eq!(regions[1].counts[&0x10], 7);
        assert!(parse("0x10 2\n").is_err());
    }

    /// `--cycle`: one index of every round, summed, the overhead first.
    #[test]
    fn sums_one_region_of_every_round() {
        let mut text = String::from("region 0 1\n0x4 1\n");
        for round in 0..2 {
            for k in 0..3 {
                text += &format!(
                    "region {} {}\n0x{:x} {}\n",
                    1 + 3 * round + k,
                    10 * k + round,
                    0x10 + k,
                    10 * k + round
                );
            }
        }
        let regions = parse(&text).unwrap();
        let second = in_rounds(&regions, 3, "1").unwrap();
        assert_eq!((second.total, second.rounds), (10 + 11, 2));
        assert_eq!(second.counts[&0x11], 21);
        assert_eq!(second.counts.len(), 1);
        assert!(in_rounds(&regions, 3, "3").is_err());
        assert!(in_rounds(&regions, 3, "estimate").is_err());
    }

    #[test]
    fn cleans_legacy_names() {
        assert_eq!(
            clean("hough_heading::align::Aligner$LT$_$C$_$GT$::bound::_$u7b$$u7b$closure$u7d$$u7d$::h7f4bffac4dc0fa7f"),
            "hough_heading::align::Aligner<_,_>::bound::{{closure}}"
        );
        assert_eq!(
            enclosing("hough_heading::align::Aligner<_,_>::bound::{{closure}}::{{closure}}"),
            "hough_heading::align::Aligner<_,_>::bound"
        );
        assert_eq!(
            demangle("_ZN13hough_heading5align4bits17h874c8de51e63f654E"),
            "hough_heading::align::bits"
        );
        assert_eq!(
            short_name("hough_heading::align::Aligner<_,_>::bound"),
            "Aligner::bound"
        );
    }
}
