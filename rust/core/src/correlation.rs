//! Lagged correlation function, Eq. (1) of the paper (METHOD.md 1).
//!
//! C(j) = S_xy(j) / sqrt(S_xx(j) S_yy(j)), with x and y centred on the means
//! of the WHOLE inputs and each sum taken over the overlap of x_i and
//! y_{i+j}. If y is x delayed by d samples, C peaks at j = +d. A zero
//! denominator gives NaN.
//!
//! Two algorithms: direct, O(n L), and FFT, O(n log n). Both use the same
//! denominators (prefix and suffix sums of squares, never a difference of
//! two large sums). The FFT numerator carries a rounding error of about
//! eps * sqrt(E_x E_y); at lags whose overlap holds little of the energy that
//! error is amplified, so such lags are recomputed directly. The two methods
//! then agree to 1e-10 absolute (tested).

use crate::error::{same_len, KernelError};
use crate::sums::{dot, mean};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::RealFftPlanner;

/// Which algorithm computes the numerator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Overlap dot products, O(n L).
    Direct,
    /// Real FFT of the centred signals, O(n log n), with direct refinement
    /// of badly conditioned edge lags.
    Fft,
    /// The faster of the two for (n, L).
    Auto,
}

/// Estimated cost ratio deciding "auto": direct when its multiply-adds are
/// fewer than `AUTO_FFT_FACTOR` times N log2 N of the FFT.
const AUTO_FFT_FACTOR: f64 = 6.0;

/// Relative size of the FFT rounding bound above which a lag is refined.
const REFINE_BOUND: f64 = 1e-12;

/// Centres `x` on its own (two-pass) mean.
pub fn centred(x: &[f64]) -> Vec<f64> {
    let m = mean(x);
    x.iter().map(|v| v - m).collect()
}

/// Pearson's r = C(0): the correlation at lag zero.
pub fn pearson(x: &[f64], y: &[f64]) -> Result<f64, KernelError> {
    same_len("x", x, "y", y)?;
    if x.len() < 2 {
        return Err(KernelError::TooShort { name: "x", len: x.len(), min: 2 });
    }
    let (mx, my) = (mean(x), mean(y));
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (a, b) in x.iter().zip(y) {
        let (dx, dy) = (a - mx, b - my);
        sxy += dx * dy;
        sxx += dx * dx;
        syy += dy * dy;
    }
    Ok(ratio(sxy, sxx, syy))
}

fn ratio(sxy: f64, sxx: f64, syy: f64) -> f64 {
    let d = (sxx * syy).sqrt();
    if d > 0.0 {
        // Rounding can push |C| a hair above 1; Eq. (1) is bounded by 1.
        (sxy / d).clamp(-1.0, 1.0)
    } else {
        f64::NAN
    }
}

/// Which method "auto" picks for n samples and lags -L..L.
pub fn auto_method(n: usize, max_lag: usize) -> Method {
    let l = max_lag as f64;
    let nn = n as f64;
    let direct = (2.0 * l + 1.0) * nn - l * (l + 1.0);
    let m = fft_len(n) as f64;
    if direct <= AUTO_FFT_FACTOR * m * m.log2().max(1.0) {
        Method::Direct
    } else {
        Method::Fft
    }
}

fn fft_len(n: usize) -> usize {
    // Smallest 2^a 3^b >= 2n - 1: no wrap-around for any lag.
    let need = (2 * n).saturating_sub(1).max(1);
    let mut best = need.next_power_of_two();
    let mut p3 = 1usize;
    while p3 < best {
        let mut v = p3;
        while v < need {
            v *= 2;
        }
        best = best.min(v);
        p3 *= 3;
    }
    best
}

