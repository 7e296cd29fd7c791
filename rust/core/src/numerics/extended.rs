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
//! - [`lag_sums`]: the instrument's two sums S_wz, S_wy at a few extra
//!   lags (w built at each exactly as [`block_sums`] builds it), over the
//!   whole window: the IV slope's moves between the admissible lags pooled
//!   over all the recording's windows (docs/method.md 3d);
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
use crate::numerics::sums;
use std::cell::RefCell;

/// Consecutive blocks of a window for the batch-means standard errors:
/// block k holds samples [k n / BLOCKS, (k + 1) n / BLOCKS) (integer division).
pub const BLOCKS: usize = 5;
/// Sums per block, in this order (z, y, w centred; docs/method.md 3a):
/// z, y, w, zz, zy, yy, wz, wy, ww, zzz, zzy, zzzz, wzz, wwz, wwy, wwzz.
pub const PRODUCTS: usize = 16;
/// Most line frequencies per call.
pub const MAX_LINES: usize = 8;
/// Most extra instrument lags per call ([`lag_sums`]).
pub const MAX_EXTRA_LAGS: usize = 8;
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
    /// Extra instrument lags, samples (first `n_extra` used): [`lag_sums`].
    pub extra_lags: [usize; MAX_EXTRA_LAGS],
    pub n_extra: usize,
    /// Segments averaged for the line spectra.
    pub segments: usize,
    /// fz is advanced by this many samples before anything else (0: none).
    pub delay: f64,
    /// The classical COF of the raw forces ([`classical`]), when asked for.
    pub classical: Option<Classical>,
}

/// How the classical COF of a window is taken (docs/method.md 6a).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Classical {
    /// Least |fz - tare_z| (N) of a sample counted.
    pub min_fn: f64,
    /// Offsets subtracted from fy and fz first (N).
    pub tare_y: f64,
    pub tare_z: f64,
}

impl Default for ExtOptions {
    fn default() -> Self {
        ExtOptions {
            sums: false,
            lag: 0,
            lines: [0.0; MAX_LINES],
            n_lines: 0,
            extra_lags: [0; MAX_EXTRA_LAGS],
            n_extra: 0,
            segments: 4,
            delay: 0.0,
            classical: None,
        }
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
        if self.n_extra > MAX_EXTRA_LAGS {
            return bad(format!("at most {MAX_EXTRA_LAGS} extra instrument lags, got {}", self.n_extra));
        }
        if let Some(l) = self.extra_lags[..self.n_extra].iter().find(|l| **l == 0) {
            return bad(format!("an extra instrument lag must be at least 1 sample, got {l}"));
        }
        if self.n_lines > 0 && self.segments == 0 {
            return bad("the line spectra need at least one segment".into());
        }
        if let Some(c) = self.classical {
            if !(c.min_fn.is_finite() && c.min_fn >= 0.0 && c.tare_y.is_finite() && c.tare_z.is_finite()) {
                return bad(format!("min_fn must be finite and >= 0 and the tares finite, got {c:?}"));
            }
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

    /// Values per window of [`lag_sums`].
    pub fn lag_sums_len(&self) -> usize {
        2 * self.n_extra
    }
}

/// Lanes of the block sums: sample j of a run of samples goes to lane j mod
/// SUM_LANES (fixed, so every CPU gives the same bits; see [`crate::numerics::windows`]).
const SUM_LANES: usize = 4;
/// Products summed per pass over a run (two passes keep the lanes in registers).
const HALF: usize = PRODUCTS / 2;

/// The block sums of one window: [`BLOCKS`] x [`PRODUCTS`] values, row-major.
/// NaN for the instrument's sums when the window is shorter than 2 lag + 1.
///
/// `means`, the window's means of (fz, fy) when the caller has them (the
/// window's own statistics), saves a pass over the samples.
pub fn block_sums(fy: &[f64], fz: &[f64], lag: usize, means: Option<(f64, f64)>) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { block_sums_avx2(fy, fz, lag, means) };
        }
    }
    block_sums_body(fy, fz, lag, means)
}

// The same code compiled for wider vectors; no multiply-add is fused and the
// lanes are fixed, so both variants give the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn block_sums_avx2(fy: &[f64], fz: &[f64], lag: usize, means: Option<(f64, f64)>) -> Vec<f64> {
    block_sums_body(fy, fz, lag, means)
}

