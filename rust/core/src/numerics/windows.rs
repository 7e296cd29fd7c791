//! Per-window statistics of a recording, batched over windows
//! (docs/method.md 4-6): the hot loop of `tribodyn.analyze`.
//!
//! For each window [start, start + len) of the channels fy (friction), fz
//! (normal), optionally fx (axial), an auxiliary channel (current or shunt
//! voltage) and the raw (unfiltered) fy, fz, one task computes:
//! - the centred moments of (fz, fy) and the regression of fy on fz
//!   (Eqs. 6-8, as a [`crate::numerics::regression::Moments`]);
//! - Pearson C_xy(0), C_xz(0), C_yz(0) (Eq. 1 at lag 0);
//! - the deadband |fz| < d (d in newtons, or k times the window's fz
//!   standard deviation) and the equal-width fz bins over [min fz, max fz]
//!   with the per-bin mean of s fy/fz (Eq. 5), and mu_a (fz <= -d) and
//!   mu_b (fz >= +d), sample-weighted;
//! - the mean of the auxiliary channel, and the classical COF
//!   mean(|fy| / |fz|) of the raw forces (paper Sec. 5).
//!
//! A window is read in three passes, all but the first from cache: (1) sums
//! and the fz range of every channel, streamed together, (2) the centred
//! second moments of all pairs at once (two-pass with the Chan et al.
//! correction of the means, so adding a constant to a channel does not move
//! the result), (3) the residuals of the fit, the deadband, the bins and
//! mu_a / mu_b together. Pass 3 computes per-sample terms (residual, s fy/fz,
//! histogram slot) into small buffers with element-wise, vectorisable code,
//! then scatters them into the histograms: two per copy (fz < 0 and fz > 0,
//! whose sums are mu_a and mu_b), in four interleaved copies (sample j into
//! copy j mod 4), which breaks the store-to-load dependency of consecutive
//! samples falling into one bin. The bin of a sample is
//! floor((fz - min) * (n_bins / (max - min))), the maximum in the last bin
//! (the reference computes exactly this, so bin counts agree exactly).
//!
//! Every sum runs in fixed lanes ([`LANES`]) and in an order fixed by the
//! window's own sample index, and no multiply-add is fused, so a window's
//! result depends only on its samples: not on the thread count, on how the
//! caller cut the recording into chunks, or on the vector width of the CPU
//! (the same code is compiled for AVX-512, AVX2 and the baseline, picked at
//! run time).
//!
//! A non-finite sample in a window is an error (the sums of pass 1 are
//! finite exactly when every sample is, barring overflow, which is then
//! told apart by a scan). A window with a force beyond [`FORCE_LIMIT`] in
//! magnitude, or whose second-moment sums overflow, is out of range
//! (docs/method.md 4): every statistic NaN, no sample counted, and
//! [`WindowStats::out_of_range`] set, so that the caller can say why.

use crate::error::KernelError;
use crate::numerics::extended::{self, ExtOptions};
use crate::numerics::regression::Moments;
use rayon::prelude::*;

/// How the deadband is given (docs/method.md 4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Deadband {
    /// Exclude |fz| < d newtons.
    Force(f64),
    /// Exclude |fz| < k * std(fz) of the window.
    Sigma(f64),
}

/// Options shared by all windows.
#[derive(Debug, Clone, Copy)]
pub struct WindowOptions {
    /// Window length in samples.
    pub len: usize,
    /// Orientation s in {+1, -1}: mu = s * slope (docs/method.md 0).
    pub orientation: f64,
    pub deadband: Deadband,
    pub n_bins: usize,
    /// Statistics beyond the paper's and the delay correction
    /// ([`crate::numerics::extended`]; docs/method.md 3a-3e). Default: none.
    pub ext: ExtOptions,
}

/// The channels of a recording (or of one chunk of it), all of one length.
#[derive(Debug, Clone, Copy)]
pub struct Channels<'a> {
    /// Axial force (optional: C_xy, C_xz are NaN without it).
    pub fx: Option<&'a [f64]>,
    /// Friction (tangential) force.
    pub fy: &'a [f64],
    /// Normal force.
    pub fz: &'a [f64],
    /// Auxiliary channel averaged per window (current or shunt voltage).
    pub aux: Option<&'a [f64]>,
    /// Raw (DC-coupled) fy and fz for the classical COF, when the forces
    /// above were high-passed.
    pub raw: Option<(&'a [f64], &'a [f64])>,
}

impl<'a> Channels<'a> {
    /// fy and fz only.
    pub fn forces(fy: &'a [f64], fz: &'a [f64]) -> Self {
        Channels { fx: None, fy, fz, aux: None, raw: None }
    }

    /// Samples per channel (that of fz).
    pub fn len(&self) -> usize {
        self.fz.len()
    }

    /// True when the channels hold no sample.
    pub fn is_empty(&self) -> bool {
        self.fz.is_empty()
    }

    fn check(&self) -> Result<(), KernelError> {
        crate::error::same_len("fy", self.fy, "fz", self.fz)?;
        if let Some(fx) = self.fx {
            crate::error::same_len("fx", fx, "fz", self.fz)?;
        }
        if let Some(a) = self.aux {
            crate::error::same_len("aux", a, "fz", self.fz)?;
        }
        if let Some((y, z)) = self.raw {
            crate::error::same_len("fy_raw", y, "fz", self.fz)?;
            crate::error::same_len("fz_raw", z, "fz", self.fz)?;
        }
        Ok(())
    }

    /// The samples `r` of every channel. Panics if `r` is out of range
    /// (callers check first).
    fn slice(&self, r: std::ops::Range<usize>) -> Channels<'a> {
        Channels {
            fx: self.fx.map(|v| &v[r.clone()]),
            fy: &self.fy[r.clone()],
            fz: &self.fz[r.clone()],
            aux: self.aux.map(|v| &v[r.clone()]),
            raw: self.raw.map(|(y, z)| (&y[r.clone()], &z[r.clone()])),
        }
    }
}

