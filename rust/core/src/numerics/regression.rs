//! Closed-form, numerically stable, mergeable least squares of y on x,
//! Eqs. (6)-(8) of the paper (docs/method.md 3).
//!
//! [`Moments`] holds (n, mean_x, mean_y, S_xx, S_yy, S_xy) with the second
//! moments centred on the running means. A block of samples is reduced by
//! two passes over the (cache-resident) block: its means, then its centred
//! sums. Blocks are combined by the pairwise update of Chan, Golub and
//! LeVeque, so the result does not move when a constant is added to x or y
//! and never forms a raw sum of squares.
//!
//! The residual sum of squares is carried as its own moment instead of being
//! formed as S_yy - S_xy^2/S_xx, which cancels catastrophically when r is
//! near 1: a block computes it by a third pass over its residuals, and a
//! merge adds the non-negative terms of the exact decomposition
//! SSE = SSE_a + SSE_b + [S_a S_b (b_a - b_b)^2 + S_a w (b_a dx - dy)^2
//!       + S_b w (b_b dx - dy)^2] / S_xx,  w = n_a n_b / n,
//! with S the blocks' S_xx, b their slopes and (dx, dy) the difference of
//! their means. No subtraction of large numbers remains.
//!
//! Determinism: a slice is cut into blocks at fixed offsets from its start
//! and blocks are merged in order, whatever the thread count.

use crate::error::{same_len, KernelError};
use crate::numerics::lanes::F4;
use rayon::prelude::*;

/// Samples reduced by one two-pass step (fits in L1 with both inputs).
const BLOCK: usize = 1024;
/// Samples per parallel task; a multiple of [`BLOCK`].
const TASK: usize = 1 << 18;

/// Whether [`Moments::of`] on `n` samples uses the thread pool; when not,
/// callers need not enter it (which costs more than one window's work).
pub fn uses_threads(n: usize) -> bool {
    n > TASK
}

/// Centred first and second moments of (x, y): a mergeable accumulator.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Moments {
    pub n: u64,
    pub mean_x: f64,
    pub mean_y: f64,
    pub sxx: f64,
    pub syy: f64,
    pub sxy: f64,
    /// Residual sum of squares of the least-squares line (S_yy when
    /// S_xx = 0).
    pub sse: f64,
    /// Low-order parts of the means (the means are `mean + mean_lo` in
    /// double-double): merges then do not round the means, so the
    /// intercept, a small difference of large numbers when the means are
    /// far from 0, keeps its digits through any number of merges.
    pub mean_x_lo: f64,
    pub mean_y_lo: f64,
}

/// Error-free sum: a + b = s + e exactly (Knuth's TwoSum).
#[inline]
pub(crate) fn two_sum(a: f64, b: f64) -> (f64, f64) {
    let s = a + b;
    let bb = s - a;
    (s, (a - (s - bb)) + (b - bb))
}

/// A mean `m0 + c` (a rough mean and its correction) as a double-double.
#[inline]
pub(crate) fn dd_mean(m0: f64, c: f64) -> (f64, f64) {
    two_sum(m0, c)
}

/// Difference of two double-double numbers, rounded to one f64.
#[inline]
fn dd_diff(a: f64, a_lo: f64, b: f64, b_lo: f64) -> f64 {
    let (s, e) = two_sum(a, -b);
    s + (e + (a_lo - b_lo))
}

/// a + step as a double-double, a given as (a, a_lo).
#[inline]
fn dd_add(a: f64, a_lo: f64, step: f64) -> (f64, f64) {
    let (s, e) = two_sum(a, step);
    two_sum(s, e + a_lo)
}

/// Result of the fit. Degenerate input (n < 3 or S_xx = 0) has NaN fields
/// and `degenerate = true`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinFit {
    pub slope: f64,
    pub intercept: f64,
    pub r: f64,
    pub slope_stderr: f64,
    pub intercept_stderr: f64,
    pub resid_std: f64,
    pub n: u64,
    pub degenerate: bool,
}

