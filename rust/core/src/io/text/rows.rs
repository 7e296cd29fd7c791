//! The quick ways through a plain data row, for the scan (its field count,
//! probe and time) and the parse (the values of the fields asked for): by
//! the row masks of a separator byte ([`scan_row_masked`], [`parse_row_masked`]),
//! field by field after a separator byte ([`scan_row_quick`],
//! [`parse_row_quick`]), or field by field for any dialect
//! ([`scan_line_fast`], [`parse_line_fast`]). Each gives up (None) on a row
//! it is not sure of, which the general way then decides.

use super::number::{bytes_ws, field_number, lex_number, quick_number, str_ws, word_at, zero_bytes, ONES};
#[cfg(target_arch = "x86_64")]
use super::simd::field_number_sse;
use super::simd::row_masks;
use super::{Dialect, ScanSpec};

/// Where the field from `buf[i..]` ends: the first separator `d` or `\n`
/// (None when the buffer ends first), eight bytes at a time.
#[inline(always)]
pub(super) fn field_end(buf: &[u8], mut i: usize, d: u8) -> Option<usize> {
    while let Some(w) = word_at(buf, i) {
        let hit = zero_bytes(w ^ (d as u64 * ONES)) | zero_bytes(w ^ (b'\n' as u64 * ONES));
        if hit != 0 {
            return Some(i + (hit.trailing_zeros() / 8) as usize);
        }
        i += 8;
    }
    buf[i..].iter().position(|&b| b == d || b == b'\n').map(|j| i + j)
}

/// The separator of a dialect whose plain rows [`quick_number`] may read,
/// with the decimal point to accept: a one-byte separator that cannot be
/// part of a number or of a line end.
#[inline]
pub(super) fn quick_sep(d: &Dialect) -> Option<(u8, u8)> {
    let s = d.delim?;
    let numeric = s.is_ascii_alphanumeric() || matches!(s, b'.' | b'+' | b'-' | b'\n' | b'\r');
    if numeric {
        return None;
    }
    Some((s, if d.decimal == s { b'.' } else { d.decimal }))
}

/// After a field that ended at `buf[p]`: Some(true) and `p` on the next
/// field for a separator, Some(false) and `p` on the line's `\n` at the
/// line's end, None for anything else.
#[inline(always)]
pub(super) fn after_field(buf: &[u8], p: &mut usize, sep: u8) -> Option<bool> {
    match *buf.get(*p)? {
        c if c == sep => {
            *p += 1;
            Some(true)
        }
        b'\n' => Some(false),
        b'\r' if buf.get(*p + 1) == Some(&b'\n') => {
            *p += 1;
            Some(false)
        }
        _ => None,
    }
}

/// Whether the line at `at` starts as a number does (so it is neither
/// blank, nor led by whitespace, nor a comment).
#[inline(always)]
pub(super) fn quick_start(buf: &[u8], at: usize, d: &Dialect, point: u8) -> bool {
    let Some(&c) = buf.get(at) else { return false };
    (c.is_ascii_digit() || matches!(c, b'-' | b'+' | b'.') || c == point)
        && d.comment.as_ref().is_none_or(|k| k.first() != Some(&c))
}

/// The quickest way through a scanned row at `at` of a file with a plain
/// separator (see [`quick_sep`]): every field up to its end, the time and
/// probe fields as [`quick_number`]s, the fields counted. Some((next line's
/// start, time)) for a row with exactly `nf` fields, None to take the line
/// the slower ways (which decide).
#[inline(always)]
pub(super) fn scan_row_quick(buf: &[u8], at: usize, spec: &ScanSpec, sep: u8, point: u8) -> Option<(usize, f64)> {
    if !quick_start(buf, at, &spec.dialect, point) {
        return None;
    }
    let last = spec.time.map_or(spec.probe, |t| t.max(spec.probe));
    let mut p = at;
    let mut t = f64::NAN;
    for k in 0..=last {
        if k == spec.probe || Some(k) == spec.time {
            let (v, e) = quick_number(buf, p, point)?;
            if Some(k) == spec.time {
                t = v;
            }
            p = e;
        } else {
            p = field_end(buf, p, sep)?;
        }
        if !after_field(buf, &mut p, sep)? {
            // the line ends: a row only when this was its last field
            return (spec.nf.is_none_or(|nf| nf == k + 1) && k == last).then_some((p + 1, t));
        }
    }
    // the other fields are only counted
    let (nl, more) = count_to_line_end(buf, p, sep)?;
    spec.nf.is_none_or(|nf| nf == last + 2 + more).then_some((nl + 1, t))
}

