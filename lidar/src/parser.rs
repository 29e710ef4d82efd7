//! The byte-at-a-time framer every protocol shares: a bounded buffer that
//! holds the current candidate packet, and the resynchronisation.
//!
//! Bytes are appended one at a time ([`Parser::push`]); [`Parser::poll`]
//! then asks the protocol's [`Layout`] what the buffered bytes are, from
//! the first one: not yet enough to tell, noise (skip one byte), a
//! candidate that must be rejected (count why, skip its first byte), a
//! response descriptor (skip it), or a complete, checked packet (hand it
//! on). Skipping one byte and asking again is the resynchronisation: a
//! packet that starts inside a rejected candidate is still found, so after
//! any damage the first intact packet is decoded.
//!
//! A damaged packet is counted once: a candidate that starts inside the
//! bytes of one just rejected (a header that its damaged bytes happen to
//! spell) is rejected too but counted as a skipped byte, not as another
//! dropped packet.

use crate::counters::{bump, Counters};
use crate::point::{Direction, Point};

/// What the buffered bytes are, as seen by a protocol's [`Layout`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Frame {
    /// A packet may start here but more bytes are needed to tell.
    NeedMore,
    /// The first byte cannot start a packet: skip it.
    Noise,
    /// A candidate packet that must be dropped, and why; its first byte is
    /// skipped and the search goes on from the second.
    Reject(Reject),
    /// A response descriptor of this many bytes: skip them.
    Descriptor(usize),
    /// A complete packet of this many bytes whose framing and checksum
    /// passed.
    Packet(usize),
}

/// Why a candidate packet was dropped (the counter it goes to).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// [`Counters::bad_checksum`].
    Checksum,
    /// [`Counters::bad_framing`].
    Framing,
    /// [`Counters::out_of_range`].
    Range,
}

/// A wire protocol: how to frame, check and decode its packets.
pub trait Layout {
    /// Bytes of the longest packet or descriptor: the parser's buffer holds
    /// at least this many.
    const MAX_LEN: usize;
    /// Which way the sensor's angles grow.
    const DIRECTION: Direction;
    /// Classifies the buffered bytes, which start at a candidate's first
    /// byte (never empty).
    fn classify(&mut self, bytes: &[u8]) -> Frame;
    /// Number of points in a packet that [`classify`](Self::classify) called
    /// complete.
    fn count(&self, packet: &[u8]) -> usize;
    /// Point `i` of such a packet (`None` past the last).
    fn point(&self, packet: &[u8], i: usize) -> Option<Point>;
}

/// One checked packet, borrowed from the parser until the next
/// [`Parser::push`] or [`Parser::poll`].
#[derive(Clone, Copy, Debug)]
pub struct Packet<'a, L> {
    layout: &'a L,
    bytes: &'a [u8],
}

impl<'a, L: Layout> Packet<'a, L> {
    /// The packet's bytes as received.
    pub fn bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.layout.count(self.bytes)
    }

    /// Whether the packet has no point.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point `i` (`None` past the last).
    pub fn point(&self, i: usize) -> Option<Point> {
        self.layout.point(self.bytes, i)
    }

    /// The points, in the order received.
    pub fn points(&self) -> impl Iterator<Item = Point> + 'a {
        let (layout, bytes) = (self.layout, self.bytes);
        (0..layout.count(bytes)).map_while(move |i| layout.point(bytes, i))
    }
}

/// A byte-at-a-time parser of protocol `L` with a buffer of `CAP` bytes
/// (`CAP ≥ L::MAX_LEN`, checked at compile time). The aliases
/// ([`Ld06`](crate::Ld06), [`Rplidar`](crate::Rplidar),
/// [`Ydlidar`](crate::Ydlidar)) pick `CAP`. RAM: `CAP` + 44 bytes on a 32-bit
/// core (three `usize`, eight `u32` counters) plus padding and the
/// layout's state.
#[derive(Clone, Debug)]
pub struct Parser<L, const CAP: usize> {
    layout: L,
    buf: [u8; CAP],
    /// Bytes buffered.
    len: usize,
    /// Bytes at the buffer's start that form the packet handed out last,
    /// removed at the next call.
    pending: usize,
    /// Bytes at the buffer's start that belong to the candidate rejected
    /// and counted last: a reject starting there is not counted again
    /// (kept by the arms of `poll` that remove bytes, zero at a packet).
    rejected_span: usize,
    counters: Counters,
}

impl<L: Layout + Default, const CAP: usize> Default for Parser<L, CAP> {
    fn default() -> Self {
        Self::with_layout(L::default())
    }
}

impl<L: Layout + Default, const CAP: usize> Parser<L, CAP> {
    /// A parser with the layout's default settings.
    pub fn new() -> Self {
        Self::default()
    }
}

