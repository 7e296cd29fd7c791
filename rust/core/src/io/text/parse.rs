//! The parse: the columns asked for of given rows, read from checkpoints of
//! the scan, each range of rows on its own thread.

use super::fields::{text_of, Fields};
use super::number::{bytes_ws, number, str_ws, strip};
use super::read::read_some;
use super::rows::{parse_line_fast, parse_row_masked, parse_row_quick, plain_start, quick_sep};
use super::simd::by_level;
use super::{Dialect, ParseError};
use crate::error::KernelError;
use crate::parallel;
use rayon::prelude::*;
use std::fs::File;

/// Rows to parse: `rows` data rows after skipping `skip`, from byte
/// `offset`, whose line has the number `line` (for messages).
#[derive(Clone, Copy, Debug)]
pub struct Piece {
    pub offset: u64,
    pub line: u64,
    pub skip: u64,
    pub rows: u64,
}

pub(super) const BLOCK: usize = 1 << 18;

by_level! {
    /// [`parse_piece_with`] in the build the CPU runs.
    fn parse_piece(
        file: &File,
        p: &Piece,
        d: &Dialect,
        usecols: &[usize],
        outs: &mut [&mut [f64]],
    ) -> Result<(), ParseError> => parse_piece_with, parse_piece_sse41, parse_piece_avx2
}

#[inline(always)]
pub(super) fn parse_piece_with<const LEVEL: u8>(
    file: &File,
    p: &Piece,
    d: &Dialect,
    usecols: &[usize],
    outs: &mut [&mut [f64]],
) -> Result<(), ParseError> {
    let need = usecols.iter().max().map_or(0, |&m| m + 1);
    // which asked column each field feeds (a field may feed several)
    let mut feeds: Vec<Vec<usize>> = vec![Vec::new(); need];
    for (c, &u) in usecols.iter().enumerate() {
        feeds[u].push(c);
    }
    let pairs: Vec<(usize, usize)> = usecols.iter().enumerate().map(|(c, &u)| (u, c)).collect();
    let used: Vec<bool> = (0..need).map(|k| !feeds[k].is_empty()).collect();
    let mut vals = vec![0.0f64; need];
    let quick = quick_sep(d);
    let mut buf: Vec<u8> = Vec::with_capacity(BLOCK);
    let mut off = p.offset;
    let mut line = p.line;
    let mut skip = p.skip;
    let mut r = 0usize;
    let rows = p.rows as usize;
    let mut eof = false;
    // a short piece (a few windows of a sample) reads about its rows' bytes, not a whole block
    let mut want = ((p.skip + p.rows) as usize).saturating_mul(64).clamp(1 << 12, BLOCK);
    // bytes and rows (data rows passed over or parsed) consumed so far: the last block of a piece reads
    // about the bytes its remaining rows take, not a whole block past them
    let (mut done_bytes, mut done_rows) = (0u64, 0u64);
    while r < rows {
        if eof && buf.is_empty() {
            return Err(ParseError::Eof { line: line.saturating_sub(1), short: (rows - r) as u64 });
        }
        if !eof {
            let have = buf.len();
            let grow = want.max(have); // doubles while one line fills the buffer
            want = BLOCK;
            buf.resize(have + grow, 0);
            let got = read_some(file, off, &mut buf[have..]).map_err(ParseError::Io)?;
            buf.truncate(have + got);
            off += got as u64;
            eof = got < grow;
        }
        // whole lines only (and the last line of the file)
        let end = if eof { buf.len() } else { memchr::memrchr(b'\n', &buf).map_or(0, |i| i + 1) };
        let view = &buf[..end];
        let mut at = 0usize;
        while at < end {
            if skip > 0 && plain_start(view, at, d) {
                // a data row to pass over (neither blank nor a comment)
                at = memchr::memchr(b'\n', &view[at..]).map_or(end, |i| at + i + 1);
                line += 1;
                skip -= 1;
                continue;
            }
            if skip == 0 {
                let row = match quick {
                    Some((sep, point)) => parse_row_masked::<LEVEL>(view, at, d, sep, point, &used, &mut vals)
                        .unwrap_or_else(|| parse_row_quick(view, at, d, sep, point, &used, &mut vals)),
                    None => None,
                };
                if let Some(nl) = row.or_else(|| parse_line_fast(view, at, d, &used, &mut vals)) {
                    for &(k, c) in &pairs {
                        outs[c][r] = vals[k];
                    }
                    r += 1;
                    line += 1;
                    at = nl;
                    if r == rows {
                        break;
                    }
                    continue;
                }
            }
            let nl = memchr::memchr(b'\n', &view[at..]).map_or(end, |i| at + i + 1);
            let text = text_of(&view[at..nl]);
            at = nl;
            let this = line;
            line += 1;
            let s = strip(text, bytes_ws);
            if (s.is_empty() && d.skip_blank) || d.comment.as_ref().is_some_and(|c| !s.is_empty() && s.starts_with(c)) {
                continue;
            }
            if skip > 0 {
                skip -= 1;
                continue;
            }
            // as Python's parse_rows: the row's width first, then its numbers
            let got = Fields::new(text, d.delim).count();
            if got < need {
                return Err(ParseError::Fields { line: this, got, need });
            }
            for (n, f) in Fields::new(text, d.delim).take(need).enumerate() {
                if !feeds[n].is_empty() {
                    let v = strip(f, str_ws);
                    let x = if v.is_empty() {
                        f64::NAN
                    } else {
                        match number(v, d.decimal) {
                            Some(x) => x,
                            None => return Err(ParseError::Number { line: this, col: feeds[n][0], text: v.to_vec() }),
                        }
                    };
                    for &c in &feeds[n] {
                        outs[c][r] = x;
                    }
                }
            }
            r += 1;
            if r == rows {
                break;
            }
        }
        buf.drain(..at);
        done_bytes += at as u64;
        let rows_now = (p.skip - skip) + r as u64;
        if rows_now > done_rows && r < rows {
            done_rows = rows_now;
            let left = (p.skip + p.rows).saturating_sub(done_rows);
            let est = left.saturating_mul(done_bytes) / done_rows;
            want = (est + est / 16 + 256).min(BLOCK as u64).max(1 << 12) as usize;
        }
    }
    Ok(())
}

