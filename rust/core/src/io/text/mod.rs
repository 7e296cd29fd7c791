//! The numeric bodies of delimited text files (CSV, TSV, LVM): a scan that
//! follows a run of data rows, and a parse of their columns from any row
//! (docs/method.md 9, "Text files").
//!
//! The Python readers sniff the header and decide, line by line, what a row
//! is; this module repeats their rules for the plain rows of a table, fast,
//! and stops at the first line it is not sure of (the reader then takes that
//! line itself). Its rules are Python's, byte for byte, on lines decoded as
//! latin-1:
//! - a line ends at `\n`; trailing `\r` are dropped (`rstrip("\r\n")`);
//! - fields are split at one separator byte, or at runs of whitespace
//!   (`str.split()`, whose whitespace includes 0x1c-0x1f, 0x85 and 0xa0);
//! - a number is a field that Python's `float` reads after `strip()`, with
//!   the decimal comma replaced and no `_` (Rust's `f64` parser reads the
//!   same strings: digits, one point, an exponent, `inf`/`infinity`/`nan`
//!   in any case, a sign); an empty field is NaN;
//! - a blank line (ASCII whitespace only) and a comment line are skipped
//!   where the reader skips them.
//!
//! Both passes read with `pread` in blocks of about a megabyte and work on
//! pieces of whole lines in parallel; results are combined in file order, so
//! they never depend on the thread count.

//!
//! The parts: `scan` and `parse` (the two passes, from `read`'s blocks of
//! whole lines), `fields` (Python's rules for a line), `number` (Python's
//! `float`, and its quick ways), `rows` (the quick ways through a plain
//! row), `simd` (their builds by CPU level) and `error` (why rows cannot be
//! parsed, in the reader's words).

mod error;
mod fields;
mod number;
mod parse;
mod read;
mod rows;
mod scan;
mod simd;

pub use error::ParseError;
pub use number::to_float;
pub use parse::{parse, parse_into, Piece};
pub use scan::{scan, Break, Run, ScanSpec};

/// Bytes of the file one piece of the scan covers (and so the spacing of
/// the checkpoints a parse may start from).
pub const PIECE: usize = 1 << 20;

/// Bytes between the checkpoints the scan keeps inside a piece: a read of a
/// few windows (the pre-pass's samples) starts at most this far before them.
pub const STRIDE: usize = 1 << 16;

/// How a file's fields are separated and which lines are skipped.
#[derive(Clone, Debug)]
pub struct Dialect {
    /// The separator byte; None: runs of whitespace.
    pub delim: Option<u8>,
    /// `b'.'`, or `b','` for a decimal comma (a point is read too).
    pub decimal: u8,
    /// Lines that start with this (after leading whitespace) are skipped.
    pub comment: Option<Vec<u8>>,
    /// Blank lines are skipped (CSV); else they end a run (LVM segments).
    pub skip_blank: bool,
}

#[cfg(test)]
mod testing {
    //! What the tests of the text modules share: files, dialects, random text.
    use super::{Dialect, ScanSpec};
    use std::fs::File;
    use std::io::Write;

    pub(super) fn file_of(text: &[u8]) -> File {
        let mut f = tempfile();
        f.write_all(text).unwrap();
        f
    }

    pub(super) fn tempfile() -> File {
        let dir = std::env::temp_dir();
        for i in 0..1000u32 {
            let p = dir.join(format!("tribodyn-text-{}-{i}", std::process::id()));
            if let Ok(f) = std::fs::OpenOptions::new().read(true).write(true).create_new(true).open(&p) {
                let _ = std::fs::remove_file(&p);
                return f;
            }
        }
        panic!("no temporary file");
    }

    pub(super) fn csv() -> Dialect {
        Dialect { delim: Some(b','), decimal: b'.', comment: Some(b"#".to_vec()), skip_blank: true }
    }

    pub(super) fn spec(d: Dialect) -> ScanSpec {
        ScanSpec { dialect: d, nf: Some(3), probe: 1, time: Some(0), gap: 0.5, t_prev: f64::NAN, keep_times: 10 }
    }

    /// A xorshift64 generator from `state` (the tests' random text, the same on every run).
    pub(super) fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        }
    }

    /// A random field for the row paths' tests: mostly numbers of the shapes data files have, some
    /// of every other kind (signs, points, exponents, blanks, text, long digit runs).
    pub(super) fn random_field(next: &mut impl FnMut() -> u64) -> String {
        let r = next();
        let digits = |n: u64, next: &mut dyn FnMut() -> u64| -> String {
            (0..n).map(|_| (b'0' + (next() % 10) as u8) as char).collect()
        };
        let sign = ["", "-", "+", "", "-", ""][(r % 6) as usize];
        match (r >> 3) % 16 {
            0 => String::new(),
            1 => ["x", "nan", "-inf", " 1", "1 ", "1e5", "1E-3", "..5", "1.2.3", "-", ".", "+.", "1_0"]
                [(r >> 8) as usize % 13]
                .to_string(),
            2 => format!("{sign}{}", digits((r >> 8) % 21, next)),
            3 => format!("{sign}{}.{}e{}", digits((r >> 8) % 3, next), digits((r >> 12) % 4, next), (r >> 16) % 30),
            _ => {
                let a = (r >> 8) % 9;
                let b = (r >> 12) % 10;
                let p = if (r >> 16) % 8 == 0 { "" } else { "." };
                format!("{sign}{}{p}{}", digits(a, next), digits(b, next))
            }
        }
    }
}
