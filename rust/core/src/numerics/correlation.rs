//! Lagged correlation function, Eq. (1) of the paper (docs/method.md 1).
//!
//! C(j) = S_xy(j) / sqrt(S_xx(j) S_yy(j)), with x and y centred on the means
//! of the WHOLE inputs and each sum taken over the overlap of x_i and
//! y_{i+j}. If y is x delayed by d samples, C peaks at j = +d. A zero
//! denominator gives NaN.
//!
//! Two algorithms for the numerator S_xy: direct, O(n L), and FFT,
//! O(n log n). Both share the denominators, which are sums of squares over
//! the overlaps built from one long sum plus the few edge terms (never a
//! difference of two large sums), so only O(L) of them are stored.
//!
//! - Direct: a tile of lags is kept in registers while x streams past
//!   (y_{i+j} for consecutive j is contiguous), which reuses every load for
//!   the whole tile. Long inputs are cut into fixed tasks whose partial sums
//!   are added in task order, so threads never change a bit.
//! - FFT: one real FFT per signal when L is comparable to n; for L << n,
//!   overlap-save blocks whose FFT length is a small multiple of the lag
//!   span (a 7.2e7-point transform would spend most of its time on lags
//!   nobody asked for, and run from memory instead of cache). The cross
//!   spectra of the blocks are summed in block order per task, one inverse
//!   FFT per task.
//!
//! The FFT numerator carries a rounding error of about eps log2(N)
//! sqrt(E_x E_y); at lags whose overlap holds little of the energy that
//! error is amplified, so such lags are recomputed directly. The two methods
//! then agree to 1e-10 absolute (tested).
//!
//! Small inputs (one analysis window) run on the calling thread: for them
//! the thread pool's hand-off costs more than the work. [`uses_threads`]
//! tells the binding layer when to enter the pool.

use crate::error::{same_len, KernelError};
use crate::numerics::sums::{dot_dev, mean, par_mean, par_sum_sq_dev, sum_sq_dev};
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use std::sync::Arc;

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

/// "auto" picks direct when its multiply-adds (n times the lag count
/// rounded up to whole tiles of [`MAX_TILE`] lags) are fewer than
/// `AUTO_FFT_FACTOR` times the FFT cost of [`FftPlan::cost`] plus
/// `FFT_CALL_COST` (plan look-up, buffers). Fitted to measured times of
/// both methods on a grid of n = 200..1e6 and L = 1..3000 (x86-64, AVX2):
/// the two cross where this ratio is 2 to 4, and wherever the rule picks
/// the slower method it loses at most 1.5x.
const AUTO_FFT_FACTOR: f64 = 3.0;
const FFT_CALL_COST: f64 = 20_000.0;

/// Relative size of the FFT rounding bound above which a lag is refined.
const REFINE_BOUND: f64 = 1e-12;

/// Work (n times the number of lags) below which everything runs on the
/// calling thread.
const SERIAL_WORK: usize = 1 << 21;

/// Samples of x per direct task (x and its y window stay in L2).
const DIRECT_TASK: usize = 1 << 14;

/// Widest lag tile of the direct kernel; y is padded by this much.
const MAX_TILE: usize = 32;

/// Smallest FFT length of an overlap-save block.
const MIN_BLOCK_FFT: usize = 1024;

/// At most this many parallel tasks for the blocked FFT (each returns one
/// partial numerator); a task holds at least `MIN_TASK_BLOCKS` blocks.
const MAX_FFT_TASKS: usize = 64;
const MIN_TASK_BLOCKS: usize = 4;

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
    let direct = n as f64 * (2 * max_lag + 1).next_multiple_of(MAX_TILE) as f64;
    if direct <= AUTO_FFT_FACTOR * (FftPlan::new(n, max_lag).cost() + FFT_CALL_COST) {
        Method::Direct
    } else {
        Method::Fft
    }
}

/// Whether [`xcorr`] with these arguments uses the thread pool; when not,
/// callers need not enter it (which costs more than one window's work).
pub fn uses_threads(n: usize, max_lag: usize) -> bool {
    n.saturating_mul(2 * max_lag + 1) >= SERIAL_WORK
}

/// Smallest 2^a 3^b >= `need`.
fn smooth_len(need: usize) -> usize {
    crate::numerics::lagprofile::smooth_length(need, false)
}

