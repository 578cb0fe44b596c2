//! What every reader shares: a file's bytes, with an error naming the file when they cannot be
//! read, and the text a message quotes, kept on one line.

use std::path::Path;

use crate::error::{RecordingError, Result};

/// `text` with every control character written as its escape (`\n`, `\r`, `\u{0}`), so that
/// a label, a key or a cell quoted in a message keeps the message on one line.
pub(crate) fn printable(text: &str) -> String {
    if !text.chars().any(char::is_control) {
        return text.to_string();
    }
    text.chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// The bytes of a file; a missing file, a folder or a read failure is an error naming it.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|e| {
        let reason = match e.kind() {
            std::io::ErrorKind::NotFound => "no such file".to_string(),
            _ if path.is_dir() => "is a folder, not a file".to_string(),
            _ => format!("cannot read: {e}"),
        };
        RecordingError::file(path.display().to_string(), reason)
    })
}
