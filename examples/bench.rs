//! Firmware benchmark: instructions, stack, state and flash of one
//! configuration, measured under QEMU by `tools/budgets` (`bash
//! tools/budgets.sh`).
//!
//! The configuration is fixed at build time from the environment (default
//! 128² and `N_THETA` = 360):
//!
//! ```text
//! HH_BENCH_SIDE=256 HH_BENCH_N_THETA=360 \
//!     cargo build --release -p hough-heading --example bench --target thumbv7em-none-eabihf
//! ```
//!
//! Two `SIDE × SIDE` room outlines live in flash, the second turned by 30° and
//! shifted. The program measures, between the marker functions
//! [`hh_bench_start`] and [`hh_bench_stop`] (which the `qemu-icount` plugin
//! watches): nothing (the markers' own overhead), preparing the reference, one
//! estimate against it (`Mode::Improved` as built: with the verification by
//! alignment), the bare vote loop over θ ∈ [0, π) (`vote_column_pair`, as the
//! estimator runs it), the same estimate with `with_verification(false)`,
//! with the scale search (verified as well), and two estimates on a pair of
//! scattered cells that defeats the branch and bound's pruning, cut by work
//! budgets of 2¹⁹ and 2²⁰ grid rows (`Thresholds::search_budget`): their
//! difference is what one budget row costs. Before each it logs
//! `bench <what> sp=<stack pointer> votes=<votes>`; the plugin reports the
//! instruction count and the lowest stack address written. It exits with 0 when
//! every estimate is right (and the verified ones were verified, the
//! unverified one not), [`support::EXIT_WRONG_ESTIMATE`] when not, and
//! [`EXIT_DOES_NOT_FIT`] when the estimator's state cannot fit the RAM below
//! the stack pointer.
//!
//! The `config` line gives the state: `size_of` the estimator and the
//! reference, and of the part that only the verification needs: the grid the
//! reference keeps (`size_of` a grid; the verification builds its pyramid on
//! its own stack).
//!
//! With `HH_BENCH_BASELINE=1` the same program is built without calling the
//! library and without the grids (every value it would log is a `black_box`),
//! so that the flash of the library's part is the difference of the two builds
//! minus the grids.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(target_os = "none")]
mod support;

#[cfg(target_os = "none")]
mod firmware {
    use core::hint::black_box;
    use core::mem::size_of;

    use hough_heading::{
        config::half_turn_steps, config::rho_bins, config::row_words, estimator, grid, reference,
        stages::vote_column, stages::vote_column_pair, stages::Column, Angle, Estimate, Grid, Mode,
        ScaleRange, Status, Thresholds,
    };

    use crate::support::room::{room_words, Pose};
    use crate::support::{self, ScopePin};

    /// Image side, cells (`HH_BENCH_SIDE`).
    const SIDE: usize = parse_or(option_env!("HH_BENCH_SIDE"), 128);
    /// θ steps over the full circle (`HH_BENCH_N_THETA`).
    const N_THETA: usize = parse_or(option_env!("HH_BENCH_N_THETA"), 360);
    /// Build without the library, for the flash difference (`HH_BENCH_BASELINE=1`).
    const BASELINE: bool = parse_or(option_env!("HH_BENCH_BASELINE"), 0) != 0;
    /// Voted θ columns.
    const HALF: usize = half_turn_steps(N_THETA);
    /// ρ bins of a column.
    const RHO: usize = rho_bins(SIDE, SIDE);
    /// Row words of a grid.
    const RW: usize = row_words(SIDE);
    /// The rotation between the two grids, degrees.
    const TURN_DEGREES: i32 = 30;
    /// Largest accepted error, millidegrees.
    const TOLERANCE_MDEG: i32 = 1_000;
    /// Exit status when the estimator's state does not fit in RAM.
    const EXIT_DOES_NOT_FIT: i32 = 3;
    /// Start of RAM on both QEMU boards (`mps2-an386`, `microbit`).
    const RAM_ORIGIN: u32 = 0x2000_0000;

    type Estimator = estimator!(SIDE, SIDE, N_THETA);
    type Reference = reference!(SIDE, SIDE, N_THETA);
    type BenchGrid = grid!(SIDE, SIDE);

