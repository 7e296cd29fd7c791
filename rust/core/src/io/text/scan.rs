//! The scan: follows a run of data rows through the file, in pieces of
//! [`PIECE`] bytes on several threads, and records their count, the time
//! column's restarts and gaps and the checkpoints a parse may start from.

use super::fields::{text_of, Fields, Kind};
use super::number::{number, str_ws, strip};
use super::read::lines_in;
use super::rows::{quick_sep, scan_line_fast, scan_row_masked, scan_row_quick};
use super::simd::by_level;
use super::{Dialect, PIECE, STRIDE};
use crate::error::KernelError;
use crate::parallel;
use rayon::prelude::*;
use std::fs::File;

/// What makes a line a data row, and what the scan records of the rows.
#[derive(Clone, Debug)]
pub struct ScanSpec {
    pub dialect: Dialect,
    /// Fields a row has (more are allowed when they are blank); None: any.
    pub nf: Option<usize>,
    /// This field must be a number or empty.
    pub probe: usize,
    /// The time column, whose restarts and gaps the scan reports.
    pub time: Option<usize>,
    /// A time step above this is a gap (NaN: only restarts are reported).
    pub gap: f64,
    /// The time of the row before the run (NaN: none).
    pub t_prev: f64,
    /// Time values kept, from the run's first row.
    pub keep_times: usize,
}

/// A time restart or gap: the row where a new segment starts.
#[derive(Clone, Debug, PartialEq)]
pub struct Break {
    /// Row of the run.
    pub row: u64,
    /// Line, counted from the run's first line (0).
    pub line: u64,
    /// Byte offset of the row in the file.
    pub offset: u64,
    pub prev: f64,
    pub now: f64,
}

/// A run of data rows found by [`scan`].
#[derive(Clone, Debug, Default)]
pub struct Run {
    /// Data rows.
    pub rows: u64,
    /// Lines consumed (data rows, and skipped blank and comment lines).
    pub lines: u64,
    /// Byte offset after the run: the line that ended it, or the file's end.
    pub end: u64,
    /// Time values of the first rows (NaN where a row's time is not a number).
    pub times: Vec<f64>,
    pub breaks: Vec<Break>,
    /// The last finite time of the run (or the one given when none).
    pub t_prev: f64,
    /// (row, byte offset, line) from which a parse can start: about one per [`PIECE`].
    pub checkpoints: Vec<(u64, u64, u64)>,
    /// More such entries, about one per [`STRIDE`] bytes: the rows from one to the next
    /// checkpoint after it are consecutive (only blank and comment lines between).
    pub marks: Vec<(u64, u64, u64)>,
    /// (line, byte offset) of the last data row.
    pub last: Option<(u64, u64)>,
}

#[derive(Default)]
pub(super) struct PieceScan {
    pub(super) rows: u64,
    pub(super) lines: u64,
    pub(super) stop: Option<usize>,
    pub(super) times: Vec<f64>,
    pub(super) breaks: Vec<Break>,
    pub(super) first: Option<(u64, u64, usize, f64)>,
    pub(super) last_t: f64,
    pub(super) last: Option<(u64, usize)>,
    /// (row, line, byte) of data rows about every [`STRIDE`] bytes after the piece's start.
    pub(super) marks: Vec<(u64, u64, usize)>,
    pub(super) next_mark: usize,
}

pub(super) fn is_break(prev: f64, now: f64, gap: f64) -> bool {
    now < prev || now - prev > gap
}

impl PieceScan {
    /// Counts a data row at byte `at` with time `t` (NaN: none): its break, if any, and its kept time.
    #[inline(always)]
    pub(super) fn row(&mut self, t: f64, t_prev: &mut f64, at: usize, spec: &ScanSpec, keep: usize) {
        if spec.time.is_some() {
            if !t.is_nan() {
                if t_prev.is_nan() {
                    self.first = Some((self.rows, self.lines, at, t));
                } else if is_break(*t_prev, t, spec.gap) {
                    self.breaks.push(Break {
                        row: self.rows,
                        line: self.lines,
                        offset: at as u64,
                        prev: *t_prev,
                        now: t,
                    });
                }
                *t_prev = t;
            }
            if self.times.len() < keep {
                self.times.push(t);
            }
        }
        if at >= self.next_mark {
            self.marks.push((self.rows, self.lines, at));
            self.next_mark = at + STRIDE;
        }
        self.last = Some((self.lines, at));
        self.rows += 1;
    }
}

by_level! {
    /// [`scan_piece_with`] in the build the CPU runs.
    fn scan_piece(buf: &[u8], spec: &ScanSpec, keep: usize) -> PieceScan
        => scan_piece_with, scan_piece_sse41, scan_piece_avx2
}