/// The FFT length a one-block correlation of n samples at all lags uses.
#[cfg(test)]
fn fft_len(n: usize) -> usize {
    smooth_len((2 * n).saturating_sub(1))
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
    let par = uses_threads(n, max_lag);
    let (mx, my) = if par { rayon::join(|| par_mean(x), || par_mean(y)) } else { (mean(x), mean(y)) };
    let den = Denominators::new(x, y, mx, my, max_lag, par);
    let l = max_lag as i64;
    let mut num = match method {
        Method::Fft => {
            let plan = FftPlan::new(n, max_lag);
            let mut num = fft_numerator(x, y, mx, my, max_lag, &plan, par);
            // Refine the lags whose overlap holds too little energy for the
            // FFT's rounding (rare: the far edges of a long lag range).
            let limit = plan.error_scale(max_lag) * (den.ex * den.ey).sqrt() / REFINE_BOUND;
            let refine: Vec<usize> = (0..num.len()).filter(|&k| limit > den.root[k]).collect();
            let exact = |k: &usize| direct_at(x, y, mx, my, *k as i64 - l);
            let fixed: Vec<f64> = if par && refine.len() > 1 {
                refine.par_iter().map(exact).collect()
            } else {
                refine.iter().map(exact).collect()
            };
            for (k, v) in refine.iter().zip(fixed) {
                num[*k] = v;
            }
            num
        }
        _ => direct_numerator(x, y, mx, my, max_lag, par),
    };
    // C = S_xy / sqrt(S_xx S_yy), as `ratio` does, one lag per element so
    // that it vectorises.
    for (c, &d) in num.iter_mut().zip(&den.root) {
        *c = if d > 0.0 { (*c / d).clamp(-1.0, 1.0) } else { f64::NAN };
    }
    Ok(num)
}

/// S_xy(j) = sum over the overlap of (x_i - mx)(y_{i+j} - my), one lag.
fn direct_at(x: &[f64], y: &[f64], mx: f64, my: f64, j: i64) -> f64 {
    let n = x.len();
    if j >= 0 {
        let j = j as usize;
        dot_dev(&x[..n - j], mx, &y[j..], my)
    } else {
        let k = (-j) as usize;
        dot_dev(&x[k..], mx, &y[..n - k], my)
    }
}

/// S_xx(j) and S_yy(j) of every lag, index j + L. For j >= 0,
/// S_xx(j) = sum_{i < n-j} xc_i^2 and S_yy(j) = sum_{i >= j} yc_i^2 (mirrored
/// for j < 0): one long sum over the part every overlap shares, then the
/// edge terms added one by one.
struct Denominators {
    /// sqrt(S_xx(j) S_yy(j)), the denominator of Eq. (1), index j + L.
    root: Vec<f64>,
    /// Energies of the centred signals, S_xx(0) and S_yy(0).
    ex: f64,
    ey: f64,
}

impl Denominators {
    fn new(x: &[f64], y: &[f64], mx: f64, my: f64, max_lag: usize, par: bool) -> Self {
        let l = max_lag;
        let ((xp, xs), (yp, ys)) = if par {
            rayon::join(|| edge_sums(x, mx, l, true), || edge_sums(y, my, l, true))
        } else {
            (edge_sums(x, mx, l, false), edge_sums(y, my, l, false))
        };
        // Lag j >= 0 uses (xp[j], ys[j]), j < 0 uses (xs[-j], yp[-j]).
        let mut root = vec![0.0; 2 * l + 1];
        for (r, (a, b)) in root[l..].iter_mut().zip(xp.iter().zip(&ys)) {
            *r = (a * b).sqrt();
        }
        for (r, (a, b)) in root[..l].iter_mut().rev().zip(xs[1..].iter().zip(&yp[1..])) {
            *r = (a * b).sqrt();
        }
        Denominators { root, ex: xp[0], ey: yp[0] }
    }
}

