//! `qemu-icount`: a QEMU TCG plugin that counts, exactly, the guest
//! instructions executed between two marker addresses.
//!
//! The firmware calls two `#[inline(never)]` marker functions around the code
//! to measure (`hh_bench_start()` / `hh_bench_stop()` in `examples/bench.rs`).
//! The caller passes their addresses, found in the ELF's symbol table, as plugin
//! arguments:
//!
//! ```text
//! qemu-system-arm ... -plugin target/tools/debug/libqemu_icount.so,start=0x1234,stop=0x1240
//! ```
//!
//! Every translated guest instruction gets an inline "add 1" on a per-vCPU
//! counter (a scoreboard entry: no helper call, so the count costs little time).
//! When the instruction at `start` executes the counter is latched; when the one
//! at `stop` executes the plugin prints `hh-icount <n>` (see below), `n`
//! being the number of instructions executed from the first instruction of the
//! start marker (excluded) up to the first instruction of the stop marker
//! (included). The count is the same on every run: it does not depend on the
//! host, on timing or on TB chaining, since every executed instruction is
//! counted individually (a conditional instruction skipped inside an IT block
//! counts as executed). Checked against QEMU's own `-d exec,nochain` trace
//! with `-accel tcg,one-insn-per-tb=on`: identical counts.
//!
//! With `stack_lo=<addr>,stack_hi=<addr>` (the stack region, e.g. `_stack_end`
//! and `_stack_start` of cortex-m-rt) the plugin also watches every guest store
//! and reports the lowest stack address written between the markers: the stack
//! high-water mark of the measured code, exact to the byte (what a painted
//! stack approximates on hardware). The line is then
//! `hh-icount <n> stack_low=0x<addr>` (`stack_low=none` if nothing was written
//! there).
//!
//! Output goes to standard error, one line per start/stop pair, so that it
//! never mixes with `defmt` frames, which the firmware sends to standard output.
//!
//! With `profile=<file>` the plugin also counts every guest instruction
//! address on its own (one more inline counter per instruction, in a second
//! scoreboard) and appends to `<file>`, for each start/stop pair, a line
//! `region <k> <n>` (`k` from 0, `n` the count above) followed by one line
//! `<address> <executions>` per instruction executed between the markers: an
//! exact flat profile, which `budgets profile` maps to the library's functions
//! and source lines (what `callgrind --toggle-collect` gives on the host).
//!
//! QEMU 10.0 speaks plugin API version 4; the bindings come from
//! `qemu-plugin-sys` (Debian's QEMU ships no plugin headers).

use std::collections::HashMap;
use std::ffi::{c_char, c_int, c_uint, c_void, CStr};
use std::io::Write;
use std::ptr;
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, Ordering};
use std::sync::Mutex;

use qemu_plugin_sys::{
    qemu_info_t, qemu_plugin_cb_flags, qemu_plugin_id_t, qemu_plugin_insn_vaddr,
    qemu_plugin_mem_rw, qemu_plugin_meminfo_t, qemu_plugin_op, qemu_plugin_register_atexit_cb,
    qemu_plugin_register_vcpu_insn_exec_cb, qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu,
    qemu_plugin_register_vcpu_mem_cb, qemu_plugin_register_vcpu_tb_trans_cb,
    qemu_plugin_scoreboard, qemu_plugin_scoreboard_new, qemu_plugin_tb, qemu_plugin_tb_get_insn,
    qemu_plugin_tb_n_insns, qemu_plugin_u64, qemu_plugin_u64_get, QEMU_PLUGIN_VERSION,
};

/// The plugin API version this plugin was built against; QEMU refuses to load
/// a plugin whose version it does not support.
#[no_mangle]
pub static qemu_plugin_version: c_int = QEMU_PLUGIN_VERSION as c_int;

