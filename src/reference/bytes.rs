//! The stored references' bytes: little-endian reads that a `const fn`
//! can make, the FNV-1a checksum, and a writer that never writes past its
//! buffer.

/// FNV-1a of the first `end` bytes (fewer if `bytes` is shorter).
pub(super) const fn fnv1a(bytes: &[u8], end: usize) -> u32 {
    let mut h = 0x811c_9dc5u32;
    let mut i = 0;
    while i < end && i < bytes.len() {
        h = (h ^ bytes[i] as u32).wrapping_mul(0x0100_0193);
        i += 1;
    }
    h
}

/// Byte `at` of `bytes`; 0 past the end (the length is checked up front).
pub(super) const fn byte(bytes: &[u8], at: usize) -> u8 {
    if at < bytes.len() {
        bytes[at]
    } else {
        0
    }
}

/// The little-endian `u16` at byte `at`.
pub(super) const fn le_u16(bytes: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([byte(bytes, at), byte(bytes, at + 1)])
}

/// The little-endian `u32` at byte `at`.
pub(super) const fn le_u32(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([
        byte(bytes, at),
        byte(bytes, at + 1),
        byte(bytes, at + 2),
        byte(bytes, at + 3),
    ])
}

pub(super) const fn all_zero(values: &[u8]) -> bool {
    let mut i = 0;
    while i < values.len() {
        if values[i] != 0 {
            return false;
        }
        i += 1;
    }
    true
}

pub(super) const fn same_words<const RW: usize, const H: usize>(
    a: &[[u32; RW]; H],
    b: &[[u32; RW]; H],
) -> bool {
    let mut r = 0;
    while r < H {
        let mut w = 0;
        while w < RW {
            if a[r][w] != b[r][w] {
                return false;
            }
            w += 1;
        }
        r += 1;
    }
    true
}

pub(super) struct Writer<'a> {
    pub(super) out: &'a mut [u8],
    pub(super) at: usize,
}

impl Writer<'_> {
    pub(super) fn put(&mut self, bytes: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + bytes.len()) {
            dst.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }

    pub(super) fn skip(&mut self, n: usize) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + n) {
            dst.fill(0);
        }
        self.at += n;
    }
}
