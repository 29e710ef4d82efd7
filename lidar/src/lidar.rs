//! A parser and an assembler together: bytes in, revolutions out.

use crate::parser::{Layout, Parser};
use crate::revolution::{Assembler, Revolution};

/// Bytes → revolutions for protocol `L` (parser buffer `CAP` bytes,
/// `N` bins a revolution). [`push`](Self::push) a byte at a time (from a
/// UART interrupt, a DMA buffer, a capture file); when it returns `true`,
/// [`revolution`](Self::revolution) is the completed turn. A
/// [`Driver`](crate::Driver) does this over a reader.
#[derive(Clone, Debug)]
pub struct Lidar<L, const CAP: usize, const N: usize> {
    parser: Parser<L, CAP>,
    assembler: Assembler<N>,
    /// The next point to take from the parser's current packet.
    next_point: Option<usize>,
}

impl<L: Layout, const CAP: usize, const N: usize> Lidar<L, CAP, N> {
    /// `parser`'s packets into revolutions with returns at or beyond
    /// `max_range` metres treated as "no return".
    pub const fn new(parser: Parser<L, CAP>, max_range: f32) -> Self {
        const {
            assert!(
                CAP > L::MAX_LEN,
                "the parser's buffer must hold one byte more than the longest packet"
            )
        };
        Self {
            parser,
            assembler: Assembler::new(L::DIRECTION, max_range),
            next_point: None,
        }
    }

    /// The parser (its counters).
    pub const fn parser(&self) -> &Parser<L, CAP> {
        &self.parser
    }

    /// The assembler (its counters).
    pub const fn assembler(&self) -> &Assembler<N> {
        &self.assembler
    }

    /// Feeds one byte; `true` when a revolution is complete (read it with
    /// [`revolution`](Self::revolution) before the next call).
    pub fn push(&mut self, byte: u8) -> bool {
        self.parser.append(byte);
        self.step()
    }

    /// Goes on with the bytes already given, without a new one; `true` when
    /// a revolution is complete. Call it until `false` at the end of a
    /// stream (packets found inside a rejected candidate come out late).
    pub fn step(&mut self) -> bool {
        loop {
            if let Some(mut i) = self.next_point {
                if let Some(packet) = self.parser.current() {
                    while let Some(point) = packet.point(i) {
                        i += 1;
                        if self.assembler.add(point) {
                            self.next_point = Some(i);
                            return true;
                        }
                    }
                }
                self.next_point = None;
            }
            if self.parser.poll().is_none() {
                return false;
            }
            self.next_point = Some(0);
        }
    }

    /// The revolution completed last, until the next
    /// [`push`](Self::push) or [`step`](Self::step).
    pub fn revolution(&self) -> Option<Revolution<'_, N>> {
        self.assembler.revolution()
    }
}