/// Eq. (1) for lags -max_lag..=max_lag; returns C in that order.
pub fn xcorr(x: &[f64], y: &[f64], max_lag: usize, method: Method) -> Result<Vec<f64>, KernelError> {
    same_len("x", x, "y", y)?;
    let n = x.len();
    if n < 2 {
        return Err(KernelError::TooShort { name: "x", len: n, min: 2 });
    }
    if max_lag >= n {
        return Err(KernelError::LagOutOfRange { max_lag, n });
    }
    let method = match method {
        Method::Auto => auto_method(n, max_lag),
        m => m,
    };
    let xc = centred(x);
    let yc = centred(y);
    let den = Denominators::new(&xc, &yc);
    let lags: Vec<i64> = (-(max_lag as i64)..=(max_lag as i64)).collect();
    let out = match method {
        Method::Fft => {
            let num = fft_numerator(&xc, &yc, max_lag);
            let (ex, ey) = (den.px[n], den.py[n]);
            lags.par_iter()
                .zip(num.par_iter())
                .map(|(&j, &s)| {
                    let (sxx, syy) = den.at(j);
                    let bound = fft_error_scale(n) * (ex * ey).sqrt();
                    let s = if bound > REFINE_BOUND * (sxx * syy).sqrt() { direct_at(&xc, &yc, j) } else { s };
                    ratio(s, sxx, syy)
                })
                .collect()
        }
        _ => lags
            .par_iter()
            .map(|&j| {
                let (sxx, syy) = den.at(j);
                ratio(direct_at(&xc, &yc, j), sxx, syy)
            })
            .collect(),
    };
    Ok(out)
}

/// Rounding error of an FFT correlation relative to sqrt(E_x E_y): a few
/// eps per butterfly stage.
fn fft_error_scale(n: usize) -> f64 {
    4.0 * f64::EPSILON * (fft_len(n) as f64).log2().max(1.0)
}

/// S_xy(j) = sum over the overlap of xc_i * yc_{i+j}.
fn direct_at(xc: &[f64], yc: &[f64], j: i64) -> f64 {
    let n = xc.len();
    if j >= 0 {
        let j = j as usize;
        dot(&xc[..n - j], &yc[j..])
    } else {
        let k = (-j) as usize;
        dot(&xc[k..], &yc[..n - k])
    }
}

/// Prefix and suffix sums of squares: S_xx(j) and S_yy(j) of every lag
/// without subtracting two large sums.
struct Denominators {
    px: Vec<f64>, // px[k] = sum_{i<k} xc_i^2
    sx: Vec<f64>, // sx[k] = sum_{i>=k} xc_i^2
    py: Vec<f64>,
    sy: Vec<f64>,
}

impl Denominators {
    fn new(xc: &[f64], yc: &[f64]) -> Self {
        let (px, sx) = prefix_suffix(xc);
        let (py, sy) = prefix_suffix(yc);
        Denominators { px, sx, py, sy }
    }

    fn at(&self, j: i64) -> (f64, f64) {
        let n = self.px.len() - 1;
        if j >= 0 {
            let j = j as usize;
            (self.px[n - j], self.sy[j])
        } else {
            let k = (-j) as usize;
            (self.sx[k], self.py[n - k])
        }
    }
}

fn prefix_suffix(v: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = v.len();
    let mut p = vec![0.0; n + 1];
    let mut s = vec![0.0; n + 1];
    for i in 0..n {
        p[i + 1] = p[i] + v[i] * v[i];
    }
    for i in (0..n).rev() {
        s[i] = s[i + 1] + v[i] * v[i];
    }
    (p, s)
}

