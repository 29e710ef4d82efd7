//! The one error type of the readers, and of the options and estimates the
//! tool and the Python package share: [`Fatal`] (nothing more can be read or
//! done) and [`RecordError`] (one record of a recording skipped, the rest
//! read on).

use std::fmt;

/// A fatal error: the recording or input cannot be used (the tool prints it
/// to stderr and exits with status 2).
#[derive(Debug)]
pub struct Fatal(String);

impl Fatal {
    /// An unusable input or output file (the message names it).
    pub fn io(message: impl Into<String>) -> Self {
        Self(message.into())
    }

    /// An unusable option value.
    pub fn usage(message: impl Into<String>) -> Self {
        Self(message.into())
    }
}

impl fmt::Display for Fatal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// A record of the file that could not be used.
#[derive(Clone, Debug)]
pub struct RecordError {
    /// Which record (`line 12`, `message 40 (topic /scan)`).
    pub record: String,
    /// Why.
    pub message: String,
}

impl RecordError {
    /// The record named `record` failed for `message`.
    pub fn new(record: impl Into<String>, message: impl Into<String>) -> Self {
        Self {
            record: record.into(),
            message: message.into(),
        }
    }
}
