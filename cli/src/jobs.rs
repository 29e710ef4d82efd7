//! Spreading independent estimates over threads (`--jobs N`), with the
//! results in input order.
//!
//! Each worker owns its state (an engine: grids and estimators); the items
//! of a batch go to whichever worker is free, and [`Workers::map`] returns
//! the results in the items' order. The commands estimate in batches of
//! [`Workers::batch`] items and emit each batch in order (output lines,
//! messages, summaries, chained trajectories), so what they print is the
//! same for every number of threads, and the memory stays bounded on long
//! inputs. One thread is the plain loop on the calling thread.

use std::num::NonZeroUsize;
use std::sync::atomic::{AtomicUsize, Ordering};

use clap::Args;

/// Stack of the worker threads: the 256² × 720 configuration keeps its
/// grids and scratch on the stack (the calling thread, the main thread, has
/// the system's default, usually 8 MiB; pages are only committed when used).
pub const STACK_BYTES: usize = 64 << 20;

/// Items per thread in one batch: enough that the threads rarely wait for
/// each other at the end of a batch, few enough to keep the memory small.
pub const BATCH_PER_THREAD: usize = 64;

/// `--jobs N`.
#[derive(Clone, Copy, Debug, Default, Args)]
pub struct JobsArgs {
    /// Threads estimating pairs; 0 or not given: every core. The output is
    /// the same, line for line, for any N (`--jobs 1`: one thread).
    #[arg(long, short = 'j', value_name = "N")]
    pub jobs: Option<usize>,
}

impl JobsArgs {
    /// The number of threads: `--jobs`, or every core
    /// (`std::thread::available_parallelism`, 1 when unknown).
    pub fn threads(&self) -> usize {
        match self.jobs {
            Some(n) if n > 0 => n,
            _ => std::thread::available_parallelism().map_or(1, NonZeroUsize::get),
        }
    }
}

/// One state per thread (e.g. an engine each).
#[derive(Debug)]
pub struct Workers<S> {
    states: Vec<S>,
}

impl<S: Send> Workers<S> {
    /// `threads` workers (at least one), each with a state from `make`.
    ///
    /// # Errors
    /// The first error of `make`.
    pub fn new<E>(threads: usize, mut make: impl FnMut() -> Result<S, E>) -> Result<Self, E> {
        let states = (0..threads.max(1))
            .map(|_| make())
            .collect::<Result<_, _>>()?;
        Ok(Self { states })
    }

    /// The number of threads.
    pub fn threads(&self) -> usize {
        self.states.len()
    }

    /// Items to gather before estimating them together: one when there is
    /// one thread (the plain loop), else [`BATCH_PER_THREAD`] per thread.
    pub fn batch(&self) -> usize {
        match self.threads() {
            1 => 1,
            n => n * BATCH_PER_THREAD,
        }
    }

    /// `work(state, i, &items[i])` for every item, spread over the workers
    /// (the calling thread is one of them); the results in the order of
    /// `items`. A panic in `work` is resumed on the calling thread.
    pub fn map<T: Sync, R: Send>(
        &mut self,
        items: &[T],
        work: impl Fn(&mut S, usize, &T) -> R + Sync,
    ) -> Vec<R> {
        let threads = self.states.len().min(items.len());
        let (first, others) = self.states.split_at_mut(1);
        let first = &mut first[0];
        if threads <= 1 {
            return items
                .iter()
                .enumerate()
                .map(|(i, item)| work(first, i, item))
                .collect();
        }
        let next = AtomicUsize::new(0);
        let run = |state: &mut S| {
            let mut done = Vec::new();
            loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(item) = items.get(i) else {
                    return done;
                };
                done.push((i, work(state, i, item)));
            }
        };
        let parts: Vec<Vec<(usize, R)>> = std::thread::scope(|scope| {
            // A thread that cannot start leaves its share to the others (the
            // calling thread always runs).
            let handles: Vec<_> = others[..threads - 1]
                .iter_mut()
                .enumerate()
                .filter_map(|(k, state)| {
                    std::thread::Builder::new()
                        .name(format!("hough-heading-{}", k + 1))
                        .stack_size(STACK_BYTES)
                        .spawn_scoped(scope, || run(state))
                        .ok()
                })
                .collect();
            let mut parts = vec![run(first)];
            for handle in handles {
                match handle.join() {
                    Ok(part) => parts.push(part),
                    Err(panic) => std::panic::resume_unwind(panic),
                }
            }
            parts
        });
        let mut slots: Vec<Option<R>> = std::iter::repeat_with(|| None).take(items.len()).collect();
        for (i, value) in parts.into_iter().flatten() {
            slots[i] = Some(value);
        }
        slots
            .into_iter()
            .map(|slot| slot.expect("every item is taken by exactly one worker"))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn results_come_in_input_order_for_any_thread_count() {
        let items: Vec<u64> = (0..1000).collect();
        let expected: Vec<u64> = items.iter().map(|v| v * v + 1).collect();
        for threads in [1, 2, 3, 7] {
            let mut workers = Workers::new(threads, || Ok::<_, ()>(0usize)).unwrap();
            assert_eq!(workers.threads(), threads);
            let got = workers.map(&items, |count, i, v| {
                *count += 1;
                assert_eq!(items[i], *v);
                v * v + 1
            });
            assert_eq!(got, expected, "{threads} threads");
            // Every item was done once, by some worker.
            assert_eq!(workers.states.iter().sum::<usize>(), items.len());
        }
    }

    #[test]
    fn empty_and_single_batches() {
        let mut workers = Workers::new(4, || Ok::<_, ()>(())).unwrap();
        assert!(workers.map(&[] as &[u8], |_, _, v| *v).is_empty());
        assert_eq!(workers.map(&[5u8], |_, _, v| *v), vec![5]);
        assert_eq!(workers.batch(), 4 * BATCH_PER_THREAD);
        let one = Workers::new(0, || Ok::<_, ()>(())).unwrap();
        assert_eq!((one.threads(), one.batch()), (1, 1));
    }

    #[test]
    fn a_panic_in_a_worker_reaches_the_caller() {
        let mut workers = Workers::new(2, || Ok::<_, ()>(())).unwrap();
        let items: Vec<usize> = (0..64).collect();
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            workers.map(&items, |_, i, _| assert!(i != 40, "item 40"))
        }));
        assert!(result.is_err());
    }
}
