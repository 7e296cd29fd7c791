//! tribodyn-core: the numeric kernels of tribodyn, free of Python.
//!
//! Two parts, each a folder:
//! - [`numerics`]: the kernels that follow `docs/method.md` (shared with the
//!   Python package; the README links every formula): the correlation
//!   function, the streaming high-pass, the mergeable regression, the
//!   per-window statistics and the sums beyond the paper, NumPy's order
//!   statistics and the bootstrap;
//! - [`io`]: what reads files: the numeric bodies of text files, the segment
//!   index of TDMS files, and the window statistics read straight from a
//!   file's pages. It builds on [`numerics`]; [`numerics`] reads no file.
//!
//! Shared by both: [`error`] (the one error type and its wording) and
//! [`parallel`] (thread pools of a given size).
//!
//! Every public function validates what a caller controls and returns
//! [`KernelError`] (or, for text rows, [`io::text::ParseError`]) instead of
//! panicking.

pub mod error;
pub mod io;
pub mod numerics;
pub mod parallel;

pub use error::KernelError;