/// Statistics of one window. NaN where undefined (see field docs).
#[derive(Debug, Clone, PartialEq)]
pub struct WindowStats {
    /// Centred moments of (fz, fy): x = fz, y = fy.
    pub moments: Moments,
    pub c_xy: f64,
    pub c_xz: f64,
    pub c_yz: f64,
    /// Deadband actually applied, in newtons.
    pub deadband: f64,
    pub mu_a: f64,
    pub mu_b: f64,
    pub n_a: u64,
    pub n_b: u64,
    /// Range of fz spanned by the bins.
    pub fz_min: f64,
    pub fz_max: f64,
    /// Samples per bin (after the deadband) and per-bin mean of s fy/fz.
    pub bin_count: Vec<u64>,
    pub bin_cof: Vec<f64>,
    /// Mean of the auxiliary channel (NaN when there is none).
    pub aux_mean: f64,
    /// mean(|fy_raw| / |fz_raw|) over fz_raw != 0 (NaN without raw forces
    /// or when every fz_raw is 0).
    pub mu_classic: f64,
    /// [`extended::block_sums`] when `opt.ext.sums`, else empty.
    pub ext_sums: Vec<f64>,
    /// [`extended::lag_sums`] at the extra lags when `opt.ext.n_extra > 0`, else empty.
    pub lag_sums: Vec<f64>,
    /// [`extended::line_spectra`] when `opt.ext.n_lines > 0`, else empty.
    pub spec: Vec<f64>,
    /// [`extended::classical`] of the raw forces (or of the forces when
    /// there are no raw ones) when `opt.ext.classical` is set, else NaN.
    pub classical: [f64; 4],
    /// A force of the window beyond [`FORCE_LIMIT`] in magnitude, or its
    /// sums overflowed: every statistic above is NaN and every count 0.
    pub out_of_range: bool,
}

/// Interleaved accumulators per sum: fixed, so the order of summation (and
/// the result) is the same whatever vector width the CPU offers.
const LANES: usize = 8;
/// Samples handled per step of pass 3: their per-sample terms are computed
/// into buffers by vectorisable element-wise code, then summed and binned.
const BLOCK: usize = 128;
/// Interleaved copies of the histograms (see the module docs).
const COPIES: usize = 4;
/// Most bins a window may have.
pub const MAX_BINS: usize = 1 << 20;
/// Largest |force| (fy, fz, fx and the raw forces), in N, of a window the
/// kernel analyses (docs/method.md 4). Far beyond any measured force, and
/// low enough that nothing computed from a window overflows: the fourth
/// powers of the estimators' block sums (1e240 a sample) and the products of
/// two second-moment sums that the finishing step forms (1e240 n^2) stay
/// below f64::MAX for any window under 1e30 samples (at 1e76 N the latter
/// overflow in a 2000-sample window). A window with a larger force is out of
/// range ([`WindowStats::out_of_range`]); so is one whose sums overflow all
/// the same.
pub const FORCE_LIMIT: f64 = 1e60;

fn pearson_from(sab: f64, saa: f64, sbb: f64) -> f64 {
    let d = (saa * sbb).sqrt();
    if d > 0.0 {
        (sab / d).clamp(-1.0, 1.0)
    } else {
        f64::NAN
    }
}

/// The lanes added by halving (lane k with lane k + 4, then k + 2, then
/// k + 1): the natural reduction of a vector register.
#[inline(always)]
fn fold(a: &[f64; LANES]) -> f64 {
    ((a[0] + a[4]) + (a[2] + a[6])) + ((a[1] + a[5]) + (a[3] + a[7]))
}

#[inline(always)]
fn lanes(c: &[f64]) -> &[f64; LANES] {
    c.try_into().expect("a chunk of LANES samples")
}

/// Lane sums of `x` and of its squares.
#[inline(always)]
fn lane_sum_sq(x: &[f64], acc: &mut [f64; LANES], acc2: &mut [f64; LANES]) {
    for v in x.chunks_exact(LANES) {
        let v = lanes(v);
        for k in 0..LANES {
            acc[k] += v[k];
            acc2[k] += v[k] * v[k];
        }
    }
}

/// Lane sum of one channel (sample i into lane i mod LANES), folded.
#[inline(always)]
fn channel_sum(x: &[f64]) -> f64 {
    let full = x.len() - x.len() % LANES;
    let mut acc = [0.0f64; LANES];
    for v in x[..full].chunks_exact(LANES) {
        let v = lanes(v);
        for k in 0..LANES {
            acc[k] += v[k];
        }
    }
    let mut t = fold(&acc);
    for &v in &x[full..] {
        t += v;
    }
    t
}

/// Lane sum, minimum and maximum of fz. Min and max by comparisons: a NaN
/// is caught by the sum.
#[inline(always)]
fn sum_min_max(z: &[f64]) -> (f64, f64, f64) {
    let full = z.len() - z.len() % LANES;
    let mut acc = [0.0f64; LANES];
    let mut lo = [f64::INFINITY; LANES];
    let mut hi = [f64::NEG_INFINITY; LANES];
    for v in z[..full].chunks_exact(LANES) {
        let v = lanes(v);
        for k in 0..LANES {
            acc[k] += v[k];
            lo[k] = if v[k] < lo[k] { v[k] } else { lo[k] };
            hi[k] = if v[k] > hi[k] { v[k] } else { hi[k] };
        }
    }
    let (mut t, mut l, mut h) = (fold(&acc), f64::INFINITY, f64::NEG_INFINITY);
    for k in 0..LANES {
        l = if lo[k] < l { lo[k] } else { l };
        h = if hi[k] > h { hi[k] } else { h };
    }
    for &v in &z[full..] {
        t += v;
        l = if v < l { v } else { l };
        h = if v > h { v } else { h };
    }
    (t, l, h)
}

/// Pass 1: (sum fz, min fz, max fz, sum fy, sum fx, sum aux), the last two
/// 0 without fx, aux. One loop per channel, each with its own vector of
/// lanes (in one loop LLVM pairs the lanes of different sums and spills).
#[inline(always)]
fn pass1(fx: Option<&[f64]>, fy: &[f64], fz: &[f64], aux: Option<&[f64]>) -> (f64, f64, f64, f64, f64, f64) {
    let (sz, lo, hi) = sum_min_max(fz);
    let sy = channel_sum(fy);
    let sx = fx.map_or(0.0, channel_sum);
    let sa = aux.map_or(0.0, channel_sum);
    (sz, lo, hi, sy, sx, sa)
}

/// Largest |x| (0 for no sample; NaN samples are caught by the sums).
fn peak(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |m, v| m.max(v.abs()))
}

