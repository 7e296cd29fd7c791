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

use crate::error::KernelError;
use crate::parallel;
use rayon::prelude::*;
use std::fs::File;

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

/// Whitespace of Python's `str.strip()`/`str.split()` on latin-1 text.
#[inline]
fn str_ws(b: u8) -> bool {
    matches!(b, 0x09..=0x0d | 0x1c..=0x20 | 0x85 | 0xa0)
}

/// Whitespace of Python's `bytes.strip()`.
#[inline]
fn bytes_ws(b: u8) -> bool {
    matches!(b, 0x09..=0x0d | 0x20)
}

/// `s` without the leading and trailing bytes `ws` says are whitespace.
#[inline(always)]
fn strip(s: &[u8], ws: impl Fn(u8) -> bool) -> &[u8] {
    let mut a = 0;
    let mut e = s.len();
    while a < e && ws(s[a]) {
        a += 1;
    }
    while e > a && ws(s[e - 1]) {
        e -= 1;
    }
    &s[a..e]
}

/// Exact powers of ten (every one up to 1e22 is a float).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16, 1e17, 1e18, 1e19, 1e20,
    1e21, 1e22,
];

/// Reads the fast path's number grammar from `s[i..]`: a sign, digits, one
/// decimal point (`.` or `point`), digits, an exponent of at most 4 digits.
/// Returns where it stopped, and the value when it is m x 10^k with at most
/// 19 digits, m <= 2^53 and |k| <= 22: then m and 10^|k| are exact floats
/// and one IEEE multiplication or division rounds their exact product or
/// quotient correctly (Clinger's fast path), the value Python's `float`
/// gives. The value is None for everything else (the callers then take the
/// general way: Rust's full parser).
#[inline(always)]
fn lex_number(s: &[u8], mut i: usize, point: u8) -> (usize, Option<f64>) {
    let n = s.len();
    let neg = i < n && s[i] == b'-';
    if i < n && (s[i] == b'-' || s[i] == b'+') {
        i += 1;
    }
    let mut m: u64 = 0;
    let mut digits = 0usize;
    while i < n && s[i].is_ascii_digit() {
        m = m.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
        digits += 1;
        i += 1;
    }
    let mut k = 0i32;
    if i < n && (s[i] == b'.' || s[i] == point) {
        i += 1;
        while i < n && s[i].is_ascii_digit() {
            m = m.wrapping_mul(10).wrapping_add((s[i] - b'0') as u64);
            digits += 1;
            k -= 1;
            i += 1;
        }
    }
    if i < n && (s[i] | 0x20) == b'e' && digits > 0 {
        i += 1;
        let eneg = i < n && s[i] == b'-';
        if i < n && (s[i] == b'-' || s[i] == b'+') {
            i += 1;
        }
        let e0 = i;
        let mut e = 0i32;
        while i < n && s[i].is_ascii_digit() && i - e0 < 4 {
            e = e * 10 + (s[i] - b'0') as i32;
            i += 1;
        }
        if i == e0 {
            return (i, None);
        }
        k += if eneg { -e } else { e };
    }
    if digits == 0 || digits > 19 || m > (1u64 << 53) || !(-22..=22).contains(&k) {
        return (i, None);
    }
    let v = if k < 0 { m as f64 / POW10[(-k) as usize] } else { m as f64 * POW10[k as usize] };
    (i, Some(if neg { -v } else { v }))
}

/// Bytes `buf[i..i + 8]` as a little-endian word (the first byte lowest), if there are 8.
#[inline(always)]
fn word_at(buf: &[u8], i: usize) -> Option<u64> {
    let b: [u8; 8] = buf.get(i..i + 8)?.try_into().ok()?;
    Some(u64::from_le_bytes(b))
}

const ONES: u64 = 0x0101_0101_0101_0101;

/// 0x80 in each byte of `x` that is zero, 0 elsewhere (exact: no carry
/// between bytes, since the addition sees 7-bit values only).
#[inline(always)]
fn zero_bytes(x: u64) -> u64 {
    !(((x & (0x7f * ONES)) + 0x7f * ONES) | x | (0x7f * ONES))
}

/// The leading ASCII digits of a word (8 bytes, first byte lowest): how
/// many (0 to 8) and the integer they write. Eight bytes at a time instead
/// of a loop of dependent multiplications: the fields of a data file are
/// runs of 1-8 digits, and this is the parse's inner loop.
#[inline(always)]
fn digits8(w: u64) -> (usize, u64) {
    // a byte is a digit when its high nibble is 3 and adding 6 keeps it 3
    // (a carry out of a non-digit byte only reaches later bytes, which do not count)
    let hi = 0xf0 * ONES;
    let nondigit = ((w & hi) ^ (0x30 * ONES)) | ((w.wrapping_add(0x06 * ONES) & hi) ^ (0x30 * ONES));
    let n = (nondigit.trailing_zeros() / 8) as usize;
    if n == 0 {
        return (0, 0);
    }
    // the digits' values, moved to the word's top so the missing ones read as leading zeros
    // (a borrow out of a non-digit byte only reaches later bytes, shifted out here)
    let mut v = w.wrapping_sub(0x30 * ONES) << (8 * (8 - n));
    v = v.wrapping_mul(10).wrapping_add(v >> 8); // pairs of digits in bytes 0, 2, 4, 6
    let m = 0x0000_00ff_0000_00ffu64;
    let a = (v & m).wrapping_mul(100 + (1_000_000 << 32));
    let b = ((v >> 16) & m).wrapping_mul(1 + (10_000 << 32));
    (n, (a.wrapping_add(b)) >> 32)
}