/// For k = 0..=L: head[k] = sum_{i < n-k} (v_i - m)^2 and
/// tail[k] = sum_{i >= k} (v_i - m)^2.
fn edge_sums(v: &[f64], m: f64, l: usize, par: bool) -> (Vec<f64>, Vec<f64>) {
    let n = v.len();
    let sq = |u: &[f64]| if par { par_sum_sq_dev(u, m) } else { sum_sq_dev(u, m) };
    let (head_base, tail_base) = if n >= 2 * l {
        // The middle is shared by both ends: one pass over it.
        let mid = sq(&v[l..n - l]);
        (sum_sq_dev(&v[..l], m) + mid, mid + sum_sq_dev(&v[n - l..], m))
    } else {
        (sq(&v[..n - l]), sq(&v[l..]))
    };
    let mut head = vec![0.0; l + 1];
    let mut tail = vec![0.0; l + 1];
    head[l] = head_base;
    tail[l] = tail_base;
    for k in (0..l).rev() {
        let d = v[n - k - 1] - m;
        head[k] = head[k + 1] + d * d;
        let d = v[k] - m;
        tail[k] = tail[k + 1] + d * d;
    }
    (head, tail)
}

// ---------------------------------------------------------------- direct

/// Numerators of lags -L..=L by tiles of lags over fixed tasks of x.
fn direct_numerator(x: &[f64], y: &[f64], mx: f64, my: f64, max_lag: usize, par: bool) -> Vec<f64> {
    let n = x.len();
    let xc: Vec<f64> = x.iter().map(|v| v - mx).collect();
    // y centred, with pad zeros on both sides so that every lag of every
    // tile reads inside the buffer; the zeros add nothing to the sums.
    let pad = max_lag + MAX_TILE;
    let mut yp = vec![0.0; n + 2 * pad];
    for (d, v) in yp[pad..pad + n].iter_mut().zip(y) {
        *d = v - my;
    }
    let task = |a: usize| direct_part(&xc, &yp, pad, max_lag, a, (a + DIRECT_TASK).min(n));
    if n <= DIRECT_TASK {
        return task(0);
    }
    let starts: Vec<usize> = (0..n).step_by(DIRECT_TASK).collect();
    let parts: Vec<Vec<f64>> =
        if par { starts.par_iter().map(|&a| task(a)).collect() } else { starts.iter().map(|&a| task(a)).collect() };
    let mut num = vec![0.0; 2 * max_lag + 1];
    for p in &parts {
        for (s, v) in num.iter_mut().zip(p) {
            *s += v;
        }
    }
    num
}

/// Partial numerators over x[a..b) of all lags, by the widest tile the CPU
/// runs well. Every lag's sum runs over i in order, whatever the tile
/// width, so the result is the same on every CPU.
fn direct_part(xc: &[f64], yp: &[f64], pad: usize, max_lag: usize, a: usize, b: usize) -> Vec<f64> {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { direct_part_avx2(xc, yp, pad, max_lag, a, b) };
        }
    }
    direct_part_tiled::<16>(xc, yp, pad, max_lag, a, b)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn direct_part_avx2(xc: &[f64], yp: &[f64], pad: usize, max_lag: usize, a: usize, b: usize) -> Vec<f64> {
    direct_part_tiled::<MAX_TILE>(xc, yp, pad, max_lag, a, b)
}

/// `T` lags at a time: acc[t] += xc_i * yc_{i+j+t}, the T accumulators in
/// registers and the y values of consecutive lags one unaligned load.
#[inline(always)]
fn direct_part_tiled<const T: usize>(
    xc: &[f64],
    yp: &[f64],
    pad: usize,
    max_lag: usize,
    a: usize,
    b: usize,
) -> Vec<f64> {
    let n = xc.len() as i64;
    let l = max_lag as i64;
    let lags = 2 * max_lag + 1;
    let mut out = vec![0.0; lags.div_ceil(T) * T];
    for (tile, dst) in out.chunks_exact_mut(T).enumerate() {
        let ja = (tile * T) as i64 - l;
        // i where some lag of the tile overlaps: i + ja + T - 1 >= 0, i + ja < n.
        let lo = (a as i64).max(-(ja + T as i64 - 1)).max(0);
        let hi = (b as i64).min(n - ja);
        if lo >= hi {
            continue;
        }
        let (lo, hi) = (lo as usize, hi as usize);
        let off = (lo as i64 + ja + pad as i64) as usize;
        let xs = &xc[lo..hi];
        let yw = &yp[off..off + (hi - lo) + T - 1];
        let mut acc = [0.0f64; T];
        for (&xi, w) in xs.iter().zip(yw.windows(T)) {
            for t in 0..T {
                acc[t] += xi * w[t];
            }
        }
        dst.copy_from_slice(&acc);
    }
    out.truncate(lags);
    out
}