/// From `buf[i..]` to the line's end: where its `\n` is and how many
/// separators `d` lie before it (None when the buffer ends first), eight
/// bytes at a time.
#[inline(always)]
pub(super) fn count_to_line_end(buf: &[u8], mut i: usize, d: u8) -> Option<(usize, usize)> {
    let mut n = 0usize;
    while let Some(w) = word_at(buf, i) {
        let seps = zero_bytes(w ^ (d as u64 * ONES));
        let nl = zero_bytes(w ^ (b'\n' as u64 * ONES));
        if nl != 0 {
            // each hit is a byte's top bit: those below the first newline's are before it
            let before = (nl & nl.wrapping_neg()) - 1;
            return Some((i + (nl.trailing_zeros() / 8) as usize, n + (seps & before).count_ones() as usize));
        }
        n += seps.count_ones() as usize;
        i += 8;
    }
    let j = buf[i..].iter().position(|&b| b == b'\n')?;
    Some((i + j, n + buf[i..i + j].iter().filter(|&&b| b == d).count()))
}

/// The quickest way through a parsed row at `at` (see [`scan_row_quick`]):
/// Some(next line's start) when the first `vals.len()` fields were
/// [`quick_number`]s (those `used`) and are in `vals`, None to take the line
/// the slower ways.
#[inline(always)]
pub(super) fn parse_row_quick(
    buf: &[u8],
    at: usize,
    d: &Dialect,
    sep: u8,
    point: u8,
    used: &[bool],
    vals: &mut [f64],
) -> Option<usize> {
    if !quick_start(buf, at, d, point) {
        return None;
    }
    let need = vals.len();
    let mut p = at;
    for (k, (v, &u)) in vals.iter_mut().zip(used).enumerate() {
        if u {
            let (x, e) = quick_number(buf, p, point)?;
            *v = x;
            p = e;
        } else {
            p = field_end(buf, p, sep)?;
        }
        let more = after_field(buf, &mut p, sep)?;
        if !more {
            // the line ends: the row is whole only after its last needed field
            return if k + 1 == need { Some(p + 1) } else { None };
        }
    }
    // fields beyond those needed are not looked at (as the general way)
    Some(memchr::memchr(b'\n', &buf[p..]).map_or(buf.len(), |i| p + i + 1))
}

/// Whether a number read from `s` to `end` (see [`quick_number`]) fills the field that ends at
/// `e`, the row's `\n` being at `nl`: it ends at the field's end, or at a `\r` just before the `\n`.
#[inline(always)]
pub(super) fn fills(buf: &[u8], end: usize, e: usize, nl: usize) -> bool {
    end == e || (e == nl && end + 1 == nl && buf[end] == b'\r')
}

/// The number that fills the field from `s` to its end `e` (a separator, or the row's `\n` at
/// `nl`: a `\r` before it is no part of the field): [`field_number`], else [`quick_number`]; None
/// when neither reads the whole field (the caller then takes the slower ways, which decide).
/// From `LEVEL` 1 on (see [`level`](super::simd::level)) a field takes [`field_number_sse`] first.
#[inline(always)]
pub(super) fn masked_number<const LEVEL: u8>(buf: &[u8], s: usize, e: usize, nl: usize, point: u8) -> Option<f64> {
    let e1 = e - (e == nl && e > s && buf[e - 1] == b'\r') as usize;
    #[cfg(target_arch = "x86_64")]
    if LEVEL >= 1 {
        // SAFETY: LEVEL 1 or 2 only in the builds run where `level` found the features
        if let Some(x) = unsafe { field_number_sse(buf, s, e1, point) } {
            return Some(x);
        }
    }
    if let Some(x) = field_number(buf, s, e1, point) {
        return Some(x);
    }
    let (x, end) = quick_number(buf, s, point)?;
    fills(buf, end, e, nl).then_some(x)
}