impl Moments {
    /// Moments of one block by two passes: exact means of the block first.
    /// Sums run in four lanes of `V` (see [`crate::numerics::lanes`]).
    #[inline(always)]
    fn of_block<V: F4>(x: &[f64], y: &[f64]) -> Moments {
        let n = x.len().min(y.len());
        if n == 0 {
            return Moments::default();
        }
        let (x, y) = (&x[..n], &y[..n]);
        let nf = n as f64;
        let split = n - n % 4;
        let (xh, xr) = x.split_at(split);
        let (yh, yr) = y.split_at(split);
        // Pass 1: the two lane-split sums of `sums::sum`, in one loop.
        let (mut ax, mut ay) = (V::zero(), V::zero());
        for (u, v) in xh.chunks_exact(4).zip(yh.chunks_exact(4)) {
            ax = ax.add(V::load(u));
            ay = ay.add(V::load(v));
        }
        let (mut sx, mut sy) = (ax.fold(), ay.fold());
        for (u, v) in xr.iter().zip(yr) {
            sx += u;
            sy += v;
        }
        let (mx, my) = (sx / nf, sy / nf);
        // Pass 2: deviation sums and centred second moments.
        let (vmx, vmy) = (V::splat(mx), V::splat(my));
        let (mut sdx, mut sdy) = (V::zero(), V::zero());
        let (mut sxx, mut syy, mut sxy) = (V::zero(), V::zero(), V::zero());
        for (u, v) in xh.chunks_exact(4).zip(yh.chunks_exact(4)) {
            let dx = V::load(u).sub(vmx);
            let dy = V::load(v).sub(vmy);
            sdx = sdx.add(dx);
            sdy = sdy.add(dy);
            sxx = sxx.add(dx.mul(dx));
            syy = syy.add(dy.mul(dy));
            sxy = sxy.add(dx.mul(dy));
        }
        let mut t = [sdx.fold(), sdy.fold(), sxx.fold(), syy.fold(), sxy.fold()];
        for (u, v) in xr.iter().zip(yr) {
            let dx = u - mx;
            let dy = v - my;
            t[0] += dx;
            t[1] += dy;
            t[2] += dx * dx;
            t[3] += dy * dy;
            t[4] += dx * dy;
        }
        // The block means carry rounding; the deviation sums t[0], t[1]
        // correct both the means and the second moments (two-pass with
        // correction, Chan et al. 1983).
        let (cx, cy) = (t[0] / nf, t[1] / nf);
        let sxx = t[2] - t[0] * cx;
        let syy = t[3] - t[1] * cy;
        let sxy = t[4] - t[0] * cy;
        // Third pass (the block is in cache): residuals about the block's
        // own line, with the same mean correction.
        let sse = if sxx > 0.0 {
            let b = sxy / sxx;
            let vb = V::splat(b);
            let (mut r, mut r2) = (V::zero(), V::zero());
            for (u, v) in xh.chunks_exact(4).zip(yh.chunks_exact(4)) {
                let e = V::load(v).sub(vmy).sub(vb.mul(V::load(u).sub(vmx)));
                r = r.add(e);
                r2 = r2.add(e.mul(e));
            }
            let mut sr = r.fold();
            let mut sr2 = r2.fold();
            for (u, v) in xr.iter().zip(yr) {
                let e = (v - my) - b * (u - mx);
                sr += e;
                sr2 += e * e;
            }
            (sr2 - sr * (sr / nf)).max(0.0)
        } else {
            syy
        };
        let (mean_x, mean_x_lo) = dd_mean(mx, cx);
        let (mean_y, mean_y_lo) = dd_mean(my, cy);
        Moments { n: n as u64, mean_x, mean_y, sxx, syy, sxy, sse, mean_x_lo, mean_y_lo }
    }

    /// Moments of a whole slice pair (no chunk state), in fixed blocks.
    pub fn of(x: &[f64], y: &[f64]) -> Result<Moments, KernelError> {
        same_len("x", x, "y", y)?;
        if x.len() <= TASK {
            return Ok(Self::of_serial(x, y));
        }
        let parts: Vec<Moments> =
            x.par_chunks(TASK).zip(y.par_chunks(TASK)).map(|(a, b)| Self::of_serial(a, b)).collect();
        Ok(parts.iter().fold(Moments::default(), |acc, m| acc.merge(m)))
    }