// ---------------------------------------------------------------- FFT

/// Shared FFT planner: plans (twiddles, algorithm choice) are made once per
/// length and reused by every call (the correlation's and the lag profile's).
pub(crate) fn plans(m: usize) -> (Arc<dyn RealToComplex<f64>>, Arc<dyn ComplexToReal<f64>>) {
    // per process: a child made by fork while another thread planned would otherwise wait forever
    static PLANNER: crate::parallel::PerProcess<RealFftPlanner<f64>> = crate::parallel::PerProcess::new();
    let mut p = PLANNER.lock(RealFftPlanner::new);
    (p.plan_fft_forward(m), p.plan_fft_inverse(m))
}

/// How the FFT numerator cuts the signals: `blocks` blocks of `block`
/// samples of x, each correlated with its y segment (the block and L
/// samples either side) by FFTs of length `m`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct FftPlan {
    m: usize,
    block: usize,
    blocks: usize,
}

impl FftPlan {
    /// The cheapest plan by [`FftPlan::cost`]: one block (m >= n + L; the
    /// y segment's leading zeros absorb the wrap-around), or blocks with
    /// m >= block + 2L.
    fn new(n: usize, max_lag: usize) -> FftPlan {
        let l = max_lag;
        let mut best = FftPlan { m: smooth_len(n + l), block: n, blocks: 1 };
        for c in [2usize, 4, 8, 16, 32] {
            let m = smooth_len((c * (2 * l + 1)).max(MIN_BLOCK_FFT));
            let block = m - 2 * l;
            if block >= n {
                break;
            }
            let p = FftPlan { m, block, blocks: n.div_ceil(block) };
            if p.cost() < best.cost() {
                best = p;
            }
        }
        best
    }

    /// Cost in multiply-add-like units: two forward FFTs per block, one
    /// inverse per task, and the O(m) filling and spectrum products.
    fn cost(&self) -> f64 {
        let m = self.m as f64;
        let fft = m * m.log2().max(1.0);
        let blocks = self.blocks as f64;
        (2.0 * blocks + self.tasks() as f64) * fft + 4.0 * blocks * m
    }

    fn blocks_per_task(&self) -> usize {
        self.blocks.div_ceil(MAX_FFT_TASKS).max(MIN_TASK_BLOCKS)
    }

    fn tasks(&self) -> usize {
        self.blocks.div_ceil(self.blocks_per_task())
    }

    /// Rounding error of the numerator relative to sqrt(E_x E_y): a few eps
    /// per butterfly stage; blocks see each y sample up to 1 + 2L/block
    /// times and add their errors (Cauchy-Schwarz bounds the sum).
    fn error_scale(&self, max_lag: usize) -> f64 {
        let base = 4.0 * f64::EPSILON * (self.m as f64).log2().max(1.0);
        if self.blocks == 1 {
            base
        } else {
            2.0 * base * (1.0 + 2.0 * max_lag as f64 / self.block as f64).sqrt()
        }
    }
}

/// Numerators of lags -L..=L (index j + L) by overlap-save real FFTs.
fn fft_numerator(x: &[f64], y: &[f64], mx: f64, my: f64, max_lag: usize, plan: &FftPlan, par: bool) -> Vec<f64> {
    let per_task = plan.blocks_per_task();
    let task = |t: usize| {
        let b0 = t * per_task;
        fft_blocks(x, y, mx, my, max_lag, plan, b0, (b0 + per_task).min(plan.blocks))
    };
    let tasks = plan.tasks();
    if tasks == 1 {
        return task(0);
    }
    let parts: Vec<Vec<f64>> =
        if par { (0..tasks).into_par_iter().map(task).collect() } else { (0..tasks).map(task).collect() };
    let mut num = vec![0.0; 2 * max_lag + 1];
    for p in &parts {
        for (s, v) in num.iter_mut().zip(p) {
            *s += v;
        }
    }
    num
}