/// The statistics of an out-of-range window of `n` samples: NaN, no sample
/// counted, the flag set.
fn out_of_range(n: usize, opt: &WindowOptions, aux_mean: f64) -> WindowStats {
    let nan = f64::NAN;
    WindowStats {
        moments: Moments {
            n: n as u64,
            mean_x: nan,
            mean_y: nan,
            sxx: nan,
            syy: nan,
            sxy: nan,
            sse: nan,
            ..Moments::default()
        },
        c_xy: nan,
        c_xz: nan,
        c_yz: nan,
        deadband: match opt.deadband {
            Deadband::Force(d) => d,
            Deadband::Sigma(_) => nan,
        },
        mu_a: nan,
        mu_b: nan,
        n_a: 0,
        n_b: 0,
        fz_min: nan,
        fz_max: nan,
        bin_count: vec![0; opt.n_bins],
        bin_cof: vec![nan; opt.n_bins],
        aux_mean,
        mu_classic: nan,
        ext_sums: Vec::new(),
        lag_sums: Vec::new(),
        spec: Vec::new(),
        classical: [nan; 4],
        out_of_range: true,
    }
}

/// Fails when `x` holds NaN or inf, given its sum: a finite sum proves
/// every sample finite; a non-finite one is checked by a scan (overflow of
/// finite samples is not an error).
fn check_finite(name: &'static str, x: &[f64], sum: f64) -> Result<(), KernelError> {
    if sum.is_finite() || x.iter().all(|v| v.is_finite()) {
        return Ok(());
    }
    Err(KernelError::NonFinite { channel: name, sample: None, window: true })
}

/// Centred sums of one pass about provisional means: for (fz, fy) and,
/// when `X`, fx: [dz, dy, zz, yy, yz, dx, xx, xy, xz], each a sum of
/// deviations or of their products.
#[inline(always)]
fn centred<const X: bool>(
    fx: &[f64],
    fy: &[f64],
    fz: &[f64],
    mx: f64,
    my: f64,
    mz: f64,
    pf: &Prefetch<'_>,
) -> [f64; 9] {
    let n = fz.len();
    let full = n - n % LANES;
    // One named array per sum (not a 2-D array) so that each stays in a
    // vector register.
    let z0 = [0.0f64; LANES];
    let (mut a0, mut a1, mut a2, mut a3, mut a4) = (z0, z0, z0, z0, z0);
    let (mut a5, mut a6, mut a7, mut a8) = (z0, z0, z0, z0);
    // BLOCK samples at a time, each step also fetching the next window's
    // lines for the first half of its samples (pass 3 fetches the rest):
    // spread over both passes, the fetches keep pace with memory. The lanes
    // and the order of every sum are those of one loop over the window.
    let mut c0 = 0;
    while c0 < full {
        let c1 = (c0 + BLOCK).min(full);
        pf.range(c0 / 2, c1 / 2);
        let (zs, ys) = (fz[c0..c1].chunks_exact(LANES), fy[c0..c1].chunks_exact(LANES));
        if X {
            for ((z, y), x) in zs.zip(ys).zip(fx[c0..c1].chunks_exact(LANES)) {
                let (z, y, x) = (lanes(z), lanes(y), lanes(x));
                for k in 0..LANES {
                    let dz = z[k] - mz;
                    let dy = y[k] - my;
                    let dx = x[k] - mx;
                    a0[k] += dz;
                    a1[k] += dy;
                    a2[k] += dz * dz;
                    a3[k] += dy * dy;
                    a4[k] += dy * dz;
                    a5[k] += dx;
                    a6[k] += dx * dx;
                    a7[k] += dx * dy;
                    a8[k] += dx * dz;
                }
            }
        } else {
            for (z, y) in zs.zip(ys) {
                let (z, y) = (lanes(z), lanes(y));
                for k in 0..LANES {
                    let dz = z[k] - mz;
                    let dy = y[k] - my;
                    a0[k] += dz;
                    a1[k] += dy;
                    a2[k] += dz * dz;
                    a3[k] += dy * dy;
                    a4[k] += dy * dz;
                }
            }
        }
        c0 = c1;
    }
    let mut t = [fold(&a0), fold(&a1), fold(&a2), fold(&a3), fold(&a4), fold(&a5), fold(&a6), fold(&a7), fold(&a8)];
    for i in full..n {
        let dz = fz[i] - mz;
        let dy = fy[i] - my;
        t[0] += dz;
        t[1] += dy;
        t[2] += dz * dz;
        t[3] += dy * dy;
        t[4] += dy * dz;
        if X {
            let dx = fx[i] - mx;
            t[5] += dx;
            t[6] += dx * dx;
            t[7] += dx * dy;
            t[8] += dx * dz;
        }
    }
    t
}

/// The next window's samples, fetched into the L2 cache while this window
/// is computed. A hint only: results do not depend on it, and prefetching
/// never faults, so ranges past a channel's end are simply skipped.
#[derive(Clone, Copy)]
struct Prefetch<'a> {
    chans: [&'a [f64]; 6],
    n: usize,
}

impl<'a> Prefetch<'a> {
    fn of(next: Option<&Channels<'a>>) -> Self {
        let mut p = Prefetch { chans: [&[]; 6], n: 0 };
        if let Some(c) = next {
            let (ry, rz) = c.raw.map_or((None, None), |(y, z)| (Some(y), Some(z)));
            for x in [c.fx, Some(c.fy), Some(c.fz), c.aux, ry, rz].into_iter().flatten() {
                p.chans[p.n] = x;
                p.n += 1;
            }
        }
        p
    }

