//! Per-window sums for the estimators beyond the paper (docs/method.md 3a-3e).
//!
//! Three window-local computations, each run only when asked for
//! ([`ExtOptions`]):
//! - [`block_sums`]: sums of products of the centred forces z = fz - mean,
//!   y = fy - mean and of the instrument w (fz lagged by `lag` samples,
//!   centred), in [`BLOCKS`] consecutive blocks of the window. From them
//!   Python forms, per window, the OLS, IV, corrected and Deming slopes,
//!   the quadratic fit of the force dependence and the batch-means
//!   (autocorrelation-robust) standard errors of all of them;
//! - [`line_spectra`]: Hann-windowed cross-spectra of fy and fz at given
//!   line frequencies (f0 harmonics, lamella frequency), averaged over
//!   [`ExtOptions::segments`] consecutive segments (Goertzel recurrences);
//! - [`delayed`]: the normal force advanced by a fractional number of
//!   samples (Kaiser-windowed sinc, [`HALF_TAPS`] taps each side), which
//!   corrects an inter-channel delay before any statistic is taken.
//!
//! Everything is summed sample by sample in index order within the window,
//! so a window's result depends only on its samples (not on threads,
//! chunks or the CPU's vector width).

use crate::error::KernelError;
use std::cell::RefCell;

/// Consecutive blocks of a window for the batch-means standard errors:
/// block k holds samples [k n / BLOCKS, (k + 1) n / BLOCKS) (integer division).
pub const BLOCKS: usize = 5;
/// Sums per block, in this order (z, y, w centred; docs/method.md 3a):
/// z, y, w, zz, zy, yy, wz, wy, ww, zzz, zzy, zzzz, wzz, wwz, wwy, wwzz.
pub const PRODUCTS: usize = 16;
/// Most line frequencies per call.
pub const MAX_LINES: usize = 8;
/// Taps on each side of the fractional-delay filter (2 HALF_TAPS + 1 in all).
pub const HALF_TAPS: usize = 16;
/// Kaiser window shape of the fractional-delay filter.
const KAISER_BETA: f64 = 8.0;

/// What to compute beyond the paper's statistics, for every window.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ExtOptions {
    /// Compute the block sums (needs `lag` >= 1).
    pub sums: bool,
    /// Instrument lag in samples: w_t = fz_{t - lag} for t >= lag, fz_{t + lag} before.
    pub lag: usize,
    /// Line frequencies in cycles per sample (first `n_lines` used).
    pub lines: [f64; MAX_LINES],
    pub n_lines: usize,
    /// Segments averaged for the line spectra.
    pub segments: usize,
    /// fz is advanced by this many samples before anything else (0: none).
    pub delay: f64,
}

impl Default for ExtOptions {
    fn default() -> Self {
        ExtOptions { sums: false, lag: 0, lines: [0.0; MAX_LINES], n_lines: 0, segments: 4, delay: 0.0 }
    }
}

impl ExtOptions {
    /// Checks what a caller controls.
    pub fn check(&self) -> Result<(), KernelError> {
        let bad = |m: String| Err(KernelError::Invalid(m));
        if self.sums && self.lag == 0 {
            return bad("the instrument lag must be at least 1 sample".into());
        }
        if self.n_lines > MAX_LINES {
            return bad(format!("at most {MAX_LINES} line frequencies, got {}", self.n_lines));
        }
        if let Some(f) = self.lines[..self.n_lines].iter().find(|f| !(f.is_finite() && **f > 0.0 && **f < 0.5)) {
            return bad(format!("a line frequency must lie in (0, fs/2), got {f} cycles per sample"));
        }
        if self.n_lines > 0 && self.segments == 0 {
            return bad("the line spectra need at least one segment".into());
        }
        if !self.delay.is_finite() || self.delay.abs() > 1e6 {
            return bad(format!("the delay must be finite and at most 1e6 samples, got {}", self.delay));
        }
        Ok(())
    }

    /// Values per window of [`line_spectra`].
    pub fn spec_len(&self) -> usize {
        4 * self.n_lines
    }
}