/// Parses the rows of `pieces` (in order, concatenated) into `cols`, one
/// slice per entry of `usecols`, each as long as the pieces' rows. The
/// first error in file order is the one returned, whatever the thread count.
pub fn parse(
    file: &File,
    pieces: &[Piece],
    d: &Dialect,
    usecols: &[usize],
    cols: &mut [&mut [f64]],
    threads: usize,
) -> Result<(), ParseError> {
    let total: usize = pieces.iter().map(|p| p.rows as usize).sum();
    if cols.len() != usecols.len() || cols.iter().any(|c| c.len() != total) {
        return Err(ParseError::Io(KernelError::Invalid(format!(
            "{} output columns for {} columns of {total} rows",
            cols.len(),
            usecols.len()
        ))));
    }
    let threads = parallel::check_threads(threads).map_err(ParseError::Io)?;
    let mut per: Vec<Vec<&mut [f64]>> = pieces.iter().map(|_| Vec::with_capacity(usecols.len())).collect();
    for col in cols.iter_mut() {
        let mut rest: &mut [f64] = col;
        for (k, p) in pieces.iter().enumerate() {
            let (a, b) = std::mem::take(&mut rest).split_at_mut(p.rows as usize);
            per[k].push(a);
            rest = b;
        }
    }
    let results: Vec<Result<(), ParseError>> = parallel::run_with(threads, || {
        pieces.par_iter().zip(per.par_iter_mut()).map(|(p, o)| parse_piece(file, p, d, usecols, o)).collect()
    })
    .map_err(ParseError::Io)?;
    results.into_iter().collect()
}

