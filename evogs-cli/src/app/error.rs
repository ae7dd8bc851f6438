//! The one error type of the commands: a line naming the file or setting at fault.

/// Why a command failed: one line naming the file or setting at fault.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct CommandError(pub String);

impl CommandError {
    /// An error from anything printable.
    pub fn from_display(e: impl std::fmt::Display) -> Self {
        Self(e.to_string())
    }
}
