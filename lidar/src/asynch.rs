//! Async driver over [`embedded_io_async::Read`] (feature `async`), for
//! embassy's UARTs and other async readers.

use embedded_io_async::Read;

use crate::feed::Feed;
use crate::lidar::Lidar;
use crate::parser::Layout;
use crate::revolution::Revolution;

/// Revolutions from an async reader; the same as [`crate::io::Driver`]
/// with `.await`.
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

    /// The next complete revolution; `Ok(None)` at the end of the stream.
    ///
    /// # Errors
    /// The reader's error; the driver can be called again after it.
    pub async fn next_revolution(&mut self) -> Result<Option<Revolution<'_, N>>, R::Error> {
        loop {
            if self.feed.drain() {
                return Ok(self.feed.revolution());
            }
            if self.feed.eof {
                return Ok(None);
            }
            let n = self.reader.read(self.feed.space()).await?;
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
