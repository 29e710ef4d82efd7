//! What the budgets need from a firmware ELF: section sizes and a few symbols.

use std::path::Path;

use object::{elf, Object, ObjectSection, ObjectSymbol, SectionFlags, SectionKind};

use crate::Error;

/// Sizes and addresses read from one firmware ELF.
#[derive(Debug, Clone)]
pub struct Image {
    /// Bytes stored in flash: code, read-only data, vector table and the
    /// initial values of `.data`.
    pub flash: u64,
    /// Bytes of RAM reserved at link time: `.data + .bss` (and `.uninit`).
    pub static_ram: u64,
    /// Size of the two grids (`FIRST`, `SECOND`) in flash.
    pub grids: u64,
    /// Address of `hh_bench_start`, Thumb bit cleared.
    pub start: Option<u64>,
    /// Address of `hh_bench_stop`, Thumb bit cleared.
    pub stop: Option<u64>,
    /// The stack region `[_stack_end, _stack_start)` of cortex-m-rt.
    pub stack: Option<(u64, u64)>,
}

/// Reads `path`.
pub fn read(path: &Path) -> Result<Image, Error> {
    let bytes = std::fs::read(path).map_err(|e| format!("read {}: {e}", path.display()))?;
    let file =
        object::File::parse(&*bytes).map_err(|e| format!("parse {}: {e}", path.display()))?;

    // Flash: every allocated section with contents (code, read-only data,
    // tables, and the initial values of `.data`). Static RAM: every allocated,
    // writable section but the stack and heap reservations of the runtimes.
    let (mut flash, mut static_ram) = (0, 0);
    for section in file.sections() {
        let SectionFlags::Elf { sh_flags } = section.flags() else {
            continue;
        };
        if sh_flags & u64::from(elf::SHF_ALLOC) == 0 {
            continue;
        }
        if section.kind() != SectionKind::UninitializedData {
            flash += section.size();
        }
        let name = section.name().unwrap_or("");
        if sh_flags & u64::from(elf::SHF_WRITE) != 0 && name != ".stack" && name != ".heap" {
            static_ram += section.size();
        }
    }

    // Rust symbols are mangled (`_ZN5bench8firmware14hh_bench_start17h…E`):
    // match on the path components.
    let find = |needle: &str| {
        file.symbols()
            .find(|s| s.name().is_ok_and(|n| n.contains(needle)))
            .map(|s| (s.address() & !1, s.size()))
    };
    let grids = [find("8firmware5FIRST"), find("8firmware6SECOND")]
        .iter()
        .flatten()
        .map(|&(_, size)| size)
        .sum();
    let exact = |name: &str| {
        file.symbols()
            .find(|s| s.name() == Ok(name))
            .map(|s| (s.address(), s.size()))
    };
    let stack = match (exact("_stack_end"), exact("_stack_start")) {
        (Some((lo, _)), Some((hi, _))) => Some((lo, hi)),
        _ => None,
    };
    Ok(Image {
        flash,
        static_ram,
        grids,
        start: find("hh_bench_start").map(|(a, _)| a),
        stop: find("hh_bench_stop").map(|(a, _)| a),
        stack,
    })
}
