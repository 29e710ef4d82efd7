//! Drivers over readers: a blocking one over [`embedded_io::Read`] (feature
//! `io`) and an async one over [`embedded_io_async::Read`] (feature
//! `async`, for embassy's UARTs and other async readers).

use crate::lidar::Lidar;
use crate::parser::Layout;
use crate::revolution::Revolution;

/// Bytes read per call to the reader.
pub const CHUNK: usize = 64;

/// Revolutions from a reader (a UART, a file): reads [`CHUNK`] bytes at a
/// time into a buffer of its own and feeds them to a [`Lidar`].
/// [`next_revolution`](Self::next_revolution) blocks on an
/// `embedded_io::Read`, [`next_revolution_async`](Self::next_revolution_async)
/// awaits an `embedded_io_async::Read`. RAM: the [`Lidar`] plus 80 bytes
/// and the reader.
#[derive(Debug)]
pub struct Driver<R, L, const CAP: usize, const N: usize> {
    reader: R,
    lidar: Lidar<L, CAP, N>,
    buf: [u8; CHUNK],
    pos: usize,
    len: usize,
    eof: bool,
}

impl<R, L: Layout, const CAP: usize, const N: usize> Driver<R, L, CAP, N> {
    /// A driver reading `reader` into `lidar`.
    pub const fn new(reader: R, lidar: Lidar<L, CAP, N>) -> Self {
        Self {
            reader,
            lidar,
            buf: [0; CHUNK],
            pos: 0,
            len: 0,
            eof: false,
        }
    }

    /// The parser and assembler (their counters).
    pub const fn lidar(&self) -> &Lidar<L, CAP, N> {
        &self.lidar
    }

    /// The reader back.
    pub fn into_reader(self) -> R {
        self.reader
    }

    /// Gives the buffered bytes to the lidar until a revolution completes
    /// (`true`) or the buffer is empty (`false`: read more; at the end of
    /// the stream, the lidar's last packets).
    fn drain(&mut self) -> bool {
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

    /// `n` bytes were read into the buffer (0: end of stream).
    fn filled(&mut self, n: usize) {
        self.pos = 0;
        self.len = n.min(CHUNK);
        self.eof = n == 0;
    }
}

#[cfg(feature = "io")]
impl<R: embedded_io::Read, L: Layout, const CAP: usize, const N: usize> Driver<R, L, CAP, N> {
    /// The next complete revolution, blocking; `Ok(None)` at the end of
    /// the stream (a reader that returned 0 bytes).
    ///
    /// # Errors
    /// The reader's error; the driver can be called again after it.
    pub fn next_revolution(&mut self) -> Result<Option<Revolution<'_, N>>, R::Error> {
        loop {
            if self.drain() {
                return Ok(self.lidar.revolution());
            }
            if self.eof {
                return Ok(None);
            }
            let n = self.reader.read(&mut self.buf)?;
            self.filled(n);
        }
    }
}

#[cfg(feature = "async")]
impl<R: embedded_io_async::Read, L: Layout, const CAP: usize, const N: usize> Driver<R, L, CAP, N> {
    /// The next complete revolution, awaiting the reader; `Ok(None)` at the
    /// end of the stream.
    ///
    /// # Errors
    /// The reader's error; the driver can be called again after it.
    pub async fn next_revolution_async(&mut self) -> Result<Option<Revolution<'_, N>>, R::Error> {
        loop {
            if self.drain() {
                return Ok(self.lidar.revolution());
            }
            if self.eof {
                return Ok(None);
            }
            let n = self.reader.read(&mut self.buf).await?;
            self.filled(n);
        }
    }
}
