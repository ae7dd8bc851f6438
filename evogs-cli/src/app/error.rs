//! The one error type of the commands: what was being worked on (a file, a setting, a flag),
//! then the cause, printed as one line: `path/config.toml: schedule.iterations must be ...`.
//!
//! Errors are made where the cause is known ([`CommandError::new`]) and get their context
//! where the file or setting is known ([`Context::at`], [`Context::context`]), so the
//! `"{path}: {cause}"` formatting lives here only.

use std::fmt;
use std::path::Path;

/// Why a command failed: a context chain (outermost first: the file, setting or flag at
/// fault) and the cause. Its `Display` is one line, the context and the cause joined by `: `.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CommandError {
    /// What was being worked on, outermost first.
    context: Vec<String>,
    /// What went wrong.
    cause: String,
}

/// The result of a command step.
pub type CommandResult<T> = Result<T, CommandError>;

impl CommandError {
    /// An error with this cause and no context yet.
    pub fn new(cause: impl fmt::Display) -> Self {
        Self {
            context: Vec::new(),
            cause: cause.to_string(),
        }
    }

    /// An error about the file or folder `path`.
    pub fn at(path: &Path, cause: impl fmt::Display) -> Self {
        Self::new(cause).context(path.display())
    }

    /// The same error inside `what` (a file, a setting, a flag): `what` is printed first.
    #[must_use]
    pub fn context(mut self, what: impl fmt::Display) -> Self {
        self.context.insert(0, what.to_string());
        self
    }

    /// The cause without its context.
    #[must_use]
    pub fn cause(&self) -> &str {
        &self.cause
    }

    /// The context, outermost first.
    #[must_use]
    pub fn context_chain(&self) -> &[String] {
        &self.context
    }
}

impl fmt::Display for CommandError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for what in &self.context {
            write!(f, "{what}: ")?;
        }
        f.write_str(&self.cause)
    }
}

impl std::error::Error for CommandError {}

impl From<String> for CommandError {
    fn from(cause: String) -> Self {
        Self::new(cause)
    }
}

impl From<&str> for CommandError {
    fn from(cause: &str) -> Self {
        Self::new(cause)
    }
}

/// Adds context to any failed result whose error prints.
pub trait Context<T> {
    /// The error inside `what` (a setting or a flag), which is printed first.
    ///
    /// # Errors
    /// The original error, with the context.
    fn context(self, what: impl fmt::Display) -> CommandResult<T>;

    /// The error about the file or folder `path`, which is printed first.
    ///
    /// # Errors
    /// The original error, with the path.
    fn at(self, path: &Path) -> CommandResult<T>;

    /// The error about `path`, after a description of what was being done with it
    /// (`cannot read`, `cannot write the log`): `path: doing: cause`.
    ///
    /// # Errors
    /// The original error, with the path and the description.
    fn doing(self, path: &Path, what: &str) -> CommandResult<T>;
}

impl<T, E: fmt::Display> Context<T> for Result<T, E> {
    fn context(self, what: impl fmt::Display) -> CommandResult<T> {
        self.map_err(|e| CommandError::new(e).context(what))
    }

    fn at(self, path: &Path) -> CommandResult<T> {
        self.map_err(|e| CommandError::at(path, e))
    }

    fn doing(self, path: &Path, what: &str) -> CommandResult<T> {
        self.map_err(|e| CommandError::new(e).context(what).context(path.display()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_context_is_printed_first_on_one_line() {
        let e = CommandError::new("must be at least 1").context("schedule.iterations");
        assert_eq!(e.to_string(), "schedule.iterations: must be at least 1");
        let e = e.context("run/config.toml");
        assert_eq!(
            e.to_string(),
            "run/config.toml: schedule.iterations: must be at least 1"
        );
        assert_eq!(e.cause(), "must be at least 1");
        assert_eq!(e.context_chain().len(), 2);
        let r: Result<(), std::io::Error> = Err(std::io::Error::other("denied"));
        let e = r
            .doing(Path::new("a/log.csv"), "cannot write the log")
            .expect_err("failed");
        assert_eq!(e.to_string(), "a/log.csv: cannot write the log: denied");
        assert!(!e.to_string().contains('\n'));
    }
}
