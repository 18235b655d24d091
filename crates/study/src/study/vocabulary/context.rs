//! The study file being loaded (path and text), so every check can name the line it fails at.

use crate::study::vocabulary::config::line_of;
use crate::study::vocabulary::error::StudyError;
use std::path::Path;

/// The study file and its text, for error messages.
pub(in crate::study) struct Context<'a> {
    pub path: &'a Path,
    pub text: &'a str,
}

impl Context<'_> {
    pub fn invalid(&self, at: usize, key: &str, message: impl Into<String>) -> StudyError {
        StudyError::Invalid {
            path: self.path.to_owned(),
            line: line_of(self.text, at),
            key: key.to_owned(),
            message: message.into(),
        }
    }

    /// The line of the first `key` (optionally quoted) at the start of a line, for keys
    /// whose span the parser does not keep.
    pub fn line_of_key(&self, key: &str) -> usize {
        let quoted = format!("\"{key}\"");
        self.text
            .lines()
            .position(|l| {
                let l = l.trim_start();
                (l.starts_with(&quoted) || l.starts_with(key))
                    && l.split_once('=').is_some_and(|(k, _)| {
                        let k = k.trim();
                        k == key || k == quoted
                    })
            })
            .map_or(1, |i| i + 1)
    }
}