/// Exact powers of ten as integers, for [`quick_number`].
const POW10U: [u64; 9] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000];

/// The commonest numbers of a data file, read from `buf[i..]`: a sign, at
/// most 7 digits, a decimal point (`.` or `point`) and at most 7 digits.
/// Returns the value and where it stopped (the first byte after the digits,
/// which the caller checks ends the field), or None for anything else
/// (fewer than 8 bytes left, longer digit runs, no digit: the caller then
/// takes the general way). The value is [`lex_number`]'s: m has at most 14
/// digits, so m <= 2^53 and one IEEE division by an exact power of ten
/// rounds it correctly, the float Python's `float` gives.
#[inline(always)]
fn quick_number(buf: &[u8], mut i: usize, point: u8) -> Option<(f64, usize)> {
    let c = *buf.get(i)?;
    let neg = c == b'-';
    i += (neg || c == b'+') as usize;
    let (n1, a) = digits8(word_at(buf, i)?);
    if n1 == 8 {
        return None;
    }
    i += n1;
    let mut m = a;
    let mut frac = 0usize;
    // buf[i] exists: it is the word's byte n1 < 8
    if buf[i] == b'.' || buf[i] == point {
        let (n2, b) = digits8(word_at(buf, i + 1)?);
        if n2 == 8 {
            return None;
        }
        m = m * POW10U[n2] + b;
        frac = n2;
        i += 1 + n2;
    }
    if n1 + frac == 0 {
        return None;
    }
    // POW10[0] = 1 divides exactly; the sign is set without a branch (signs of data are random, so a
    // branch on them is mispredicted every other field)
    let v = (m as i64) as f64 / POW10[frac]; // m < 2^53: exact either way, one instruction as i64
    Some((f64::from_bits(v.to_bits() | ((neg as u64) << 63)), i))
}

/// The number that fills the field `buf[s..e]` when it is short: a sign, then at most 8 bytes of
/// digits with at most one decimal point (`.` or `point`), at least one digit. The field's end is
/// known (from [`row_masks`]), so the digits are read in one word whatever their count: the point
/// is taken out by moving the bytes before it up one, and every byte left is checked to be a
/// digit. None for any other field (the caller then takes [`quick_number`]). The value is
/// [`quick_number`]'s: m has at most 8 digits and one IEEE division by an exact power of ten
/// rounds it correctly.
#[inline(always)]
fn field_number(buf: &[u8], s: usize, e: usize, point: u8) -> Option<f64> {
    let c = *buf.get(s)?;
    let neg = c == b'-';
    let s1 = s + (neg || c == b'+') as usize;
    let len = e.wrapping_sub(s1);
    if len.wrapping_sub(1) >= 8 {
        return None;
    }
    // the field's bytes at the word's top (the first byte lowest), zero bytes below them
    let w = word_at(buf, s1)? << (8 * (8 - len));
    let dots = zero_bytes(w ^ (b'.' as u64 * ONES)) | zero_bytes(w ^ (point as u64 * ONES));
    if dots & dots.wrapping_sub(1) != 0 {
        return None; // two points
    }
    // the bytes below the point move up one over it (no point: nothing moves)
    let low = (dots >> 7).wrapping_sub(1) & 0u64.wrapping_sub((dots != 0) as u64);
    let w = ((w & low) << 8) | (w & !low & !((dots >> 7) * 0xff));
    // the digits fill the top len - (one if a point) bytes, and there is at least one
    let nd = len - (dots != 0) as usize;
    if nd == 0 {
        return None;
    }
    let top = u64::MAX << (8 * (8 - nd));
    // a byte is a digit when its high nibble is 3 and adding 6 keeps it 3 (a carry only leaves a
    // byte of 0xfa or more, itself no digit)
    let hi = 0xf0 * ONES;
    let nondigit = ((w & hi) ^ (0x30 * ONES)) | ((w.wrapping_add(0x06 * ONES) & hi) ^ (0x30 * ONES));
    if nondigit & top != 0 {
        return None;
    }
    let mut v = w.wrapping_sub((0x30 * ONES) & top);
    v = v.wrapping_mul(10).wrapping_add(v >> 8); // pairs of digits in bytes 0, 2, 4, 6
    let m2 = 0x0000_00ff_0000_00ffu64;
    let a = (v & m2).wrapping_mul(100 + (1_000_000 << 32));
    let b = ((v >> 16) & m2).wrapping_mul(1 + (10_000 << 32));
    let m = (a.wrapping_add(b)) >> 32;
    // digits after the point: the bytes above it (the point's top bit is bit 8p + 7)
    let frac = (dots.leading_zeros() / 8) as usize & 7;
    let x = (m as i64) as f64 / POW10[frac];
    // the sign by an exact multiplication, in the float registers (-0.0 for a zero too)
    Some(x * [1.0, -1.0][neg as usize])
}