#[inline(always)]
pub(super) fn scan_piece_with<const LEVEL: u8>(buf: &[u8], spec: &ScanSpec, keep: usize) -> PieceScan {
    let mut out = PieceScan { last_t: f64::NAN, next_mark: STRIDE, ..Default::default() };
    let d = &spec.dialect;
    let mut t_prev = f64::NAN;
    let mut at = 0usize;
    let quick = quick_sep(d);
    while at < buf.len() {
        let row = quick.and_then(|(sep, point)| {
            scan_row_masked::<LEVEL>(buf, at, spec, sep, point)
                .unwrap_or_else(|| scan_row_quick(buf, at, spec, sep, point))
        });
        if let Some((nl, t)) = row {
            out.row(t, &mut t_prev, at, spec, keep);
            out.lines += 1;
            at = nl;
            continue;
        }
        if let Some((nl, t)) = scan_line_fast(buf, at, spec) {
            out.row(t, &mut t_prev, at, spec, keep);
            out.lines += 1;
            at = nl;
            continue;
        }
        let nl = memchr::memchr(b'\n', &buf[at..]).map_or(buf.len(), |i| at + i + 1);
        let text = text_of(&buf[at..nl]);
        match d.classify(text) {
            Kind::Skip => {}
            Kind::Other => {
                out.stop = Some(at);
                return out;
            }
            Kind::Data => {
                let mut n = 0usize;
                let mut ok = true;
                let mut t = f64::NAN;
                for f in Fields::new(text, d.delim) {
                    if n == spec.probe || Some(n) == spec.time {
                        let v = strip(f, str_ws);
                        let x = number(v, d.decimal);
                        if n == spec.probe && !v.is_empty() && x.is_none() {
                            ok = false;
                            break;
                        }
                        if Some(n) == spec.time {
                            t = x.unwrap_or(f64::NAN);
                        }
                    }
                    if let Some(nf) = spec.nf {
                        if n >= nf && !strip(f, str_ws).is_empty() {
                            ok = false;
                            break;
                        }
                    }
                    n += 1;
                }
                if !ok || n <= spec.probe || spec.nf.is_some_and(|nf| n < nf) || spec.time.is_some_and(|j| n <= j) {
                    out.stop = Some(at);
                    return out;
                }
                out.row(t, &mut t_prev, at, spec, keep);
            }
        }
        out.lines += 1;
        at = nl;
    }
    out.last_t = t_prev;
    out
}

