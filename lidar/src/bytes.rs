//! Little-endian field reads that cannot panic.

/// The little-endian `u16` at `at` (0 past the end: callers check lengths
/// first, this only keeps the code free of panics).
pub(crate) fn u16_at(bytes: &[u8], at: usize) -> u16 {
    match (bytes.get(at), bytes.get(at + 1)) {
        (Some(&lo), Some(&hi)) => u16::from_le_bytes([lo, hi]),
        _ => 0,
    }
}

/// The byte at `at` (0 past the end).
pub(crate) fn u8_at(bytes: &[u8], at: usize) -> u8 {
    bytes.get(at).copied().unwrap_or(0)
}