    /// Requests the cache lines of samples [a, b) of every channel.
    #[inline(always)]
    fn range(&self, a: usize, b: usize) {
        #[cfg(target_arch = "x86_64")]
        for c in &self.chans[..self.n] {
            let end = b.min(c.len());
            let mut j = a;
            while j < end {
                // SAFETY: a prefetch is a hint that never faults; the
                // address lies inside the slice (j < len).
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(c.as_ptr().add(j) as *const i8)
                };
                j += 8; // 64-byte lines
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = (a, b);
    }
}

/// What pass 3 accumulates.
struct Pass3 {
    /// Sum of residuals and of their squares.
    sr: f64,
    sr2: f64,
    sa: f64,
    sb: f64,
    na: u64,
    nb: u64,
    /// Per bin (`n_bins`, the deadband's samples dropped).
    cnt: Vec<u64>,
    acc: Vec<f64>,
}

/// The bins of pass 3: fz in [lo, lo + span] to bin
/// floor((fz - lo) * (n_bins / span)), the top edge in the last bin.
#[derive(Clone, Copy)]
struct Bins {
    lo: f64,
    /// n_bins / span, or 0 when span = 0 (everything in bin 0).
    scale: f64,
    n: usize,
}

/// Residuals of the line (slope `b` about the provisional means), the
/// deadband |fz| >= d (d = inf bins nothing), the bins and the sided means,
/// in one pass over the window, [`BLOCK`] samples at a time.
///
/// The histograms are kept per sign of fz, so mu_a (fz < 0) and mu_b
/// (fz > 0) are the sums over the negative and the positive slots and need
/// no accumulation of their own.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn pass3(fy: &[f64], fz: &[f64], my: f64, mz: f64, b: f64, s: f64, d: f64, bins: Bins, pf: &Prefetch<'_>) -> Pass3 {
    let nb = bins.n;
    // COPIES interleaved copies of two histograms (fz < 0, fz > 0) of
    // nb + 1 slots, each slot a (sum, count) pair; slot nb collects the
    // deadband's samples and is dropped. A count kept as f64 is exact below
    // 2^53.
    let side = nb + 1;
    let stride = 2 * side;
    let mut hist = vec![[0.0f64; 2]; COPIES * stride];
    let (mut r, mut r2) = ([0.0f64; LANES], [0.0f64; LANES]);
    let top = (nb - 1) as f64;
    // nb <= MAX_BINS, so every slot index fits in u32.
    let (dump, side32, stride32) = (nb as u32, side as u32, stride as u32);
    let (lo, scale) = (bins.lo, bins.scale);
    let mut ebuf = [0.0f64; BLOCK];
    let mut ibuf = [0u32; BLOCK];
    let mut mbuf = [0.0f64; BLOCK];
    let n = fz.len();
    let mut start = 0;
    while start < n {
        let m = BLOCK.min(n - start);
        // The next window's lines, spread over this pass (the longest), so
        // that memory works while this one computes.
        pf.range(n / 2 + start / 2, n / 2 + (start + m) / 2);
        let (yb, zb) = (&fy[start..start + m], &fz[start..start + m]);
        // Element-wise (vectorised): residual, Eq. 5 per sample, and the
        // histogram slot: copy (i mod COPIES), sign of fz, bin of the
        // re-sorting by fz.
        for i in 0..m {
            let (y, z) = (yb[i], zb[i]);
            ebuf[i] = (y - my) - b * (z - mz);
            let keep = z.abs() >= d && z != 0.0;
            mbuf[i] = s * y / z;
            // The bin, forced into [0, nb - 1] (z >= lo holds for the
            // window's own samples; NaN from inf * 0 goes to 0).
            let t = (z - lo) * scale;
            let t = if t < top { t } else { top };
            let t = if t >= 0.0 { t } else { 0.0 };
            // SAFETY: 0 <= t <= nb - 1 < 2^31 (above), so the conversion is
            // defined; it is the plain (vectorisable) truncation.
            let t = unsafe { t.to_int_unchecked::<i32>() } as u32;
            let half = if z > 0.0 { side32 } else { 0 };
            ibuf[i] = if keep { t } else { dump } + half + (i % COPIES) as u32 * stride32;
        }
        if m == BLOCK {
            let (mut t0, mut t1) = ([0.0f64; LANES], [0.0f64; LANES]);
            lane_sum_sq(&ebuf, &mut t0, &mut t1);
            for k in 0..LANES {
                r[k] += t0[k];
                r2[k] += t1[k];
            }
        } else {
            // The last, partial block: sample i into lane i mod LANES.
            for (i, &e) in ebuf[..m].iter().enumerate() {
                r[i % LANES] += e;
                r2[i % LANES] += e * e;
            }
        }
        for (&ix, &mu) in ibuf[..m].iter().zip(&mbuf[..m]) {
            let slot = &mut hist[ix as usize];
            slot[0] += mu;
            slot[1] += 1.0;
        }
        start += m;
    }
    // Copies added in a fixed tree, then the two signs.
    let total = |slot: usize, c: usize| -> f64 {
        let h = |copy: usize| hist[copy * stride + slot][c];
        (h(0) + h(2)) + (h(1) + h(3))
    };
    let mut cnt = vec![0u64; nb];
    let mut acc = vec![0.0f64; nb];
    let (mut sa, mut sb, mut na, mut nbb) = (0.0, 0.0, 0.0, 0.0);
    for k in 0..nb {
        let (a_sum, a_cnt) = (total(k, 0), total(k, 1));
        let (b_sum, b_cnt) = (total(side + k, 0), total(side + k, 1));
        acc[k] = a_sum + b_sum;
        cnt[k] = (a_cnt + b_cnt) as u64;
        sa += a_sum;
        sb += b_sum;
        na += a_cnt;
        nbb += b_cnt;
    }
    Pass3 { sr: fold(&r), sr2: fold(&r2), sa, sb, na: na as u64, nb: nbb as u64, cnt, acc }
}

/// mean(|y| / |z|) over z != 0, the classical COF of raw forces, with the
/// sums of y and z (for the finiteness check): (sum y, sum z, mean).
#[inline(always)]
fn classic(y: &[f64], z: &[f64]) -> (f64, f64, f64) {
    let z0 = [0.0f64; LANES];
    let (mut acc, mut sy, mut sz) = (z0, z0, z0);
    let mut c = 0u64;
    let n = z.len();
    let full = n - n % LANES;
    for i in (0..full).step_by(LANES) {
        let (yc, zc) = (lanes(&y[i..i + LANES]), lanes(&z[i..i + LANES]));
        for k in 0..LANES {
            sy[k] += yc[k];
            sz[k] += zc[k];
            let (a, b) = (yc[k].abs(), zc[k].abs());
            let keep = b > 0.0;
            acc[k] += if keep { a / b } else { 0.0 };
            c += keep as u64;
        }
    }
    let (mut s, mut ty, mut tz) = (fold(&acc), fold(&sy), fold(&sz));
    for i in full..n {
        ty += y[i];
        tz += z[i];
        let (a, b) = (y[i].abs(), z[i].abs());
        if b > 0.0 {
            s += a / b;
            c += 1;
        }
    }
    (ty, tz, if c > 0 { s / c as f64 } else { f64::NAN })
}

/// Statistics of one window (all channels of one length).
pub fn window_stats(ch: &Channels<'_>, opt: &WindowOptions) -> Result<WindowStats, KernelError> {
    window_stats_then(ch, None, opt)
}