/// Adds the products of `lanes` samples (z, y, w centred by the means `m`)
/// to the lane sums `a`: the first half of [`PRODUCTS`] (`FIRST`) or the
/// second.
#[inline(always)]
fn step<const FIRST: bool>(a: &mut [[f64; SUM_LANES]; HALF], z: &[f64], y: &[f64], w: &[f64], m: (f64, f64, f64)) {
    let lanes = z.len();
    for k in 0..lanes {
        let (zc, yc, wc) = (z[k] - m.0, y[k] - m.1, w[k] - m.2);
        if FIRST {
            a[0][k] += zc;
            a[1][k] += yc;
            a[2][k] += wc;
            a[3][k] += zc * zc;
            a[4][k] += zc * yc;
            a[5][k] += yc * yc;
            a[6][k] += wc * zc;
            a[7][k] += wc * yc;
        } else {
            let (zz, ww) = (zc * zc, wc * wc);
            a[0][k] += ww;
            a[1][k] += zz * zc;
            a[2][k] += zz * yc;
            a[3][k] += zz * zz;
            a[4][k] += wc * zz;
            a[5][k] += ww * zc;
            a[6][k] += ww * yc;
            a[7][k] += ww * zz;
        }
    }
}

/// Adds the products of a run of samples to `out` (lane j mod SUM_LANES, folded in a fixed order).
#[inline(always)]
fn run<const FIRST: bool>(z: &[f64], y: &[f64], w: &[f64], m: (f64, f64, f64), out: &mut [f64]) {
    const L: usize = SUM_LANES;
    let mut a = [[0.0f64; L]; HALF];
    let n = z.len();
    let full = n - n % L;
    for ((zs, ys), ws) in z[..full].chunks_exact(L).zip(y[..full].chunks_exact(L)).zip(w[..full].chunks_exact(L)) {
        step::<FIRST>(&mut a, zs, ys, ws, m);
    }
    step::<FIRST>(&mut a, &z[full..], &y[full..], &w[full..], m);
    for (o, a) in out.iter_mut().zip(a) {
        *o += (a[0] + a[2]) + (a[1] + a[3]);
    }
}

#[inline(always)]
fn block_sums_body(fy: &[f64], fz: &[f64], lag: usize, means: Option<(f64, f64)>) -> Vec<f64> {
    let n = fz.len();
    let mut out = vec![0.0; BLOCKS * PRODUCTS];
    if n == 0 {
        return out;
    }
    let nf = n as f64;
    let has_w = lag >= 1 && n > 2 * lag;
    let (mz, my) = means.unwrap_or_else(|| (sums::sum(fz) / nf, sums::sum(fy) / nf));
    // w_t = fz[t + lag] for t < lag, fz[t - lag] after: the sum of w is that
    // of fz less fz[n - lag..] plus fz[lag..2 lag].
    let mw = if has_w { mz + (sums::sum(&fz[lag..2 * lag]) - sums::sum(&fz[n - lag..])) / nf } else { mz };
    let means = (mz, my, mw);
    for k in 0..BLOCKS {
        let (a, b) = (k * n / BLOCKS, (k + 1) * n / BLOCKS);
        let s = &mut out[k * PRODUCTS..(k + 1) * PRODUCTS];
        // The block in runs where the instrument is a contiguous slice of fz.
        let split = if has_w { lag.clamp(a, b) } else { a };
        for (r0, r1) in [(a, split), (split, b)] {
            if r1 <= r0 {
                continue;
            }
            let w = if !has_w {
                &fz[r0..r1]
            } else if r0 < lag {
                &fz[r0 + lag..r1 + lag]
            } else {
                &fz[r0 - lag..r1 - lag]
            };
            run::<true>(&fz[r0..r1], &fy[r0..r1], w, means, &mut s[..HALF]);
            run::<false>(&fz[r0..r1], &fy[r0..r1], w, means, &mut s[HALF..]);
        }
        if !has_w {
            for j in [2, 6, 7, 8, 12, 13, 14, 15] {
                s[j] = f64::NAN;
            }
        }
    }
    out
}