/// The numerator summed over blocks b0..b1: the cross spectra
/// conj(X_b) Y_b are added in block order, then one inverse FFT.
#[allow(clippy::too_many_arguments)]
fn fft_blocks(
    x: &[f64],
    y: &[f64],
    mx: f64,
    my: f64,
    max_lag: usize,
    plan: &FftPlan,
    b0: usize,
    b1: usize,
) -> Vec<f64> {
    let n = x.len();
    let l = max_lag;
    let m = plan.m;
    let (fwd, inv) = plans(m);
    let mut xb = vec![0.0; m];
    let mut yb = vec![0.0; m];
    let mut fx = fwd.make_output_vec();
    let mut fy = fwd.make_output_vec();
    let mut scratch = vec![Complex::new(0.0, 0.0); fwd.get_scratch_len().max(inv.get_scratch_len())];
    let mut acc = vec![Complex::new(0.0, 0.0); fx.len()];
    for b in b0..b1 {
        // x block at offset 0; y from i0 - L at offset 0, so lag j lands at
        // j + L and no lag wraps around (m >= block + 2L, or for one block
        // m >= n + L with the L leading zeros taking the wrap).
        let i0 = b * plan.block;
        let i1 = (i0 + plan.block).min(n);
        for (d, v) in xb.iter_mut().zip(&x[i0..i1]) {
            *d = v - mx;
        }
        xb[i1 - i0..].fill(0.0);
        let s0 = i0.saturating_sub(l);
        let s1 = (i1 + l).min(n);
        let off = s0 + l - i0;
        yb[..off].fill(0.0);
        for (d, v) in yb[off..].iter_mut().zip(&y[s0..s1]) {
            *d = v - my;
        }
        yb[off + s1 - s0..].fill(0.0);
        // Lengths come from the plan itself, so these cannot fail.
        let _ = fwd.process_with_scratch(&mut xb, &mut fx, &mut scratch);
        let _ = fwd.process_with_scratch(&mut yb, &mut fy, &mut scratch);
        // r(j) = sum_i x_i y_{i+j}  <=>  R = conj(X) Y.
        for ((a, p), q) in acc.iter_mut().zip(&fx).zip(&fy) {
            *a += p.conj() * q;
        }
    }
    // The inverse real FFT needs purely real DC and Nyquist bins.
    acc[0].im = 0.0;
    if m % 2 == 0 {
        if let Some(last) = acc.last_mut() {
            last.im = 0.0;
        }
    }
    let _ = inv.process_with_scratch(&mut acc, &mut xb, &mut scratch);
    let scale = 1.0 / m as f64;
    xb[..=2 * l].iter().map(|v| v * scale).collect()
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
    fn long_inputs_blocks_and_tasks_match_definition() {
        // Long enough for several direct tasks and a blocked FFT plan.
        let n = 3 * DIRECT_TASK + 123;
        let x = signal(n, 7);
        let y: Vec<f64> = signal(n, 8).iter().zip(&x).map(|(a, b)| a + 0.5 * b + 4.0).collect();
        for l in [0usize, 1, 37, 300] {
            let plan = FftPlan::new(n, l);
            assert!(plan.blocks > 1, "L={l}: {plan:?}");
            let a = xcorr(&x, &y, l, Method::Direct).unwrap();
            let b = xcorr(&x, &y, l, Method::Fft).unwrap();
            for (k, (u, v)) in a.iter().zip(&b).enumerate() {
                assert!((u - v).abs() < 1e-10, "L={l} lag {}: {u} vs {v}", k as i64 - l as i64);
            }
            for j in [-(l as i64), -1, 0, 1, l as i64] {
                if j.unsigned_abs() as usize <= l {
                    let want = naive(&x, &y, j);
                    assert!((a[(j + l as i64) as usize] - want).abs() < 1e-12, "L={l} lag {j}");
                }
            }
        }
        // Threads never change a bit.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let two = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        for m in [Method::Direct, Method::Fft] {
            let a = one.install(|| xcorr(&x, &y, 300, m).unwrap());
            let b = two.install(|| xcorr(&x, &y, 300, m).unwrap());
            assert_eq!(a, b);
        }
    }

    #[test]
    fn plans_block_long_records() {
        let p = FftPlan::new(36_000_000, 1000);
        assert!(p.blocks > 1 && p.m >= p.block + 2000 && p.block * p.blocks >= 36_000_000, "{p:?}");
        let p = FftPlan::new(2000, 500);
        assert_eq!((p.blocks, p.block), (1, 2000));
        assert!(p.m >= 2500);
        assert_eq!(auto_method(2000, 3), Method::Direct);
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