/// [`window_stats`] of `ch`, fetching the samples of `next` (the window
/// computed after it, if known) into cache meanwhile. Same results.
pub fn window_stats_then(
    ch: &Channels<'_>,
    next: Option<&Channels<'_>>,
    opt: &WindowOptions,
) -> Result<WindowStats, KernelError> {
    ch.check()?;
    opt.ext.check()?;
    if opt.ext.delay != 0.0 {
        // fz advanced by the delay over the samples where every tap is
        // inside the window; the other channels cut to the same samples.
        return extended::delayed(ch.fz, opt.ext.delay, |g, t0, t1| {
            let cut = Channels { fz: g, ..ch.slice(t0..t1) };
            let no_delay = WindowOptions { ext: ExtOptions { delay: 0.0, ..opt.ext }, ..*opt };
            window_stats_then(&cut, None, &no_delay).map_err(|e| e.shifted(t0))
        })?;
    }
    let mut w = window_dispatch(ch, next, opt)?;
    if w.out_of_range {
        // The same shapes as a window in range, all NaN.
        if opt.ext.sums {
            w.ext_sums = vec![f64::NAN; extended::BLOCKS * extended::PRODUCTS];
        }
        w.lag_sums = vec![f64::NAN; opt.ext.lag_sums_len()];
        w.spec = vec![f64::NAN; opt.ext.spec_len()];
        return Ok(w);
    }
    if opt.ext.sums {
        let means = (w.moments.mean_x, w.moments.mean_y);
        w.ext_sums = extended::block_sums(ch.fy, ch.fz, opt.ext.lag, Some(means));
    }
    if opt.ext.n_extra > 0 {
        let means = (w.moments.mean_x, w.moments.mean_y);
        w.lag_sums = extended::lag_sums(ch.fy, ch.fz, &opt.ext.extra_lags[..opt.ext.n_extra], Some(means));
    }
    if opt.ext.n_lines > 0 {
        w.spec = extended::line_spectra(ch.fy, ch.fz, &opt.ext);
    }
    if let Some(c) = &opt.ext.classical {
        let (y, z) = ch.raw.unwrap_or((ch.fy, ch.fz));
        w.classical = extended::classical(y, z, c);
    }
    Ok(w)
}

fn window_dispatch(
    ch: &Channels<'_>,
    next: Option<&Channels<'_>>,
    opt: &WindowOptions,
) -> Result<WindowStats, KernelError> {
    let pf = Prefetch::of(next);
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            return unsafe { window_avx512(ch, opt, &pf) };
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            return unsafe { window_avx2(ch, opt, &pf) };
        }
    }
    window_body(ch, opt, &pf)
}

// The same code compiled for wider vectors. Every sum has its fixed lanes
// and no multiply-add is fused, so each variant gives the same bits.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn window_avx512(ch: &Channels<'_>, opt: &WindowOptions, pf: &Prefetch<'_>) -> Result<WindowStats, KernelError> {
    window_body(ch, opt, pf)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn window_avx2(ch: &Channels<'_>, opt: &WindowOptions, pf: &Prefetch<'_>) -> Result<WindowStats, KernelError> {
    window_body(ch, opt, pf)
}

#[inline(always)]
fn window_body(ch: &Channels<'_>, opt: &WindowOptions, pf: &Prefetch<'_>) -> Result<WindowStats, KernelError> {
    let (fy, fz) = (ch.fy, ch.fz);
    let n = fz.len();
    let nb = opt.n_bins;
    if nb == 0 || nb > MAX_BINS {
        return Err(KernelError::Invalid(format!("n_bins must be in [1, {MAX_BINS}], got {nb}")));
    }
    let nf = n as f64;
    // Pass 1: sums (means) and the fz range, all channels streamed together.
    let (sz, lo, hi, sy, sx, sa) = pass1(ch.fx, fy, fz, ch.aux);
    check_finite("fz", fz, sz)?;
    check_finite("fy", fy, sy)?;
    if let Some(x) = ch.fx {
        check_finite("fx", x, sx)?;
    }
    let aux_mean = match ch.aux {
        Some(a) if n > 0 => {
            check_finite("aux", a, sa)?;
            sa / nf
        }
        _ => f64::NAN,
    };
    // The range of fz is at hand; fy and fx are bounded after pass 2.
    let top = if n > 0 { lo.abs().max(hi.abs()) } else { 0.0 };
    let (mu_classic, top) = match ch.raw {
        Some((y, z)) => {
            let (syr, szr, mean) = classic(y, z);
            check_finite("fy_raw", y, syr)?;
            check_finite("fz_raw", z, szr)?;
            (mean, top.max(peak(y)).max(peak(z)))
        }
        None => (f64::NAN, top),
    };
    if top > FORCE_LIMIT {
        return Ok(out_of_range(n, opt, aux_mean));
    }
    if n == 0 {
        return Ok(WindowStats {
            moments: Moments::default(),
            c_xy: f64::NAN,
            c_xz: f64::NAN,
            c_yz: f64::NAN,
            deadband: match opt.deadband {
                Deadband::Force(d) => d,
                Deadband::Sigma(_) => f64::NAN,
            },
            mu_a: f64::NAN,
            mu_b: f64::NAN,
            n_a: 0,
            n_b: 0,
            fz_min: f64::NAN,
            fz_max: f64::NAN,
            bin_count: vec![0; nb],
            bin_cof: vec![f64::NAN; nb],
            aux_mean,
            mu_classic,
            ext_sums: Vec::new(),
            lag_sums: Vec::new(),
            spec: Vec::new(),
            classical: [f64::NAN; 4],
            out_of_range: false,
        });
    }
    let (mz0, my0, mx0) = (sz / nf, sy / nf, sx / nf);
    // Pass 2: centred second moments, corrected by the deviation sums
    // (two-pass with correction, Chan et al. 1983).
    let t = match ch.fx {
        Some(x) => centred::<true>(x, fy, fz, mx0, my0, mz0, pf),
        None => centred::<false>(&[], fy, fz, mx0, my0, mz0, pf),
    };
    let (cz, cy, cx) = (t[0] / nf, t[1] / nf, t[5] / nf);
    let szz = t[2] - t[0] * cz;
    let syy = t[3] - t[1] * cy;
    let syz = t[4] - t[0] * cy;
    // |x_i| <= |m| + sqrt(sum (x_j - m)^2) for any m: a bound on fy and fx for free; a scan
    // decides only when it comes near the limit (or the sums overflowed).
    let beyond = |x: &[f64], m: f64, ss: f64| {
        let bound = m.abs() + ss.sqrt();
        (bound.is_nan() || bound > 0.5 * FORCE_LIMIT) && peak(x) > FORCE_LIMIT
    };
    let overflow = !(szz.is_finite() && syy.is_finite() && syz.is_finite() && t[6..].iter().all(|v| v.is_finite()));
    if beyond(fy, my0, t[3]) || ch.fx.is_some_and(|x| beyond(x, mx0, t[6])) || overflow {
        return Ok(out_of_range(n, opt, aux_mean)); // or products of forces under FORCE_LIMIT summed past f64::MAX
    }
    let c_yz = pearson_from(syz, szz, syy);
    let (c_xy, c_xz) = if ch.fx.is_some() && n >= 2 {
        let sxx = t[6] - t[5] * cx;
        let sxy = t[7] - t[5] * cy;
        let sxz = t[8] - t[5] * cz;
        (pearson_from(sxy, sxx, syy), pearson_from(sxz, sxx, szz))
    } else {
        (f64::NAN, f64::NAN)
    };
    let d = match opt.deadband {
        Deadband::Force(d) => d,
        Deadband::Sigma(k) => {
            if n >= 2 {
                k * (szz / (nf - 1.0)).sqrt()
            } else {
                f64::NAN
            }
        }
    };
    // Pass 3: residuals about the block's line (same mean correction as
    // the moments), deadband, bins, mu_a and mu_b.
    let b = if szz > 0.0 { syz / szz } else { 0.0 };
    let span = hi - lo;
    let bins = Bins { lo, scale: if span > 0.0 { nb as f64 / span } else { 0.0 }, n: nb };
    let p = pass3(fy, fz, my0, mz0, b, opt.orientation, if d.is_finite() { d } else { f64::INFINITY }, bins, pf);
    let sse = if szz > 0.0 { (p.sr2 - p.sr * (p.sr / nf)).max(0.0) } else { syy };
    let mean_or_nan = |s: f64, c: u64| if c > 0 { s / c as f64 } else { f64::NAN };
    let bin_cof = p.acc.iter().zip(&p.cnt).map(|(&a, &c)| mean_or_nan(a, c)).collect();
    Ok(WindowStats {
        moments: {
            let (mean_x, mean_x_lo) = crate::numerics::regression::dd_mean(mz0, cz);
            let (mean_y, mean_y_lo) = crate::numerics::regression::dd_mean(my0, cy);
            Moments { n: n as u64, mean_x, mean_y, sxx: szz, syy, sxy: syz, sse, mean_x_lo, mean_y_lo }
        },
        c_xy,
        c_xz,
        c_yz,
        deadband: d,
        mu_a: mean_or_nan(p.sa, p.na),
        mu_b: mean_or_nan(p.sb, p.nb),
        n_a: p.na,
        n_b: p.nb,
        fz_min: lo,
        fz_max: hi,
        bin_count: p.cnt,
        bin_cof,
        aux_mean,
        mu_classic,
        ext_sums: Vec::new(),
        lag_sums: Vec::new(),
        spec: Vec::new(),
        classical: [f64::NAN; 4],
        out_of_range: false,
    })
}