/// [`scan_row_quick`] of a row that ends within 64 bytes, its field ends found all at once from
/// [`row_masks`] (so no field waits for the one before it). None when the row does not fit (or
/// too few bytes are left: take [`scan_row_quick`]); Some(None) when it is no plain row (take the
/// slower ways, which decide); else what [`scan_row_quick`] gives.
#[inline(always)]
pub(super) fn scan_row_masked<const LEVEL: u8>(
    buf: &[u8],
    at: usize,
    spec: &ScanSpec,
    sep: u8,
    point: u8,
) -> Option<Option<(usize, f64)>> {
    let (ends, nl) = row_masks::<LEVEL>(buf, at, sep)?;
    if nl == 0 {
        return None;
    }
    if !quick_start(buf, at, &spec.dialect, point) {
        return Some(None);
    }
    let nlp = at + nl.trailing_zeros() as usize;
    let mut m = ends & (nl ^ (nl - 1)); // the field ends up to the row's `\n`: one per field
    let fields = m.count_ones() as usize;
    let last = spec.time.map_or(spec.probe, |t| t.max(spec.probe));
    if fields <= last || spec.nf.is_some_and(|nf| nf != fields) {
        return Some(None);
    }
    let mut s = at;
    let mut t = f64::NAN;
    for k in 0..=last {
        let e = at + m.trailing_zeros() as usize;
        m &= m - 1;
        if k == spec.probe || Some(k) == spec.time {
            let Some(v) = masked_number::<LEVEL>(buf, s, e, nlp, point) else { return Some(None) };
            if Some(k) == spec.time {
                t = v;
            }
        }
        s = e + 1;
    }
    Some(Some((nlp + 1, t)))
}

/// [`parse_row_quick`] of a row whose needed fields end within 64 bytes, found all at once from
/// [`row_masks`]. None: take [`parse_row_quick`]; Some(None): take the slower ways; else what
/// [`parse_row_quick`] gives.
#[inline(always)]
pub(super) fn parse_row_masked<const LEVEL: u8>(
    buf: &[u8],
    at: usize,
    d: &Dialect,
    sep: u8,
    point: u8,
    used: &[bool],
    vals: &mut [f64],
) -> Option<Option<usize>> {
    let (ends, nl) = row_masks::<LEVEL>(buf, at, sep)?;
    if nl == 0 {
        return None;
    }
    if !quick_start(buf, at, d, point) {
        return Some(None);
    }
    let nlp = at + nl.trailing_zeros() as usize;
    let mut m = ends & (nl ^ (nl - 1));
    if (m.count_ones() as usize) < vals.len() {
        return Some(None);
    }
    let mut s = at;
    for (v, &u) in vals.iter_mut().zip(used) {
        let e = at + m.trailing_zeros() as usize;
        m &= m - 1;
        if u {
            let Some(x) = masked_number::<LEVEL>(buf, s, e, nlp, point) else { return Some(None) };
            *v = x;
        }
        s = e + 1;
    }
    Some(Some(nlp + 1))
}

/// Whether byte `c` ends a field: the separator, the line end, or (for
/// whitespace-separated files) whitespace.
#[inline(always)]
pub(super) fn ends_field(c: u8, delim: Option<u8>) -> bool {
    c == b'\n' || delim.map_or(str_ws(c), |d| c == d)
}

/// The common case of one field, read in place from `buf[*p..]` (a buffer
/// whose end is a line end): a number, or nothing (NaN), between
/// whitespace. Moves `*p` to the byte that ends the field and returns its
/// value; None when the field is anything else (the caller then takes the
/// line the general way, which decides).
#[inline(always)]
pub(super) fn field_fast(buf: &[u8], p: &mut usize, delim: Option<u8>, decimal: u8) -> Option<f64> {
    let n = buf.len();
    let mut i = *p;
    let skip = |c: u8| c != b'\n' && Some(c) != delim && str_ws(c);
    while i < n && skip(buf[i]) {
        i += 1;
    }
    let s = i;
    let (e, v) = lex_number(buf, i, if Some(decimal) == delim { b'.' } else { decimal });
    i = e;
    while i < n && skip(buf[i]) {
        i += 1;
    }
    if i < n && !ends_field(buf[i], delim) {
        return None;
    }
    *p = i;
    if s == e {
        return if delim.is_some() { Some(f64::NAN) } else { None };
    }
    v
}

