//! One error type for user-facing failures: it names the file (when there is one) and the problem,
//! so the CLI can print it on one line and exit with status 2.

use std::fmt;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone)]
pub struct Error {
    pub path: Option<PathBuf>,
    pub message: String,
}

impl Error {
    pub fn new(message: impl Into<String>) -> Self {
        Error { path: None, message: message.into() }
    }
    pub fn file(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error { path: Some(path.as_ref().to_path_buf()), message: message.into() }
    }
    /// Attach a path if the error does not already carry one.
    pub fn in_file(mut self, path: impl AsRef<Path>) -> Self {
        if self.path.is_none() {
            self.path = Some(path.as_ref().to_path_buf());
        }
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Keep it on one line whatever the underlying library printed.
        let msg = self.message.replace('\n', " ");
        match &self.path {
            Some(p) => write!(f, "{}: {}", p.display(), msg),
            None => write!(f, "{msg}"),
        }
    }
}

impl std::error::Error for Error {}

pub type Result<T> = std::result::Result<T, Error>;
