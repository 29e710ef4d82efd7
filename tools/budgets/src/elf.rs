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
    /// Size of the bench's grids (`FIRST`, `SECOND`, `SCATTERED`) in flash.
    pub grids: u64,
    /// Address of `hh_bench_start`, Thumb bit cleared.
    pub start: Option<u64>,
    /// Address of `hh_bench_stop`, Thumb bit cleared.
    pub stop: Option<u64>,
    /// The stack region `[_stack_end, _stack_start)` of cortex-m-rt.
    pub stack: Option<(u64, u64)>,
    /// Software floating-point routines linked in (see [`is_float_routine`]).
    pub float_routines: Vec<String>,
}

/// Whether `name` is one of the compiler runtime's floating-point routines
/// (`compiler-builtins`: the ARM EABI names `__aeabi_f…`/`__aeabi_d…`, and
/// the generic `__addsf3`, `__muldf3`, `__fixsfsi`, `__floatsidf`,
/// `__ltsf2`, `__extendsfdf2`, … that RISC-V links). A core without an FPU
/// (Cortex-M0, RV32IMAC) calls one for every `f32`/`f64` operation, and the
/// Cortex-M4F for every `f64` one.
pub fn is_float_routine(name: &str) -> bool {
    let Some(rest) = name.strip_prefix("__") else {
        return false;
    };
    if let Some(eabi) = rest.strip_prefix("aeabi_") {
        // `fadd`, `dmul`, `f2iz`, `d2f`, `fcmplt`, … and `i2f`, `ul2d`, ….
        return eabi.starts_with(['f', 'd']) || eabi.ends_with("2f") || eabi.ends_with("2d");
    }
    rest.starts_with("fix")
        || rest.starts_with("float")
        || ["sf2", "df2", "sf3", "df3"]
            .iter()
            .any(|s| rest.ends_with(s))
        || rest.starts_with("extendsfdf")
        || rest.starts_with("truncdfsf")
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
    let grids = [
        find("8firmware5FIRST"),
        find("8firmware6SECOND"),
        find("8firmware9SCATTERED"),
    ]
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
    let mut float_routines: Vec<String> = file
        .symbols()
        .filter_map(|s| s.name().ok())
        .filter(|n| is_float_routine(n))
        .map(String::from)
        .collect();
    float_routines.sort();
    float_routines.dedup();
    Ok(Image {
        float_routines,
        flash,
        static_ram,
        grids,
        start: find("hh_bench_start").map(|(a, _)| a),
        stop: find("hh_bench_stop").map(|(a, _)| a),
        stack,
    })
}

#[cfg(test)]
mod tests {
    use super::is_float_routine;

    #[test]
    fn float_routines_by_name() {
        for name in [
            "__aeabi_fadd",
            "__aeabi_fmul",
            "__aeabi_dmul",
            "__aeabi_d2f",
            "__aeabi_f2iz",
            "__aeabi_i2f",
            "__aeabi_ul2d",
            "__aeabi_fcmplt",
            "__addsf3",
            "__muldf3",
            "__divsf3",
            "__fixsfsi",
            "__fixunsdfdi",
            "__floatsisf",
            "__floatundidf",
            "__ltsf2",
            "__unorddf2",
            "__extendsfdf2",
            "__truncdfsf2",
        ] {
            assert!(is_float_routine(name), "{name}");
        }
        for name in [
            "__aeabi_ldivmod",
            "__aeabi_uidiv",
            "__aeabi_idivmod",
            "__aeabi_lmul",
            "__aeabi_llsl",
            "__aeabi_memcpy4",
            "__aeabi_memclr8",
            "__divdi3",
            "__udivdi3",
            "__muldi3",
            "__multi3",
            "__clzsi2",
            "fit",
            "_ZN13hough_heading4pose11translation3fit17hdf32836b40f90ca8E",
        ] {
            assert!(!is_float_routine(name), "{name}");
        }
    }
}