/// [`parse`] into channels-first `out` (`usecols.len()` rows of the pieces' rows).
pub fn parse_into(
    file: &File,
    pieces: &[Piece],
    d: &Dialect,
    usecols: &[usize],
    out: &mut [f64],
    threads: usize,
) -> Result<(), ParseError> {
    let total: usize = pieces.iter().map(|p| p.rows as usize).sum();
    let mut cols: Vec<&mut [f64]> = if total == 0 { Vec::new() } else { out.chunks_mut(total).collect() };
    if total == 0 {
        return Ok(());
    }
    parse(file, pieces, d, usecols, &mut cols, threads)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::text::scan::scan_piece_with;
    #[cfg(target_arch = "x86_64")]
    use crate::io::text::scan::{scan_piece, scan_piece_sse41};
    #[cfg(target_arch = "x86_64")]
    use crate::io::text::simd::level;
    use crate::io::text::testing::{csv, file_of, random_field, spec, xorshift};
    use crate::io::text::{scan, ScanSpec};
    use std::io::Write;

    #[test]
    fn pieces_read_the_same_with_and_without_sse() {
        // a file of random rows (numbers of every length, blanks, text, \r\n): the portable scan and
        // parse of a piece give what the dispatched ones (SSE4.1 here, where the CPU has it) give
        let mut next = xorshift(0x0bad_cafe_1234_5678u64);
        let mut text = Vec::new();
        for i in 0..20_000u32 {
            write!(text, "{}", i as f64 * 1e-3).unwrap();
            for k in 0..3 {
                let f = random_field(&mut next);
                // numbers and blanks (NaN), and in the last column a rare other field (the parse's error)
                let ok = f.parse::<f64>().is_ok() || f.is_empty() || (k == 2 && next() % 5_000 == 0);
                let f = if ok { f } else { "1.5".into() };
                write!(text, ",{f}").unwrap();
            }
            text.extend_from_slice(if next() % 5 == 0 { b"\r\n" } else { b"\n" });
        }
        let f = file_of(&text);
        let mut sp = spec(csv());
        sp.nf = Some(4);
        sp.gap = 0.0015;
        let a = scan_piece_with::<0>(&text, &sp, 100);
        let mut others = vec![scan_piece(&text, &sp, 100)];
        #[cfg(target_arch = "x86_64")]
        if level() >= 1 {
            // SAFETY: the CPU has the features of level 1
            others.push(unsafe { scan_piece_sse41(&text, &sp, 100) });
        }
        for b in &others {
            assert_eq!((a.rows, a.lines, a.stop, &a.breaks, a.last), (b.rows, b.lines, b.stop, &b.breaks, b.last));
            assert!(a.times.iter().zip(&b.times).all(|(x, y)| x.to_bits() == y.to_bits()));
        }
        let rows = a.rows;
        assert!(rows > 1_000, "{rows}");
        let d = csv();
        let p = Piece { offset: 0, line: 1, skip: 3, rows: rows - 3 };
        for cols in [vec![1usize, 2, 3], vec![3, 0], vec![2]] {
            let mut x = vec![vec![0.0; p.rows as usize]; cols.len()];
            let mut y = x.clone();
            let ra = {
                let mut o: Vec<&mut [f64]> = x.iter_mut().map(|c| c.as_mut_slice()).collect();
                parse_piece_with::<0>(&f, &p, &d, &cols, &mut o)
            };
            let rb = {
                let mut o: Vec<&mut [f64]> = y.iter_mut().map(|c| c.as_mut_slice()).collect();
                parse_piece(&f, &p, &d, &cols, &mut o)
            };
            assert_eq!(ra, rb);
            #[cfg(target_arch = "x86_64")]
            if level() >= 1 {
                let mut z = x.clone();
                let mut o: Vec<&mut [f64]> = z.iter_mut().map(|c| c.as_mut_slice()).collect();
                // SAFETY: the CPU has the features of level 1
                assert_eq!(unsafe { parse_piece_sse41(&f, &p, &d, &cols, &mut o) }, ra);
                assert!(z.iter().flatten().zip(y.iter().flatten()).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
            assert!(ra.is_ok() || cols.contains(&3));
            for (u, v) in x.iter().zip(&y) {
                assert!(u.iter().zip(v).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
    }

    #[test]
    fn parse_reads_columns_and_names_bad_lines() {
        let text = b"0,1,2\n\n0.1,,2.5\n0.2,x,3\n0.3,1\n";
        let f = file_of(text);
        let d = csv();
        let mut out = vec![0.0; 4];
        parse_into(&f, &[Piece { offset: 0, line: 1, skip: 0, rows: 2 }], &d, &[2, 1], &mut out, 2).unwrap();
        assert_eq!(out[..3], [2.0, 2.5, 1.0]);
        assert!(out[3].is_nan());
        let mut out = vec![0.0; 1];
        let e = parse_into(&f, &[Piece { offset: 0, line: 1, skip: 2, rows: 1 }], &d, &[1], &mut out, 1).unwrap_err();
        assert_eq!(e, ParseError::Number { line: 4, col: 0, text: b"x".to_vec() });
        let e = parse_into(&f, &[Piece { offset: 0, line: 1, skip: 3, rows: 1 }], &d, &[2], &mut out, 1).unwrap_err();
        assert_eq!(e, ParseError::Fields { line: 5, got: 2, need: 3 });
        let e = parse_into(&f, &[Piece { offset: 0, line: 1, skip: 4, rows: 1 }], &d, &[0], &mut out, 1).unwrap_err();
        assert!(matches!(e, ParseError::Eof { short: 1, .. }));
    }

    #[test]
    fn lines_led_by_whitespace_take_the_same_way() {
        // a one-column file: a blank line is skipped, not a row of NaN
        let d = Dialect { delim: Some(b','), decimal: b'.', comment: Some(b"#".to_vec()), skip_blank: true };
        let sp = ScanSpec {
            dialect: d.clone(),
            nf: Some(1),
            probe: 0,
            time: None,
            gap: f64::NAN,
            t_prev: f64::NAN,
            keep_times: 0,
        };
        let f = file_of(b" 1.5\n   \n  # c\n\t2\n \xa0\n");
        let r = scan(&f, 0, &sp, 1).unwrap();
        assert_eq!((r.rows, r.lines), (3, 5)); // "\xa0" is no blank line to Python's bytes.strip: a row (NaN)
        let mut out = vec![0.0; 3];
        parse_into(&f, &[Piece { offset: 0, line: 1, skip: 0, rows: 3 }], &d, &[0], &mut out, 1).unwrap();
        assert_eq!(out[..2], [1.5, 2.0]);
        assert!(out[2].is_nan());
        let mut one = vec![0.0; 1];
        parse_into(&f, &[Piece { offset: 0, line: 1, skip: 1, rows: 1 }], &d, &[0], &mut one, 1).unwrap();
        assert_eq!(one, vec![2.0]);
    }

    #[test]
    fn a_line_of_tabs_is_blank() {
        let d = Dialect { delim: Some(b'\t'), decimal: b'.', comment: None, skip_blank: true };
        let sp = ScanSpec {
            dialect: d.clone(),
            nf: Some(2),
            probe: 0,
            time: None,
            gap: f64::NAN,
            t_prev: f64::NAN,
            keep_times: 0,
        };
        let f = file_of(b"1\t2\n\t\n \t \n\t3\n");
        let r = scan(&f, 0, &sp, 1).unwrap();
        assert_eq!((r.rows, r.lines), (2, 4));
        let mut out = vec![0.0; 2];
        parse_into(&f, &[Piece { offset: 0, line: 1, skip: 1, rows: 1 }], &d, &[0, 1], &mut out, 1).unwrap();
        assert!(out[0].is_nan() && out[1] == 3.0);
    }

    #[test]
    fn whitespace_and_decimal_comma() {
        let d = Dialect { delim: None, decimal: b',', comment: None, skip_blank: true };
        let f = file_of(b"  1,5\t2,25  \n3 4\n");
        let mut out = vec![0.0; 4];
        parse_into(&f, &[Piece { offset: 0, line: 1, skip: 0, rows: 2 }], &d, &[0, 1], &mut out, 1).unwrap();
        assert_eq!(out, vec![1.5, 3.0, 2.25, 4.0]);
    }
}