fn check_starts(ch: &Channels<'_>, starts: &[usize], opt: &WindowOptions) -> Result<(), KernelError> {
    ch.check()?;
    let n = ch.len();
    if opt.n_bins == 0 || opt.n_bins > MAX_BINS {
        return Err(KernelError::Invalid(format!("n_bins must be in [1, {MAX_BINS}], got {}", opt.n_bins)));
    }
    if opt.len == 0 {
        return Err(KernelError::Invalid("window length must be at least 1 sample".into()));
    }
    if let Some(&bad) = starts.iter().find(|&&s| s.checked_add(opt.len).is_none_or(|e| e > n)) {
        return Err(KernelError::Invalid(format!(
            "window starting at sample {bad} with {} samples runs past the {n} samples given",
            opt.len
        )));
    }
    Ok(())
}

/// Window k of `starts`, prefetching window k + 1.
fn one(ch: &Channels<'_>, starts: &[usize], k: usize, opt: &WindowOptions) -> Result<WindowStats, KernelError> {
    let s = starts[k];
    let next = starts.get(k + 1).map(|&t| ch.slice(t..t + opt.len));
    window_stats_then(&ch.slice(s..s + opt.len), next.as_ref(), opt).map_err(|e| match e {
        KernelError::NonFinite { .. } => e.shifted(s),
        other => KernelError::Invalid(format!("{other} (window starting at sample {s})")),
    })
}

/// Statistics of every window `[starts[k], starts[k] + opt.len)` of the
/// channels, in parallel on the current pool, in the order of `starts`.
pub fn windows_stats(
    ch: &Channels<'_>,
    starts: &[usize],
    opt: &WindowOptions,
) -> Result<Vec<WindowStats>, KernelError> {
    check_starts(ch, starts, opt)?;
    // A task per few windows: a 2000-sample window is a few microseconds of
    // work, so one task each would spend a noticeable share on scheduling.
    (0..starts.len()).into_par_iter().with_min_len(4).map(|k| one(ch, starts, k, opt)).collect()
}

