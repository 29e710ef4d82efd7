//! How a raw lidar capture is stored: its bytes as the sensor sent them, or
//! hex text as serial loggers print them ([`HexText`], read directly), and
//! which sensor a binary file given without `--format` most likely holds
//! ([`likely_protocol`]), for the message that says which `--format` reads it.
//!
//! Hex text is tokens of hex digits, two a byte, each with an optional
//! `0x`/`0X`, separated by whitespace, `,`, `:` or `;` (`54 2C 68 08 …`,
//! `542C6808…` or `0x54, 0x2c, …`, one packet a line or not: lines don't
//! matter). A token with an odd number of digits or any other character is a
//! read error naming its line, never a byte guessed.

use std::io::{self, BufRead, BufReader, Read};

use crate::error::Fatal;
use crate::wire::Protocol;

/// The hex digits a head of the file must hold at least to be taken for
/// hex text (a few packets' bytes, not one stray line of digits).
const HEX_TEXT_MIN_DIGITS: usize = 32;

fn is_separator(b: u8) -> bool {
    b.is_ascii_whitespace() || matches!(b, b',' | b':' | b';')
}

/// Whether `head` (the first bytes of a file) is hex text: only hex digits,
/// separators and `0x` prefixes, with at least 32 digits.
pub fn is_hex_text(head: &[u8]) -> bool {
    let only_text = head
        .iter()
        .all(|&b| b.is_ascii_hexdigit() || is_separator(b) || matches!(b, b'x' | b'X'));
    only_text && head.iter().filter(|b| b.is_ascii_hexdigit()).count() >= HEX_TEXT_MIN_DIGITS
}

