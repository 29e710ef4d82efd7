//! Running a firmware ELF under `qemu-system-arm` and decoding its `defmt` log.

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use defmt_decoder::{DecodeError, Table};

use crate::Error;

/// What one QEMU run produced.
#[derive(Debug)]
pub struct Run {
    /// Exit status of QEMU, which is the firmware's semihosting exit status;
    /// `None` when the run timed out or QEMU died from a signal.
    pub status: Option<i32>,
    /// Whether the run was killed at the time limit.
    pub timed_out: bool,
    /// The decoded `defmt` messages, in order.
    pub log: Vec<String>,
    /// QEMU's standard error: the plugin's lines and any panic message.
    pub stderr: String,
}

/// The `qemu-icount` plugin and the marker and stack addresses to give it.
#[derive(Debug, Clone)]
pub struct Plugin {
    /// Path of `libqemu_icount.so`.
    pub library: PathBuf,
    /// Address of `hh_bench_start`.
    pub start: u64,
    /// Address of `hh_bench_stop`.
    pub stop: u64,
    /// The stack region `[lo, hi)` to watch.
    pub stack: (u64, u64),
    /// Where the plugin writes its flat profile, if one is wanted
    /// (`budgets profile`).
    pub profile: Option<PathBuf>,
}

impl Plugin {
    /// The plugin `library` set to the markers and stack of a bench ELF's
    /// `image`, writing a flat profile to `profile` if given.
    pub fn for_image(
        library: PathBuf,
        image: &crate::elf::Image,
        profile: Option<PathBuf>,
    ) -> Result<Self, Error> {
        Ok(Self {
            library,
            start: image.start.ok_or("no hh_bench_start symbol")?,
            stop: image.stop.ok_or("no hh_bench_stop symbol")?,
            stack: image.stack.ok_or("no _stack_end/_stack_start symbols")?,
            profile,
        })
    }
}

/// Runs `elf` on QEMU machine `machine` with semihosting, optionally with the
/// instruction-count plugin, killing it after `timeout`.
pub fn run(
    elf: &Path,
    machine: &str,
    plugin: Option<&Plugin>,
    timeout: Duration,
) -> Result<Run, Error> {
    let bytes = std::fs::read(elf).map_err(|e| format!("read {}: {e}", elf.display()))?;
    let mut command = Command::new("qemu-system-arm");
    command
        .args([
            "-machine", machine, "-display", "none", "-monitor", "none", "-serial", "null",
        ])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(p) = plugin {
        let mut argument = format!(
            "{},start={:#x},stop={:#x},stack_lo={:#x},stack_hi={:#x}",
            p.library.display(),
            p.start,
            p.stop,
            p.stack.0,
            p.stack.1
        );
        if let Some(file) = &p.profile {
            argument.push_str(&format!(",profile={}", file.display()));
        }
        command.arg("-plugin").arg(argument);
    }
    let mut child = command
        .spawn()
        .map_err(|e| format!("start qemu-system-arm: {e}"))?;
    let stdout = drain(&mut child, true);
    let stderr = drain(&mut child, false);

    let deadline = Instant::now() + timeout;
    let (status, timed_out) = loop {
        if let Some(status) = child
            .try_wait()
            .map_err(|e| format!("wait for QEMU: {e}"))?
        {
            break (status.code(), false);
        }
        if Instant::now() >= deadline {
            // Our own child, by its handle.
            let _ = child.kill();
            let _ = child.wait();
            break (None, true);
        }
        thread::sleep(Duration::from_millis(5));
    };
    let stdout = stdout.join().unwrap_or_default();
    let stderr = String::from_utf8_lossy(&stderr.join().unwrap_or_default()).into_owned();
    Ok(Run {
        status,
        timed_out,
        log: decode(&bytes, &stdout)?,
        stderr,
    })
}

/// Reads the child's standard output (`true`) or error to the end on a thread.
fn drain(child: &mut Child, stdout: bool) -> thread::JoinHandle<Vec<u8>> {
    let mut pipe: Box<dyn Read + Send> = if stdout {
        Box::new(child.stdout.take().expect("piped"))
    } else {
        Box::new(child.stderr.take().expect("piped"))
    };
    thread::spawn(move || {
        let mut buffer = Vec::new();
        let _ = pipe.read_to_end(&mut buffer);
        buffer
    })
}

/// Decodes the `defmt` frames in `stream` with the table of `elf`.
pub fn decode(elf: &[u8], stream: &[u8]) -> Result<Vec<String>, Error> {
    let table = Table::parse(elf)
        .map_err(|e| format!("defmt table: {e}"))?
        .ok_or("the ELF has no defmt table")?;
    let mut decoder = table.new_stream_decoder();
    decoder.received(stream);
    let mut log = Vec::new();
    loop {
        match decoder.decode() {
            Ok(frame) => log.push(frame.display_message().to_string()),
            Err(DecodeError::UnexpectedEof) => break,
            Err(DecodeError::Malformed) if table.encoding().can_recover() => {
                log.push("(malformed defmt frame skipped)".into());
            }
            Err(DecodeError::Malformed) => return Err("malformed defmt frame".into()),
        }
    }
    Ok(log)
}

/// The `key=value` words of a log line, e.g. `bench estimate sp=1 votes=2`.
pub fn field<'a>(line: &'a str, key: &str) -> Option<&'a str> {
    line.split_whitespace()
        .filter_map(|word| word.split_once('='))
        .find_map(|(k, v)| (k == key).then_some(v))
}

/// Parses a decimal or `0x` hexadecimal number.
pub fn number(text: &str) -> Option<u64> {
    match text.strip_prefix("0x") {
        Some(hex) => u64::from_str_radix(hex, 16).ok(),
        None => text.parse().ok(),
    }
}

#[cfg(test)]
mod tests {
    use super::{field, number};

    #[test]
    fn fields_and_numbers() {
        let line = "bench estimate sp=536870000 votes=42";
        assert_eq!(field(line, "votes"), Some("42"));
        assert_eq!(field(line, "sp").and_then(number), Some(536_870_000));
        assert_eq!(field(line, "nope"), None);
        assert_eq!(number("0x20"), Some(32));
    }
}
