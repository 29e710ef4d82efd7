//! What a parser did with the bytes it was given: every byte is either in a
//! packet passed on or counted here by why it was dropped.

/// Counters of one parser, by cause. They saturate at `u32::MAX`.
///
/// Every byte given to a parser ends in exactly one place: a packet passed
/// on (`packets`), the first byte of a rejected candidate packet (one of
/// `bad_checksum`, `bad_framing`, `out_of_range`: each counts candidates,
/// not bytes), a response descriptor (`descriptors`), or `skipped_bytes`
/// (noise, the rest of a rejected candidate, a partial packet at the start
/// of a stream). After a candidate is rejected, the parser looks for the
/// next packet from the candidate's second byte on, so a real packet
/// hidden inside a rejected candidate is found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Packets whose framing and checksum passed, handed on (for RPLIDAR:
    /// scan nodes, 5 bytes each).
    pub packets: u32,
    /// Points in those packets.
    pub points: u32,
    /// Candidate packets dropped because their checksum or CRC failed. This
    /// and the next two count each damaged packet once: a candidate that
    /// starts inside one already counted (a header its damaged bytes spell)
    /// goes to [`skipped_bytes`](Self::skipped_bytes).
    pub bad_checksum: u32,
    /// Candidate packets dropped because a structural field is impossible:
    /// a sample count of 0 or above the protocol's maximum, a check bit
    /// that must be 1, RPLIDAR start bits `S = !S`, or an RPLIDAR node that
    /// does not continue the angles of its neighbours.
    pub bad_framing: u32,
    /// Candidate packets with a good checksum dropped because a value is out
    /// of the protocol's range (an angle at or beyond 360 °).
    pub out_of_range: u32,
    /// Response descriptors (`A5 5A …`) recognised and skipped.
    pub descriptors: u32,
    /// Bytes dropped outside any packet: noise, the tail of a rejected
    /// candidate (and the first byte of a candidate inside it), a partial
    /// packet at the start of a stream.
    pub skipped_bytes: u32,
    /// Bytes refused because the parser's buffer was full (only when
    /// [`Parser::push`](crate::Parser::push) is called without draining the
    /// packets with [`Parser::poll`](crate::Parser::poll)).
    pub overflow_bytes: u32,
}

impl Counters {
    /// Candidate packets dropped for any reason.
    pub const fn dropped_packets(&self) -> u32 {
        self.bad_checksum
            .saturating_add(self.bad_framing)
            .saturating_add(self.out_of_range)
    }
}

/// `*c += n`, saturating.
pub(crate) fn bump(c: &mut u32, n: u32) {
    *c = c.saturating_add(n);
}
