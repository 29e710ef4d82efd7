//! The part of the drivers that does not read: a small byte buffer drained
//! into a [`Lidar`].

use crate::lidar::Lidar;
use crate::parser::Layout;
use crate::revolution::Revolution;

/// Bytes read per call to the reader.
pub const CHUNK: usize = 64;

/// A [`Lidar`] and the bytes read but not yet given to it.
#[derive(Clone, Debug)]
pub(crate) struct Feed<L, const CAP: usize, const N: usize> {
    pub(crate) lidar: Lidar<L, CAP, N>,
    buf: [u8; CHUNK],
    pos: usize,
    len: usize,
    pub(crate) eof: bool,
}

impl<L: Layout, const CAP: usize, const N: usize> Feed<L, CAP, N> {
    pub(crate) const fn new(lidar: Lidar<L, CAP, N>) -> Self {
        Self {
            lidar,
            buf: [0; CHUNK],
            pos: 0,
            len: 0,
            eof: false,
        }
    }

    /// Gives the buffered bytes to the lidar until a revolution completes
    /// (`true`) or the buffer is empty (`false`: read more, or at the end
    /// of the stream, `None` from [`finish`](Self::finish)).
    pub(crate) fn drain(&mut self) -> bool {
        if self.eof {
            return self.lidar.step();
        }
        while let Some(&byte) = self.buf.get(self.pos).filter(|_| self.pos < self.len) {
            self.pos += 1;
            if self.lidar.push(byte) {
                return true;
            }
        }
        false
    }

    /// The buffer to read into; then [`filled`](Self::filled).
    pub(crate) fn space(&mut self) -> &mut [u8] {
        &mut self.buf
    }

    /// `n` bytes were read into [`space`](Self::space) (0: end of stream).
    pub(crate) fn filled(&mut self, n: usize) {
        self.pos = 0;
        self.len = n.min(CHUNK);
        self.eof = n == 0;
    }

    pub(crate) fn revolution(&self) -> Option<Revolution<'_, N>> {
        self.lidar.revolution()
    }
}
