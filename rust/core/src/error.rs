//! The one error type of the kernels; the binding layer maps it to Python
//! exceptions in one place.

use std::fmt;

/// Why a kernel refused its input. Messages name the offending argument.
#[derive(Debug, Clone, PartialEq)]
pub enum KernelError {
    /// Two inputs that must have equal lengths do not.
    LengthMismatch { a: &'static str, b: &'static str, len_a: usize, len_b: usize },
    /// An input has fewer samples than the kernel needs.
    TooShort { name: &'static str, len: usize, min: usize },
    /// A lag outside 0..=n-1 was asked for.
    LagOutOfRange { max_lag: usize, n: usize },
    /// Any other malformed argument (shape, value), described in words.
    Invalid(String),
}

impl fmt::Display for KernelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KernelError::LengthMismatch { a, b, len_a, len_b } => {
                write!(f, "{a} and {b} must have equal lengths, got {len_a} and {len_b}")
            }
            KernelError::TooShort { name, len, min } => {
                write!(f, "{name} needs at least {min} samples, got {len}")
            }
            KernelError::LagOutOfRange { max_lag, n } => {
                write!(f, "max_lag must be in [0, n-1] = [0, {}], got {max_lag}", n.saturating_sub(1))
            }
            KernelError::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl std::error::Error for KernelError {}

/// Checks that two inputs have the same length.
pub(crate) fn same_len(a: &'static str, x: &[f64], b: &'static str, y: &[f64]) -> Result<(), KernelError> {
    if x.len() != y.len() {
        return Err(KernelError::LengthMismatch { a, b, len_a: x.len(), len_b: y.len() });
    }
    Ok(())
}
