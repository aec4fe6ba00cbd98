//! What the library's JSON files (scenes, F-rep models, surface models) share: the
//! error that names the file, the offending field, what it must be and what it was.

use std::fmt;
use std::path::{Path, PathBuf};

/// A JSON file's field that is missing, malformed or out of range.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldError {
    /// The file, when the text came from one.
    pub file: Option<PathBuf>,
    /// Where in the file, as `objects[2].solid.q`; empty for the file as a whole.
    pub field: String,
    /// What the field must be; empty when `found` says it all (`missing field`).
    pub expected: String,
    /// What the field was.
    pub found: String,
}

impl FieldError {
    /// `field` was `found` where `expected` was required.
    pub fn new(
        field: impl Into<String>,
        expected: impl Into<String>,
        found: impl Into<String>,
    ) -> Self {
        FieldError {
            file: None,
            field: field.into(),
            expected: expected.into(),
            found: found.into(),
        }
    }

    /// `reason` about the value at `field`: a leading `expected ...` (and a `, found ...`
    /// after it) is what was expected, anything else what was found.
    pub fn from_reason(field: impl Into<String>, reason: impl Into<String>) -> Self {
        let reason = reason.into();
        match reason.strip_prefix("expected ") {
            Some(rest) => match rest.split_once(", found ") {
                Some((expected, found)) => Self::new(field, expected, found),
                None => Self::new(field, rest, ""),
            },
            None => Self::new(field, "", reason),
        }
    }

    /// A number outside `[lo, hi]`.
    pub fn out_of_range(field: impl Into<String>, value: f64, lo: f64, hi: f64) -> Self {
        Self::new(
            field,
            format!("a value in [{lo:e}, {hi:e}]"),
            format!("{value:e}"),
        )
    }

    /// A parser's message about `field` (serde's `invalid type: X, expected Y` is split
    /// at its `expected`).
    pub fn parse(field: impl Into<String>, message: &str) -> Self {
        let (found, expected) = match message.split_once(", expected ") {
            Some((f, e)) => (f, e),
            None => (message, ""),
        };
        Self::new(field, expected, found)
    }

    /// A `serde_path_to_error` failure, its path below `prefix` (empty at the root).
    pub fn from_path_error<E: fmt::Display>(
        prefix: &str,
        e: &serde_path_to_error::Error<E>,
    ) -> Self {
        let at = e.path().to_string();
        let field = match (prefix.is_empty(), at == ".") {
            (_, true) => prefix.to_string(),
            (true, false) => at,
            (false, false) if at.starts_with('[') => format!("{prefix}{at}"),
            (false, false) => format!("{prefix}.{at}"),
        };
        Self::parse(field, &e.inner().to_string())
    }

    /// The same error placed below `prefix` (`prefix.field`).
    pub fn under(mut self, prefix: &str) -> Self {
        self.field = match (prefix.is_empty(), self.field.is_empty()) {
            (true, _) => self.field,
            (false, true) => prefix.to_string(),
            (false, false) if self.field.starts_with('[') => format!("{prefix}{}", self.field),
            (false, false) => format!("{prefix}.{}", self.field),
        };
        self
    }

    /// The same error in `file`.
    pub fn in_file(mut self, file: &Path) -> Self {
        self.file = Some(file.to_path_buf());
        self
    }

    /// The error with control characters in its texts escaped, so that it prints as
    /// one line whatever the file held.
    pub fn printable(self) -> Self {
        let clean = |s: String| printable(&s);
        FieldError {
            file: self.file,
            field: clean(self.field),
            expected: clean(self.expected),
            found: clean(self.found),
        }
    }
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(file) = &self.file {
            write!(f, "{}: ", file.display())?;
        }
        if !self.field.is_empty() {
            write!(f, "{}: ", self.field)?;
        }
        match (self.found.is_empty(), self.expected.is_empty()) {
            (true, _) => write!(f, "expected {}", self.expected),
            (false, true) => f.write_str(&self.found),
            (false, false) => write!(f, "{}, expected {}", self.found, self.expected),
        }
    }
}

impl std::error::Error for FieldError {}

/// Checks that `v` is in `[lo, hi]` (NaN is not).
pub fn check_number(field: &str, v: f64, lo: f64, hi: f64) -> Result<f64, FieldError> {
    if v >= lo && v <= hi {
        Ok(v)
    } else {
        Err(FieldError::out_of_range(field, v, lo, hi))
    }
}

/// Checks a position or direction: every coordinate within `[-limit, limit]`.
pub fn check_vec(field: &str, v: [f64; 3], limit: f64) -> Result<[f64; 3], FieldError> {
    if v.iter().all(|x| x.abs() <= limit) {
        Ok(v)
    } else {
        Err(FieldError::new(
            field,
            format!("components within [-{limit:e}, {limit:e}]"),
            format!("{v:?}"),
        ))
    }
}

pub use caoen_base::printable;