/// Where each byte of a number goes for [`field_number_sse`]: for a number of `len` bytes (1-16)
/// with its point at `p` (16: none), the source byte of each of 16 digit places, the digits
/// right-aligned (the last at place 15), 0x80 (a zero) before them.
#[cfg(target_arch = "x86_64")]
const fn shuffles() -> [[[u8; 16]; 17]; 17] {
    let mut t = [[[0x80u8; 16]; 17]; 17];
    let mut len = 1;
    while len <= 16 {
        let mut p = 0;
        while p <= 16 {
            // the digits' sources, from the last back
            let mut place = 16;
            let mut src = len;
            while src > 0 {
                src -= 1;
                if src != p {
                    place -= 1;
                    t[len][p][place] = src as u8;
                }
            }
            p += 1;
        }
        len += 1;
    }
    t
}

#[cfg(target_arch = "x86_64")]
static SHUFFLES: [[[u8; 16]; 17]; 17] = shuffles();

/// [`field_number`] of up to 16 bytes after the sign (at most 15 digits), with SSE4.1: the bytes
/// checked to be digits but one point at once, the digits moved right-aligned past the point by
/// one shuffle ([`SHUFFLES`]) and summed in pairs, fours and eights by multiply-adds. The value is
/// [`quick_number`]'s: m < 10^15 < 2^53, so one IEEE division by an exact power of ten rounds it
/// correctly.
///
/// # Safety
/// The CPU must have SSE4.1 and SSSE3.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse4.1,ssse3")]
#[inline]
unsafe fn field_number_sse(buf: &[u8], s: usize, e: usize, point: u8) -> Option<f64> {
    use std::arch::x86_64::*;
    let c = *buf.get(s)?;
    let neg = c == b'-';
    let s1 = s + (neg || c == b'+') as usize;
    let len = e.wrapping_sub(s1);
    if len.wrapping_sub(1) >= 16 {
        return None;
    }
    let b: &[u8; 16] = buf.get(s1..s1 + 16)?.try_into().ok()?;
    // the bytes `b` holds; every later byte read is in `b` or a table row of 16
    let v = _mm_loadu_si128(b.as_ptr() as *const __m128i);
    let d = _mm_sub_epi8(v, _mm_set1_epi8(b'0' as i8));
    let nine = _mm_set1_epi8(9);
    // the field's bytes that are no digit (above 9 once '0' is taken off, unsigned): the point only
    let bad = (_mm_movemask_epi8(_mm_cmpeq_epi8(_mm_max_epu8(d, nine), nine)) as u32 ^ 0xffff) & ((1u32 << len) - 1);
    if bad & bad.wrapping_sub(1) != 0 {
        return None;
    }
    let p = (bad.trailing_zeros() as usize).min(16);
    if p < 16 && b[p] != b'.' && b[p] != point {
        return None;
    }
    let nd = len - (p < 16) as usize;
    if nd == 0 || nd > 15 {
        return None;
    }
    let frac = if p < 16 { len - p - 1 } else { 0 };
    // the digits right-aligned, zeros before them (the shuffle's 0x80), then summed: the first
    // byte is the first digit
    let idx = _mm_loadu_si128(SHUFFLES[len][p].as_ptr() as *const __m128i);
    let x = _mm_shuffle_epi8(d, idx);
    let t1 = _mm_maddubs_epi16(x, _mm_setr_epi8(10, 1, 10, 1, 10, 1, 10, 1, 10, 1, 10, 1, 10, 1, 10, 1));
    let t2 = _mm_madd_epi16(t1, _mm_setr_epi16(100, 1, 100, 1, 100, 1, 100, 1));
    let t3 = _mm_packus_epi32(t2, t2);
    let t4 = _mm_madd_epi16(t3, _mm_setr_epi16(10000, 1, 10000, 1, 10000, 1, 10000, 1));
    let hi = _mm_cvtsi128_si32(t4) as u32 as u64;
    let lo = _mm_extract_epi32(t4, 1) as u32 as u64;
    let m = hi * 100_000_000 + lo;
    let x = (m as i64) as f64 / POW10[frac];
    // the sign by an exact multiplication, in the float registers (-0.0 for a zero too)
    Some(x * [1.0, -1.0][neg as usize])
}