    /// One task's blocks, merged in order, in the widest vectors the CPU
    /// has (the same bits on every CPU, see [`crate::numerics::lanes`]).
    fn of_serial(x: &[f64], y: &[f64]) -> Moments {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU supports AVX2, checked just above.
                return unsafe { Self::of_serial_avx2(x, y) };
            }
            Self::of_serial_generic::<crate::numerics::lanes::Sse2>(x, y)
        }
        #[cfg(not(target_arch = "x86_64"))]
        Self::of_serial_generic::<crate::numerics::lanes::Scalar>(x, y)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn of_serial_avx2(x: &[f64], y: &[f64]) -> Moments {
        Self::of_serial_generic::<crate::numerics::lanes::Avx>(x, y)
    }

    /// A plain loop, so that the block kernel is inlined into the caller
    /// that carries the target features.
    #[inline(always)]
    fn of_serial_generic<V: F4>(x: &[f64], y: &[f64]) -> Moments {
        let n = x.len().min(y.len());
        let mut acc = Moments::default();
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            acc = acc.merge(&Self::of_block::<V>(&x[start..end], &y[start..end]));
            start = end;
        }
        acc
    }

    /// Adds a chunk of samples.
    pub fn update(&mut self, x: &[f64], y: &[f64]) -> Result<(), KernelError> {
        let m = Self::of(x, y)?;
        *self = self.merge(&m);
        Ok(())
    }

    /// Pairwise combination (Chan, Golub, LeVeque): the moments of the union.
    pub fn merge(&self, o: &Moments) -> Moments {
        if o.n == 0 {
            return *self;
        }
        if self.n == 0 {
            return *o;
        }
        let (na, nb) = (self.n as f64, o.n as f64);
        let n = na + nb;
        let dx = dd_diff(o.mean_x, o.mean_x_lo, self.mean_x, self.mean_x_lo);
        let dy = dd_diff(o.mean_y, o.mean_y_lo, self.mean_y, self.mean_y_lo);
        let w = na * nb / n;
        let (sa, sb) = (self.sxx, o.sxx);
        let sxx = sa + sb + dx * dx * w;
        let slope = |m: &Moments| if m.sxx > 0.0 { m.sxy / m.sxx } else { 0.0 };
        let (ba, bb) = (slope(self), slope(o));
        let between = if sxx > 0.0 {
            (sa * sb * (ba - bb).powi(2) + sa * w * (ba * dx - dy).powi(2) + sb * w * (bb * dx - dy).powi(2)) / sxx
        } else {
            dy * dy * w
        };
        let (mean_x, mean_x_lo) = dd_add(self.mean_x, self.mean_x_lo, dx * (nb / n));
        let (mean_y, mean_y_lo) = dd_add(self.mean_y, self.mean_y_lo, dy * (nb / n));
        Moments {
            n: self.n + o.n,
            mean_x,
            mean_y,
            mean_x_lo,
            mean_y_lo,
            sxx,
            syy: self.syy + o.syy + dy * dy * w,
            sxy: self.sxy + o.sxy + dx * dy * w,
            sse: self.sse + o.sse + between,
        }
    }

    /// Least-squares fit of y on x from the moments (Eqs. 6-8).
    pub fn fit(&self) -> LinFit {
        let nan = LinFit {
            slope: f64::NAN,
            intercept: f64::NAN,
            r: f64::NAN,
            slope_stderr: f64::NAN,
            intercept_stderr: f64::NAN,
            resid_std: f64::NAN,
            n: self.n,
            degenerate: true,
        };
        // `sxx` must be strictly positive; NaN counts as degenerate too.
        if self.n < 3 || self.sxx.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
            return nan;
        }
        let nf = self.n as f64;
        let slope = self.sxy / self.sxx;
        // intercept = mean_y - slope * mean_x with the product's rounding
        // error recovered exactly (FMA) and the low parts of the means.
        let p = slope * self.mean_x;
        let p_err = slope.mul_add(self.mean_x, -p);
        let intercept = (self.mean_y - p) + ((self.mean_y_lo - p_err) - slope * self.mean_x_lo);
        let den = (self.sxx * self.syy).sqrt();
        let r = if den > 0.0 { (self.sxy / den).clamp(-1.0, 1.0) } else { f64::NAN };
        let resid_var = self.sse / (nf - 2.0);
        let slope_stderr = (resid_var / self.sxx).sqrt();
        let intercept_stderr = slope_stderr * (self.sxx / nf + self.mean_x * self.mean_x).sqrt();
        LinFit {
            slope,
            intercept,
            r,
            slope_stderr,
            intercept_stderr,
            resid_std: resid_var.sqrt(),
            n: self.n,
            degenerate: false,
        }
    }
}