    static FIRST: BenchGrid = Grid::from_words(room_words::<SIDE, SIDE, RW>(Pose::ORIGIN));
    static SECOND: BenchGrid = Grid::from_words(room_words::<SIDE, SIDE, RW>(Pose {
        degrees: TURN_DEGREES as f64,
        dx: 3.0,
        dy: -2.0,
    }));

    /// Work budgets (grid rows per sampled point) of the two cut estimates
    /// on [`SCATTERED`]: the difference of their instructions over the
    /// difference of these is what one budget row costs. Each is logged
    /// (`budget <what> rows=<budget>`) for the budget tool.
    const CUT_BUDGETS: [u32; 2] = [1 << 19, 1 << 20];

    /// Scattered single cells (one in 27) away from the border, and the
    /// second view a copy shifted by (3, −2) cells with every fourth cell
    /// put elsewhere: every block of translations reaches occupied cells, so
    /// the branch and bound cannot prune and explores until its budget runs
    /// out (the host's `work_budget.rs` builds the same kind of pair).
    static SCATTERED: [BenchGrid; 2] = [
        Grid::from_words(scattered_words(false)),
        Grid::from_words(scattered_words(true)),
    ];

    /// The rows of one view of [`SCATTERED`] (xorshift32 draws).
    const fn scattered_words(second: bool) -> [[u32; RW]; SIDE] {
        let mut rows = [[0u32; RW]; SIDE];
        let mut draws = [0usize; 4];
        let mut state: u32 = 0x2545_F491;
        let mut i = 0;
        while i < SIDE * SIDE / 27 {
            let mut d = 0;
            while d < draws.len() {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                draws[d] = state as usize;
                d += 1;
            }
            let (c, r) = (8 + draws[0] % (SIDE - 16), 8 + draws[1] % (SIDE - 16));
            let elsewhere = (draws[2] % SIDE, draws[3] % SIDE);
            let (c, r) = match (second, i % 4 == 3) {
                (false, _) => (c, r),
                (true, true) => elsewhere,
                (true, false) => (c + 3, r - 2),
            };
            rows[r][c / 32] |= 1 << (c % 32);
            i += 1;
        }
        rows
    }

    /// Start marker: the plugin latches its instruction counter here. The
    /// `black_box` keeps the call (the optimiser cannot see that it does
    /// nothing), and its different constant keeps the two markers from being
    /// merged into one function.
    #[inline(never)]
    pub fn hh_bench_start() {
        black_box(1u32);
    }

    /// Stop marker: the plugin prints the count since [`hh_bench_start`].
    #[inline(never)]
    pub fn hh_bench_stop() {
        black_box(2u32);
    }

    /// Runs `work` between the two markers.
    #[inline(never)]
    fn measure<T>(work: impl FnOnce() -> T) -> T {
        hh_bench_start();
        let out = work();
        hh_bench_stop();
        out
    }

    /// One estimate between the markers: every measured estimate goes
    /// through this one function, so that the library's code is inlined
    /// alike in each (more call sites of `estimate` in the program changed
    /// its inlining, and so its measured stack, by about 100 B).
    #[inline(never)]
    fn measured_estimate(
        estimator: &mut Estimator,
        reference: &Reference,
        grid: &BenchGrid,
    ) -> Estimate {
        measure(|| estimator.estimate(reference, grid))
    }

    /// The stack pointer (on RISC-V, which is only built, an address in the
    /// current frame).
    #[inline(always)]
    fn stack_pointer() -> u32 {
        #[cfg(target_arch = "arm")]
        return cortex_m::register::msp::read();
        #[cfg(not(target_arch = "arm"))]
        {
            let probe = 0u32;
            core::ptr::from_ref(black_box(&probe)) as usize as u32
        }
    }

    /// Logs what is measured next: the budget tool pairs this line with the
    /// plugin's count.
    fn announce(what: &str, votes: u32) {
        defmt::println!(
            "bench {=str} sp={=u32} votes={=u32}",
            what,
            stack_pointer(),
            votes
        );
    }

    /// Whether `estimate` went through the verification by alignment: a
    /// positive overlap and an alignment on every candidate (none without).
    fn verified(estimate: &Estimate) -> bool {
        estimate.overlap > 0
            && !estimate.candidates.is_empty()
            && estimate.candidates.iter().all(|c| c.alignment.is_some())
    }

