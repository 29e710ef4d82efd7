//! Blocking driver over [`embedded_io::Read`] (feature `io`).

use embedded_io::Read;

use crate::feed::Feed;
use crate::lidar::Lidar;
use crate::parser::Layout;
use crate::revolution::Revolution;

/// Revolutions from a blocking reader (a UART, a file): reads
/// [`CHUNK`](crate::CHUNK) bytes at a time into a buffer of its own.
/// RAM: the [`Lidar`] plus 80 bytes and the reader.
#[derive(Debug)]
pub struct Driver<R, L, const CAP: usize, const N: usize> {
    reader: R,
    feed: Feed<L, CAP, N>,
}

impl<R: Read, L: Layout, const CAP: usize, const N: usize> Driver<R, L, CAP, N> {
    /// A driver reading `reader` into `lidar`.
    pub const fn new(reader: R, lidar: Lidar<L, CAP, N>) -> Self {
        Self {
            reader,
            feed: Feed::new(lidar),
        }
    }

    /// The next complete revolution; `Ok(None)` at the end of the stream
    /// (a reader that returned 0 bytes).
    ///
    /// # Errors
    /// The reader's error; the driver can be called again after it.
    pub fn next_revolution(&mut self) -> Result<Option<Revolution<'_, N>>, R::Error> {
        loop {
            if self.feed.drain() {
                return Ok(self.feed.revolution());
            }
            if self.feed.eof {
                return Ok(None);
            }
            let n = self.reader.read(self.feed.space())?;
            self.feed.filled(n);
        }
    }

    /// The parser and assembler (their counters).
    pub const fn lidar(&self) -> &Lidar<L, CAP, N> {
        &self.feed.lidar
    }

    /// The reader back.
    pub fn into_reader(self) -> R {
        self.reader
    }
}
