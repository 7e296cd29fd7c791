//! The builds of the row loops by CPU level: the SSE4.1 number reader, the
//! row masks (the ends of a row's fields, 64 bytes at a time: AVX2, SSE2 or
//! eight bytes at a time), the run-time choice of a level and the macro that
//! compiles a loop once per level. Every build gives the same results.

#[cfg(target_arch = "x86_64")]
use super::number::POW10;
use super::number::{zero_bytes, ONES};

/// Where each byte of a number goes for [`field_number_sse`]: for a number of `len` bytes (1-16)
/// with its point at `p` (16: none), the source byte of each of 16 digit places, the digits
/// right-aligned (the last at place 15), 0x80 (a zero) before them.
#[cfg(target_arch = "x86_64")]
pub(super) const fn shuffles() -> [[[u8; 16]; 17]; 17] {
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
pub(super) static SHUFFLES: [[[u8; 16]; 17]; 17] = shuffles();

/// [`field_number`](super::number::field_number) of up to 16 bytes after the sign (at most 15
/// digits), with SSE4.1: the bytes checked to be digits but one point at once, the digits moved
/// right-aligned past the point by one shuffle ([`SHUFFLES`]) and summed in pairs, fours and
/// eights by multiply-adds. The value is [`quick_number`](super::number::quick_number)'s:
/// m < 10^15 < 2^53, so one IEEE division by an exact power of ten rounds it correctly.
///
/// # Safety
/// The CPU must have SSE4.1 and SSSE3.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse4.1,ssse3")]
#[inline]
pub(super) unsafe fn field_number_sse(buf: &[u8], s: usize, e: usize, point: u8) -> Option<f64> {
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

/// Gathers the top bit of each byte of `x` into the byte's bit of one byte (the first byte lowest):
/// 8 bits. Each product term of the multiplication lands on its own bit, so nothing carries.
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
pub(super) fn gather_bytes(x: u64) -> u64 {
    ((x >> 7) & ONES).wrapping_mul(0x0102_0408_1020_4080) >> 56
}

/// [`row_masks`] eight bytes at a time (any target; the reference of the SSE2 one).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
pub(super) fn row_masks_swar(b: &[u8; 64], sep: u8) -> (u64, u64) {
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
pub(super) fn row_masks_sse2(b: &[u8; 64], sep: u8) -> (u64, u64) {
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
pub(super) unsafe fn row_masks_avx2(b: &[u8; 64], sep: u8) -> (u64, u64) {
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
pub(super) fn row_masks<const LEVEL: u8>(buf: &[u8], at: usize, sep: u8) -> Option<(u64, u64)> {
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

/// Which build of the row loops the CPU runs: 2 with AVX2 (the row masks 32 bytes at a time) and
/// everything of 1; 1 with SSE4.1, SSSE3, POPCNT and BMI1 (the numbers by [`field_number_sse`]);
/// 0 the portable one. All give the same results.
#[cfg(target_arch = "x86_64")]
#[inline]
pub(super) fn level() -> u8 {
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
        pub(super) fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            match $crate::io::text::simd::level() {
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
        /// The CPU must have the features of level 1 (see `simd::level`).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "sse4.1,ssse3,popcnt,bmi1")]
        pub(super) unsafe fn $one($($arg: $ty),*) -> $ret {
            $with::<1>($($arg),*)
        }

        #[doc = concat!("[`", stringify!($with), "`] compiled for level 2.")]
        ///
        /// # Safety
        /// The CPU must have the features of level 2 (see `simd::level`).
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,bmi1,bmi2,lzcnt,popcnt,sse4.1,ssse3")]
        pub(super) unsafe fn $two($($arg: $ty),*) -> $ret {
            $with::<2>($($arg),*)
        }
    };
}

pub(super) use by_level;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::text::testing::xorshift;

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
}