    /// Whether `estimate` is an unverified one: no overlap, no alignments.
    fn unverified(estimate: &Estimate) -> bool {
        estimate.overlap == 0 && estimate.candidates.iter().all(|c| c.alignment.is_none())
    }

    /// The estimate and what the run saw of it.
    struct Outcome {
        alpha: Angle,
        status: &'static str,
        pin_edges: u32,
    }

    /// The measured runs, with the library.
    fn run() -> Outcome {
        let mut pin = ScopePin::default();
        let mut estimator = Estimator::new(Mode::Improved);
        let first_votes = FIRST.occupied() * HALF as u32;
        let second_votes = SECOND.occupied() * HALF as u32;

        announce("overhead", 0);
        measure(|| ());

        announce("reference", first_votes);
        let mut reference = Reference::empty(Mode::Improved.peak_kind());
        measure(|| prepare(&mut estimator, &FIRST, &mut reference));

        // As built, the improved mode verifies by alignment.
        let verifies = estimator.verification();
        announce("estimate", second_votes);
        let Ok(estimate) = support::timed(&mut pin, || {
            measured_estimate(&mut estimator, &reference, &SECOND)
        });

        // The estimator's vote primitives: two θ columns per pass over the
        // grid, and one for the last column when HALF is odd.
        let mut columns: [Column<RHO>; 2] = [[0; RHO]; 2];
        announce("votes", second_votes);
        measure(|| {
            for k in (0..HALF - 1).step_by(2) {
                vote_column_pair::<SIDE, SIDE, RW, N_THETA, RHO>(&SECOND, k, &mut columns);
            }
            if HALF % 2 == 1 {
                let [first, _] = &mut columns;
                vote_column::<SIDE, SIDE, RW, N_THETA, RHO>(&SECOND, HALF - 1, first);
            }
        });
        black_box(&columns);

        // The same estimate without the verification: the difference is
        // the verification's cost.
        // (Assigned back to the same binding: a new one would be a second
        // copy of the estimator in this frame, which the M0 cannot spare.)
        estimator = estimator.with_verification(false);
        announce("unverified", second_votes);
        let plain = measured_estimate(&mut estimator, &reference, &SECOND);
        let plain_right =
            support::error_millidegrees(plain.alpha, support::angle_of_degrees(TURN_DEGREES)).abs()
                <= TOLERANCE_MDEG;

        // The same estimate with the scale search (the scenes have s = 1),
        // as configured by a user (verification on): its extra cost over the
        // first estimate is the scale search's.
        estimator = estimator.with_verification(true);
        estimator.set_scale_search(Some(ScaleRange::DEFAULT));
        announce("scaled", second_votes);
        let scaled = measured_estimate(&mut estimator, &reference, &SECOND);
        let scale_right =
            support::error_millidegrees(scaled.alpha, support::angle_of_degrees(TURN_DEGREES))
                .abs()
                <= TOLERANCE_MDEG
                && scaled
                    .translation
                    .is_some_and(|t| (t.scale.to_bits() - (1 << 16)).abs() <= 1 << 11);

        let cut_both = measure_cuts(&mut estimator, &mut reference);

        let consistent = verifies
            && verified(&estimate)
            && unverified(&plain)
            && plain_right
            && verified(&scaled)
            && scale_right
            && cut_both;
        defmt::println!(
            "checks verified={=bool} unverified={=bool} plain_alpha_mdeg={=i32} scale={=bool} scaled_verified={=bool} cut={=bool} overlap_permille={=i32}",
            verifies && verified(&estimate),
            unverified(&plain),
            support::millidegrees(plain.alpha),
            scale_right,
            verified(&scaled),
            cut_both,
            ((i64::from(estimate.overlap.to_bits()) * 1000) >> 16) as i32
        );
        Outcome {
            // A wrong scale, an unverified estimate or a wrong one without
            // the verification makes the run fail like a wrong angle.
            alpha: if consistent {
                estimate.alpha
            } else {
                estimate.alpha + Angle::HALF_TURN
            },
            status: support::status_name(estimate.status),
            pin_edges: pin.rising_edges(),
        }
    }

