//! The resample statistics of the moving-block bootstrap (`tribodyn.results.bootstrap_ci`, issue 25).
//!
//! For every resample (a row of block starts), the median, mean, 5th and 95th
//! percentiles of its values, as `tribodyn.results._resample_stats` computes
//! them with NumPy, bit for bit: the order statistics through
//! [`crate::numerics::order`]'s selection (NumPy's `nanmedian`/`nanpercentile`), the
//! mean as NumPy's pairwise sum divided by the count. One pass per resample
//! and no temporaries: the rows are independent, so the thread count never
//! changes a result.

use crate::error::KernelError;
use rayon::prelude::*;

/// The recording's fz-noise estimate moved with each resample (`tribodyn.results.NoiseResample`).
pub struct Noise<'a> {
    /// Every window's noise measurement (NaN: none).
    pub var: &'a [f64],
    /// For each of those windows its row in `v`, or -1.
    pub pos: &'a [i64],
    /// d value / d noise of each of `v`'s windows.
    pub dnoise: &'a [f64],
    /// The noise estimate of the recording (the median of `var`, at least 0).
    pub used: f64,
}

/// NumPy's pairwise summation of `a` (`pairwise_sum` of its add loops: 8 accumulators up to 128
/// values, halves at multiples of 8 above), which `np.sum` and `np.mean` of a contiguous row use.
fn pairwise_sum(a: &[f64]) -> f64 {
    let n = a.len();
    if n < 8 {
        let mut res = 0.0;
        for &x in a {
            res += x;
        }
        res
    } else if n <= 128 {
        let mut r = [a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7]];
        let mut i = 8;
        while i < n - (n % 8) {
            for j in 0..8 {
                r[j] += a[i + j];
            }
            i += 8;
        }
        let mut res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
        while i < n {
            res += a[i];
            i += 1;
        }
        res
    } else {
        let mut n2 = n / 2;
        n2 -= n2 % 8;
        pairwise_sum(&a[..n2]) + pairwise_sum(&a[n2..])
    }
}

/// NumPy's `maximum(m, 0.0)`: NaN stays NaN, and of two equal zeros the second (+0.0).
fn numpy_max0(m: f64) -> f64 {
    if m.is_nan() {
        f64::NAN
    } else if m > 0.0 {
        m
    } else {
        0.0
    }
}

/// Values sorted once, and each one's position among them: the order statistics of a resample (a
/// multiset of the values) by counting how often it holds each position, O(n) per resample with a small
/// constant, instead of selecting in a copy (issue 38 point 2). The order statistics are values of the
/// input either way, so they are the same numbers.
struct Ranked {
    sorted: Vec<f64>,
    /// Position of each value in `sorted`; `u32::MAX` for NaN (left out, as the selections leave it out).
    pos: Vec<u32>,
}

impl Ranked {
    fn new(v: &[f64]) -> Option<Ranked> {
        if v.len() >= u32::MAX as usize {
            return None;
        }
        let mut order: Vec<u32> = (0..v.len() as u32).filter(|&i| !v[i as usize].is_nan()).collect();
        order.sort_by(|&a, &b| v[a as usize].partial_cmp(&v[b as usize]).unwrap_or(std::cmp::Ordering::Equal));
        let mut pos = vec![u32::MAX; v.len()];
        for (at, &i) in order.iter().enumerate() {
            pos[i as usize] = at as u32;
        }
        Some(Ranked { sorted: order.iter().map(|&i| v[i as usize]).collect(), pos })
    }