/// Numerators of all lags -L..=L by one real FFT of each centred signal.
fn fft_numerator(xc: &[f64], yc: &[f64], max_lag: usize) -> Vec<f64> {
    let n = xc.len();
    let m = fft_len(n);
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(m);
    let inv = planner.plan_fft_inverse(m);
    let spectrum = |v: &[f64]| -> Vec<Complex<f64>> {
        let mut buf = vec![0.0; m];
        buf[..n].copy_from_slice(v);
        let mut out = fwd.make_output_vec();
        // Lengths come from the plan itself, so this cannot fail.
        let _ = fwd.process(&mut buf, &mut out);
        out
    };
    let (fx, fy) = rayon::join(|| spectrum(xc), || spectrum(yc));
    // r(j) = sum_i x_i y_{i+j}  <=>  R = conj(X) Y.
    let mut prod: Vec<Complex<f64>> = fx.iter().zip(&fy).map(|(a, b)| a.conj() * b).collect();
    // The inverse real FFT needs purely real DC and Nyquist bins.
    prod[0].im = 0.0;
    if m % 2 == 0 {
        if let Some(last) = prod.last_mut() {
            last.im = 0.0;
        }
    }
    let mut r = inv.make_output_vec();
    let _ = inv.process(&mut prod, &mut r);
    let scale = 1.0 / m as f64;
    (-(max_lag as i64)..=(max_lag as i64))
        .map(|j| r[(j.rem_euclid(m as i64)) as usize] * scale)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn signal(n: usize, seed: u64) -> Vec<f64> {
        // Small deterministic generator (xorshift) so tests need no crates.
        let mut s = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        (0..n)
            .map(|i| {
                s ^= s << 13;
                s ^= s >> 7;
                s ^= s << 17;
                (s as f64 / u64::MAX as f64 - 0.5) + (i as f64 * 0.05).sin()
            })
            .collect()
    }

    fn naive(x: &[f64], y: &[f64], j: i64) -> f64 {
        let n = x.len() as i64;
        let mx = x.iter().sum::<f64>() / n as f64;
        let my = y.iter().sum::<f64>() / n as f64;
        let (mut a, mut b, mut c) = (0.0, 0.0, 0.0);
        for i in 0..n {
            let k = i + j;
            if k < 0 || k >= n {
                continue;
            }
            let (dx, dy) = (x[i as usize] - mx, y[k as usize] - my);
            a += dx * dy;
            b += dx * dx;
            c += dy * dy;
        }
        a / (b * c).sqrt()
    }

    #[test]
    fn direct_matches_definition() {
        let x = signal(50, 1);
        let y = signal(50, 2);
        let c = xcorr(&x, &y, 49, Method::Direct).unwrap();
        for (idx, j) in (-49i64..=49).enumerate() {
            assert!((c[idx] - naive(&x, &y, j)).abs() < 1e-12, "lag {j}");
        }
    }

    #[test]
    fn fft_matches_direct() {
        for &n in &[2usize, 3, 7, 64, 1000, 4097] {
            let x = signal(n, 3);
            let y = signal(n, 4);
            let l = n - 1;
            let a = xcorr(&x, &y, l, Method::Direct).unwrap();
            let b = xcorr(&x, &y, l, Method::Fft).unwrap();
            for (u, v) in a.iter().zip(&b) {
                assert!((u - v).abs() < 1e-10, "n={n}: {u} vs {v}");
            }
        }
    }

    #[test]
    fn delay_peaks_at_plus_d() {
        let x = signal(500, 5);
        let d = 7;
        let mut y = vec![0.0; 500];
        y[d..].copy_from_slice(&x[..500 - d]);
        let c = xcorr(&x, &y, 20, Method::Auto).unwrap();
        let imax = c.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0;
        assert_eq!(imax as i64 - 20, d as i64);
    }

    #[test]
    fn zero_variance_gives_nan_and_bad_input_errors() {
        let x = vec![0.1; 10];
        let y = signal(10, 6);
        assert!(pearson(&x, &y).unwrap().is_nan());
        assert!(xcorr(&x, &y, 3, Method::Fft).unwrap().iter().all(|v| v.is_nan()));
        assert!(matches!(xcorr(&y, &y, 10, Method::Auto), Err(KernelError::LagOutOfRange { .. })));
        assert!(matches!(xcorr(&y[..1], &y[..1], 0, Method::Auto), Err(KernelError::TooShort { .. })));
        assert!(matches!(pearson(&y, &y[..3]), Err(KernelError::LengthMismatch { .. })));
    }

    #[test]
    fn fft_len_is_smooth_and_large_enough() {
        for n in 1..300 {
            let m = fft_len(n);
            assert!(m >= 2 * n - 1);
            let mut v = m;
            while v % 2 == 0 {
                v /= 2;
            }
            while v % 3 == 0 {
                v /= 3;
            }
            assert_eq!(v, 1);
        }
    }
}
