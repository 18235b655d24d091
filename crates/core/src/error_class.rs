//! Whose fault an error is. Every error type of the library says it itself ([`Classify`]):
//! bad input — a scene, mesh, study or option the user can fix, which the command line answers
//! with exit code 2 and the Python package with `BadInputError` — or a failure of the
//! computation or the system (exit code 1, `SoftbenchError`). Callers ask the error, so a new
//! error type cannot fall into the wrong class unnoticed: the command line and the Python
//! package take only errors that implement [`Classify`].

/// The two classes of error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ErrorClass {
    /// The input is at fault (a file, a key, a value, an option): fixing it fixes the error.
    BadInput,
    /// Something failed that the input does not decide: a write, a solve, another process.
    Failure,
}

impl ErrorClass {
    /// Whether this is [`ErrorClass::BadInput`].
    pub fn is_bad_input(self) -> bool {
        self == Self::BadInput
    }

    /// `BadInput` when `bad`, else `Failure`.
    pub fn bad_input_if(bad: bool) -> Self {
        if bad { Self::BadInput } else { Self::Failure }
    }
}

/// An error that says whose fault it is. An error wrapping another one answers with the inner
/// error's class where the inner error decides it.
pub trait Classify {
    /// The error's class.
    fn class(&self) -> ErrorClass;
}

/// Implements [`Classify`] with one class for every value of each type listed.
#[macro_export]
macro_rules! classify_all {
    ($class:ident: $($ty:ty),+ $(,)?) => {
        $(impl $crate::error_class::Classify for $ty {
            fn class(&self) -> $crate::error_class::ErrorClass {
                $crate::error_class::ErrorClass::$class
            }
        })+
    };
}

// A read or write that the system refused: the files named are the user's, but whether they
// can be read is not something a scene or study decides.
classify_all!(Failure: std::io::Error);

impl<E: Classify + ?Sized> Classify for Box<E> {
    fn class(&self) -> ErrorClass {
        (**self).class()
    }
}