/// Where the field from `buf[i..]` ends: the first separator `d` or `\n`
/// (None when the buffer ends first), eight bytes at a time.
#[inline(always)]
fn field_end(buf: &[u8], mut i: usize, d: u8) -> Option<usize> {
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
fn quick_sep(d: &Dialect) -> Option<(u8, u8)> {
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
fn after_field(buf: &[u8], p: &mut usize, sep: u8) -> Option<bool> {
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
fn quick_start(buf: &[u8], at: usize, d: &Dialect, point: u8) -> bool {
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
fn scan_row_quick(buf: &[u8], at: usize, spec: &ScanSpec, sep: u8, point: u8) -> Option<(usize, f64)> {
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
fn count_to_line_end(buf: &[u8], mut i: usize, d: u8) -> Option<(usize, usize)> {
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
fn parse_row_quick(
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

/// Gathers the top bit of each byte of `x` into the byte's bit of one byte (the first byte lowest):
/// 8 bits. Each product term of the multiplication lands on its own bit, so nothing carries.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn gather_bytes(x: u64) -> u64 {
    ((x >> 7) & ONES).wrapping_mul(0x0102_0408_1020_4080) >> 56
}

/// [`row_masks`] eight bytes at a time (any target; the reference of the SSE2 one).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn row_masks_swar(b: &[u8; 64], sep: u8) -> (u64, u64) {
    let (mut ends, mut nl) = (0u64, 0u64);
    for (j, c) in b.chunks_exact(8).enumerate() {
        let w = u64::from_le_bytes(c.try_into().unwrap_or([0; 8]));
        let n = zero_bytes(w ^ (b'\n' as u64 * ONES));
        let s = zero_bytes(w ^ (sep as u64 * ONES));
        nl |= gather_bytes(n) << (8 * j);
        ends |= gather_bytes(n | s) << (8 * j);
    }
    (ends, nl)
}

/// [`row_masks`] sixteen bytes at a time (SSE2 is part of every x86-64).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn row_masks_sse2(b: &[u8; 64], sep: u8) -> (u64, u64) {
    use std::arch::x86_64::*;
    let (mut ends, mut nl) = (0u64, 0u64);
    // SAFETY: SSE2 is always there on x86-64, and each unaligned 16-byte load lies inside `b`.
    unsafe {
        let vs = _mm_set1_epi8(sep as i8);
        let vn = _mm_set1_epi8(b'\n' as i8);
        for j in 0..4 {
            let v = _mm_loadu_si128(b.as_ptr().add(16 * j) as *const __m128i);
            let n = _mm_cmpeq_epi8(v, vn);
            let e = _mm_or_si128(n, _mm_cmpeq_epi8(v, vs));
            nl |= (_mm_movemask_epi8(n) as u32 as u64) << (16 * j);
            ends |= (_mm_movemask_epi8(e) as u32 as u64) << (16 * j);
        }
    }
    (ends, nl)
}

/// [`row_masks`] thirty-two bytes at a time.
///
/// # Safety
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn row_masks_avx2(b: &[u8; 64], sep: u8) -> (u64, u64) {
    use std::arch::x86_64::*;
    let vs = _mm256_set1_epi8(sep as i8);
    let vn = _mm256_set1_epi8(b'\n' as i8);
    // both unaligned 32-byte loads lie inside `b`
    let lo = _mm256_loadu_si256(b.as_ptr() as *const __m256i);
    let hi = _mm256_loadu_si256(b.as_ptr().add(32) as *const __m256i);
    let (nlo, nhi) = (_mm256_cmpeq_epi8(lo, vn), _mm256_cmpeq_epi8(hi, vn));
    let elo = _mm256_or_si256(nlo, _mm256_cmpeq_epi8(lo, vs));
    let ehi = _mm256_or_si256(nhi, _mm256_cmpeq_epi8(hi, vs));
    let join = |a: __m256i, b: __m256i| {
        (_mm256_movemask_epi8(a) as u32 as u64) | ((_mm256_movemask_epi8(b) as u32 as u64) << 32)
    };
    (join(elo, ehi), join(nlo, nhi))
}

/// The 64 bytes from `buf[at]` as bit masks (bit i: byte `at + i`): those that end a field (the
/// separator `sep` or `\n`), and the `\n`. None when fewer than 64 bytes are left. `LEVEL` is
/// the build's (see [`level`]): 2 reads with AVX2, else SSE2 (x86-64) or eight bytes at a time.
#[inline(always)]
fn row_masks<const LEVEL: u8>(buf: &[u8], at: usize, sep: u8) -> Option<(u64, u64)> {
    let b: &[u8; 64] = buf.get(at..at.checked_add(64)?)?.try_into().ok()?;
    #[cfg(target_arch = "x86_64")]
    if LEVEL >= 2 {
        // SAFETY: LEVEL 2 only in the build run where `level` found AVX2
        return Some(unsafe { row_masks_avx2(b, sep) });
    }
    #[cfg(target_arch = "x86_64")]
    return Some(row_masks_sse2(b, sep));
    #[cfg(not(target_arch = "x86_64"))]
    return Some(row_masks_swar(b, sep));
}

/// Whether a number read from `s` to `end` (see [`quick_number`]) fills the field that ends at
/// `e`, the row's `\n` being at `nl`: it ends at the field's end, or at a `\r` just before the `\n`.
#[inline(always)]
fn fills(buf: &[u8], end: usize, e: usize, nl: usize) -> bool {
    end == e || (e == nl && end + 1 == nl && buf[end] == b'\r')
}

/// Which build of the row loops the CPU runs: 2 with AVX2 (the row masks 32 bytes at a time) and
/// everything of 1; 1 with SSE4.1, SSSE3, POPCNT and BMI1 (the numbers by [`field_number_sse`]);
/// 0 the portable one. All give the same results.
#[cfg(target_arch = "x86_64")]
#[inline]
fn level() -> u8 {
    use std::arch::is_x86_feature_detected as has;
    let one = has!("sse4.1") && has!("ssse3") && has!("popcnt") && has!("bmi1");
    let two = one && has!("avx2") && has!("bmi2") && has!("lzcnt");
    two as u8 + one as u8
}

/// `fn $name(args) -> ret`: `$with::<LEVEL>` in the build the CPU runs (see [`level`]; all give the
/// same results), and the builds `$one` (level 1) and `$two` (level 2), each compiled with its
/// features enabled.
macro_rules! by_level {
    ($(#[$doc:meta])* fn $name:ident($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty
     => $with:ident, $one:ident, $two:ident) => {
        $(#[$doc])*
        fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            match level() {
                // SAFETY: `level` found the features of each build on this CPU
                2 => return unsafe { $two($($arg),*) },
                1 => return unsafe { $one($($arg),*) },
                _ => {}
            }
            $with::<0>($($arg),*)
        }

        #[doc = concat!("[`", stringify!($with), "`] compiled for level 1.")]
        ///
        /// # Safety
        /// The CPU must have the features of level 1 (see [`level`]).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "sse4.1,ssse3,popcnt,bmi1")]
        unsafe fn $one($($arg: $ty),*) -> $ret {
            $with::<1>($($arg),*)
        }

        #[doc = concat!("[`", stringify!($with), "`] compiled for level 2.")]
        ///
        /// # Safety
        /// The CPU must have the features of level 2 (see [`level`]).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt,sse4.1,ssse3")]
        unsafe fn $two($($arg: $ty),*) -> $ret {
            $with::<2>($($arg),*)
        }
    };
}

/// The number that fills the field from `s` to its end `e` (a separator, or the row's `\n` at
/// `nl`: a `\r` before it is no part of the field): [`field_number`], else [`quick_number`]; None
/// when neither reads the whole field (the caller then takes the slower ways, which decide).
/// From `LEVEL` 1 on (see [`level`]) a field takes [`field_number_sse`] first.
#[inline(always)]
fn masked_number<const LEVEL: u8>(buf: &[u8], s: usize, e: usize, nl: usize, point: u8) -> Option<f64> {
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
fn scan_row_masked<const LEVEL: u8>(
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
fn parse_row_masked<const LEVEL: u8>(
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

/// The common case of [`to_float`] (a stripped field): [`lex_number`] of the whole field.
#[inline(always)]
fn fast_float(s: &[u8], decimal: u8) -> Option<f64> {
    match lex_number(s, 0, decimal) {
        (e, v) if e == s.len() => v,
        _ => None,
    }
}

/// A field as Python's `to_float` reads it; None when it is not a number
/// (an empty field included).
#[inline]
pub fn to_float(field: &[u8], decimal: u8) -> Option<f64> {
    number(strip(field, str_ws), decimal)
}

/// [`to_float`] of a field already stripped.
#[inline(always)]
fn number(s: &[u8], decimal: u8) -> Option<f64> {
    if let Some(v) = fast_float(s, decimal) {
        return Some(v);
    }
    if s.is_empty() || s.contains(&b'_') {
        return None;
    }
    if decimal != b'.' && s.contains(&decimal) {
        let t: Vec<u8> = s.iter().map(|&c| if c == decimal { b'.' } else { c }).collect();
        return std::str::from_utf8(&t).ok()?.parse().ok();
    }
    std::str::from_utf8(s).ok()?.parse().ok()
}

/// The fields of a line (without its end), as Python's `split`.
struct Fields<'a> {
    rest: Option<&'a [u8]>,
    delim: Option<u8>,
}

impl<'a> Fields<'a> {
    fn new(line: &'a [u8], delim: Option<u8>) -> Self {
        Fields { rest: Some(line), delim }
    }
}

impl<'a> Iterator for Fields<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let rest = self.rest?;
        match self.delim {
            Some(d) => match memchr::memchr(d, rest) {
                Some(i) => {
                    self.rest = Some(&rest[i + 1..]);
                    Some(&rest[..i])
                }
                None => {
                    self.rest = None;
                    Some(rest)
                }
            },
            None => {
                let a = rest.iter().position(|&b| !str_ws(b));
                let Some(a) = a else {
                    self.rest = None;
                    return None;
                };
                let e = rest[a..].iter().position(|&b| str_ws(b)).map_or(rest.len(), |i| a + i);
                self.rest = Some(&rest[e..]);
                Some(&rest[a..e])
            }
        }
    }
}

/// A line's text: up to its `\n`, without trailing `\r`.
#[inline]
fn text_of(line: &[u8]) -> &[u8] {
    let mut e = line.len();
    while e > 0 && (line[e - 1] == b'\r' || line[e - 1] == b'\n') {
        e -= 1;
    }
    &line[..e]
}

/// Whether byte `c` ends a field: the separator, the line end, or (for
/// whitespace-separated files) whitespace.
#[inline(always)]
fn ends_field(c: u8, delim: Option<u8>) -> bool {
    c == b'\n' || delim.map_or(str_ws(c), |d| c == d)
}

/// The common case of one field, read in place from `buf[*p..]` (a buffer
/// whose end is a line end): a number, or nothing (NaN), between
/// whitespace. Moves `*p` to the byte that ends the field and returns its
/// value; None when the field is anything else (the caller then takes the
/// line the general way, which decides).
#[inline(always)]
fn field_fast(buf: &[u8], p: &mut usize, delim: Option<u8>, decimal: u8) -> Option<f64> {
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
fn next_field(buf: &[u8], p: &mut usize, delim: Option<u8>) -> bool {
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
fn plain_start(buf: &[u8], at: usize, d: &Dialect) -> bool {
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
fn scan_line_fast(buf: &[u8], at: usize, spec: &ScanSpec) -> Option<(usize, f64)> {
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
fn parse_line_fast(buf: &[u8], at: usize, d: &Dialect, used: &[bool], vals: &mut [f64]) -> Option<usize> {
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

enum Kind {
    Skip,
    Data,
    Other,
}

impl Dialect {
    /// Whether a line is skipped, or ends a run, before its fields are looked at.
    fn classify(&self, text: &[u8]) -> Kind {
        let s = strip(text, bytes_ws);
        if s.is_empty() {
            return if self.skip_blank { Kind::Skip } else { Kind::Other };
        }
        if let Some(c) = &self.comment {
            if s.starts_with(c) {
                return Kind::Skip;
            }
        }
        if !self.skip_blank && text.iter().all(|&b| bytes_ws(b) || Some(b) == self.delim) {
            return Kind::Other; // an LVM line of separators only is blank too
        }
        Kind::Data
    }
}

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
struct PieceScan {
    rows: u64,
    lines: u64,
    stop: Option<usize>,
    times: Vec<f64>,
    breaks: Vec<Break>,
    first: Option<(u64, u64, usize, f64)>,
    last_t: f64,
    last: Option<(u64, usize)>,
    /// (row, line, byte) of data rows about every [`STRIDE`] bytes after the piece's start.
    marks: Vec<(u64, u64, usize)>,
    next_mark: usize,
}

fn is_break(prev: f64, now: f64, gap: f64) -> bool {
    now < prev || now - prev > gap
}

impl PieceScan {
    /// Counts a data row at byte `at` with time `t` (NaN: none): its break, if any, and its kept time.
    #[inline(always)]
    fn row(&mut self, t: f64, t_prev: &mut f64, at: usize, spec: &ScanSpec, keep: usize) {
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
fn scan_piece_with<const LEVEL: u8>(buf: &[u8], spec: &ScanSpec, keep: usize) -> PieceScan {
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

/// Reads up to `buf.len()` bytes from byte `at` (fewer at the file's end).
#[cfg(unix)]
fn read_some(file: &File, at: u64, buf: &mut [u8]) -> Result<usize, KernelError> {
    use std::os::unix::fs::FileExt;
    let mut got = 0;
    while got < buf.len() {
        match file.read_at(&mut buf[got..], at + got as u64) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(KernelError::Invalid(format!("cannot read the file at byte {at}: {e}"))),
        }
    }
    Ok(got)
}

#[cfg(not(unix))]
fn read_some(_file: &File, _at: u64, _buf: &mut [u8]) -> Result<usize, KernelError> {
    Err(KernelError::Invalid("reading text natively needs a Unix system".into()))
}

/// The whole lines that start in bytes `[lo, hi)` of a file of `size`
/// bytes: the offset of the first and the buffer from which they are read
/// (`buf[skip..]`). The first line starts at `lo` when `at_start`, else after
/// the first `\n` from `lo - 1`; the last runs on past `hi` to its `\n`, and
/// a last line of the file without one is left out (the reader's to judge).
/// So consecutive ranges share no line and miss none, and each is read by
/// the thread that scans it.
fn lines_in(file: &File, lo: u64, hi: u64, at_start: bool, size: u64) -> Result<(u64, Vec<u8>, usize), KernelError> {
    let from = if at_start { lo } else { lo - 1 };
    let mut buf = vec![0u8; (hi - from) as usize];
    let got = read_some(file, from, &mut buf)?;
    buf.truncate(got);
    let skip = if at_start {
        0
    } else {
        match memchr::memchr(b'\n', &buf) {
            Some(i) => i + 1,
            None => return Ok((hi, Vec::new(), 0)),
        }
    };
    if from + skip as u64 >= hi {
        return Ok((hi, Vec::new(), 0)); // inside a line that started before lo
    }
    // the last line that starts before hi ends at the first `\n` from byte hi - 1
    let mut search = ((hi - 1 - from) as usize).max(skip);
    let mut more = 1usize << 12; // a line's rest: small reads, doubling for long lines
    loop {
        if let Some(j) = memchr::memchr(b'\n', &buf[search.min(buf.len())..]) {
            buf.truncate(search + j + 1);
            break;
        }
        let at = from + buf.len() as u64;
        let old = buf.len();
        if at < size {
            buf.resize(old + more.min((size - at) as usize), 0);
            more = (2 * more).min(PIECE);
            let got = read_some(file, at, &mut buf[old..])?;
            buf.truncate(old + got);
            if got > 0 {
                search = old;
                continue;
            }
        }
        // the file ends without a last `\n`: whole lines only
        let end = memchr::memrchr(b'\n', &buf[skip..]).map_or(skip, |i| skip + i + 1);
        buf.truncate(end);
        break;
    }
    Ok((from + skip as u64, buf, skip))
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

/// Rows to parse: `rows` data rows after skipping `skip`, from byte
/// `offset`, whose line has the number `line` (for messages).
#[derive(Clone, Copy, Debug)]
pub struct Piece {
    pub offset: u64,
    pub line: u64,
    pub skip: u64,
    pub rows: u64,
}

/// Why rows could not be parsed (the reader words the message).
#[derive(Clone, Debug, PartialEq)]
pub enum ParseError {
    /// A row with fewer fields than the columns need.
    Fields {
        line: u64,
        got: usize,
        need: usize,
    },
    /// A field that is not a number: `col` indexes the columns asked for.
    Number {
        line: u64,
        col: usize,
        text: Vec<u8>,
    },
    /// The file ended `short` rows early (after line `line`).
    Eof {
        line: u64,
        short: u64,
    },
    Io(KernelError),
}

const BLOCK: usize = 1 << 18;

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
fn parse_piece_with<const LEVEL: u8>(
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
    use std::io::Write;

    fn file_of(text: &[u8]) -> File {
        let mut f = tempfile();
        f.write_all(text).unwrap();
        f
    }

    fn tempfile() -> File {
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

    fn csv() -> Dialect {
        Dialect { delim: Some(b','), decimal: b'.', comment: Some(b"#".to_vec()), skip_blank: true }
    }

    fn spec(d: Dialect) -> ScanSpec {
        ScanSpec { dialect: d, nf: Some(3), probe: 1, time: Some(0), gap: 0.5, t_prev: f64::NAN, keep_times: 10 }
    }

    #[test]
    fn numbers_as_python_reads_them() {
        for (s, v) in [("1.5", 1.5), (" -2e3 ", -2000.0), ("+.5", 0.5), ("5.", 5.0), ("\u{a0}1", 1.0)] {
            let b: Vec<u8> = s.chars().map(|c| c as u32 as u8).collect();
            assert_eq!(to_float(&b, b'.'), Some(v), "{s}");
        }
        assert_eq!(to_float(b"1,5", b','), Some(1.5));
        let long = [b"0.".as_slice(), &[b'0'; 500], b"15"].concat();
        assert_eq!(to_float(&long, b'.'), Some(0.0)); // 1.5e-501 underflows, as in Python
        assert_eq!(to_float(&[b'1'; 401], b','), Some(f64::INFINITY)); // long fields are numbers too
        assert_eq!(to_float(b"1.5", b','), Some(1.5));
        for s in ["", " ", "1_0", "1,5", "0x1", ".", "e5", "1e", "abc"] {
            assert_eq!(to_float(s.as_bytes(), b'.'), None, "{s}");
        }
        assert!(to_float(b"-NaN", b'.').unwrap().is_nan());
        assert_eq!(to_float(b"iNfInItY", b'.'), Some(f64::INFINITY));
    }

    /// A xorshift64 generator from `state` (the tests' random text, the same on every run).
    fn xorshift(mut state: u64) -> impl FnMut() -> u64 {
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        }
    }

    #[test]
    fn quick_numbers_are_the_general_parsers_bits() {
        // every shape quick_number takes or refuses: signs, 0-9 digits on each side of the point,
        // digits that fill a word; the value must be Rust's correctly rounded parse (Python's float)
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        for _ in 0..200_000 {
            let r = next();
            let mut s = String::new();
            s.push_str(["", "-", "+", ""][(r & 3) as usize]);
            let (a, b) = ((r >> 2) % 10, (r >> 6) % 10);
            for j in 0..a {
                s.push((b'0' + ((r >> (10 + 3 * j)) % 10) as u8) as char);
            }
            let point = (r >> 50) & 7 != 0;
            if point {
                s.push('.');
            }
            for _ in 0..b {
                s.push((b'0' + (next() % 10) as u8) as char);
            }
            let end = ["\n", ",", "\r\n", "e5,", "x", ",1,2,3,4,5,6,7"][((r >> 53) % 6) as usize];
            let text = format!("{s}{end}");
            let got = quick_number(text.as_bytes(), 0, b'.');
            if let Some((v, e)) = got {
                assert_eq!(e, s.len(), "{text:?}");
                let want: f64 = s.parse().unwrap();
                assert_eq!(v.to_bits(), want.to_bits(), "{text:?}");
                assert_eq!(Some(v), fast_float(s.as_bytes(), b'.'), "{text:?}");
            } else if end.len() > 8 && a + b > 0 && if point { a < 8 && b < 8 } else { a + b < 8 } {
                panic!("{text:?} refused");
            }
        }
        // the words: digits8 counts leading digits and reads them
        assert_eq!(digits8(u64::from_le_bytes(*b"12345678")), (8, 12_345_678));
        assert_eq!(digits8(u64::from_le_bytes(*b"0070,abc")), (4, 70));
        assert_eq!(digits8(u64::from_le_bytes(*b"9\xff999999")), (1, 9));
        assert_eq!(digits8(u64::from_le_bytes(*b"/:123456")), (0, 0));
        assert_eq!(quick_number(b"1,5;xxxxxx", 0, b','), Some((1.5, 3)));
        assert_eq!(quick_number(b"-0.0,xxxxxx", 0, b'.').map(|(v, _)| v.to_bits()), Some((-0.0f64).to_bits()));
        assert_eq!(count_to_line_end(b"1,2,,3\r\nxxxxxxxxxxxxxxxx", 0, b','), Some((7, 3)));
        assert_eq!(count_to_line_end(b"1,2,,3,", 0, b','), None);
    }

    /// A random field for the row paths' tests: mostly numbers of the shapes data files have, some
    /// of every other kind (signs, points, exponents, blanks, text, long digit runs).
    fn random_field(next: &mut impl FnMut() -> u64) -> String {
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

    #[test]
    fn row_masks_find_every_separator_and_line_end() {
        let mut next = xorshift(0x2545_f491_4f6c_dd1du64);
        for _ in 0..20_000 {
            let sep = [b',', b'\t', b';', b' ', 0xa0, 0x80][(next() % 6) as usize];
            let b: Vec<u8> = (0..70)
                .map(|_| match next() % 8 {
                    0 => sep,
                    1 => b'\n',
                    2 => (next() & 0xff) as u8,
                    _ => b'0' + (next() % 10) as u8,
                })
                .collect();
            let at = (next() % 7) as usize;
            let (ends, nl) = row_masks::<0>(&b, at, sep).unwrap();
            #[cfg(target_arch = "x86_64")]
            if level() >= 2 {
                assert_eq!(row_masks::<2>(&b, at, sep), Some((ends, nl)));
            }
            let want_nl: u64 = (0..64).filter(|&i| b[at + i] == b'\n').map(|i| 1u64 << i).sum();
            let want_ends: u64 =
                (0..64).filter(|&i| matches!(b[at + i], b'\n') || b[at + i] == sep).map(|i| 1u64 << i).sum();
            assert_eq!((ends, nl), (want_ends, want_nl));
            let arr: &[u8; 64] = b[at..at + 64].try_into().unwrap();
            assert_eq!(row_masks_swar(arr, sep), (want_ends, want_nl));
        }
        assert_eq!(row_masks::<0>(&[b'1'; 63], 0, b','), None);
        assert_eq!(row_masks::<0>(&[b'1'; 80], 17, b','), None);
    }

    #[test]
    fn field_numbers_are_the_general_parsers_bits() {
        let mut next = xorshift(0x9e37_79b9_7f4a_7c15u64);
        for _ in 0..300_000 {
            let f = random_field(&mut next);
            let point = if next() % 4 == 0 { b',' } else { b'.' };
            let f = if point == b',' && next() % 2 == 0 { f.replace('.', ",") } else { f };
            let text = format!("{f},xxxxxxxxxxxxxxxx");
            let got = field_number(text.as_bytes(), 0, f.len(), point);
            let want = fast_float(f.as_bytes(), point);
            #[cfg(target_arch = "x86_64")]
            if level() >= 1 {
                // SAFETY: the CPU has the features
                match unsafe { field_number_sse(text.as_bytes(), 0, f.len(), point) } {
                    Some(v) => assert_eq!(Some(v.to_bits()), want.map(f64::to_bits), "{f:?}"),
                    None => {
                        let body = f.trim_start_matches(['-', '+']);
                        let digits = body.bytes().filter(u8::is_ascii_digit).count();
                        let points = body.bytes().filter(|&c| c == b'.' || c == point).count();
                        let plain = f.len() - body.len() <= 1 && digits + points == body.len() && points <= 1;
                        assert!(!(plain && (1..=15).contains(&digits) && body.len() <= 16), "{f:?} refused (SSE)");
                    }
                }
            }
            match got {
                Some(v) => assert_eq!(Some(v.to_bits()), want.map(f64::to_bits), "{f:?}"),
                None => {
                    let body = f.trim_start_matches(['-', '+']);
                    let short = f.len() - body.len() <= 1 && body.len() <= 8;
                    let grammar = body.bytes().all(|c| c.is_ascii_digit() || c == b'.' || c == point)
                        && body.bytes().filter(|&c| c == b'.' || c == point).count() <= 1
                        && body.bytes().any(|c| c.is_ascii_digit());
                    assert!(!(short && grammar), "{f:?} refused");
                }
            }
        }
        assert_eq!(field_number(b"-0.982056,", 0, 9, b'.'), Some(-0.982056));
        assert_eq!(field_number(b"+5.,xxxxxxxx", 0, 3, b'.'), Some(5.0));
        assert_eq!(field_number(b".25\nxxxxxxxx", 0, 3, b'.'), Some(0.25));
        assert_eq!(field_number(b"1,5;xxxxxxxx", 0, 3, b','), Some(1.5));
        assert_eq!(field_number(b"12345678,xxxxxxxx", 0, 8, b'.'), Some(12_345_678.0));
        assert_eq!(field_number(b"1.5.1,xxxxxxxx", 0, 5, b'.'), None);
        assert_eq!(field_number(b"1.5", 0, 3, b'.'), None); // fewer than 8 bytes from the digits
        #[cfg(target_arch = "x86_64")]
        if level() >= 1 {
            // SAFETY: the CPU has the features
            let sse = |t: &[u8], e: usize, point: u8| unsafe { field_number_sse(t, 0, e, point) };
            assert_eq!(sse(b"-123456.789012345,xxxxxxxxxxxxxxxx", 17, b'.'), Some(-123456.789012345));
            assert_eq!(sse(b"1234567890123456,xxxxxxxxxxxxxxxx", 16, b'.'), None); // 16 digits
            assert_eq!(sse(b"0.5", 3, b'.'), None); // fewer than 16 bytes from the digits
            assert_eq!(sse(b"7,25;xxxxxxxxxxxxxxxx", 4, b','), Some(7.25));
        }
    }

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
    fn fields_split_like_python() {
        let f: Vec<&[u8]> = Fields::new(b"a,,b,", Some(b',')).collect();
        assert_eq!(f, vec![&b"a"[..], b"", b"b", b""]);
        let f: Vec<&[u8]> = Fields::new(b"  1\t 2 \x0c3 ", None).collect();
        assert_eq!(f, vec![&b"1"[..], b"2", b"3"]);
        assert_eq!(Fields::new(b"   ", None).count(), 0);
        assert_eq!(Fields::new(b"", Some(b',')).count(), 1);
    }

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
