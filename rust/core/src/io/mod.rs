//! Reading files natively:
//! - [`digest`]: the SHA-256 of an input file, in steps, without the GIL;
//! - [`text`]: the numeric bodies of CSV, TSV and LVM files (scan and parse);
//! - [`tdms`]: the segment index of NI TDMS files, as extents [`mapped`] reads;
//! - [`mapped`]: the window statistics of [`crate::numerics::windows`], read
//!   straight from a file's pages.

pub mod digest;
pub mod mapped;
pub mod tdms;
pub mod text;
