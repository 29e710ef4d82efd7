//! Build script: linker setup of the firmware examples (`examples/*.rs`).
//!
//! The library itself needs nothing from here. When the target is bare metal
//! (`target_os = "none"`), this script writes the memory layout of the board the
//! examples run on to `$OUT_DIR/hh-board.x` and passes the runtime's linker
//! scripts to the examples only (`cargo:rustc-link-arg-examples`). The root
//! `memory.x`, which the runtimes `INCLUDE`, includes `hh-board.x` in turn, so
//! one file serves every board (the linker finds `memory.x` in the package
//! root, which is its working directory, before any search path).
//!
//! | target                          | board (QEMU machine)       | flash           | RAM               |
//! |---------------------------------|----------------------------|-----------------|-------------------|
//! | `thumbv7em-none-eabihf` (M4F)   | MPS2 AN386 (`mps2-an386`)  | 4 MiB @ 0x0     | 4 MiB @ 0x2000_0000 |
//! | `thumbv6m-none-eabi` (M0)       | BBC micro:bit (`microbit`) | 256 KiB @ 0x0   | 16 KiB @ 0x2000_0000 |
//! | `riscv32imac-unknown-none-elf`  | none (built for sizes)     | 4 MiB @ 0x2000_0000 | 1 MiB @ 0x8000_0000 |
//!
//! The RISC-V layout is generous on purpose: that target is only built, to
//! measure flash and static RAM, so every configuration must link.

use std::env;
use std::fs;
use std::path::PathBuf;

/// Memory layout of the Cortex-M4F board (QEMU `mps2-an386`: SSRAM1 holds the
/// image, SSRAM2/3 are the RAM).
const MPS2_AN386: &str = "\
MEMORY
{
  FLASH : ORIGIN = 0x00000000, LENGTH = 4M
  RAM   : ORIGIN = 0x20000000, LENGTH = 4M
}
";

/// Memory layout of the Cortex-M0 board (QEMU `microbit`: nRF51822).
const MICROBIT: &str = "\
MEMORY
{
  FLASH : ORIGIN = 0x00000000, LENGTH = 256K
  RAM   : ORIGIN = 0x20000000, LENGTH = 16K
}
";

/// Memory layout of the RISC-V size build, in `riscv-rt`'s region aliases.
const RISCV32: &str = "\
MEMORY
{
  FLASH : ORIGIN = 0x20000000, LENGTH = 4M
  RAM   : ORIGIN = 0x80000000, LENGTH = 1M
}
REGION_ALIAS(\"REGION_TEXT\", FLASH);
REGION_ALIAS(\"REGION_RODATA\", FLASH);
REGION_ALIAS(\"REGION_DATA\", RAM);
REGION_ALIAS(\"REGION_BSS\", RAM);
REGION_ALIAS(\"REGION_HEAP\", RAM);
REGION_ALIAS(\"REGION_STACK\", RAM);
";

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-changed=memory.x");

    // `hh_small_ram`: the board has 16 KiB of RAM (the micro:bit); the
    // real-scans firmware then leaves out the scans' free-space grids.
    println!("cargo:rustc-check-cfg=cfg(hh_small_ram)");
    let target = env::var("TARGET").unwrap_or_default();
    let layout = if target.starts_with("thumbv6m-") {
        println!("cargo:rustc-cfg=hh_small_ram");
        MICROBIT
    } else if target.starts_with("thumbv7em-") {
        MPS2_AN386
    } else if target.starts_with("riscv32") && target.ends_with("-none-elf") {
        RISCV32
    } else {
        // The host, or a target the examples do not support: nothing to link.
        return;
    };

    let out = PathBuf::from(env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    fs::write(out.join("hh-board.x"), layout).expect("write hh-board.x");
    println!("cargo:rustc-link-search={}", out.display());

    // cortex-m-rt's and riscv-rt's `link.x` include `memory.x`; `defmt.x`
    // places the log strings.
    println!("cargo:rustc-link-arg-examples=-Tlink.x");
    println!("cargo:rustc-link-arg-examples=-Tdefmt.x");
}