/// Steps over the byte that ended a field to the next field's start; false
/// at the line's end (no next field).
#[inline(always)]
pub(super) fn next_field(buf: &[u8], p: &mut usize, delim: Option<u8>) -> bool {
    match buf.get(*p) {
        None | Some(b'\n') => false,
        Some(_) if delim.is_some() => {
            *p += 1;
            true
        }
        Some(_) => {
            while *p < buf.len() && buf[*p] != b'\n' && str_ws(buf[*p]) {
                *p += 1;
            }
            *p < buf.len() && buf[*p] != b'\n'
        }
    }
}

/// Whether the line at `at` may take the fast path: its first byte after
/// any whitespace starts a number or is the separator (so the line is not
/// blank and not a comment).
#[inline(always)]
pub(super) fn plain_start(buf: &[u8], at: usize, d: &Dialect) -> bool {
    let mut i = at;
    while i < buf.len() && buf[i] != b'\n' && str_ws(buf[i]) && Some(buf[i]) != d.delim {
        i += 1;
    }
    let Some(&c) = buf.get(i) else { return false };
    if Some(c) == d.delim && bytes_ws(c) {
        // a tab-separated line of tabs and spaces only is blank to Python's bytes.strip()
        let nl = memchr::memchr(b'\n', &buf[i..]).map_or(buf.len(), |j| i + j);
        return buf[i..nl].iter().any(|&b| !bytes_ws(b));
    }
    (c.is_ascii_digit() || c == b'-' || c == b'+' || c == b'.' || Some(c) == d.delim)
        && d.comment.as_ref().is_none_or(|k| k.first() != Some(&c))
}

/// The fast path of a scanned line at `at`: Some((next line's start, time)) for a
/// data row whose fields are all plain, None to take the line the general way.
#[inline(always)]
pub(super) fn scan_line_fast(buf: &[u8], at: usize, spec: &ScanSpec) -> Option<(usize, f64)> {
    let d = &spec.dialect;
    if !plain_start(buf, at, d) {
        return None;
    }
    let last = spec.time.map_or(spec.probe, |t| t.max(spec.probe));
    let mut p = at;
    let mut t = f64::NAN;
    for k in 0..=last {
        if k > 0 && !next_field(buf, &mut p, d.delim) {
            return None;
        }
        if k == spec.probe || Some(k) == spec.time {
            let v = field_fast(buf, &mut p, d.delim, d.decimal)?;
            if Some(k) == spec.time {
                t = v;
            }
        } else {
            while p < buf.len() && !ends_field(buf[p], d.delim) {
                p += 1;
            }
        }
    }
    let mut fields = last + 1;
    let nl = match d.delim {
        Some(dl) => {
            let i = memchr::memchr(b'\n', &buf[p..]).map_or(buf.len(), |j| p + j);
            fields += buf[p..i].iter().filter(|&&b| b == dl).count();
            i
        }
        None => {
            let mut i = p;
            let mut in_ws = true;
            while i < buf.len() && buf[i] != b'\n' {
                let w = str_ws(buf[i]);
                fields += (in_ws && !w) as usize;
                in_ws = w;
                i += 1;
            }
            i
        }
    };
    if spec.nf.is_some_and(|nf| fields != nf) {
        return None;
    }
    Some(((nl + 1).min(buf.len()), t))
}

