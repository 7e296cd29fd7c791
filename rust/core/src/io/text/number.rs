//! Numbers as Python's `float` reads them, from the bytes of a field: the
//! general way ([`to_float`]: Rust's parser, whose grammar is Python's) and the
//! quick ways of the common shapes (a word of digits at a time, Clinger's fast
//! path), which give the same bits.

/// Whitespace of Python's `str.strip()`/`str.split()` on latin-1 text.
#[inline]
pub(super) fn str_ws(b: u8) -> bool {
    matches!(b, 0x09..=0x0d | 0x1c..=0x20 | 0x85 | 0xa0)
}

/// Whitespace of Python's `bytes.strip()`.
#[inline]
pub(super) fn bytes_ws(b: u8) -> bool {
    matches!(b, 0x09..=0x0d | 0x20)
}

/// `s` without the leading and trailing bytes `ws` says are whitespace.
#[inline(always)]
pub(super) fn strip(s: &[u8], ws: impl Fn(u8) -> bool) -> &[u8] {
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
pub(super) const POW10: [f64; 23] = [
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
pub(super) fn lex_number(s: &[u8], mut i: usize, point: u8) -> (usize, Option<f64>) {
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
pub(super) fn word_at(buf: &[u8], i: usize) -> Option<u64> {
    let b: [u8; 8] = buf.get(i..i + 8)?.try_into().ok()?;
    Some(u64::from_le_bytes(b))
}

pub(super) const ONES: u64 = 0x0101_0101_0101_0101;

/// 0x80 in each byte of `x` that is zero, 0 elsewhere (exact: no carry
/// between bytes, since the addition sees 7-bit values only).
#[inline(always)]
pub(super) fn zero_bytes(x: u64) -> u64 {
    !(((x & (0x7f * ONES)) + 0x7f * ONES) | x | (0x7f * ONES))
}

/// The leading ASCII digits of a word (8 bytes, first byte lowest): how
/// many (0 to 8) and the integer they write. Eight bytes at a time instead
/// of a loop of dependent multiplications: the fields of a data file are
/// runs of 1-8 digits, and this is the parse's inner loop.
#[inline(always)]
pub(super) fn digits8(w: u64) -> (usize, u64) {
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
pub(super) const POW10U: [u64; 9] = [1, 10, 100, 1_000, 10_000, 100_000, 1_000_000, 10_000_000, 100_000_000];

/// The commonest numbers of a data file, read from `buf[i..]`: a sign, at
/// most 7 digits, a decimal point (`.` or `point`) and at most 7 digits.
/// Returns the value and where it stopped (the first byte after the digits,
/// which the caller checks ends the field), or None for anything else
/// (fewer than 8 bytes left, longer digit runs, no digit: the caller then
/// takes the general way). The value is [`lex_number`]'s: m has at most 14
/// digits, so m <= 2^53 and one IEEE division by an exact power of ten
/// rounds it correctly, the float Python's `float` gives.
#[inline(always)]
pub(super) fn quick_number(buf: &[u8], mut i: usize, point: u8) -> Option<(f64, usize)> {
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
/// known (from [`row_masks`](super::simd::row_masks)), so the digits are read in one word
/// whatever their count: the point is taken out by moving the bytes before it up one, and every
/// byte left is checked to be a digit. None for any other field (the caller then takes [`quick_number`]). The value is
/// [`quick_number`]'s: m has at most 8 digits and one IEEE division by an exact power of ten
/// rounds it correctly.
#[inline(always)]
pub(super) fn field_number(buf: &[u8], s: usize, e: usize, point: u8) -> Option<f64> {
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

/// The common case of [`to_float`] (a stripped field): [`lex_number`] of the whole field.
#[inline(always)]
pub(super) fn fast_float(s: &[u8], decimal: u8) -> Option<f64> {
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
pub(super) fn number(s: &[u8], decimal: u8) -> Option<f64> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::text::rows::count_to_line_end;
    #[cfg(target_arch = "x86_64")]
    use crate::io::text::simd::{field_number_sse, level};
    use crate::io::text::testing::{random_field, xorshift};

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
}