/// Guest address of the start marker's first instruction.
static START_ADDR: AtomicU64 = AtomicU64::new(u64::MAX);
/// Guest address of the stop marker's first instruction.
static STOP_ADDR: AtomicU64 = AtomicU64::new(u64::MAX);
/// Per-vCPU instruction counters (one `u64` per vCPU).
static SCOREBOARD: AtomicPtr<qemu_plugin_scoreboard> = AtomicPtr::new(ptr::null_mut());
/// Counter value latched when the start marker executed.
static LATCHED: AtomicU64 = AtomicU64::new(0);
/// Whether a start marker executed with no stop marker after it yet.
static RUNNING: AtomicBool = AtomicBool::new(false);
/// Stack region `[STACK_LO, STACK_HI)` watched for stores; empty when not asked.
static STACK_LO: AtomicU64 = AtomicU64::new(0);
/// End of the watched stack region (exclusive).
static STACK_HI: AtomicU64 = AtomicU64::new(0);
/// Lowest stack address stored to since the start marker (`u64::MAX`: none).
static STACK_LOW: AtomicU64 = AtomicU64::new(u64::MAX);

/// Most distinct instruction addresses the profile counts (8 bytes each per
/// vCPU; a firmware's code is far smaller).
const PROFILE_SLOTS: usize = 1 << 18;

/// The flat profile, when `profile=<file>` was given.
struct Profile {
    /// Where the regions are appended.
    path: String,
    /// Per-vCPU counters, one `u64` per profiled instruction address.
    scoreboard: *mut qemu_plugin_scoreboard,
    /// Instruction address → counter slot.
    slots: HashMap<u64, usize>,
    /// The counters' values when the start marker executed (vCPU 0).
    latched: Vec<u64>,
    /// Regions written so far.
    regions: usize,
}

// SAFETY: the scoreboard pointer is only handed back to QEMU's API, which
// may be called from any vCPU thread; the profile sits behind a mutex.
unsafe impl Send for Profile {}

/// The profile, if asked for.
static PROFILE: Mutex<Option<Profile>> = Mutex::new(None);

/// The counter of profile slot `slot`.
fn slot_counter(scoreboard: *mut qemu_plugin_scoreboard, slot: usize) -> qemu_plugin_u64 {
    qemu_plugin_u64 {
        score: scoreboard,
        offset: slot * std::mem::size_of::<u64>(),
    }
}

/// The profile counters of vCPU `vcpu`, slots `0..used`.
fn profile_counts(profile: &Profile, vcpu: c_uint, used: usize) -> Vec<u64> {
    (0..used)
        // SAFETY: the scoreboard lives for the whole run; every slot is
        // within the entry size it was created with.
        .map(|slot| unsafe { qemu_plugin_u64_get(slot_counter(profile.scoreboard, slot), vcpu) })
        .collect()
}

/// Latches the profile counters at the start marker.
fn profile_start(vcpu: c_uint) {
    let Ok(mut guard) = PROFILE.lock() else {
        return;
    };
    if let Some(profile) = guard.as_mut() {
        let used = profile.slots.len();
        profile.latched = profile_counts(profile, vcpu, used);
    }
}

/// Appends the region that just ended to the profile file.
fn profile_stop(vcpu: c_uint, count: u64) {
    let Ok(mut guard) = PROFILE.lock() else {
        return;
    };
    let Some(profile) = guard.as_mut() else {
        return;
    };
    let now = profile_counts(profile, vcpu, profile.slots.len());
    let mut lines: Vec<(u64, u64)> = profile
        .slots
        .iter()
        .filter_map(|(&addr, &slot)| {
            let before = profile.latched.get(slot).copied().unwrap_or(0);
            let n = now.get(slot).copied().unwrap_or(0).wrapping_sub(before);
            (n > 0).then_some((addr, n))
        })
        .collect();
    lines.sort_unstable();
    let mut text = format!("region {} {count}\n", profile.regions);
    for (addr, n) in lines {
        text.push_str(&format!("{addr:#x} {n}\n"));
    }
    profile.regions += 1;
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&profile.path)
        .and_then(|mut f| f.write_all(text.as_bytes()));
    if let Err(e) = written {
        emit(&format!("hh-icount error: profile {}: {e}", profile.path));
    }
}

/// The profile counter of the instruction at `vaddr`, allocating a slot on
/// its first translation; `None` without a profile or when the slots ran out.
fn profile_slot(vaddr: u64) -> Option<qemu_plugin_u64> {
    let mut guard = PROFILE.lock().ok()?;
    let profile = guard.as_mut()?;
    let next = profile.slots.len();
    let slot = *profile.slots.entry(vaddr).or_insert(next);
    if slot >= PROFILE_SLOTS {
        profile.slots.remove(&vaddr);
        return None;
    }
    Some(slot_counter(profile.scoreboard, slot))
}