    /// The median and quantiles `qs` (as [`crate::numerics::order::from_ranks`]) of the values at `idx`
    /// (NaN left out), with `counts` as scratch; returns how many values were not NaN.
    fn stats(
        &self,
        idx: impl Iterator<Item = usize>,
        counts: &mut Vec<u32>,
        qs: &[f64],
        median: &mut f64,
        out: &mut [f64],
    ) -> usize {
        counts.clear();
        counts.resize(self.sorted.len(), 0);
        let mut k = 0usize;
        for i in idx {
            let p = self.pos[i];
            if p != u32::MAX {
                counts[p as usize] += 1;
                k += 1;
            }
        }
        if k == 0 {
            crate::numerics::order::from_ranks(0, qs, median, out, |_| f64::NAN);
            return 0;
        }
        // the ranks from_ranks asks for, found in one walk over the counts
        let mut want: Vec<usize> = Vec::with_capacity(2 + 2 * qs.len());
        want.push(k / 2);
        if k % 2 == 0 {
            want.push(k / 2 - 1);
        }
        for &q in qs {
            let (a, b, _) = crate::numerics::order::quantile_ranks(k, q);
            want.extend([a, b]);
        }
        want.sort_unstable();
        want.dedup();
        let mut got: Vec<f64> = Vec::with_capacity(want.len());
        let (mut cum, mut at) = (0usize, 0usize);
        for &j in &want {
            while cum + counts[at] as usize <= j {
                cum += counts[at] as usize;
                at += 1;
            }
            got.push(self.sorted[at]);
        }
        crate::numerics::order::from_ranks(k, qs, median, out, |j| got[want.binary_search(&j).unwrap_or(0)]);
        k
    }
}

/// Row `row` of the resamples: value j is window `starts[row][j / ell] + j % ell`, j < width.
fn indices(starts: &[i64], per_row: usize, row: usize, ell: usize, width: usize) -> impl Iterator<Item = usize> + '_ {
    let s = &starts[row * per_row..(row + 1) * per_row];
    // block by block (no division per value); the last block cut at `width` values
    s.iter().enumerate().flat_map(move |(b, &a)| {
        let a = a as usize;
        a..a + ell.min(width.saturating_sub(b * ell))
    })
}

