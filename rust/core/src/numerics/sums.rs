//! Small summation helpers shared by the kernels: lane-split sums that the
//! compiler vectorises, and the corrected two-pass mean.
//!
//! Floating-point addition is not reassociated by the compiler, so the
//! explicit four lanes are what lets it use SIMD; the lane order is fixed,
//! so results are deterministic.

use rayon::prelude::*;

const LANES: usize = 4;

/// Sum of `x` with four interleaved accumulators.
pub fn sum(x: &[f64]) -> f64 {
    let mut acc = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            acc[k] += c[k];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for v in rest {
        s += v;
    }
    s
}

/// Dot product of two equal-length slices with four accumulators.
pub fn dot(x: &[f64], y: &[f64]) -> f64 {
    debug_assert_eq!(x.len(), y.len());
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0f64; LANES];
    let xc = x.chunks_exact(LANES);
    let yc = y.chunks_exact(LANES);
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..LANES {
            acc[k] += a[k] * b[k];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (a, b) in xr.iter().zip(yr) {
        s += a * b;
    }
    s
}

/// Dot product of the deviations, sum (x_i - mx)(y_i - my), with four
/// accumulators: [`dot`] of the centred signals without centred copies.
pub fn dot_dev(x: &[f64], mx: f64, y: &[f64], my: f64) -> f64 {
    debug_assert_eq!(x.len(), y.len());
    let n = x.len().min(y.len());
    let (x, y) = (&x[..n], &y[..n]);
    let mut acc = [0.0f64; LANES];
    let xc = x.chunks_exact(LANES);
    let yc = y.chunks_exact(LANES);
    let (xr, yr) = (xc.remainder(), yc.remainder());
    for (a, b) in xc.zip(yc) {
        for k in 0..LANES {
            acc[k] += (a[k] - mx) * (b[k] - my);
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (a, b) in xr.iter().zip(yr) {
        s += (a - mx) * (b - my);
    }
    s
}

/// Sum of deviations from `m`, sum (x_i - m), with four accumulators.
fn sum_dev(x: &[f64], m: f64) -> f64 {
    let mut acc = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            acc[k] += c[k] - m;
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for v in rest {
        s += v - m;
    }
    s
}

/// Sum of squared deviations from `m`, sum (x_i - m)^2, with four
/// accumulators.
pub fn sum_sq_dev(x: &[f64], m: f64) -> f64 {
    let mut acc = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            let d = c[k] - m;
            acc[k] += d * d;
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for v in rest {
        let d = v - m;
        s += d * d;
    }
    s
}

/// Inputs longer than this are reduced in chunks of this length by the
/// `par_` functions, on the thread pool.
pub const PAR_CHUNK: usize = 1 << 16;

/// `f` over chunks of [`PAR_CHUNK`] in parallel, the partial results added
/// in chunk order: the same bits for any thread count.
fn chunked(x: &[f64], f: impl Fn(&[f64]) -> f64 + Sync + Send) -> f64 {
    if x.len() <= PAR_CHUNK {
        return f(x);
    }
    let parts: Vec<f64> = x.par_chunks(PAR_CHUNK).map(f).collect();
    parts.iter().fold(0.0, |a, b| a + b)
}

/// [`mean`] of a long input on the thread pool; equal to `mean(x)` for
/// inputs of at most [`PAR_CHUNK`] samples.
pub fn par_mean(x: &[f64]) -> f64 {
    if x.len() <= PAR_CHUNK {
        return mean(x);
    }
    let n = x.len() as f64;
    let m0 = chunked(x, sum) / n;
    let s = chunked(x, |c| sum_dev(c, m0));
    m0 + s / n
}

/// [`sum_sq_dev`] of a long input on the thread pool; equal to it for
/// inputs of at most [`PAR_CHUNK`] samples.
pub fn par_sum_sq_dev(x: &[f64], m: f64) -> f64 {
    chunked(x, |c| sum_sq_dev(c, m))
}

/// Whether every value is finite: x * 0 is 0 for finite x and NaN for inf
/// or NaN, so the test vectorises and reads memory once, without a mask.
pub fn all_finite(x: &[f64]) -> bool {
    let mut probe = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            probe[k] += c[k] * 0.0;
        }
    }
    probe.iter().chain(rest).all(|v| (v * 0.0) == 0.0)
}

/// [`all_finite`] in chunks on the thread pool.
pub fn par_all_finite(x: &[f64]) -> bool {
    if x.len() <= PAR_CHUNK {
        return all_finite(x);
    }
    x.par_chunks(PAR_CHUNK).all(all_finite)
}

/// Mean by two passes: the naive mean, then the mean of the deviations from
/// it added back. For a constant input this returns the constant exactly
/// (so a constant signal centres to exact zeros and its variance is 0).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let n = x.len() as f64;
    let m0 = sum(x) / n;
    let s = sum_dev(x, m0);
    m0 + s / n
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_of_constant_is_exact() {
        for &c in &[0.1, 1e6 + 0.3, -7.77e-5, 3.0] {
            for n in [1usize, 2, 3, 5, 17, 1000] {
                let x = vec![c; n];
                assert_eq!(mean(&x), c);
            }
        }
    }

    #[test]
    fn all_finite_finds_nan_and_inf_anywhere() {
        let mut x: Vec<f64> = (0..(PAR_CHUNK * 2 + 7)).map(|i| (i as f64).sin() * 1e300).collect();
        assert!(all_finite(&x) && par_all_finite(&x));
        for at in [0usize, 5, PAR_CHUNK + 1, x.len() - 1] {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let keep = x[at];
                x[at] = bad;
                assert!(!all_finite(&x) && !par_all_finite(&x), "{bad} at {at}");
                x[at] = keep;
            }
        }
        assert!(all_finite(&[]) && par_all_finite(&[]));
    }

    #[test]
    fn sum_and_dot_match_naive() {
        let x: Vec<f64> = (0..13).map(|i| i as f64 * 0.5).collect();
        let y: Vec<f64> = (0..13).map(|i| 1.0 - i as f64).collect();
        let naive: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        assert!((dot(&x, &y) - naive).abs() < 1e-12);
        assert!((sum(&x) - 39.0).abs() < 1e-12);
    }
}