/// The fast path of a parsed line at `at`: Some(next line's start) when the
/// first `vals.len()` fields were plain and are in `vals`, None to take the
/// line the general way.
#[inline(always)]
pub(super) fn parse_line_fast(buf: &[u8], at: usize, d: &Dialect, used: &[bool], vals: &mut [f64]) -> Option<usize> {
    if !plain_start(buf, at, d) {
        return None;
    }
    let mut p = at;
    for (k, (v, &u)) in vals.iter_mut().zip(used).enumerate() {
        if k > 0 && !next_field(buf, &mut p, d.delim) {
            return None;
        }
        if u {
            *v = field_fast(buf, &mut p, d.delim, d.decimal)?;
        } else {
            if d.delim.is_none() {
                while p < buf.len() && buf[p] != b'\n' && str_ws(buf[p]) {
                    p += 1;
                }
                if p >= buf.len() || buf[p] == b'\n' {
                    return None;
                }
            }
            while p < buf.len() && !ends_field(buf[p], d.delim) {
                p += 1;
            }
        }
    }
    let nl = memchr::memchr(b'\n', &buf[p..]).map_or(buf.len(), |i| p + i + 1);
    Some(nl)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::text::fields::{text_of, Fields};
    use crate::io::text::number::{number, str_ws, strip};
    #[cfg(target_arch = "x86_64")]
    use crate::io::text::simd::level;
    use crate::io::text::testing::{random_field, xorshift};
    use crate::io::text::{Dialect, ScanSpec};

    #[test]
    fn masked_rows_read_as_the_general_way() {
        // rows of random fields; wherever the masked paths take a row, its end, time and values must be
        // those of the general way (Python's rules), bit for bit
        let mut next = xorshift(0x1234_5678_9abc_def1u64);
        let mut taken = (0, 0);
        for _ in 0..100_000 {
            let sep = [b',', b';', b'\t', b','][(next() % 4) as usize];
            let nf = 1 + (next() % 6) as usize;
            let mut line: Vec<u8> = Vec::new();
            for k in 0..nf {
                if k > 0 {
                    line.push(sep);
                }
                line.extend_from_slice(random_field(&mut next).as_bytes());
            }
            line.extend_from_slice(["\n", "\r\n", "\r\r\n", "\n"][(next() % 4) as usize].as_bytes());
            let mut buf = line.clone();
            buf.extend_from_slice(&[b'9'; 80]);
            let point = if sep != b',' && next() % 3 == 0 { b',' } else { b'.' };
            let d = Dialect { delim: Some(sep), decimal: point, comment: Some(b"#".to_vec()), skip_blank: true };
            let text = text_of(&line);
            let fields: Vec<&[u8]> = Fields::new(text, Some(sep)).collect();
            let general = |k: usize| number(strip(fields[k], str_ws), point);
            // the parse of the first `need` fields, some of them
            let need = 1 + (next() as usize % nf.max(1));
            let used: Vec<bool> = (0..need).map(|k| k + 1 == need || next() % 3 != 0).collect();
            // the portable way, and those of the levels the CPU has (SSE4.1's takes more rows: up to 15 digits)
            #[cfg(target_arch = "x86_64")]
            let ways: Vec<u8> = (0..=level()).collect();
            #[cfg(not(target_arch = "x86_64"))]
            let ways = vec![0u8];
            for &way in &ways {
                let mut vals = vec![0.0; need];
                let row = match way {
                    2 => parse_row_masked::<2>(&buf, 0, &d, sep, point, &used, &mut vals),
                    1 => parse_row_masked::<1>(&buf, 0, &d, sep, point, &used, &mut vals),
                    _ => parse_row_masked::<0>(&buf, 0, &d, sep, point, &used, &mut vals),
                };
                if let Some(Some(nl)) = row {
                    taken.0 += 1;
                    assert_eq!(nl, line.len(), "{line:?}");
                    assert!(fields.len() >= need);
                    for k in 0..need {
                        if used[k] {
                            assert_eq!(Some(vals[k].to_bits()), general(k).map(f64::to_bits), "{line:?} field {k}");
                        }
                    }
                }
            }
            // the scan's: field count, probe and time
            let probe = next() as usize % nf;
            let time = if next() % 2 == 0 { Some(next() as usize % nf) } else { None };
            let sp = ScanSpec {
                dialect: d.clone(),
                nf: if next() % 4 == 0 { None } else { Some(nf) },
                probe,
                time,
                gap: f64::NAN,
                t_prev: f64::NAN,
                keep_times: 0,
            };
            for &way in &ways {
                let row = match way {
                    2 => scan_row_masked::<2>(&buf, 0, &sp, sep, point),
                    1 => scan_row_masked::<1>(&buf, 0, &sp, sep, point),
                    _ => scan_row_masked::<0>(&buf, 0, &sp, sep, point),
                };
                if let Some(Some((nl, t))) = row {
                    taken.1 += 1;
                    assert_eq!(nl, line.len(), "{line:?}");
                    assert_eq!(fields.len(), nf);
                    assert!(general(probe).is_some(), "{line:?}");
                    if let Some(j) = time {
                        assert_eq!(Some(t.to_bits()), general(j).map(f64::to_bits), "{line:?}");
                    }
                }
            }
        }
        assert!(taken.0 > 5_000 && taken.1 > 5_000, "{taken:?}");
    }
}
