//! The one error type of the kernels and its wording (in the kernels' names,
//! or a caller's: [`Naming`]); the binding layer maps it to Python exceptions
//! in one place.

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

/// How a caller names a NaN or inf in its own terms (the recording's): the
/// auxiliary channel by its role (`aux`: "i" or "u"), the raw forces as the
/// forces, and with the sampling rate `fs` the time of the sample.
#[derive(Clone, Debug, PartialEq)]
pub struct Naming {
    pub aux: String,
    pub fs: Option<f64>,
}

impl Naming {
    /// The caller's name of the kernel's channel (`aux`, `fy_raw`, ...).
    pub fn role<'a>(&'a self, channel: &'a str) -> &'a str {
        if channel == "aux" {
            &self.aux
        } else {
            channel.strip_suffix("_raw").unwrap_or(channel)
        }
    }
}

impl KernelError {
    /// The error in the words of `naming` (None: the kernel's own names).
    pub fn named<'a>(&'a self, naming: Option<&'a Naming>) -> Named<'a> {
        Named { error: self, naming }
    }
}

/// A [`KernelError`] in a caller's words (see [`KernelError::named`]): the
/// one place its messages are worded.
pub struct Named<'a> {
    error: &'a KernelError,
    naming: Option<&'a Naming>,
}

impl fmt::Display for Named<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.error {
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
                let role = self.naming.map_or(*channel, |n| n.role(channel));
                write!(f, "{role} contains NaN or inf")?;
                let Some(s) = sample else { return Ok(()) };
                if *window {
                    write!(f, " in the window starting at sample {s}")?;
                } else {
                    write!(f, " at sample {s}")?;
                }
                match self.naming.and_then(|n| n.fs) {
                    // "fy contains NaN or inf in the window starting at sample 5000 (t = 5 s)"
                    Some(fs) => {
                        let tail = if *window { "" } else { "; the high-pass filter needs every sample" };
                        write!(f, " (t = {} s{tail})", format_g(*s as f64 / fs))
                    }
                    None => Ok(()),
                }
            }
            KernelError::Invalid(msg) => f.write_str(msg),
        }
    }
}

impl fmt::Display for KernelError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.named(None).fmt(f)
    }
}

/// `x` as Python's `f"{x:g}"` writes it: 6 significant digits, trailing
/// zeros dropped, an exponent below 1e-4 and from 1e6 on.
fn format_g(x: f64) -> String {
    if !x.is_finite() {
        return if x.is_nan() {
            "nan".into()
        } else if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        };
    }
    if x == 0.0 {
        return if x.is_sign_negative() { "-0".into() } else { "0".into() };
    }
    let sci = format!("{x:.5e}"); // rounded to 6 significant digits: its exponent decides
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let trim = |t: &str| -> String {
        if t.contains('.') {
            t.trim_end_matches('0').trim_end_matches('.').to_owned()
        } else {
            t.to_owned()
        }
    };
    if (-4..6).contains(&exp) {
        trim(&format!("{x:.*}", (5 - exp) as usize))
    } else {
        let sign = if exp < 0 { '-' } else { '+' };
        format!("{}e{sign}{:02}", trim(mantissa), exp.abs())
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn format_g_writes_as_python() {
        // f"{x:g}" in Python 3
        for (x, want) in [
            (5.0, "5"),
            (0.5, "0.5"),
            (1e-5, "1e-05"),
            (123456.0, "123456"),
            (1234567.0, "1.23457e+06"),
            (0.0001, "0.0001"),
            (0.00012345678, "0.000123457"),
            (2.5e-7, "2.5e-07"),
            (1e16, "1e+16"),
            (100000.0, "100000"),
            (999999.5, "1e+06"),
            (9.9999995e-05, "0.0001"),
            (12.3456789, "12.3457"),
            (1e100, "1e+100"),
            (-0.0, "-0"),
            (f64::NEG_INFINITY, "-inf"),
        ] {
            assert_eq!(format_g(x), want, "{x:?}");
        }
    }

    #[test]
    fn non_finite_is_named_by_role_and_time() {
        let e = KernelError::NonFinite { channel: "aux", sample: Some(5000), window: true };
        assert_eq!(e.to_string(), "aux contains NaN or inf in the window starting at sample 5000");
        let n = Naming { aux: "i".into(), fs: Some(1000.0) };
        assert_eq!(
            e.named(Some(&n)).to_string(),
            "i contains NaN or inf in the window starting at sample 5000 (t = 5 s)"
        );
        let e = KernelError::NonFinite { channel: "fy_raw", sample: Some(1234567), window: false };
        assert_eq!(
            e.named(Some(&n)).to_string(),
            "fy contains NaN or inf at sample 1234567 (t = 1234.57 s; the high-pass filter needs every sample)"
        );
        let unnamed = KernelError::NonFinite { channel: "fz", sample: None, window: false };
        assert_eq!(unnamed.named(Some(&n)).to_string(), "fz contains NaN or inf");
    }
}