/// One-shot fit of y on x.
pub fn linfit(x: &[f64], y: &[f64]) -> Result<LinFit, KernelError> {
    Ok(Moments::of(x, y)?.fit())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn data(n: usize) -> (Vec<f64>, Vec<f64>) {
        let x: Vec<f64> = (0..n).map(|i| (i as f64 * 0.731).sin() * 3.0 + i as f64 * 1e-3).collect();
        let y: Vec<f64> = x.iter().enumerate().map(|(i, v)| 0.15 * v - 0.2 + 0.05 * (i as f64 * 1.3).cos()).collect();
        (x, y)
    }

    fn close(a: f64, b: f64, rel: f64) -> bool {
        (a - b).abs() <= rel * b.abs().max(1e-300)
    }

    #[test]
    fn exact_line_and_offsets() {
        let (x, _) = data(5000);
        let y: Vec<f64> = x.iter().map(|v| 2.5 * v - 1.0).collect();
        let f = linfit(&x, &y).unwrap();
        assert!(close(f.slope, 2.5, 1e-13) && close(f.intercept, -1.0, 1e-12));
        let (x, y) = data(3000);
        let base = linfit(&x, &y).unwrap();
        let xs: Vec<f64> = x.iter().map(|v| v + 1e6).collect();
        let ys: Vec<f64> = y.iter().map(|v| v - 1e5).collect();
        let shifted = linfit(&xs, &ys).unwrap();
        assert!(close(shifted.slope, base.slope, 1e-9));
        assert!(close(shifted.r, base.r, 1e-9));
        assert!(close(shifted.resid_std, base.resid_std, 1e-8));
    }

    #[test]
    fn chunked_and_merged_match_one_shot() {
        let (x, y) = data(700_000);
        let one = Moments::of(&x, &y).unwrap();
        let mut acc = Moments::default();
        let mut start = 0;
        for len in [0usize, 1, 2, 999, 1025, 300_000, 17] {
            acc.update(&x[start..start + len], &y[start..start + len]).unwrap();
            start += len;
        }
        let rest = Moments::of(&x[start..], &y[start..]).unwrap();
        let merged = acc.merge(&rest);
        let (a, b) = (one.fit(), merged.fit());
        assert_eq!(merged.n, one.n);
        assert!(close(a.slope, b.slope, 1e-12));
        assert!(close(a.intercept, b.intercept, 1e-12));
        assert!(close(a.resid_std, b.resid_std, 1e-12), "{} {}", a.resid_std, b.resid_std);
    }

    #[test]
    fn vector_paths_give_the_same_bits() {
        let (x, y) = data(10_007);
        let xs: Vec<f64> = x.iter().map(|v| v * 1e3 + 12.5).collect();
        let want = Moments::of_serial_generic::<crate::numerics::lanes::Scalar>(&xs, &y);
        assert_eq!(Moments::of_serial(&xs, &y), want);
        #[cfg(target_arch = "x86_64")]
        assert_eq!(Moments::of_serial_generic::<crate::numerics::lanes::Sse2>(&xs, &y), want);
    }

    #[test]
    fn degenerate_is_nan_not_error() {
        let f = linfit(&[1.0, 2.0], &[1.0, 2.0]).unwrap();
        assert!(f.degenerate && f.slope.is_nan());
        let f = linfit(&[0.3; 10], &[1.0; 10]).unwrap();
        assert!(f.degenerate && f.slope.is_nan());
        assert!(linfit(&[1.0], &[1.0, 2.0]).is_err());
    }
}