/// [`windows_stats`] on the calling thread (for a handful of windows, where
/// entering the pool costs more than it saves). Same results.
pub fn windows_stats_serial(
    ch: &Channels<'_>,
    starts: &[usize],
    opt: &WindowOptions,
) -> Result<Vec<WindowStats>, KernelError> {
    check_starts(ch, starts, opt)?;
    (0..starts.len()).map(|k| one(ch, starts, k, opt)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig(n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let fz: Vec<f64> = (0..n).map(|i| 1.2 * (i as f64 * 0.63).sin() + 0.3 * (i as f64 * 2.1).cos()).collect();
        let fy: Vec<f64> = fz.iter().enumerate().map(|(i, z)| -0.12 * z + 0.01 * (i as f64 * 5.3).sin()).collect();
        let fx: Vec<f64> = fz.iter().enumerate().map(|(i, z)| 0.2 * z + (i as f64 * 0.9).cos()).collect();
        (fx, fy, fz)
    }

    fn with_x<'a>(fx: &'a [f64], fy: &'a [f64], fz: &'a [f64]) -> Channels<'a> {
        Channels { fx: Some(fx), ..Channels::forces(fy, fz) }
    }

    /// The window's statistics by plain loops, in sample order.
    fn naive(
        fx: &[f64],
        fy: &[f64],
        fz: &[f64],
        s: f64,
        d: f64,
        nb: usize,
    ) -> (Vec<u64>, Vec<f64>, f64, f64, f64, f64) {
        let n = fz.len() as f64;
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n;
        let (mx, my, mz) = (mean(fx), mean(fy), mean(fz));
        let (mut sxx, mut syy, mut szz, mut sxy, mut syz) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..fz.len() {
            let (dx, dy, dz) = (fx[i] - mx, fy[i] - my, fz[i] - mz);
            sxx += dx * dx;
            syy += dy * dy;
            szz += dz * dz;
            sxy += dx * dy;
            syz += dy * dz;
        }
        let lo = fz.iter().cloned().fold(f64::INFINITY, f64::min);
        let hi = fz.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let (mut cnt, mut acc) = (vec![0u64; nb], vec![0.0; nb]);
        for (&y, &z) in fy.iter().zip(fz) {
            if z.abs() >= d && z != 0.0 {
                let k = (((z - lo) * (nb as f64 / (hi - lo))).min(nb as f64 - 1.0) as usize).min(nb - 1);
                cnt[k] += 1;
                acc[k] += s * y / z;
            }
        }
        let cof = acc.iter().zip(&cnt).map(|(a, &c)| a / c as f64).collect();
        (cnt, cof, syz / szz, syz / (syy * szz).sqrt(), sxy / (sxx * syy).sqrt(), my - syz / szz * mz)
    }

    #[test]
    fn one_window_by_hand() {
        let (fx, fy, fz) = rig(2003);
        let opt = WindowOptions {
            len: 2003,
            orientation: -1.0,
            deadband: Deadband::Force(0.35),
            n_bins: 16,
            ext: ExtOptions::default(),
        };
        let w = window_stats(&with_x(&fx, &fy, &fz), &opt).unwrap();
        let fit = w.moments.fit();
        assert!((-fit.slope - 0.12).abs() < 2e-3);
        assert!(w.c_yz < -0.99);
        let (cnt, cof, slope, r, c_xy, intercept) = naive(&fx, &fy, &fz, -1.0, 0.35, 16);
        assert_eq!(w.bin_count, cnt);
        for (a, b) in w.bin_cof.iter().zip(&cof) {
            assert!((a - b).abs() <= 1e-13 * b.abs() || (a.is_nan() && b.is_nan()), "{a} {b}");
        }
        assert!((fit.slope - slope).abs() < 1e-13 * slope.abs());
        assert!((fit.intercept - intercept).abs() < 1e-12);
        assert!((w.c_yz - r).abs() < 1e-13 && (w.c_xy - c_xy).abs() < 1e-13);
        // Sided means by a plain loop.
        let (mut sa, mut na) = (0.0, 0);
        for (&y, &z) in fy.iter().zip(&fz) {
            if z <= -0.35 {
                sa += -y / z;
                na += 1;
            }
        }
        assert_eq!(w.n_a, na);
        assert!((w.mu_a - sa / na as f64).abs() < 1e-12);
        let total: u64 = w.bin_count.iter().sum();
        assert_eq!(total, w.n_a + w.n_b);
        assert!(w.aux_mean.is_nan() && w.mu_classic.is_nan());
        // The residual sum of squares equals the plain one.
        let (my, mz) = (fit.intercept + fit.slope * w.moments.mean_x, w.moments.mean_x);
        let sse: f64 = fy.iter().zip(&fz).map(|(y, z)| (y - my - fit.slope * (z - mz)).powi(2)).sum();
        assert!((w.moments.sse - sse).abs() < 1e-10 * sse);
    }

    #[test]
    fn offsets_do_not_move_the_fit() {
        let (fx, fy, fz) = rig(2000);
        let opt = WindowOptions {
            len: 2000,
            orientation: 1.0,
            deadband: Deadband::Sigma(0.5),
            n_bins: 8,
            ext: ExtOptions::default(),
        };
        let a = window_stats(&with_x(&fx, &fy, &fz), &opt).unwrap();
        let fys: Vec<f64> = fy.iter().map(|v| v + 1e4).collect();
        let fxs: Vec<f64> = fx.iter().map(|v| v - 1e5).collect();
        let b = window_stats(&with_x(&fxs, &fys, &fz), &opt).unwrap();
        let (fa, fb) = (a.moments.fit(), b.moments.fit());
        assert!((fa.slope - fb.slope).abs() < 1e-9 * fa.slope.abs());
        assert!((fa.resid_std - fb.resid_std).abs() < 1e-8 * fa.resid_std);
        assert!((a.c_xy - b.c_xy).abs() < 1e-9 && (a.c_yz - b.c_yz).abs() < 1e-9);
    }

    #[test]
    fn batch_equals_single_and_is_checked() {
        let (fx, fy, fz) = rig(10_000);
        let opt = WindowOptions {
            len: 1000,
            orientation: 1.0,
            deadband: Deadband::Sigma(0.7),
            n_bins: 8,
            ext: ExtOptions::default(),
        };
        let starts = [0usize, 1000, 4321, 9000];
        let ch = Channels { aux: Some(&fx), raw: Some((&fy, &fz)), ..with_x(&fx, &fy, &fz) };
        let all = windows_stats(&ch, &starts, &opt).unwrap();
        assert_eq!(format!("{all:?}"), format!("{:?}", windows_stats_serial(&ch, &starts, &opt).unwrap()));
        for (s, w) in starts.iter().zip(&all) {
            let r = *s..*s + 1000;
            let one = window_stats(&ch.slice(r), &opt).unwrap();
            assert_eq!(format!("{one:?}"), format!("{w:?}"));
            assert!(w.mu_classic > 0.0 && w.aux_mean.is_finite());
        }
        let short = Channels::forces(&fy, &fz);
        assert!(windows_stats(&short, &[9500], &opt).is_err());
        assert!(windows_stats(&Channels::forces(&fy[..10], &fz), &[0], &opt).is_err());
        assert!(windows_stats(&short, &[0], &WindowOptions { n_bins: 0, ..opt }).is_err());
    }

    #[test]
    fn non_finite_samples_are_refused() {
        let (_, mut fy, fz) = rig(3000);
        let opt = WindowOptions {
            len: 1000,
            orientation: 1.0,
            deadband: Deadband::Force(0.35),
            n_bins: 8,
            ext: ExtOptions::default(),
        };
        fy[1500] = f64::NAN;
        let e = windows_stats(&Channels::forces(&fy, &fz), &[0, 1000], &opt).unwrap_err();
        assert!(e.to_string().contains("fy contains NaN") && e.to_string().contains("1000"), "{e}");
        // Outside every window it does not matter.
        assert!(windows_stats(&Channels::forces(&fy, &fz), &[0, 2000], &opt).is_ok());
        // Huge finite values overflow the sum but are not an error: the window is out of range.
        let big = vec![1e308; 8];
        let z: Vec<f64> = (0..8).map(|i| i as f64).collect();
        let w = window_stats(&Channels::forces(&big, &z), &opt).unwrap();
        assert!(w.out_of_range && w.moments.n == 8 && w.moments.fit().slope.is_nan());
    }

    #[test]
    fn forces_beyond_the_limit_make_the_window_out_of_range() {
        let (fx, fy, fz) = rig(3000);
        let mut ext = ExtOptions { sums: true, lag: 10, n_extra: 2, ..ExtOptions::default() };
        ext.extra_lags[..2].copy_from_slice(&[12, 20]);
        let opt = WindowOptions { len: 1000, orientation: 1.0, deadband: Deadband::Force(0.35), n_bins: 8, ext };
        let all = |fx: &[f64], fy: &[f64], fz: &[f64]| {
            let ch = Channels { fx: Some(fx), fy, fz, aux: None, raw: Some((fy, fz)) };
            windows_stats(&ch, &[0, 1000, 2000], &opt).unwrap()
        };
        let clean = all(&fx, &fy, &fz);
        assert!(clean.iter().all(|w| !w.out_of_range && w.moments.fit().slope.is_finite()));
        assert!(clean.iter().all(|w| w.lag_sums.len() == 4 && w.lag_sums.iter().all(|v| v.is_finite())));
        for (channel, value) in [(0, 1.0000001e60), (1, -2e150), (2, 1e300)] {
            let mut ch = [fx.clone(), fy.clone(), fz.clone()];
            ch[channel][1500] = value;
            let got = all(&ch[0], &ch[1], &ch[2]);
            // Only the window holding the sample, and all of it NaN with the shapes of a window in range.
            assert!(!got[0].out_of_range && got[1].out_of_range && !got[2].out_of_range, "channel {channel}");
            assert_eq!(format!("{:?}", (&got[0], &got[2])), format!("{:?}", (&clean[0], &clean[2]))); // NaN != NaN
            let w = &got[1];
            assert!(w.moments.mean_x.is_nan() && w.c_yz.is_nan() && w.mu_a.is_nan() && w.fz_max.is_nan());
            assert_eq!((w.moments.n, w.n_a + w.n_b, w.bin_count.iter().sum::<u64>()), (1000, 0, 0));
            assert!(w.ext_sums.len() == extended::BLOCKS * extended::PRODUCTS && w.ext_sums.iter().all(|v| v.is_nan()));
            assert!(w.lag_sums.len() == 4 && w.lag_sums.iter().all(|v| v.is_nan()));
        }
        // A raw force alone beyond the limit (the high-pass would lose the rest in rounding).
        let mut fz_raw = fz.clone();
        fz_raw[500] = 1e61;
        let ch = Channels { fx: None, fy: &fy, fz: &fz, aux: None, raw: Some((&fy, &fz_raw)) };
        let got = windows_stats(&ch, &[0, 1000], &opt).unwrap();
        assert!(got[0].out_of_range && !got[1].out_of_range);
        // At the limit itself the window is analysed.
        let mut fz_at = fz.clone();
        fz_at[1500] = FORCE_LIMIT;
        assert!(all(&fx, &fy, &fz_at).iter().all(|w| !w.out_of_range));
    }

    #[test]
    fn degenerate_windows_do_not_panic() {
        let opt = WindowOptions {
            len: 5,
            orientation: 1.0,
            deadband: Deadband::Force(0.0),
            n_bins: 3,
            ext: ExtOptions::default(),
        };
        let w = window_stats(&Channels::forces(&[1.0; 5], &[2.0; 5]), &opt).unwrap();
        assert!(w.moments.fit().slope.is_nan() && w.c_yz.is_nan());
        assert_eq!(w.bin_count, vec![5, 0, 0]);
        let w = window_stats(&Channels::forces(&[], &[]), &opt).unwrap();
        assert!(w.fz_min.is_nan() && w.bin_cof.iter().all(|v| v.is_nan()));
        let sigma = WindowOptions { deadband: Deadband::Sigma(1.0), ..opt };
        let w = window_stats(&Channels::forces(&[1.0], &[1.0]), &sigma).unwrap();
        assert!(w.deadband.is_nan() && w.bin_count.iter().all(|&c| c == 0));
    }

    #[test]
    fn every_instruction_set_gives_the_same_bits() {
        let (fx, fy, fz) = rig(2037);
        let ch = Channels { aux: Some(&fx), raw: Some((&fy, &fz)), ..with_x(&fx, &fy, &fz) };
        for opt in [
            WindowOptions {
                len: 2037,
                orientation: -1.0,
                deadband: Deadband::Force(0.35),
                n_bins: 16,
                ext: ExtOptions::default(),
            },
            WindowOptions {
                len: 2037,
                orientation: 1.0,
                deadband: Deadband::Sigma(0.7),
                n_bins: 7,
                ext: ExtOptions::default(),
            },
        ] {
            let base = format!("{:?}", window_body(&ch, &opt, &Prefetch::of(None)).unwrap());
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: AVX2 is available (checked).
                    assert_eq!(
                        format!("{:?}", unsafe { window_avx2(&ch, &opt, &Prefetch::of(Some(&ch))) }.unwrap()),
                        base
                    );
                }
                if std::arch::is_x86_feature_detected!("avx512f") {
                    // SAFETY: AVX-512F is available (checked).
                    assert_eq!(
                        format!("{:?}", unsafe { window_avx512(&ch, &opt, &Prefetch::of(Some(&ch))) }.unwrap()),
                        base
                    );
                }
            }
            assert_eq!(format!("{:?}", window_stats(&ch, &opt).unwrap()), base);
        }
    }

    #[test]
    fn deadband_excluding_everything_gives_nan() {
        let (_, fy, fz) = rig(500);
        let opt = WindowOptions {
            len: 500,
            orientation: 1.0,
            deadband: Deadband::Force(1e9),
            n_bins: 4,
            ext: ExtOptions::default(),
        };
        let w = window_stats(&Channels::forces(&fy, &fz), &opt).unwrap();
        assert!(w.mu_a.is_nan() && w.mu_b.is_nan());
        assert!(w.bin_cof.iter().all(|v| v.is_nan()));
    }
}