fn is_control(b: u8) -> bool {
    (b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r')) || b == 0x7F
}

/// Whether `head` is binary: one byte in 20 or more a control character
/// (NUL, …; not tab or line ends). A log in Latin-1 or with a stray
/// control byte is still text; a lidar's packets, whose ranges' high bytes
/// are mostly small, are not.
pub fn is_binary(head: &[u8]) -> bool {
    head.iter().filter(|&&b| is_control(b)).count() * 20 >= head.len().max(1)
}

/// Whether `head` is plain text: UTF-8 (a sequence cut by the end of `head`
/// allowed) without a control character. A binary capture of a few KiB
/// always has some.
pub fn is_text(head: &[u8]) -> bool {
    !head.iter().any(|&b| is_control(b))
        && std::str::from_utf8(head).map_or_else(|e| e.error_len().is_none(), |_| true)
}

/// The message for a file given without `--format` that is a capture, not a
/// log or a bag: hex text or binary (`None` for anything else, read as
/// CARMEN), naming the `--format` its bytes look like.
pub fn unread_capture(file: &str, head: &[u8]) -> Option<String> {
    let (what, bytes) = if is_hex_text(head) {
        let mut bytes = Vec::new();
        // The head's bytes as far as they decode: enough for a guess.
        let _ = HexText::new(head).read_to_end(&mut bytes);
        ("hex text", bytes)
    } else if is_binary(head) {
        ("binary", head.to_vec())
    } else {
        return None;
    };
    let guess = likely_protocol(&bytes).map_or(String::new(), |p| {
        format!(" (its bytes look like {p} packets: `--format {p}`)")
    });
    Some(format!(
        "{file}: {what}, not a CARMEN log or a bag: a raw lidar capture is read with its \
         --format (ld06, rplidar, ydlidar or xv11; binary or hex text){guess}, and \
         `hough-heading wire` turns it into a CARMEN log"
    ))
}

/// A capture's bytes from `input`: as stored, or decoded when the file is
/// hex text (said on stderr). Plain text that is not hex (a log given a
/// capture's `--format`) is a usage error.
///
/// # Errors
/// The file cannot be read, or is text but not hex text.
pub fn capture_bytes(
    mut input: Box<dyn BufRead>,
    file: &str,
    protocol: Protocol,
) -> Result<Box<dyn BufRead>, Fatal> {
    let head = input
        .fill_buf()
        .map_err(|e| Fatal::io(format!("{file}: cannot read: {e}")))?;
    if is_hex_text(head) {
        eprintln!("hough-heading: {file}: hex text, read as the bytes it spells");
        return Ok(Box::new(BufReader::new(HexText::new(input))));
    }
    if !head.is_empty() && is_text(head) {
        return Err(Fatal::usage(format!(
            "{file}: text but not hex text, not a raw {protocol} capture: a CARMEN log is \
             read without --format"
        )));
    }
    Ok(input)
}

/// The protocol whose packet headers `head` holds most often (at least 8 of
/// them), `None` when no protocol's are that frequent. LD06: `54 2C`;
/// YDLIDAR: `AA 55`; XV-11: `FA` and an index `A0`–`F9`; RPLIDAR: its
/// response descriptor `A5 5A` at the start. A guess for a message, not a
/// parse: the parser of the protocol named decides.
pub fn likely_protocol(head: &[u8]) -> Option<Protocol> {
    if head.starts_with(&[0xA5, 0x5A]) {
        return Some(Protocol::Rplidar);
    }
    let count = |is_header: fn(&[u8]) -> bool| head.windows(2).filter(|w| is_header(w)).count();
    [
        (Protocol::Ld06, count(|w| w == [0x54, 0x2C])),
        (Protocol::Ydlidar, count(|w| w == [0xAA, 0x55])),
        (
            Protocol::Xv11,
            count(|w| w[0] == 0xFA && (0xA0..=0xF9).contains(&w[1])),
        ),
    ]
    .into_iter()
    .filter(|&(_, n)| n >= 8)
    .max_by_key(|&(_, n)| n)
    .map(|(p, _)| p)
}

/// A hex-text capture read as the bytes it spells.
pub struct HexText<R> {
    input: R,
    decoder: Decoder,
}

/// Where the text is: within a token or between, a byte half read.
#[derive(Default)]
struct Decoder {
    /// The high nibble of a byte whose low one is still to come.
    high: Option<u8>,
    /// The token so far is a lone `0` (a `0x` prefix may follow).
    lone_zero: bool,
    /// The token has digits.
    in_token: bool,
    /// Newlines read so far (the line is one more).
    line: usize,
}

impl Decoder {
    fn invalid(&self, what: &str) -> io::Error {
        io::Error::new(
            io::ErrorKind::InvalidData,
            format!("hex text, line {}: {what}", self.line + 1),
        )
    }

    /// The token ends; an odd digit count is an error (and stays one).
    fn end_token(&mut self) -> io::Result<()> {
        if self.high.is_some() {
            return Err(self.invalid("a byte of one hex digit"));
        }
        (self.in_token, self.lone_zero) = (false, false);
        Ok(())
    }

    /// One character of the text: `Some(byte)` when it completes a byte. An
    /// error leaves the state as it was, so the same character fails again.
    fn take(&mut self, c: u8) -> io::Result<Option<u8>> {
        if is_separator(c) {
            self.end_token()?;
            self.line += usize::from(c == b'\n');
            return Ok(None);
        }
        if matches!(c, b'x' | b'X') && self.lone_zero {
            (self.high, self.lone_zero, self.in_token) = (None, false, false);
            return Ok(None);
        }
        let Some(nibble) = char::from(c)
            .to_digit(16)
            .and_then(|d| u8::try_from(d).ok())
        else {
            return Err(self.invalid(&format!("{:?} is not a hex digit", char::from(c))));
        };
        self.lone_zero = !self.in_token && nibble == 0;
        self.in_token = true;
        Ok(match self.high.take() {
            Some(high) => Some(high << 4 | nibble),
            None => {
                self.high = Some(nibble);
                None
            }
        })
    }
}

impl<R: BufRead> HexText<R> {
    /// The bytes spelled by `input`'s hex text.
    pub fn new(input: R) -> Self {
        Self {
            input,
            decoder: Decoder::default(),
        }
    }
}

impl<R: BufRead> Read for HexText<R> {
    /// The bytes decoded; an error (naming its line) once the bytes before
    /// it have been returned.
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let mut written = 0;
        while written < buf.len() {
            let text = self.input.fill_buf()?;
            if text.is_empty() {
                if written == 0 {
                    self.decoder.end_token()?;
                }
                break;
            }
            let mut used = 0;
            let mut failed = None;
            for &c in text {
                let Some(slot) = buf.get_mut(written) else {
                    break;
                };
                match self.decoder.take(c) {
                    Ok(byte) => {
                        used += 1;
                        if let Some(byte) = byte {
                            *slot = byte;
                            written += 1;
                        }
                    }
                    Err(e) => {
                        failed = Some(e);
                        break;
                    }
                }
            }
            // The failing character stays unread: the next read fails on it.
            self.input.consume(used);
            if let Some(e) = failed {
                return if written == 0 { Err(e) } else { Ok(written) };
            }
        }
        Ok(written)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decoded(text: &str) -> io::Result<Vec<u8>> {
        let mut bytes = Vec::new();
        // A reader that hands over one character at a time, so that tokens
        // and prefixes cross the buffer's edges.
        let input = io::BufReader::with_capacity(1, text.as_bytes());
        HexText::new(input).read_to_end(&mut bytes)?;
        Ok(bytes)
    }

    #[test]
    fn every_written_form_spells_the_same_bytes() {
        let bytes = vec![0x54, 0x2C, 0x68, 0x08, 0x00, 0xFF, 0x0A];
        for text in [
            "54 2C 68 08 00 FF 0A\n",
            "542C6808\r\n00ff0a",
            "0x54, 0x2c, 0x68, 0x08, 0X00, 0xFF, 0x0a",
            "54:2C:68:08;00:FF:0A",
            "\n\n  542c 680800ff0A  \n",
        ] {
            assert_eq!(decoded(text).unwrap(), bytes, "{text:?}");
        }
    }

    #[test]
    fn a_bad_character_or_half_byte_is_an_error_naming_its_line() {
        for (text, what) in [
            ("54 2C\n68 0G\n", "line 2: 'G' is not a hex digit"),
            ("54 2C\n\n68 0\n", "line 3: a byte of one hex digit"),
            ("54 2C 6", "line 1: a byte of one hex digit"),
            ("54 x2", "line 1: 'x' is not a hex digit"),
        ] {
            let e = decoded(text).unwrap_err();
            assert_eq!(e.kind(), io::ErrorKind::InvalidData);
            assert!(e.to_string().ends_with(what), "{text:?}: {e}");
        }
    }

    #[test]
    fn the_bytes_before_an_error_are_read_first() {
        let mut reader = HexText::new("54 2C 68 ZZ".as_bytes());
        let mut buf = [0; 16];
        assert_eq!(reader.read(&mut buf).unwrap(), 3);
        assert_eq!(buf[..3], [0x54, 0x2C, 0x68]);
        assert!(reader.read(&mut buf).is_err());
        assert!(reader.read(&mut buf).is_err(), "the error stays");
    }

    #[test]
    fn text_binary_and_hex_text_are_told_apart() {
        let hex = "54 2C 68 08 00 FF 0A 54 2C 68 08 00 FF 0A 54 2C\n".as_bytes();
        assert!(is_hex_text(hex) && is_text(hex) && !is_binary(hex));
        let log = b"FLASER 3 1.0 2.0 3.0 0 0 0 0 0 0 0 0 0 1.0 host 1.0\n";
        assert!(!is_hex_text(log) && is_text(log) && !is_binary(log));
        assert!(!is_hex_text(b"54 2C\n"), "too few digits");
        let packet = [0x54, 0x2C, 0x68, 0x08, 0x10, 0x27, 0x03, 0xC8, 0x01, 0x00];
        assert!(is_binary(&packet) && !is_text(&packet));
        // Latin-1 in a comment, or one stray control byte: still not binary.
        let latin1 = b"# r\xe9sum\xe9\nODOM 1 2 3 0 0 0 1.0 host 1.0\n";
        assert!(!is_binary(latin1) && !is_text(latin1));
        let mut stray = log.repeat(2);
        stray[5] = 0x1B;
        assert!(!is_binary(&stray));
        // A UTF-8 sequence cut by the end of the head is still text.
        assert!(is_text("ODOM é".as_bytes().split_last().unwrap().1));
    }

    #[test]
    fn a_capture_given_without_format_is_named_with_its_likely_format() {
        let packets: Vec<u8> = (0..20u8).flat_map(|i| [0x54, 0x2C, i, 0, 1, 2]).collect();
        let binary = unread_capture("c.bin", &packets).unwrap();
        assert!(
            binary.starts_with("c.bin: binary, not a CARMEN log"),
            "{binary}"
        );
        assert!(binary.contains("`--format ld06`"), "{binary}");
        let text: String = packets.iter().map(|b| format!("{b:02X} ")).collect();
        let hex = unread_capture("c.txt", text.as_bytes()).unwrap();
        assert!(hex.starts_with("c.txt: hex text, not"), "{hex}");
        assert!(hex.contains("`--format ld06`"), "{hex}");
        assert_eq!(
            unread_capture("l.log", b"ODOM 1 2 3 0 0 0 1.0 host 1.0\n"),
            None
        );
    }

    #[test]
    fn the_likely_protocol_is_the_one_whose_headers_recur() {
        let packets = |header: [u8; 2], n: usize| -> Vec<u8> {
            (0..n)
                .flat_map(|i| [header[0], header[1], i as u8, 7, 9])
                .collect()
        };
        assert_eq!(
            likely_protocol(&packets([0x54, 0x2C], 20)),
            Some(Protocol::Ld06)
        );
        assert_eq!(
            likely_protocol(&packets([0xAA, 0x55], 20)),
            Some(Protocol::Ydlidar)
        );
        assert_eq!(
            likely_protocol(&packets([0xFA, 0xB0], 20)),
            Some(Protocol::Xv11)
        );
        assert_eq!(
            likely_protocol(&[0xA5, 0x5A, 5, 0, 0, 0x40, 0x81]),
            Some(Protocol::Rplidar)
        );
        assert_eq!(likely_protocol(&packets([0x54, 0x2C], 3)), None);
        assert_eq!(likely_protocol(&[1, 2, 3, 4, 5, 6]), None);
    }
}