/// The scoreboard entry holding the instruction counter.
fn counter() -> qemu_plugin_u64 {
    qemu_plugin_u64 {
        score: SCOREBOARD.load(Ordering::Relaxed),
        offset: 0,
    }
}

/// Prints one line on standard error and flushes it.
fn emit(line: &str) {
    let mut out = std::io::stderr().lock();
    // A failed write cannot be reported anywhere better; the budget script
    // notices the missing line.
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}

/// Parses an unsigned integer given in decimal or with a `0x` prefix.
fn parse_addr(text: &str) -> Option<u64> {
    match text.strip_prefix("0x").or_else(|| text.strip_prefix("0X")) {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => text.parse().ok(),
    }
}

/// Runs when the start marker's first instruction executes.
unsafe extern "C" fn on_start(vcpu: c_uint, _: *mut c_void) {
    // SAFETY: the scoreboard was created in `qemu_plugin_install` and is never freed.
    let now = unsafe { qemu_plugin_u64_get(counter(), vcpu) };
    LATCHED.store(now, Ordering::Relaxed);
    STACK_LOW.store(u64::MAX, Ordering::Relaxed);
    profile_start(vcpu);
    RUNNING.store(true, Ordering::Relaxed);
}

/// Runs when the stop marker's first instruction executes.
unsafe extern "C" fn on_stop(vcpu: c_uint, _: *mut c_void) {
    if !RUNNING.swap(false, Ordering::Relaxed) {
        emit("hh-icount error: stop marker without start marker");
        return;
    }
    // SAFETY: as in `on_start`.
    let now = unsafe { qemu_plugin_u64_get(counter(), vcpu) };
    let count = now - LATCHED.load(Ordering::Relaxed);
    profile_stop(vcpu, count);
    if STACK_HI.load(Ordering::Relaxed) == 0 {
        emit(&format!("hh-icount {count}"));
    } else {
        match STACK_LOW.load(Ordering::Relaxed) {
            u64::MAX => emit(&format!("hh-icount {count} stack_low=none")),
            low => emit(&format!("hh-icount {count} stack_low={low:#x}")),
        }
    }
}

/// Runs after every guest store when the stack region is watched.
unsafe extern "C" fn on_store(_: c_uint, _: qemu_plugin_meminfo_t, vaddr: u64, _: *mut c_void) {
    if RUNNING.load(Ordering::Relaxed)
        && (STACK_LO.load(Ordering::Relaxed)..STACK_HI.load(Ordering::Relaxed)).contains(&vaddr)
    {
        STACK_LOW.fetch_min(vaddr, Ordering::Relaxed);
    }
}

/// Instruments every instruction of a freshly translated block.
unsafe extern "C" fn on_translate(_: qemu_plugin_id_t, tb: *mut qemu_plugin_tb) {
    let start = START_ADDR.load(Ordering::Relaxed);
    let stop = STOP_ADDR.load(Ordering::Relaxed);
    let watch_stack = STACK_HI.load(Ordering::Relaxed) != 0;
    // SAFETY: `tb` and the instructions it hands out are valid for the duration
    // of this translation callback, which is where QEMU allows instrumenting them.
    unsafe {
        for i in 0..qemu_plugin_tb_n_insns(tb) {
            let insn = qemu_plugin_tb_get_insn(tb, i);
            qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu(
                insn,
                qemu_plugin_op::QEMU_PLUGIN_INLINE_ADD_U64,
                counter(),
                1,
            );
            if let Some(entry) = profile_slot(qemu_plugin_insn_vaddr(insn)) {
                qemu_plugin_register_vcpu_insn_exec_inline_per_vcpu(
                    insn,
                    qemu_plugin_op::QEMU_PLUGIN_INLINE_ADD_U64,
                    entry,
                    1,
                );
            }
            if watch_stack {
                qemu_plugin_register_vcpu_mem_cb(
                    insn,
                    Some(on_store),
                    qemu_plugin_cb_flags::QEMU_PLUGIN_CB_NO_REGS,
                    qemu_plugin_mem_rw::QEMU_PLUGIN_MEM_W,
                    ptr::null_mut(),
                );
            }
            let vaddr = qemu_plugin_insn_vaddr(insn);
            let marker: Option<unsafe extern "C" fn(c_uint, *mut c_void)> = if vaddr == start {
                Some(on_start)
            } else if vaddr == stop {
                Some(on_stop)
            } else {
                None
            };
            if marker.is_some() {
                qemu_plugin_register_vcpu_insn_exec_cb(
                    insn,
                    marker,
                    qemu_plugin_cb_flags::QEMU_PLUGIN_CB_NO_REGS,
                    ptr::null_mut(),
                );
            }
        }
    }
}