/// Follows the run of data rows that starts at byte `start` of `file` (the
/// line there is its first) until a line that is not one (by `spec`'s
/// rules; see the module doc) or the file's end. A last line without its
/// `\n` ends the run too (it may be a row being written).
///
/// The file is cut at every [`PIECE`] bytes; each piece's thread reads its
/// own bytes and finds its first whole line (see [`lines_in`]), so the
/// reads run in parallel too; the pieces are then joined in file order.
pub fn scan(file: &File, start: u64, spec: &ScanSpec, threads: usize) -> Result<Run, KernelError> {
    let size = file.metadata().map_err(|e| KernelError::Invalid(format!("cannot stat the file: {e}")))?.len();
    let threads = parallel::check_threads(threads)?;
    let mut run = Run { t_prev: spec.t_prev, end: start, ..Default::default() };
    let mut pos = start;
    while pos < size {
        let batch: Vec<(u64, u64)> = (0..4 * threads as u64)
            .map(|k| (pos + k * PIECE as u64, (pos + (k + 1) * PIECE as u64).min(size)))
            .filter(|&(lo, _)| lo < size)
            .collect();
        // times still wanted: a piece keeps no more (those after the first pieces are dropped anyway)
        let keep = spec.keep_times.saturating_sub(run.times.len());
        let pieces: Vec<Result<(u64, usize, PieceScan), KernelError>> = parallel::run_with(threads, || {
            batch
                .par_iter()
                .map(|&(lo, hi)| {
                    let (base, buf, skip) = lines_in(file, lo, hi, lo == start, size)?;
                    Ok((base, buf.len() - skip, scan_piece(&buf[skip..], spec, keep)))
                })
                .collect()
        })?;
        pos = batch.last().map_or(size, |b| b.1);
        for piece in pieces {
            let (base, len, p) = piece?;
            if len == 0 {
                continue;
            }
            if p.rows > 0 {
                run.checkpoints.push((run.rows, base, run.lines));
            }
            for &(row, line, at) in p.marks.iter().filter(|m| m.2 > 0) {
                run.marks.push((run.rows + row, base + at as u64, run.lines + line));
            }
            if let Some((row, line, at, t)) = p.first {
                if !run.t_prev.is_nan() && is_break(run.t_prev, t, spec.gap) {
                    run.breaks.push(Break {
                        row: run.rows + row,
                        line: run.lines + line,
                        offset: base + at as u64,
                        prev: run.t_prev,
                        now: t,
                    });
                }
            }
            for b in p.breaks {
                run.breaks.push(Break {
                    row: run.rows + b.row,
                    line: run.lines + b.line,
                    offset: base + b.offset,
                    ..b
                });
            }
            let room = spec.keep_times.saturating_sub(run.times.len());
            run.times.extend_from_slice(&p.times[..p.times.len().min(room)]);
            if !p.last_t.is_nan() {
                run.t_prev = p.last_t;
            }
            if let Some((line, at)) = p.last {
                run.last = Some((run.lines + line, base + at as u64));
            }
            run.rows += p.rows;
            run.lines += p.lines;
            if let Some(stop) = p.stop {
                run.end = base + stop as u64;
                return Ok(run);
            }
            run.end = base + len as u64;
        }
    }
    Ok(run)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::text::testing::{csv, file_of, spec};
    use crate::io::text::{parse_into, Piece};
    use std::io::Write;

    #[test]
    fn scan_stops_at_other_lines_and_reports_breaks() {
        let text = b"0,1,2\n\n# note\n0.1,1,2\r\n0.2,,3\n0.1,4,5\n1.5,4,5\nfoot,er,x\n9,9,9\n";
        let f = file_of(text);
        let r = scan(&f, 0, &spec(csv()), 2).unwrap();
        assert_eq!(r.rows, 5);
        assert_eq!(r.lines, 7);
        assert_eq!(&text[r.end as usize..r.end as usize + 4], b"foot");
        assert_eq!(r.times, vec![0.0, 0.1, 0.2, 0.1, 1.5]);
        assert_eq!(r.breaks.len(), 2);
        assert_eq!((r.breaks[0].row, r.breaks[0].line, r.breaks[0].prev, r.breaks[0].now), (3, 5, 0.2, 0.1));
        assert_eq!((r.breaks[1].row, r.breaks[1].now), (4, 1.5));
        assert_eq!(r.last, Some((6, 38)));
        assert_eq!(r.checkpoints, vec![(0, 0, 0)]);
    }

    #[test]
    fn scan_leaves_an_unterminated_last_line() {
        let f = file_of(b"0,1,2\n1,2,3");
        let r = scan(&f, 0, &spec(csv()), 1).unwrap();
        assert_eq!((r.rows, r.end), (1, 6));
    }

    #[test]
    fn scan_is_the_same_for_any_thread_count_and_piece() {
        let mut text = Vec::new();
        for i in 0..300_000u32 {
            let t = if i == 150_001 { 0.0 } else { i as f64 * 1e-3 };
            writeln!(text, "{t},{},{}", i % 7, i % 3).unwrap();
        }
        text.extend_from_slice(b"end\n");
        let f = file_of(&text);
        let a = scan(&f, 0, &spec(csv()), 1).unwrap();
        let b = scan(&f, 0, &spec(csv()), 3).unwrap();
        assert_eq!(a.rows, 300_000);
        assert_eq!((a.rows, a.lines, a.end, &a.times, &a.breaks), (b.rows, b.lines, b.end, &b.times, &b.breaks));
        assert_eq!(a.breaks.len(), 2); // the restart at 150001 and the jump back at 150002
                                       // every checkpoint starts a parse that reads the right rows
        let d = csv();
        for &(row, off, line) in b.checkpoints.iter() {
            let mut out = vec![0.0; 2];
            parse_into(&f, &[Piece { offset: off, line: line + 1, skip: 0, rows: 1 }], &d, &[1, 2], &mut out, 1)
                .unwrap();
            assert_eq!(out, vec![(row % 7) as f64, (row % 3) as f64]);
        }
    }

    #[test]
    fn scan_pieces_meet_at_line_starts_whatever_the_lines() {
        // a comment line longer than two pieces, lines that end exactly at a piece's edge, and an
        // unterminated last row: every thread count finds the same run, and the parse from every
        // checkpoint reads the right row
        let mut text = Vec::new();
        let mut row = 0u64;
        while text.len() < PIECE - 6 {
            writeln!(text, "{row},{},1", row % 10).unwrap();
            row += 1;
        }
        while text.len() % PIECE != PIECE - 6 {
            text.push(b'#');
        }
        text.extend_from_slice(b"\n"); // ends 5 bytes before the edge
        writeln!(text, "{row},{},1", row % 10).unwrap();
        row += 1;
        text.push(b'#');
        text.extend(std::iter::repeat_n(b'x', 2 * PIECE + 3));
        text.push(b'\n');
        for _ in 0..50_000 {
            writeln!(text, "{row},{},1", row % 10).unwrap();
            row += 1;
        }
        let whole = text.len() as u64;
        text.extend_from_slice(b"9,9"); // no line end
        let f = file_of(&text);
        let runs: Vec<Run> = [1, 2, 3].iter().map(|&n| scan(&f, 0, &spec(csv()), n).unwrap()).collect();
        for r in &runs {
            assert_eq!((r.rows, r.end), (row, whole));
            assert_eq!((&r.checkpoints, &r.marks, &r.times), (&runs[0].checkpoints, &runs[0].marks, &runs[0].times));
            assert_eq!(r.last, runs[0].last);
        }
        assert!(runs[0].marks.len() > 10);
        for &(row, off, line) in runs[0].checkpoints.iter().chain(&runs[0].marks) {
            let mut out = vec![0.0; 2];
            parse_into(&f, &[Piece { offset: off, line: line + 1, skip: 0, rows: 1 }], &csv(), &[0, 1], &mut out, 1)
                .unwrap();
            assert_eq!(out, vec![row as f64, (row % 10) as f64]);
        }
    }
}
