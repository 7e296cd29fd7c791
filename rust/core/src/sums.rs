//! Small summation helpers shared by the kernels: lane-split sums that the
//! compiler vectorises, and the corrected two-pass mean.
//!
//! Floating-point addition is not reassociated by the compiler, so the
//! explicit four lanes are what lets it use SIMD; the lane order is fixed,
//! so results are deterministic.

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

/// Mean by two passes: the naive mean, then the mean of the deviations from
/// it added back. For a constant input this returns the constant exactly
/// (so a constant signal centres to exact zeros and its variance is 0).
pub fn mean(x: &[f64]) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    let n = x.len() as f64;
    let m0 = sum(x) / n;
    let mut acc = [0.0f64; LANES];
    let chunks = x.chunks_exact(LANES);
    let rest = chunks.remainder();
    for c in chunks {
        for k in 0..LANES {
            acc[k] += c[k] - m0;
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for v in rest {
        s += v - m0;
    }
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
    fn sum_and_dot_match_naive() {
        let x: Vec<f64> = (0..13).map(|i| i as f64 * 0.5).collect();
        let y: Vec<f64> = (0..13).map(|i| 1.0 - i as f64).collect();
        let naive: f64 = x.iter().zip(&y).map(|(a, b)| a * b).sum();
        assert!((dot(&x, &y) - naive).abs() < 1e-12);
        assert!((sum(&x) - 39.0).abs() < 1e-12);
    }
}