/// Warns when the guest stopped between a start and a stop marker.
unsafe extern "C" fn on_exit(_: qemu_plugin_id_t, _: *mut c_void) {
    if RUNNING.load(Ordering::Relaxed) {
        emit("hh-icount error: exit between start and stop markers");
    }
}

/// Entry point called by QEMU when it loads the plugin.
///
/// Arguments: `start=<addr>` and `stop=<addr>` (decimal or `0x` hex), and
/// optionally `stack_lo=<addr>,stack_hi=<addr>` and `profile=<file>`. Returns non-zero, which makes
/// QEMU refuse to start, when an argument is unknown or a marker is missing.
///
/// # Safety
///
/// Called by QEMU only, with `argv` holding `argc` valid C strings.
#[no_mangle]
pub unsafe extern "C" fn qemu_plugin_install(
    id: qemu_plugin_id_t,
    _info: *const qemu_info_t,
    argc: c_int,
    argv: *mut *mut c_char,
) -> c_int {
    let mut have = (false, false);
    let mut profile = None;
    for i in 0..usize::try_from(argc).unwrap_or(0) {
        // SAFETY: QEMU passes `argc` NUL-terminated strings.
        let arg = unsafe { CStr::from_ptr(*argv.add(i)) }.to_string_lossy();
        if let Some(path) = arg.strip_prefix("profile=") {
            profile = Some(path.to_string());
            continue;
        }
        let parsed = arg
            .split_once('=')
            .and_then(|(k, v)| Some((k, parse_addr(v)?)));
        match parsed {
            Some(("start", addr)) => {
                START_ADDR.store(addr & !1, Ordering::Relaxed);
                have.0 = true;
            }
            Some(("stop", addr)) => {
                STOP_ADDR.store(addr & !1, Ordering::Relaxed);
                have.1 = true;
            }
            Some(("stack_lo", addr)) => STACK_LO.store(addr, Ordering::Relaxed),
            Some(("stack_hi", addr)) => STACK_HI.store(addr, Ordering::Relaxed),
            _ => {
                eprintln!(
                    "qemu-icount: unknown argument `{arg}` \
                     (expected start=, stop=, stack_lo=, stack_hi= with an address, or profile=FILE)"
                );
                return 1;
            }
        }
    }
    if have != (true, true) {
        eprintln!("qemu-icount: both start=ADDR and stop=ADDR are required");
        return 1;
    }
    // SAFETY: plain calls into QEMU's plugin API from the install hook.
    unsafe {
        SCOREBOARD.store(
            qemu_plugin_scoreboard_new(std::mem::size_of::<u64>()),
            Ordering::Relaxed,
        );
        if let Some(path) = profile {
            // A fresh file: `profile_stop` appends.
            if let Err(e) = std::fs::write(&path, "") {
                eprintln!("qemu-icount: profile file {path}: {e}");
                return 1;
            }
            let scoreboard = qemu_plugin_scoreboard_new(PROFILE_SLOTS * std::mem::size_of::<u64>());
            if let Ok(mut guard) = PROFILE.lock() {
                *guard = Some(Profile {
                    path,
                    scoreboard,
                    slots: HashMap::new(),
                    latched: Vec::new(),
                    regions: 0,
                });
            }
        }
        qemu_plugin_register_vcpu_tb_trans_cb(id, Some(on_translate));
        qemu_plugin_register_atexit_cb(id, Some(on_exit), ptr::null_mut());
    }
    0
}

#[cfg(test)]
mod tests {
    use super::parse_addr;

    #[test]
    fn parses_hex_and_decimal_addresses() {
        assert_eq!(parse_addr("0x1f00"), Some(0x1f00));
        assert_eq!(parse_addr("0X10"), Some(16));
        assert_eq!(parse_addr("4096"), Some(4096));
        assert_eq!(parse_addr("0xzz"), None);
    }
}