/// The block sums of one window: [`BLOCKS`] x [`PRODUCTS`] values, row-major.
/// NaN for the instrument's sums when the window is shorter than 2 lag + 1.
pub fn block_sums(fy: &[f64], fz: &[f64], lag: usize) -> Vec<f64> {
    let n = fz.len();
    let mut out = vec![0.0; BLOCKS * PRODUCTS];
    if n == 0 {
        return out;
    }
    let nf = n as f64;
    let mz = fz.iter().sum::<f64>() / nf;
    let my = fy.iter().sum::<f64>() / nf;
    let has_w = lag >= 1 && n > 2 * lag;
    let inst = |t: usize| if t >= lag { fz[t - lag] } else { fz[t + lag] };
    let mw = if has_w { (0..n).map(inst).sum::<f64>() / nf } else { 0.0 };
    for k in 0..BLOCKS {
        let (a, b) = (k * n / BLOCKS, (k + 1) * n / BLOCKS);
        let mut s = [0.0f64; PRODUCTS];
        for t in a..b {
            let z = fz[t] - mz;
            let y = fy[t] - my;
            let w = if has_w { inst(t) - mw } else { 0.0 };
            let (zz, ww) = (z * z, w * w);
            s[0] += z;
            s[1] += y;
            s[2] += w;
            s[3] += zz;
            s[4] += z * y;
            s[5] += y * y;
            s[6] += w * z;
            s[7] += w * y;
            s[8] += ww;
            s[9] += zz * z;
            s[10] += zz * y;
            s[11] += zz * zz;
            s[12] += w * zz;
            s[13] += ww * z;
            s[14] += ww * y;
            s[15] += ww * zz;
        }
        if !has_w {
            for j in [2, 6, 7, 8, 12, 13, 14, 15] {
                s[j] = f64::NAN;
            }
        }
        out[k * PRODUCTS..(k + 1) * PRODUCTS].copy_from_slice(&s);
    }
    out
}

thread_local! {
    /// The Hann window of the last segment length used on this thread.
    static HANN: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
    /// The delayed fz of the window being computed on this thread.
    static SHIFTED: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
}

/// Cross-spectra of fy and fz at each line, per window: for line j,
/// [Re S_yz, Im S_yz, S_zz, S_yy] (S_yz = mean over segments of Y conj(Z),
/// Y, Z the DFTs of the Hann-windowed, centred segment at the line; units
/// N^2 up to a constant factor common to all three, which cancels in H1 and
/// the coherence). NaN when a segment is shorter than 4 samples.
pub fn line_spectra(fy: &[f64], fz: &[f64], opt: &ExtOptions) -> Vec<f64> {
    let nl = opt.n_lines;
    let mut out = vec![0.0; 4 * nl];
    let n = fz.len();
    let m = n / opt.segments.max(1);
    if nl == 0 {
        return out;
    }
    if m < 4 {
        out.fill(f64::NAN);
        return out;
    }
    HANN.with(|h| {
        let mut h = h.borrow_mut();
        if h.len() != m {
            h.clear();
            h.extend((0..m).map(|t| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * t as f64 / m as f64).cos()));
        }
        for seg in 0..opt.segments {
            let (y, z) = (&fy[seg * m..(seg + 1) * m], &fz[seg * m..(seg + 1) * m]);
            let my = y.iter().sum::<f64>() / m as f64;
            let mz = z.iter().sum::<f64>() / m as f64;
            for (j, &f) in opt.lines[..nl].iter().enumerate() {
                let w = 2.0 * std::f64::consts::PI * f;
                let c = 2.0 * w.cos();
                // Goertzel: s_t = x_t + c s_{t-1} - s_{t-2}; the DFT at w is
                // then e^{iw} s_{m-1} - s_{m-2}, up to a phase common to fy and fz.
                let (mut y1, mut y2, mut z1, mut z2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
                for t in 0..m {
                    let yn = h[t] * (y[t] - my) + c * y1 - y2;
                    let zn = h[t] * (z[t] - mz) + c * z1 - z2;
                    (y2, y1, z2, z1) = (y1, yn, z1, zn);
                }
                let (cw, sw) = (w.cos(), w.sin());
                let (yr, yi) = (cw * y1 - y2, sw * y1);
                let (zr, zi) = (cw * z1 - z2, sw * z1);
                out[4 * j] += yr * zr + yi * zi;
                out[4 * j + 1] += yi * zr - yr * zi;
                out[4 * j + 2] += zr * zr + zi * zi;
                out[4 * j + 3] += yr * yr + yi * yi;
            }
        }
    });
    let s = opt.segments as f64;
    for v in out.iter_mut() {
        *v /= s;
    }
    out
}

/// Modified Bessel function I0 (power series; converges for every x).
fn bessel_i0(x: f64) -> f64 {
    let (mut term, mut sum, q) = (1.0f64, 1.0f64, 0.25 * x * x);
    for k in 1..200 {
        term *= q / (k as f64 * k as f64);
        sum += term;
        if term < 1e-17 * sum {
            break;
        }
    }
    sum
}

