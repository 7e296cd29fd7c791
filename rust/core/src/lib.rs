//! tribodyn-core: the numeric kernels of tribodyn, free of Python.
//!
//! Each kernel lives in its own module and follows `docs/method.md` (shared with
//! the Python package; the README links every formula):
//! - [`correlation`]: lagged correlation function, Eq. (1) (docs/method.md 1);
//! - [`iir`]: streaming second-order-sections filter (docs/method.md 2);
//! - [`regression`]: mergeable, centred least-squares moments, Eqs. (6)-(8)
//!   (docs/method.md 3);
//! - [`windows`]: per-window statistics of a recording (docs/method.md 4-6);
//! - [`extended`]: sums for the estimators beyond the paper, line spectra and
//!   the fractional-delay correction (docs/method.md 3a-3e);
//! - [`mapped`]: the same, read straight from a file's pages (memory maps).
//! - [`tdms`]: the segment index of NI TDMS files, as extents `mapped` reads.
//! - [`text`]: the numeric bodies of CSV, TSV and LVM files (scan and parse).
//! - [`order`]: per-row medians and percentiles as NumPy's (the bootstrap).
//!
//! Every public function validates what a caller controls and returns
//! [`KernelError`] instead of panicking.

pub mod bootstrap;
pub mod correlation;
pub mod error;
pub mod extended;
pub mod iir;
mod lanes;
pub mod mapped;
pub mod order;
pub mod parallel;
pub mod regression;
pub mod sums;
pub mod tdms;
pub mod text;
pub mod windows;

pub use error::KernelError;