/// Per resample (a row of `starts`, `per_row` block starts of `ell` windows each): median, mean,
/// p05 and p95 of its values into `out` (4 x rows, statistic-major).
///
/// Without `noise` the values are `v`'s windows (a resample holding NaN gives NaN, as NumPy's
/// statistics do); with it they are the resample's windows of `v` moved by `dnoise * (sigma*^2 -
/// used)`, sigma*^2 the median of the resample's `var` (at least 0; NaN ignored), and the
/// statistics ignore NaN (a window not among `v`'s is NaN). `nan_mean`: the mean ignores NaN
/// (NumPy's `nanmean`) rather than propagating it.
pub fn resample_stats(
    v: &[f64],
    starts: &[i64],
    per_row: usize,
    ell: usize,
    noise: Option<&Noise<'_>>,
    out: &mut [f64],
) -> Result<(), KernelError> {
    let width = noise.map_or(v.len(), |nz| nz.var.len());
    if per_row == 0 || ell == 0 || starts.len() % per_row != 0 || per_row * ell < width {
        return Err(KernelError::Invalid("resample_stats: starts must hold rows of ceil(width / ell) starts".into()));
    }
    let rows = starts.len() / per_row;
    if out.len() != 4 * rows {
        return Err(KernelError::Invalid("resample_stats: out must hold 4 x rows values".into()));
    }
    if starts.iter().any(|&s| s < 0 || s as usize + ell > width) {
        return Err(KernelError::Invalid("resample_stats: a block runs past the windows".into()));
    }
    if let Some(nz) = noise {
        if nz.pos.len() != width || nz.dnoise.len() != v.len() || nz.pos.iter().any(|&p| p >= v.len() as i64) {
            return Err(KernelError::Invalid("resample_stats: noise.pos and noise.dnoise must match".into()));
        }
    }
    // Counting needs the values sorted once: v's without noise when it holds no NaN (with NaN a resample
    // holding one is NaN), and the noise measurements' (their NaN left out, as the median leaves it out).
    let ranked = match noise {
        None if !v.iter().any(|x| x.is_nan()) => Ranked::new(v),
        Some(nz) => Ranked::new(nz.var),
        None => None,
    };
    let mut per: Vec<[f64; 4]> = vec![[0.0; 4]; rows];
    per.par_iter_mut().enumerate().for_each_init(
        || (Vec::with_capacity(width), Vec::with_capacity(width), Vec::new()),
        |(vals, buf, counts), (row, o)| {
            vals.clear();
            match noise {
                None => {
                    vals.extend(indices(starts, per_row, row, ell, width).map(|k| v[k]));
                    if let Some(rk) = &ranked {
                        let (mut med, mut q) = (0.0, [0.0; 2]);
                        let k = rk.stats(
                            indices(starts, per_row, row, ell, width),
                            counts,
                            &[0.05, 0.95],
                            &mut med,
                            &mut q,
                        );
                        *o = [med, pairwise_sum(vals) / k as f64, q[0], q[1]];
                        return;
                    }
                }
                Some(nz) => {
                    let mut m = 0.0;
                    if let Some(rk) = &ranked {
                        rk.stats(indices(starts, per_row, row, ell, width), counts, &[], &mut m, &mut []);
                    } else {
                        buf.clear();
                        buf.extend(
                            indices(starts, per_row, row, ell, width).map(|k| nz.var[k]).filter(|x| !x.is_nan()),
                        );
                        crate::numerics::order::one_row(buf, &[], &mut m, &mut []);
                    }
                    let delta = numpy_max0(m) - nz.used;
                    vals.extend(indices(starts, per_row, row, ell, width).map(|k| {
                        let p = nz.pos[k];
                        if p < 0 {
                            f64::NAN
                        } else {
                            nz.dnoise[p as usize] * delta + v[p as usize]
                        }
                    }));
                }
            }
            let nan = vals.iter().any(|x| x.is_nan());
            if nan && noise.is_none() {
                *o = [f64::NAN; 4];
                return;
            }
            let (mean, count) = if nan {
                buf.clear();
                buf.extend(vals.iter().map(|&x| if x.is_nan() { 0.0 } else { x }));
                (pairwise_sum(buf), vals.iter().filter(|x| !x.is_nan()).count())
            } else {
                (pairwise_sum(vals), vals.len())
            };
            buf.clear();
            buf.extend(vals.iter().copied().filter(|x| !x.is_nan()));
            let (mut med, mut q) = (0.0, [0.0; 2]);
            crate::numerics::order::one_row(buf, &[0.05, 0.95], &mut med, &mut q);
            *o = [med, mean / count as f64, q[0], q[1]];
        },
    );
    for (r, s) in per.iter().enumerate() {
        for (j, x) in s.iter().enumerate() {
            out[j * rows + r] = *x;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pairwise_sum_groups_as_numpy() {
        let a: Vec<f64> = (0..300).map(|i| 1.0 / (i as f64 + 1.0)).collect();
        let seq: f64 = a.iter().sum();
        assert!((pairwise_sum(&a) - seq).abs() < 1e-12);
        assert_eq!(pairwise_sum(&a[..3]), (0.0 + a[0] + a[1]) + a[2]);
        assert_eq!(pairwise_sum(&[]), 0.0);
    }

    #[test]
    fn counting_gives_the_selections_order_statistics() {
        let mut state = 7u64;
        let mut rnd = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as usize
        };
        for n in [1usize, 2, 3, 10, 57, 400] {
            // quantised values (ties), a NaN among them
            let mut v: Vec<f64> = (0..n).map(|_| (rnd() % 13) as f64 * 0.25 - 1.0).collect();
            if n > 3 {
                v[n / 2] = f64::NAN;
            }
            let rk = Ranked::new(&v).unwrap();
            let mut counts = Vec::new();
            for _ in 0..20 {
                let idx: Vec<usize> = (0..n + rnd() % 5).map(|_| rnd() % n).collect();
                let (mut m1, mut q1) = (0.0, [0.0; 2]);
                let k = rk.stats(idx.iter().copied(), &mut counts, &[0.05, 0.95], &mut m1, &mut q1);
                let mut sel: Vec<f64> = idx.iter().map(|&i| v[i]).filter(|x| !x.is_nan()).collect();
                assert_eq!(k, sel.len());
                let (mut m2, mut q2) = (0.0, [0.0; 2]);
                crate::numerics::order::one_row(&mut sel, &[0.05, 0.95], &mut m2, &mut q2);
                assert_eq!(m1.to_bits(), m2.to_bits());
                assert_eq!(q1.map(f64::to_bits), q2.map(f64::to_bits));
            }
        }
    }

    #[test]
    fn rows_and_checks() {
        let v = [1.0, 2.0, 3.0, 4.0];
        let starts = [0i64, 2, 1, 1];
        let mut out = [0.0; 8];
        resample_stats(&v, &starts, 2, 2, None, &mut out).unwrap();
        assert_eq!(out[0], 2.5); // row 0: 1 2 3 4
        assert_eq!(out[1], 2.5); // row 1: 2 3 2 3
        assert_eq!(out[2], 2.5);
        assert!(resample_stats(&v, &[0, 3], 2, 2, None, &mut out[..4]).is_err());
    }
}