    /// The estimates on [`SCATTERED`] cut by each of [`CUT_BUDGETS`]; whether
    /// both said so (their difference is then search work only). Not
    /// inlined, and reusing the caller's estimator and reference, so that
    /// the measured runs before it keep their frames (a second reference
    /// would not fit the M0).
    #[inline(never)]
    fn measure_cuts(estimator: &mut Estimator, reference: &mut Reference) -> bool {
        let [first, second] = &SCATTERED;
        estimator.set_scale_search(None);
        prepare(estimator, first, reference);
        let mut cut_both = true;
        for (what, budget) in [("cut-small", CUT_BUDGETS[0]), ("cut-large", CUT_BUDGETS[1])] {
            estimator.set_thresholds(Thresholds {
                search_budget: budget,
                ..Thresholds::DEFAULT
            });
            defmt::println!("budget {=str} rows={=u32}", what, budget);
            announce(what, second.occupied() * HALF as u32);
            let cut = measured_estimate(estimator, reference, second);
            cut_both &= cut.status == Status::SearchCut;
        }
        cut_both
    }

    /// Makes `reference` the reference of `grid`, in place (as a firmware
    /// short of RAM does: no second reference on the stack): every
    /// reference of the bench is prepared through this one function, so
    /// that the library's code for it is linked once (two inlined call
    /// sites cost 4 KiB of flash) and its scratch stays in this frame,
    /// popped before the next estimate.
    #[inline(never)]
    fn prepare(estimator: &mut Estimator, grid: &BenchGrid, reference: &mut Reference) {
        estimator.reference_in_place(grid, reference);
    }

    /// The same runs and logs without the library and the grids.
    fn run_baseline() -> Outcome {
        let mut pin = ScopePin::default();
        for what in [
            "overhead",
            "reference",
            "estimate",
            "votes",
            "unverified",
            "scaled",
            "cut-small",
            "cut-large",
        ] {
            announce(what, black_box(0));
            let Ok(()) = support::timed(&mut pin, || measure(|| black_box(())));
        }
        Outcome {
            alpha: Angle(black_box(0)),
            status: black_box("baseline"),
            pin_edges: pin.rising_edges(),
        }
    }

    #[cfg_attr(target_arch = "arm", cortex_m_rt::entry)]
    #[cfg_attr(target_arch = "riscv32", riscv_rt::entry)]
    fn main() -> ! {
        let state = size_of::<Estimator>() + size_of::<Reference>();
        defmt::println!(
            "config side={=usize} n_theta={=usize} estimator={=usize} reference={=usize} reference_grid={=usize}",
            SIDE,
            N_THETA,
            size_of::<Estimator>(),
            size_of::<Reference>(),
            size_of::<BenchGrid>()
        );
        if state as u32 > stack_pointer().saturating_sub(RAM_ORIGIN) {
            defmt::println!("does-not-fit state={=usize}", state);
            support::exit(EXIT_DOES_NOT_FIT);
        }

        let outcome = if BASELINE { run_baseline() } else { run() };

        let error =
            support::error_millidegrees(outcome.alpha, support::angle_of_degrees(TURN_DEGREES));
        defmt::println!(
            "result alpha_mdeg={=i32} error_mdeg={=i32} status={=str} pin_edges={=u32}",
            support::millidegrees(outcome.alpha),
            error,
            outcome.status,
            outcome.pin_edges
        );
        support::exit(if error.abs() <= TOLERANCE_MDEG {
            0
        } else {
            support::EXIT_WRONG_ESTIMATE
        })
    }

    /// `text` parsed as a decimal number, or `default` when absent.
    const fn parse_or(text: Option<&str>, default: usize) -> usize {
        let Some(text) = text else { return default };
        let bytes = text.as_bytes();
        assert!(!bytes.is_empty(), "empty number in HH_BENCH_*");
        let mut value = 0;
        let mut i = 0;
        while i < bytes.len() {
            assert!(
                bytes[i].is_ascii_digit(),
                "HH_BENCH_* must be a decimal number"
            );
            value = value * 10 + (bytes[i] - b'0') as usize;
            i += 1;
        }
        value
    }
}

/// On the host this example does nothing: it is firmware.
#[cfg(not(target_os = "none"))]
fn main() {
    println!("bench is firmware: see tools/budgets.sh");
}