/// Taps h_j, j = -HALF_TAPS..=HALF_TAPS, of the filter that advances a
/// band-limited signal by `frac` in [0, 1) samples: g[t] = sum_j h_j x[t + j]
/// (Kaiser-windowed sinc, normalised to unit gain at 0 Hz).
fn fractional_taps(frac: f64) -> [f64; 2 * HALF_TAPS + 1] {
    let mut h = [0.0; 2 * HALF_TAPS + 1];
    let half = (HALF_TAPS + 1) as f64;
    let norm = bessel_i0(KAISER_BETA);
    for (i, v) in h.iter_mut().enumerate() {
        let x = i as f64 - HALF_TAPS as f64 - frac;
        let sinc = if x == 0.0 { 1.0 } else { (std::f64::consts::PI * x).sin() / (std::f64::consts::PI * x) };
        let r = (x / half).clamp(-1.0, 1.0);
        *v = sinc * bessel_i0(KAISER_BETA * (1.0 - r * r).sqrt()) / norm;
    }
    let s: f64 = h.iter().sum();
    h.iter_mut().for_each(|v| *v /= s);
    h
}

/// The samples [t0, t1) of the window whose fz can be advanced by `delay`
/// samples (every tap inside the window), or None when under 3 remain.
pub fn delayed_range(n: usize, delay: f64) -> Option<(usize, usize)> {
    let m = delay.floor() as i64;
    let k = HALF_TAPS as i64;
    let t0 = (k - m).max(0);
    let t1 = (n as i64 - k - m).min(n as i64);
    (t1 - t0 >= 3).then_some((t0 as usize, t1 as usize))
}

/// Calls `f` with fz advanced by `delay` samples over [t0, t1) of the
/// window (see [`delayed_range`]): g[t] = fz(t + delay).
pub fn delayed<R>(fz: &[f64], delay: f64, f: impl FnOnce(&[f64], usize, usize) -> R) -> Result<R, KernelError> {
    let (t0, t1) = delayed_range(fz.len(), delay).ok_or_else(|| {
        KernelError::Invalid(format!(
            "a window of {} samples is too short to advance fz by {delay} samples ({} taps each side)",
            fz.len(),
            HALF_TAPS
        ))
    })?;
    let m = delay.floor();
    let h = fractional_taps(delay - m);
    let m = m as i64;
    Ok(SHIFTED.with(|buf| {
        let mut g = buf.borrow_mut();
        g.clear();
        g.extend((t0..t1).map(|t| {
            let base = t as i64 + m - HALF_TAPS as i64;
            let mut acc = 0.0;
            for (j, &hj) in h.iter().enumerate() {
                acc += hj * fz[(base + j as i64) as usize];
            }
            acc
        }));
        f(&g, t0, t1)
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(n: usize, f: f64, shift: f64) -> Vec<f64> {
        (0..n).map(|t| (2.0 * std::f64::consts::PI * f * (t as f64 - shift)).sin()).collect()
    }

    #[test]
    fn delay_filter_advances_a_tone() {
        // fz is the tone delayed by 0.3 samples; advancing by 0.3 gives the tone back.
        let (n, f) = (400, 0.07);
        let fz = tone(n, f, 0.3);
        let want = tone(n, f, 0.0);
        delayed(&fz, 0.3, |g, t0, _| {
            for (k, v) in g.iter().enumerate() {
                assert!((v - want[t0 + k]).abs() < 2e-4, "{v} vs {}", want[t0 + k]);
            }
        })
        .unwrap();
        // Integer delays are exact shifts.
        delayed(&fz, 2.0, |g, t0, _| assert_eq!(g[0], fz[t0 + 2])).unwrap();
        assert!(delayed(&fz[..20], 0.5, |_, _, _| ()).is_err());
    }

    #[test]
    fn block_sums_match_direct_sums() {
        let n = 1003;
        let fz: Vec<f64> = (0..n).map(|t| (t as f64 * 0.21).sin() + 0.3 * (t as f64 * 1.7).cos()).collect();
        let fy: Vec<f64> = fz.iter().map(|z| 0.1 * z + 0.2).collect();
        let s = block_sums(&fy, &fz, 10);
        let tot = |j: usize| (0..BLOCKS).map(|k| s[k * PRODUCTS + j]).sum::<f64>();
        assert!(tot(0).abs() < 1e-9 && tot(1).abs() < 1e-9 && tot(2).abs() < 1e-9);
        assert!((tot(4) - 0.1 * tot(3)).abs() < 1e-9 * tot(3));
        assert!(block_sums(&fy[..15], &fz[..15], 10)[6].is_nan());
    }

    #[test]
    fn line_spectra_see_a_delay() {
        let (n, f) = (2000, 0.1);
        let fy = tone(n, f, 0.0);
        let fz = tone(n, f, 0.5);
        let mut opt = ExtOptions { n_lines: 1, ..Default::default() };
        opt.lines[0] = f;
        let s = line_spectra(&fy, &fz, &opt);
        let phase = s[1].atan2(s[0]);
        let delay = phase / (2.0 * std::f64::consts::PI * f);
        assert!((delay - 0.5).abs() < 1e-3, "{delay}");
        assert!((s[0] * s[0] + s[1] * s[1] - s[2] * s[3]).abs() < 1e-9 * s[2] * s[3]);
    }
}
