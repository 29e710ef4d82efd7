//! `budgets floats`: the software floating point every firmware example
//! links, checked against the allow-list the README states.
//!
//! The README's paragraph on floating point ends with the list, e.g.
//!
//! ```text
//! CI checks every firmware example against this list: none: `bench`,
//! `two_grids`; f32: `lidar_bench`; f64: `real_scans`, ….
//! ```
//!
//! `none` allows no floating-point routine, `f32` the single-precision ones
//! (which a core without an FPU calls for every `f32` operation), `f64`
//! both. Every example of `examples/` must be listed, and its ELF on every
//! target given must link nothing beyond its class.

use std::collections::BTreeMap;
use std::path::Path;

use crate::{elf, Error};

/// What an example may link, from the least to the most.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Precision {
    /// No floating-point routine.
    None,
    /// Single-precision routines only.
    Single,
    /// Double-precision routines too (conversions from and to `f64` count
    /// as double).
    Double,
}

impl Precision {
    /// The README's name of the class.
    fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Single => "f32",
            Self::Double => "f64",
        }
    }
}

/// The precision of a floating-point routine (see
/// [`elf::is_float_routine`]): double when it takes or returns an `f64`.
pub fn precision(routine: &str) -> Precision {
    let rest = routine.trim_start_matches('_');
    match rest.strip_prefix("aeabi_") {
        Some(op) if op.starts_with('d') || op.ends_with("2d") => Precision::Double,
        Some(_) => Precision::Single,
        None if rest.contains("df") => Precision::Double,
        None => Precision::Single,
    }
}

/// The sentence that introduces the list in the README.
const MARKER: &str = "CI checks every firmware example against this list:";

/// The allow-list of the README's text: example name → class.
pub fn allow_list(readme: &str) -> Result<BTreeMap<String, Precision>, Error> {
    let text = readme.split_whitespace().collect::<Vec<_>>().join(" ");
    let start = text
        .find(MARKER)
        .ok_or_else(|| format!("the README states no list (\"{MARKER}\")"))?
        + MARKER.len();
    let rest = &text[start..];
    let end = rest.find(". ").unwrap_or(rest.len());
    let mut list = BTreeMap::new();
    for group in rest[..end].trim_end_matches('.').split(';') {
        let (class, names) = group
            .split_once(':')
            .ok_or_else(|| format!("README list: `{group}` has no `class:`"))?;
        let class = match class.trim() {
            "none" => Precision::None,
            "f32" => Precision::Single,
            "f64" => Precision::Double,
            other => return Err(format!("README list: unknown class `{other}`").into()),
        };
        for name in names.split(',') {
            let name = name.trim().trim_matches('`');
            if list.insert(name.to_string(), class).is_some() {
                return Err(format!("README list: `{name}` twice").into());
            }
        }
    }
    Ok(list)
}

/// Checks the examples of `examples_dir` built for `triples` under
/// `target_dir` against the README's list; prints one line per ELF and
/// returns whether every one is within its class.
pub fn check(
    readme: &Path,
    examples_dir: &Path,
    target_dir: &Path,
    triples: &[&str],
) -> Result<bool, Error> {
    let text =
        std::fs::read_to_string(readme).map_err(|e| format!("read {}: {e}", readme.display()))?;
    let list = allow_list(&text)?;
    let mut examples: Vec<String> = std::fs::read_dir(examples_dir)
        .map_err(|e| format!("read {}: {e}", examples_dir.display()))?
        .filter_map(|entry| entry.ok()?.file_name().into_string().ok())
        .filter_map(|name| name.strip_suffix(".rs").map(String::from))
        .collect();
    examples.sort();
    let mut ok = true;
    for name in list.keys().filter(|n| !examples.contains(n)) {
        println!("floats: `{name}` is in the README's list but not in examples/");
        ok = false;
    }
    for example in &examples {
        let Some(&allowed) = list.get(example) else {
            println!("floats: `{example}` is missing from the README's list");
            ok = false;
            continue;
        };
        for triple in triples {
            let path = target_dir
                .join(triple)
                .join("release/examples")
                .join(example);
            let image = elf::read(&path)?;
            let linked = image
                .float_routines
                .iter()
                .map(|r| precision(r))
                .max()
                .unwrap_or(Precision::None);
            let verdict = if linked <= allowed {
                "ok"
            } else {
                "NOT ALLOWED"
            };
            ok &= linked <= allowed;
            println!(
                "floats: {example:<18} {triple:<29} allowed {:<4} links {:<4} {verdict}{}",
                allowed.name(),
                linked.name(),
                match image.float_routines.as_slice() {
                    [] => String::new(),
                    routines => format!(" ({})", routines.join(" ")),
                }
            );
        }
    }
    Ok(ok)
}

#[cfg(test)]
mod tests {
    use super::{allow_list, precision, Precision};

    #[test]
    fn precision_by_name() {
        for name in [
            "__aeabi_fadd",
            "__aeabi_ui2f",
            "__aeabi_fcmplt",
            "__addsf3",
            "__fixsfsi",
        ] {
            assert_eq!(precision(name), Precision::Single, "{name}");
        }
        for name in [
            "__aeabi_dmul",
            "__aeabi_f2d",
            "__aeabi_d2f",
            "__aeabi_l2d",
            "__muldf3",
            "__extendsfdf2",
            "__truncdfsf2",
            "__floatsidf",
        ] {
            assert_eq!(precision(name), Precision::Double, "{name}");
        }
    }

    #[test]
    fn list_from_wrapped_text() {
        let readme = "Floating point ... CI checks every firmware\nexample against this list: none: `bench`,\n`two_grids`; f32: `lidar_bench`;\nf64: `real_scans`. Next sentence: x.";
        let list = allow_list(readme).unwrap();
        assert_eq!(list.len(), 4);
        assert_eq!(list["bench"], Precision::None);
        assert_eq!(list["two_grids"], Precision::None);
        assert_eq!(list["lidar_bench"], Precision::Single);
        assert_eq!(list["real_scans"], Precision::Double);
        assert!(allow_list("no list here").is_err());
        assert!(
            allow_list("CI checks every firmware example against this list: half: `x`.").is_err()
        );
    }
}