impl<L: Layout, const CAP: usize> Parser<L, CAP> {
    /// A parser for `layout`.
    pub const fn with_layout(layout: L) -> Self {
        const { assert!(CAP >= L::MAX_LEN, "the buffer must hold the longest packet") };
        Self {
            layout,
            buf: [0; CAP],
            len: 0,
            pending: 0,
            rejected_span: 0,
            counters: Counters {
                packets: 0,
                points: 0,
                bad_checksum: 0,
                bad_framing: 0,
                out_of_range: 0,
                descriptors: 0,
                skipped_bytes: 0,
                overflow_bytes: 0,
            },
        }
    }

    /// The counters so far.
    pub const fn counters(&self) -> &Counters {
        &self.counters
    }

    /// Bytes held in the buffer: a candidate packet not yet complete (and
    /// the packet handed out last, until the next call).
    pub const fn buffered(&self) -> usize {
        self.len
    }

    /// The protocol's layout (its settings).
    pub const fn layout(&self) -> &L {
        &self.layout
    }

    /// Appends `byte` and returns the next complete packet, if any. A byte
    /// can complete more than one packet (packets found inside a rejected
    /// candidate): call [`poll`](Self::poll) until it returns `None` to get
    /// them all, and at the end of a stream.
    pub fn push(&mut self, byte: u8) -> Option<Packet<'_, L>> {
        self.release();
        self.append(byte);
        self.poll()
    }

    /// Drops the packet handed out last.
    fn release(&mut self) {
        let pending = self.pending;
        self.pending = 0;
        self.discard(pending);
    }

    /// Appends `byte` without looking for packets; a packet handed out
    /// before stays readable through [`current`](Self::current) (so the
    /// buffer needs one byte more than the longest packet: `CAP >
    /// L::MAX_LEN`, as [`Lidar`](crate::Lidar) checks). A full buffer
    /// refuses the byte and counts it in [`Counters::overflow_bytes`]
    /// (cannot happen when each `append` is followed by `poll` until `None`,
    /// or by at most one `current`).
    pub fn append(&mut self, byte: u8) {
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = byte;
                self.len += 1;
            }
            None => bump(&mut self.counters.overflow_bytes, 1),
        }
    }

    /// Drops the packet handed out last and returns the next complete one
    /// among the buffered bytes, if any.
    pub fn poll(&mut self) -> Option<Packet<'_, L>> {
        self.release();
        loop {
            let data = self.buf.get(..self.len)?;
            if data.is_empty() {
                return None;
            }
            match self.layout.classify(data) {
                Frame::NeedMore => return None,
                Frame::Noise => {
                    bump(&mut self.counters.skipped_bytes, 1);
                    self.discard(1);
                    self.rejected_span = self.rejected_span.saturating_sub(1);
                }
                Frame::Reject(_) if self.rejected_span > 0 => {
                    // Inside the candidate counted last: one of its bytes.
                    bump(&mut self.counters.skipped_bytes, 1);
                    self.discard(1);
                    self.rejected_span -= 1;
                }
                Frame::Reject(why) => {
                    bump(
                        match why {
                            Reject::Checksum => &mut self.counters.bad_checksum,
                            Reject::Framing => &mut self.counters.bad_framing,
                            Reject::Range => &mut self.counters.out_of_range,
                        },
                        1,
                    );
                    // The candidate is the bytes the layout looked at to
                    // reject it: all those buffered, at most a packet's;
                    // its first byte goes now.
                    self.rejected_span = self.len.min(L::MAX_LEN).saturating_sub(1);
                    self.discard(1);
                }
                Frame::Descriptor(n) => {
                    bump(&mut self.counters.descriptors, 1);
                    self.discard(n.max(1));
                    self.rejected_span = self.rejected_span.saturating_sub(n.max(1));
                }
                Frame::Packet(n) => {
                    // `data` is not empty: 1 ≤ len.
                    let n = n.min(self.len).max(1);
                    self.pending = n;
                    // A good packet ends any rejected candidate before it.
                    self.rejected_span = 0;
                    bump(&mut self.counters.packets, 1);
                    let packet = self.current()?;
                    let points = u32::try_from(packet.len()).unwrap_or(u32::MAX);
                    bump(&mut self.counters.points, points);
                    return self.current();
                }
            }
        }
    }

    /// The packet handed out last, until the next [`poll`](Self::poll) or
    /// [`push`](Self::push).
    pub fn current(&self) -> Option<Packet<'_, L>> {
        if self.pending == 0 {
            return None;
        }
        let bytes = self.buf.get(..self.pending)?;
        Some(Packet {
            layout: &self.layout,
            bytes,
        })
    }

    /// Forgets the buffered bytes (the counters stay), e.g. after the UART
    /// reported an overrun.
    pub fn clear(&mut self) {
        self.len = 0;
        self.pending = 0;
        self.rejected_span = 0;
    }

    /// Removes the first `n` buffered bytes.
    fn discard(&mut self, n: usize) {
        let n = n.min(self.len);
        if n == 0 {
            return;
        }
        for i in n..self.len {
            if let Some(&b) = self.buf.get(i) {
                if let Some(slot) = self.buf.get_mut(i - n) {
                    *slot = b;
                }
            }
        }
        self.len -= n;
    }
}