/// The instrument's sums at each of `lags` over the whole window:
/// [S_wz, S_wy] per lag, S_wz = sum_t (w_t - mean w)(z_t - mean z) and
/// S_wy likewise with y = fy, w built at that lag exactly as in
/// [`block_sums`] (w_t = fz_{t - L} for t >= L, fz_{t + L} before). NaN
/// for a lag the window cannot hold (n <= 2 L). Summed in index order in
/// [`SUM_LANES`] fixed lanes: a window's result depends only on its samples.
///
/// `means`: the window's means of (fz, fy) when the caller has them.
pub fn lag_sums(fy: &[f64], fz: &[f64], lags: &[usize], means: Option<(f64, f64)>) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { lag_sums_avx2(fy, fz, lags, means) };
        }
    }
    lag_sums_body(fy, fz, lags, means)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn lag_sums_avx2(fy: &[f64], fz: &[f64], lags: &[usize], means: Option<(f64, f64)>) -> Vec<f64> {
    lag_sums_body(fy, fz, lags, means)
}

/// Adds (w - mw)(z - mz) and (w - mw)(y - my) of a run to the lane sums `a`.
#[inline(always)]
fn cross_run(a: &mut [[f64; SUM_LANES]; 2], z: &[f64], y: &[f64], w: &[f64], m: (f64, f64, f64)) {
    const L: usize = SUM_LANES;
    let full = z.len() - z.len() % L;
    let mut add = |zs: &[f64], ys: &[f64], ws: &[f64]| {
        for k in 0..zs.len() {
            let wc = ws[k] - m.2;
            a[0][k] += wc * (zs[k] - m.0);
            a[1][k] += wc * (ys[k] - m.1);
        }
    };
    for ((zs, ys), ws) in z[..full].chunks_exact(L).zip(y[..full].chunks_exact(L)).zip(w[..full].chunks_exact(L)) {
        add(zs, ys, ws);
    }
    add(&z[full..], &y[full..], &w[full..]);
}

#[inline(always)]
fn lag_sums_body(fy: &[f64], fz: &[f64], lags: &[usize], means: Option<(f64, f64)>) -> Vec<f64> {
    let n = fz.len();
    let mut out = vec![f64::NAN; 2 * lags.len()];
    if n == 0 {
        return out;
    }
    let nf = n as f64;
    let (mz, my) = means.unwrap_or_else(|| (sums::sum(fz) / nf, sums::sum(fy) / nf));
    for (j, &lag) in lags.iter().enumerate() {
        if lag == 0 || n <= 2 * lag {
            continue;
        }
        let mw = mz + (sums::sum(&fz[lag..2 * lag]) - sums::sum(&fz[n - lag..])) / nf;
        let m = (mz, my, mw);
        let mut a = [[0.0f64; SUM_LANES]; 2];
        // t < lag: w_t = fz[t + lag]; t >= lag: w_t = fz[t - lag]
        cross_run(&mut a, &fz[..lag], &fy[..lag], &fz[lag..2 * lag], m);
        cross_run(&mut a, &fz[lag..], &fy[lag..], &fz[..n - lag], m);
        for (o, a) in out[2 * j..2 * j + 2].iter_mut().zip(a) {
            *o = (a[0] + a[2]) + (a[1] + a[3]);
        }
    }
    out
}

/// The classical COF of one window (docs/method.md 6a): [mean, median] of
/// |fy - tare_y| / |fz - tare_z| over the samples with |fz - tare_z| >=
/// min_fn (and > 0), then the mean and the standard deviation (n in the
/// denominator) of fz - tare_z over the window. NaN where no sample counts.
pub fn classical(fy: &[f64], fz: &[f64], c: &Classical) -> [f64; 4] {
    let n = fz.len();
    if n == 0 {
        return [f64::NAN; 4];
    }
    let mut r = RATIOS.with(|b| b.take());
    r.clear();
    let (mut sum_r, mut sum_z) = (0.0f64, 0.0f64);
    for (&y, &z) in fy.iter().zip(fz) {
        let zr = z - c.tare_z;
        sum_z += zr;
        let az = zr.abs();
        if az >= c.min_fn && az > 0.0 {
            let v = (y - c.tare_y).abs() / az;
            sum_r += v;
            r.push(v);
        }
    }
    let mz = sum_z / n as f64;
    let var = fz.iter().map(|&z| (z - c.tare_z - mz) * (z - c.tare_z - mz)).sum::<f64>() / n as f64;
    let (mean, median) = if r.is_empty() {
        (f64::NAN, f64::NAN)
    } else {
        let k = r.len();
        let mean = sum_r / k as f64;
        let m = k / 2;
        let (lower, &mut hi, _) = r.select_nth_unstable_by(m, f64::total_cmp);
        let median = if k % 2 == 1 { hi } else { 0.5 * (lower.iter().copied().fold(f64::NEG_INFINITY, f64::max) + hi) };
        (mean, median)
    };
    RATIOS.with(|b| b.replace(r));
    [mean, median, mz, var.sqrt()]
}

