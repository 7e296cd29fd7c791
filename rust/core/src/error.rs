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
    /// A sample that must be finite is NaN or inf. `channel` is the
    /// kernel's name of the channel (`fx`, `fy`, `fz`, `aux`, `fy_raw`,
    /// `fz_raw`); `sample` the start of the window that holds it
    /// (`window`), or the sample itself (not `window`: a filter needs every
    /// sample), counted from the start of the data the caller names (see
    /// [`KernelError::shifted`]); None until a caller knows it.
    NonFinite { channel: &'static str, sample: Option<usize>, window: bool },
    /// Any other malformed argument (shape, value), described in words.
    Invalid(String),
}

impl KernelError {
    /// The error with its sample position moved by `offset` (a window or
    /// block that starts at `offset` of the caller's data); a position not
    /// known yet becomes `offset` with `window` (the window itself).
    pub fn shifted(self, offset: usize) -> KernelError {
        match self {
            KernelError::NonFinite { channel, sample: None, .. } => {
                KernelError::NonFinite { channel, sample: Some(offset), window: true }
            }
            KernelError::NonFinite { channel, sample: Some(s), window } => {
                KernelError::NonFinite { channel, sample: Some(s + offset), window }
            }
            other => other,
        }
    }
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
            KernelError::NonFinite { channel, sample, window } => {
                write!(f, "{channel} contains NaN or inf")?;
                match (sample, window) {
                    (Some(s), true) => write!(f, " in the window starting at sample {s}"),
                    (Some(s), false) => write!(f, " at sample {s}"),
                    (None, _) => Ok(()),
                }
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
