//! The numeric kernels, each in its own module, following `docs/method.md`:
//! - [`correlation`]: lagged correlation function, Eq. (1) (docs/method.md 1);
//! - [`iir`]: streaming second-order-sections filter (docs/method.md 2);
//! - [`regression`]: mergeable, centred least-squares moments, Eqs. (6)-(8)
//!   (docs/method.md 3);
//! - [`windows`]: per-window statistics of a recording (docs/method.md 4-6);
//! - [`extended`]: sums for the estimators beyond the paper, line spectra and
//!   the fractional-delay correction (docs/method.md 3a-3e);
//! - [`lagprofile`]: the lagged sums of the instrument's lag profile (docs/method.md 3b);
//! - [`peaks`]: local maxima and their prominence (the stick-slip search);
//! - [`order`]: per-row medians and percentiles as NumPy's (the bootstrap);
//! - [`bootstrap`]: the moving-block bootstrap's resample statistics;
//! - [`sums`]: lane-split sums and the corrected two-pass mean;
//! - `lanes`: four-lane sums with the same bits on every CPU.
//!
//! Nothing here reads a file (that is [`crate::io`]).

pub mod bootstrap;
pub mod correlation;
pub mod extended;
pub mod iir;
pub mod lagprofile;
mod lanes;
pub mod order;
pub mod peaks;
pub mod regression;
pub mod sums;
pub mod windows;