thread_local! {
    /// The ratios of the window being computed on this thread ([`classical`]).
    static RATIOS: RefCell<Vec<f64>> = const { RefCell::new(Vec::new()) };
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
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { line_spectra_avx2(fy, fz, opt) };
        }
    }
    line_spectra_body(fy, fz, opt)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn line_spectra_avx2(fy: &[f64], fz: &[f64], opt: &ExtOptions) -> Vec<f64> {
    line_spectra_body(fy, fz, opt)
}

#[inline(always)]
fn line_spectra_body(fy: &[f64], fz: &[f64], opt: &ExtOptions) -> Vec<f64> {
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
    // The thread's Hann table moved out for the call (the loops below then
    // run in this function, compiled for the CPU's vectors) and back after.
    let mut h = HANN.with(|c| c.take());
    if h.len() != m {
        h.clear();
        h.extend((0..m).map(|t| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * t as f64 / m as f64).cos()));
    }
    {
        // Every line's Goertzel recurrence side by side (lines inner, in
        // fixed-size arrays): independent chains the CPU runs in parallel.
        let mut c = [0.0f64; MAX_LINES];
        for (cj, &f) in c.iter_mut().zip(&opt.lines[..nl]) {
            *cj = 2.0 * (2.0 * std::f64::consts::PI * f).cos();
        }
        for seg in 0..opt.segments {
            let (y, z) = (&fy[seg * m..(seg + 1) * m], &fz[seg * m..(seg + 1) * m]);
            let my = sums::sum(y) / m as f64;
            let mz = sums::sum(z) / m as f64;
            let (mut y1, mut y2, mut z1, mut z2) =
                ([0.0f64; MAX_LINES], [0.0f64; MAX_LINES], [0.0f64; MAX_LINES], [0.0f64; MAX_LINES]);
            for t in 0..m {
                let (hy, hz) = (h[t] * (y[t] - my), h[t] * (z[t] - mz));
                for j in 0..MAX_LINES {
                    let yn = hy + c[j] * y1[j] - y2[j];
                    let zn = hz + c[j] * z1[j] - z2[j];
                    y2[j] = y1[j];
                    y1[j] = yn;
                    z2[j] = z1[j];
                    z1[j] = zn;
                }
            }
            for (j, &f) in opt.lines[..nl].iter().enumerate() {
                // The DFT at w is e^{iw} s_{m-1} - s_{m-2}, up to a phase common to fy and fz.
                let w = 2.0 * std::f64::consts::PI * f;
                let (cw, sw) = (w.cos(), w.sin());
                let (yr, yi) = (cw * y1[j] - y2[j], sw * y1[j]);
                let (zr, zi) = (cw * z1[j] - z2[j], sw * z1[j]);
                out[4 * j] += yr * zr + yi * zi;
                out[4 * j + 1] += yi * zr - yr * zi;
                out[4 * j + 2] += zr * zr + zi * zi;
                out[4 * j + 3] += yr * yr + yi * yi;
            }
        }
    }
    HANN.with(|c| c.replace(h));
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
        let s = block_sums(&fy, &fz, 10, None);
        let tot = |j: usize| (0..BLOCKS).map(|k| s[k * PRODUCTS + j]).sum::<f64>();
        assert!(tot(0).abs() < 1e-9 && tot(1).abs() < 1e-9 && tot(2).abs() < 1e-9);
        assert!((tot(4) - 0.1 * tot(3)).abs() < 1e-9 * tot(3));
        assert!(block_sums(&fy[..15], &fz[..15], 10, None)[6].is_nan());
        let m = (fz.iter().sum::<f64>() / n as f64, fy.iter().sum::<f64>() / n as f64);
        let t = block_sums(&fy, &fz, 10, Some(m));
        assert!(s.iter().zip(&t).all(|(a, b)| (a - b).abs() <= 1e-9 * (1.0 + a.abs())));
    }

    #[test]
    fn lag_sums_match_the_block_sums_and_direct_sums() {
        let n = 1003;
        let fz: Vec<f64> = (0..n).map(|t| (t as f64 * 0.21).sin() + 0.3 * (t as f64 * 1.7).cos() + 2.0).collect();
        let fy: Vec<f64> = fz.iter().enumerate().map(|(t, z)| 0.1 * z + 0.05 * (t as f64 * 0.9).sin()).collect();
        let lags = [3, 10, 501, 502, 0];
        let s = lag_sums(&fy, &fz, &lags, None);
        assert_eq!(s.len(), 10);
        for (j, &lag) in lags.iter().enumerate().take(3) {
            // the block sums' S_wz, S_wy (products 6, 7) at that lag, summed over the blocks
            let b = block_sums(&fy, &fz, lag, None);
            let tot = |p: usize| (0..BLOCKS).map(|k| b[k * PRODUCTS + p]).sum::<f64>();
            assert!((s[2 * j] - tot(6)).abs() <= 1e-10 * tot(6).abs().max(1.0), "lag {lag}");
            assert!((s[2 * j + 1] - tot(7)).abs() <= 1e-10 * tot(7).abs().max(1.0), "lag {lag}");
            // and the direct definition
            let w: Vec<f64> = (0..n).map(|t| if t >= lag { fz[t - lag] } else { fz[t + lag] }).collect();
            let mean = |v: &[f64]| v.iter().sum::<f64>() / n as f64;
            let (mw, mz, my) = (mean(&w), mean(&fz), mean(&fy));
            let wz: f64 = (0..n).map(|t| (w[t] - mw) * (fz[t] - mz)).sum();
            let wy: f64 = (0..n).map(|t| (w[t] - mw) * (fy[t] - my)).sum();
            assert!((s[2 * j] - wz).abs() <= 1e-10 * wz.abs().max(1.0) && (s[2 * j + 1] - wy).abs() <= 1e-10);
        }
        // a lag the window cannot hold (n <= 2 L), and a lag 0: NaN, no panic
        assert!(s[6..].iter().all(|v| v.is_nan()));
        assert!(lag_sums(&[], &[], &[3], None).iter().all(|v| v.is_nan()));
        // the caller's means give the same sums; the same bits on every call
        let m = (fz.iter().sum::<f64>() / n as f64, fy.iter().sum::<f64>() / n as f64);
        let t = lag_sums(&fy, &fz, &lags, Some(m));
        assert!(s.iter().zip(&t).all(|(a, b)| a.is_nan() && b.is_nan() || (a - b).abs() <= 1e-12 * (1.0 + a.abs())));
        assert_eq!(format!("{:?}", lag_sums_body(&fy, &fz, &lags, None)), format!("{s:?}"));
        // checked options
        let mut o = ExtOptions { n_extra: 2, ..Default::default() };
        o.extra_lags[0] = 4;
        assert!(o.check().is_err());
        o.extra_lags[1] = 5;
        assert!(o.check().is_ok() && o.lag_sums_len() == 4);
        assert!(ExtOptions { n_extra: MAX_EXTRA_LAGS + 1, ..Default::default() }.check().is_err());
    }

    #[test]
    fn classical_counts_the_loaded_samples() {
        let fz = [10.0, 10.0, 0.5, 10.0, 12.0];
        let fy = [1.0, 1.0, 5.0, 2.0, -1.2];
        let c = Classical { min_fn: 1.0, tare_y: 0.0, tare_z: 0.0 };
        let [mean, median, mz, sz] = classical(&fy, &fz, &c);
        assert!((mean - (0.1 + 0.1 + 0.2 + 0.1) / 4.0).abs() < 1e-15);
        assert!((median - 0.1).abs() < 1e-15);
        assert!((mz - 8.5).abs() < 1e-12 && sz > 0.0);
        let none = classical(&fy, &fz, &Classical { min_fn: 100.0, ..c });
        assert!(none[0].is_nan() && none[1].is_nan());
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
