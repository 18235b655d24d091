//! An error on its way to a user: the whole chain of causes for the message, and its
//! [`ErrorClass`], which the library error that started it gave ([`Classify`]). The command
//! line turns the class into an exit code (2 for bad input) and the Python package into an
//! exception class (`BadInputError`).
//!
//! Only classified errors convert into an [`Error`] (`?` on a library result, or
//! [`Context::context`] on one), so an error type that does not say its class does not compile
//! into the command line or the Python package:
//!
//! ```compile_fail
//! #[derive(Debug, thiserror::Error)]
//! #[error("not classified")]
//! struct NotClassified;
//!
//! fn command() -> Result<(), softbench::error::Error> {
//!     Err(NotClassified)?
//! }
//! ```
//!
//! Errors that are not the library's (writing to stdout, serializing a report) are wrapped
//! explicitly, with [`Context::failure`] or [`Error::bad_input`].

use std::fmt::{self, Display};

pub use softbench_core::error_class::{Classify, ErrorClass};

/// An error with its class and its chain of causes.
pub struct Error {
    class: ErrorClass,
    chain: anyhow::Error,
}

impl Error {
    /// Whose fault it is.
    pub fn class(&self) -> ErrorClass {
        self.class
    }

    /// The chain of causes, outermost first (for a caller looking for a cause of a given
    /// type, such as a signal or a full disk).
    pub fn chain(&self) -> anyhow::Chain<'_> {
        self.chain.chain()
    }

    /// Bad input described by `message` (an option's value, a folder given on the command
    /// line).
    pub fn bad_input(message: impl Display + fmt::Debug + Send + Sync + 'static) -> Self {
        Self {
            class: ErrorClass::BadInput,
            chain: anyhow::Error::msg(message),
        }
    }

    /// A failure of the system that no library error describes (`error`, with `context`).
    pub fn failure<E>(error: E, context: impl Display + Send + Sync + 'static) -> Self
    where
        E: std::error::Error + Send + Sync + 'static,
    {
        Self {
            class: ErrorClass::Failure,
            chain: anyhow::Error::new(error).context(context),
        }
    }

    /// The same error under one more line of context (the class does not change).
    pub fn context(self, context: impl Display + Send + Sync + 'static) -> Self {
        Self {
            class: self.class,
            chain: self.chain.context(context),
        }
    }
}

impl<E> From<E> for Error
where
    E: Classify + std::error::Error + Send + Sync + 'static,
{
    fn from(error: E) -> Self {
        Self {
            class: error.class(),
            chain: anyhow::Error::new(error),
        }
    }
}

/// Shown as the command line prints it: every cause, outermost first, joined by `: `.
impl Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:#}", self.chain)
    }
}

impl fmt::Debug for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:?} ({:?})", self.chain, self.class)
    }
}

/// Context on a result, keeping the error's class (as anyhow's `Context` does the message).
pub trait Context<T> {
    /// The error under `context`.
    fn context(self, context: impl Display + Send + Sync + 'static) -> Result<T, Error>;

    /// The error under the context `f` makes (only when there is an error).
    fn with_context<C: Display + Send + Sync + 'static>(
        self,
        f: impl FnOnce() -> C,
    ) -> Result<T, Error>;
}

impl<T, E> Context<T> for Result<T, E>
where
    E: Classify + std::error::Error + Send + Sync + 'static,
{
    fn context(self, context: impl Display + Send + Sync + 'static) -> Result<T, Error> {
        self.map_err(|e| Error::from(e).context(context))
    }

    fn with_context<C: Display + Send + Sync + 'static>(
        self,
        f: impl FnOnce() -> C,
    ) -> Result<T, Error> {
        self.map_err(|e| Error::from(e).context(f()))
    }
}

impl<T> Context<T> for Result<T, Error> {
    fn context(self, context: impl Display + Send + Sync + 'static) -> Result<T, Error> {
        self.map_err(|e| e.context(context))
    }

    fn with_context<C: Display + Send + Sync + 'static>(
        self,
        f: impl FnOnce() -> C,
    ) -> Result<T, Error> {
        self.map_err(|e| e.context(f()))
    }
}

/// A result whose error is not the library's, made a failure with its context.
pub trait Failure<T> {
    /// The error, a failure, under `context`.
    fn failure(self, context: impl Display + Send + Sync + 'static) -> Result<T, Error>;
}

impl<T, E> Failure<T> for Result<T, E>
where
    E: std::error::Error + Send + Sync + 'static,
{
    fn failure(self, context: impl Display + Send + Sync + 'static) -> Result<T, Error> {
        self.map_err(|e| Error::failure(e, context))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use softbench_run::lock::LockError;

    #[test]
    fn the_class_is_the_library_errors_and_context_keeps_it() {
        let bad: Result<(), _> = Err(softbench_core::limits::OverBudget {
            what: "tets",
            value: "10".into(),
            limit: 1,
            variable: "SOFTBENCH_MAX_TETS",
        });
        let e = bad.context("cannot load").unwrap_err();
        assert_eq!(e.class(), ErrorClass::BadInput);
        assert!(
            e.to_string().starts_with("cannot load: tets would be 10"),
            "{e}"
        );
        let io: Result<(), std::io::Error> = Err(std::io::Error::other("disk on fire"));
        let e = io
            .context("cannot write")
            .context("study stopped")
            .unwrap_err();
        assert_eq!(e.class(), ErrorClass::Failure);
        assert_eq!(e.to_string(), "study stopped: cannot write: disk on fire");
        assert_eq!(e.chain().count(), 3);
    }

    #[test]
    fn a_wrapping_error_answers_with_the_class_of_what_it_wraps() {
        let unreadable = LockError::Unreadable {
            folder: "x".into(),
            lock: "x/.softbench.lock".into(),
            excerpt: "garbage".into(),
        };
        let run = softbench_study::study::RunError::Lock(unreadable);
        assert_eq!(Error::from(run).class(), ErrorClass::BadInput);
        let run = softbench_study::study::RunError::Run("the reference failed".into());
        assert_eq!(Error::from(run).class(), ErrorClass::Failure);
    }
}
