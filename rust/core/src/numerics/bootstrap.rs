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

/// The positions of `v`'s values in ascending order, NaN left out; None when they do not fit a u32.
fn sort_order(v: &[f64]) -> Option<Vec<u32>> {
    if v.len() >= u32::MAX as usize {
        return None;
    }
    let mut order: Vec<u32> = (0..v.len() as u32).filter(|&i| !v[i as usize].is_nan()).collect();
    order.sort_by(|&a, &b| v[a as usize].partial_cmp(&v[b as usize]).unwrap_or(std::cmp::Ordering::Equal));
    Some(order)
}

/// The ranks [`crate::numerics::order::from_ranks`] asks of `k` > 0 values for the median and `qs`,
/// ascending and distinct.
fn wanted_ranks(k: usize, qs: &[f64]) -> Vec<usize> {
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
    want
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
        let order = sort_order(v)?;
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
        let want = wanted_ranks(k, qs);
        let mut got: Vec<f64> = Vec::with_capacity(want.len());
        let (mut cum, mut at) = (0usize, 0usize);
        for &j in &want {
            walk(counts, &mut cum, &mut at, j);
            got.push(self.sorted[at]);
        }
        crate::numerics::order::from_ranks(k, qs, median, out, |j| got[want.binary_search(&j).unwrap_or(0)]);
        k
    }
}

/// Row `row` of the resamples: value j is window `starts[row][j / ell] + j % ell`, j < width.
fn indices(starts: &[i64], per_row: usize, row: usize, ell: usize, width: usize) -> impl Iterator<Item = usize> + '_ {
    blocks(starts, per_row, row, ell, width).flatten()
}

/// The windows of row `row` of the resamples block by block (no division per value; the last block cut
/// at `width` values).
fn blocks(
    starts: &[i64],
    per_row: usize,
    row: usize,
    ell: usize,
    width: usize,
) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
    let s = &starts[row * per_row..(row + 1) * per_row];
    s.iter().enumerate().map(move |(b, &a)| {
        let a = a as usize;
        a..a + ell.min(width.saturating_sub(b * ell))
    })
}

/// Moves `(cum, at)` (the values counted at positions before `at`, and `at`) to the position of rank `j`
/// (0-based, below the total count): whole chunks of positions first (their sums vectorise), then one
/// position at a time.
fn walk(counts: &[u32], cum: &mut usize, at: &mut usize, j: usize) {
    const CHUNK: usize = 64;
    while *at + CHUNK <= counts.len() {
        // at most the total count, below u32::MAX (Ranked and Moved hold fewer values)
        let s = counts[*at..*at + CHUNK].iter().fold(0u32, |a, &c| a.wrapping_add(c)) as usize;
        if *cum + s > j {
            break;
        }
        *cum += s;
        *at += CHUNK;
    }
    while *cum + counts[*at] as usize <= j {
        *cum += counts[*at] as usize;
        *at += 1;
    }
}

/// `v`'s values sorted once, each with its `dnoise`: the order statistics of a noise resample's moved
/// values `dnoise * delta + v` exactly without selecting among all of them (issue 38).
///
/// Take `dc` the middle of the range of `dnoise` and `w = v + dc * delta` (in real arithmetic: the same
/// order as `v`). Every moved value, as rounded, lies within `e` ([`Moved::bound`]: max |dnoise - dc|
/// |delta| and room for the rounding) of its window's `w`, so the resample's moved value of rank j lies
/// within `e` of its `w` of rank j, `v_(j) + dc * delta`. A window whose `v` is more than `2e` below
/// `v_(j)` is then below that order statistic, one more than `2e` above it above it, and the order
/// statistic is the one of rank j - (windows below) among the few windows in between: the resample's
/// windows are counted by position in `v`'s order (O(n) per resample, a small constant) and only those
/// few are moved and selected among. The order statistics are values of the resample either way, so they
/// are the selection's numbers; only a zero could differ (-0.0 and +0.0 compare equal, and which one a
/// selection returns depends on its path), and a zero is left to the selection among all the values.
struct Moved {
    /// The non-NaN values of `v`, ascending.
    sorted: Vec<f64>,
    /// The `dnoise` of each of them.
    dn: Vec<f64>,
    /// The largest |dnoise - dc|, |dnoise| and |v|.
    gmax: f64,
    dmax: f64,
    vmax: f64,
}

/// A bound whose windows between are more than this share of the values: left to the selection.
const MOVED_SHARE: usize = 4;

impl Moved {
    /// The sorted values and each row's position among them (`sorted.len()` for NaN); None where a
    /// value of `v` is infinite, a window of `v` moves by a non-finite `dnoise`, or none is a number.
    fn new(v: &[f64], dnoise: &[f64]) -> Option<(Moved, Vec<u32>)> {
        let order = sort_order(v)?;
        let (first, last) = (*order.first()?, *order.last()?);
        if !v[first as usize].is_finite() || !v[last as usize].is_finite() {
            return None;
        }
        let dn: Vec<f64> = order.iter().map(|&i| dnoise[i as usize]).collect();
        if dn.iter().any(|d| !d.is_finite()) {
            return None;
        }
        let (lo, hi) = dn.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &d| (a.min(d), b.max(d)));
        let dc = 0.5 * lo + 0.5 * hi;
        let gmax = dn.iter().fold(0.0f64, |g, &d| g.max((d - dc).abs()));
        let dmax = lo.abs().max(hi.abs());
        let vmax = v[first as usize].abs().max(v[last as usize].abs());
        let mut pos = vec![order.len() as u32; v.len()];
        for (at, &i) in order.iter().enumerate() {
            pos[i as usize] = at as u32;
        }
        Some((Moved { sorted: order.iter().map(|&i| v[i as usize]).collect(), dn, gmax, dmax, vmax }, pos))
    }

    /// The bound `e` on |moved value - w| for the move `delta`, with room for every rounding (each a
    /// relative error below 2^-52, far below the 1e-12 allowed, or below 1e-300 where it underflows);
    /// None where `delta` is not a finite number or a moved value could overflow.
    fn bound(&self, delta: f64) -> Option<f64> {
        let ad = delta.abs();
        let reach = self.dmax * ad + self.vmax;
        let e = self.gmax * ad + 1e-12 * reach + 1e-300;
        (e.is_finite() && reach <= 1e300).then_some(e)
    }

    /// The moved values of ranks `want` (ascending, distinct, each below the total count) of the windows
    /// that `counts` counts by position in `sorted` (NaN's count last), into `got`; false where they are
    /// left to the selection (a zero among them; too many windows between a rank's bounds).
    #[allow(clippy::too_many_arguments)]
    fn values(
        &self,
        counts: &[u32],
        delta: f64,
        e: f64,
        want: &[usize],
        got: &mut Vec<f64>,
        sel: &mut Vec<f64>,
        fixed: &mut Vec<usize>,
    ) -> bool {
        let len = self.sorted.len();
        let counts = &counts[..len];
        let limit = len / MOVED_SHARE + 16;
        got.clear();
        let (mut cum, mut at) = (0usize, 0usize);
        let mut i = 0;
        while i < want.len() {
            // the first rank of a group: its position, the windows before it, its bounds
            walk(counts, &mut cum, &mut at, want[i]);
            let floor = self.sorted[at] - 2.0 * e;
            let (mut lo, mut below) = (at, cum);
            while lo > 0 && self.sorted[lo - 1] >= floor {
                lo -= 1;
                below -= counts[lo] as usize;
            }
            let (mut hi, mut end) = (at + 1, i + 1);
            loop {
                let ceil = self.sorted[at] + 2.0 * e;
                while hi < len && self.sorted[hi] <= ceil {
                    hi += 1;
                }
                if hi - lo > limit {
                    return false;
                }
                // the next rank joins the group when it lies between (its own lower bound is then
                // above the group's, and the group's upper bound is moved up to its own)
                if end == want.len() {
                    break;
                }
                let (mut c, mut a) = (cum, at);
                walk(counts, &mut c, &mut a, want[end]);
                if a >= hi {
                    break;
                }
                (cum, at) = (c, a);
                end += 1;
            }
            sel.clear();
            for ((&d, &x), &c) in self.dn[lo..hi].iter().zip(&self.sorted[lo..hi]).zip(&counts[lo..hi]) {
                sel.extend(std::iter::repeat_n(d * delta + x, c as usize));
            }
            fixed.clear();
            for &j in &want[i..end] {
                let r = j - below;
                if r >= sel.len() {
                    return false; // cannot happen (the bounds hold every window of these ranks)
                }
                let x = crate::numerics::order::rank(sel, r, fixed);
                if x == 0.0 {
                    return false;
                }
                got.push(x);
            }
            i = end;
        }
        true
    }
}

/// Per thread: a resample's values, the selections' buffers, counts.
#[derive(Default)]
struct Scratch {
    vals: Vec<f64>,
    buf: Vec<f64>,
    /// Counts by position of [`Ranked`] and of [`Moved`].
    counts: Vec<u32>,
    moved: Vec<u32>,
    got: Vec<f64>,
    fixed: Vec<usize>,
}

/// The noise resamples' arrays (see [`resample_stats`]).
struct Resamples<'a> {
    starts: &'a [i64],
    per_row: usize,
    ell: usize,
    width: usize,
    nz: &'a Noise<'a>,
    /// The noise measurements sorted once (NaN left out), and each window's position among them (NaN:
    /// last), when they fit.
    ranked: Option<(Vec<f64>, Vec<u32>)>,
    /// Each window's value and d value / d noise (`v` and `dnoise` at its row of `v`; NaN and 0 for a
    /// window not among `v`'s, whose moved value `0 * delta + NaN` is NaN, as it always was).
    vw: Vec<f64>,
    dw: Vec<f64>,
    /// `v`'s values sorted, and each window's position among them (NaN and windows not among `v`'s: last).
    moved: Option<(Moved, Vec<u32>)>,
}

impl<'a> Resamples<'a> {
    fn new(v: &[f64], starts: &'a [i64], per_row: usize, ell: usize, nz: &'a Noise<'a>) -> Resamples<'a> {
        let (vw, dw) = nz
            .pos
            .iter()
            .map(|&p| if p < 0 { (f64::NAN, 0.0) } else { (v[p as usize], nz.dnoise[p as usize]) })
            .unzip();
        let moved = Moved::new(v, nz.dnoise).map(|(mv, pos)| {
            let slot = mv.sorted.len() as u32;
            let pw = nz.pos.iter().map(|&p| if p < 0 { slot } else { pos[p as usize] }).collect();
            (mv, pw)
        });
        let width = nz.var.len();
        let ranked = sort_order(nz.var).map(|order| {
            let mut pos = vec![order.len() as u32; width];
            for (at, &i) in order.iter().enumerate() {
                pos[i as usize] = at as u32;
            }
            (order.iter().map(|&i| nz.var[i as usize]).collect(), pos)
        });
        Resamples { starts, per_row, ell, width, nz, ranked, vw, dw, moved }
    }

    fn indices(&self, row: usize) -> impl Iterator<Item = usize> + '_ {
        indices(self.starts, self.per_row, row, self.ell, self.width)
    }

    fn blocks(&self, row: usize) -> impl Iterator<Item = std::ops::Range<usize>> + '_ {
        blocks(self.starts, self.per_row, row, self.ell, self.width)
    }

    /// Median, mean, p05 and p95 of resample `row` with the noise estimate drawn anew.
    fn row(&self, row: usize, s: &mut Scratch) -> [f64; 4] {
        let nz = self.nz;
        let Scratch { vals, buf, counts, moved, got, fixed } = s;
        // the resample's windows counted by position among the noise measurements and among v's values,
        // in one pass (the last position counts NaN and the windows not among v's)
        let var_slot = self.ranked.as_ref().map(|r| r.0.len());
        let v_slot = self.moved.as_ref().map(|m| m.0.sorted.len());
        counts.clear();
        counts.resize(var_slot.map_or(0, |n| n + 1), 0);
        moved.clear();
        moved.resize(v_slot.map_or(0, |n| n + 1), 0);
        for r in self.blocks(row) {
            match (&self.ranked, &self.moved) {
                (Some((_, pv)), Some((_, pw))) => {
                    for (&a, &b) in pv[r.clone()].iter().zip(&pw[r]) {
                        counts[a as usize] += 1;
                        moved[b as usize] += 1;
                    }
                }
                (Some((_, pv)), None) => pv[r].iter().for_each(|&a| counts[a as usize] += 1),
                (None, Some((_, pw))) => pw[r].iter().for_each(|&b| moved[b as usize] += 1),
                (None, None) => {}
            }
        }
        let mut m = 0.0;
        if let (Some((sorted, _)), Some(slot)) = (&self.ranked, var_slot) {
            let k = self.width - counts[slot] as usize; // a resample holds `width` windows
            m = if k == 0 {
                f64::NAN
            } else {
                let h = k / 2;
                let (mut cum, mut at) = (0usize, 0usize);
                let lo = if k % 2 == 0 {
                    walk(&counts[..slot], &mut cum, &mut at, h - 1);
                    sorted[at]
                } else {
                    0.0
                };
                walk(&counts[..slot], &mut cum, &mut at, h);
                crate::numerics::order::median_of(k, lo, sorted[at])
            };
        } else {
            buf.clear();
            buf.extend(self.indices(row).map(|k| nz.var[k]).filter(|x| !x.is_nan()));
            crate::numerics::order::one_row(buf, &[], &mut m, &mut []);
        }
        let delta = numpy_max0(m) - nz.used;
        vals.clear();
        for r in self.blocks(row) {
            vals.extend(self.dw[r.clone()].iter().zip(&self.vw[r]).map(|(&d, &x)| d * delta + x));
        }
        // the order statistics from Moved where its bound holds
        let fast = self.moved.as_ref().and_then(|(mv, _)| {
            let e = mv.bound(delta)?;
            Some((mv, e, vals.len() - moved[mv.sorted.len()] as usize))
        });
        let nan = match fast {
            Some((.., k)) => k < vals.len(),
            None => vals.iter().any(|x| x.is_nan()),
        };
        let mean = if nan {
            buf.clear();
            buf.extend(vals.iter().map(|&x| if x.is_nan() { 0.0 } else { x }));
            pairwise_sum(buf) / vals.iter().filter(|x| !x.is_nan()).count() as f64
        } else {
            pairwise_sum(vals) / vals.len() as f64
        };
        let qs = [0.05, 0.95];
        let (mut med, mut q) = (0.0, [0.0; 2]);
        if let Some((mv, e, k)) = fast.filter(|f| f.2 > 0) {
            let want = wanted_ranks(k, &qs);
            if mv.values(moved, delta, e, &want, got, buf, fixed) {
                let got = &*got;
                crate::numerics::order::from_ranks(k, &qs, &mut med, &mut q, |j| {
                    got[want.binary_search(&j).unwrap_or(0)]
                });
                return [med, mean, q[0], q[1]];
            }
        }
        buf.clear();
        buf.extend(vals.iter().copied().filter(|x| !x.is_nan()));
        crate::numerics::order::one_row(buf, &qs, &mut med, &mut q);
        [med, mean, q[0], q[1]]
    }
}

/// Per resample (a row of `starts`, `per_row` block starts of `ell` windows each): median, mean,
/// p05 and p95 of its values into `out` (4 x rows, statistic-major).
///
/// Without `noise` the values are `v`'s windows (a resample holding NaN gives NaN, as NumPy's
/// statistics do); with it they are the resample's windows of `v` moved by `dnoise * (sigma*^2 -
/// used)`, sigma*^2 the median of the resample's `var` (at least 0; NaN ignored), and the
/// statistics ignore NaN (a window not among `v`'s is NaN): the mean too, as NumPy's `nanmean`
/// (the pairwise sum of the values with NaN as 0, over the count of the others).
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
    // holding one is NaN); with noise, Resamples sorts the noise measurements (their NaN left out, as the
    // median leaves it out) and v's values.
    let ranked = match noise {
        None if !v.iter().any(|x| x.is_nan()) => Ranked::new(v),
        _ => None,
    };
    let mut per: Vec<[f64; 4]> = vec![[0.0; 4]; rows];
    if let Some(nz) = noise {
        let rs = Resamples::new(v, starts, per_row, ell, nz);
        per.par_iter_mut().enumerate().for_each_init(Scratch::default, |s, (row, o)| *o = rs.row(row, s));
    } else {
        per.par_iter_mut().enumerate().for_each_init(
            || (Vec::with_capacity(width), Vec::new()),
            |(vals, counts), (row, o)| {
                vals.clear();
                vals.extend(indices(starts, per_row, row, ell, width).map(|k| v[k]));
                if let Some(rk) = &ranked {
                    let (mut med, mut q) = (0.0, [0.0; 2]);
                    let k =
                        rk.stats(indices(starts, per_row, row, ell, width), counts, &[0.05, 0.95], &mut med, &mut q);
                    *o = [med, pairwise_sum(vals) / k as f64, q[0], q[1]];
                } else if vals.iter().any(|x| x.is_nan()) {
                    *o = [f64::NAN; 4];
                } else {
                    let mean = pairwise_sum(vals) / vals.len() as f64;
                    let (mut med, mut q) = (0.0, [0.0; 2]);
                    crate::numerics::order::one_row(vals, &[0.05, 0.95], &mut med, &mut q);
                    *o = [med, mean, q[0], q[1]];
                }
            },
        );
    }
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

    /// A small linear congruential generator (no dependency; the same numbers on every machine).
    fn lcg(seed: u64) -> impl FnMut() -> u64 {
        let mut state = seed;
        move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            state >> 11
        }
    }

    /// Values of `n` windows of a kind: 0 spread, 1 quantised (ties, zeros of both signs), 2 all equal,
    /// 3 spread with NaN, 4 few distinct values.
    fn values_of(kind: usize, n: usize, rnd: &mut impl FnMut() -> u64) -> Vec<f64> {
        (0..n)
            .map(|i| {
                let u = (rnd() % 1_000_000) as f64 / 1e6;
                match kind {
                    0 => 0.12 + 0.003 * (u - 0.5),
                    1 => match rnd() % 9 {
                        0 => -0.0,
                        1 => 0.0,
                        r => (r as f64 - 4.0) * 0.25,
                    },
                    2 => 0.3,
                    3 if i % 5 == 2 => f64::NAN,
                    3 => u - 0.5,
                    _ => [0.1, 0.2, 0.2, 0.5][(rnd() % 4) as usize],
                }
            })
            .collect()
    }

    fn dnoise_of(kind: usize, n: usize, rnd: &mut impl FnMut() -> u64) -> Vec<f64> {
        (0..n)
            .map(|_| {
                let u = (rnd() % 1_000_000) as f64 / 1e6;
                match kind {
                    0 => 0.5 + 0.1 * (u - 0.5),
                    1 => 0.5,
                    2 => 0.0,
                    _ => 6.0 * (u - 0.5),
                }
            })
            .collect()
    }

    #[test]
    fn moved_order_statistics_are_the_selections_at_every_rank() {
        let mut rnd = lcg(11);
        let (mut tried, mut found) = (0usize, 0usize);
        let (mut easy, mut easy_found) = (0usize, 0usize);
        for n in [1usize, 2, 3, 4, 5, 9, 40, 300] {
            for kind in 0..5 {
                for dkind in 0..4 {
                    let v = values_of(kind, n, &mut rnd);
                    let dn = dnoise_of(dkind, n, &mut rnd);
                    let Some((mv, pos)) = Moved::new(&v, &dn) else {
                        assert!(v.iter().all(|x| x.is_nan()));
                        continue;
                    };
                    for delta in [0.0, -0.0, 1e-4, -3e-3, 0.7, 1e-310] {
                        let e = mv.bound(delta).unwrap();
                        // a resample: windows drawn with repetition
                        let idx: Vec<usize> =
                            (0..n + (rnd() % 5) as usize).map(|_| (rnd() % n as u64) as usize).collect();
                        let mut counts = vec![0u32; mv.sorted.len() + 1];
                        idx.iter().for_each(|&i| counts[pos[i] as usize] += 1);
                        let moved: Vec<f64> =
                            idx.iter().map(|&i| dn[i] * delta + v[i]).filter(|x| !x.is_nan()).collect();
                        let k = moved.len();
                        assert_eq!(k, idx.len() - counts[mv.sorted.len()] as usize);
                        let (mut got, mut sel, mut fixed) = (Vec::new(), Vec::new(), Vec::new());
                        // every rank alone, then the ranks the statistics ask for together
                        let mut sets: Vec<Vec<usize>> = (0..k).map(|j| vec![j]).collect();
                        if k > 0 {
                            sets.push(wanted_ranks(k, &[0.05, 0.95]));
                        }
                        for want in sets {
                            // spread values moving together: always found without the selection among all
                            let plain = kind == 0 && (dkind == 1 || dkind == 2);
                            tried += 1;
                            easy += plain as usize;
                            if !mv.values(&counts, delta, e, &want, &mut got, &mut sel, &mut fixed) {
                                continue;
                            }
                            found += 1;
                            easy_found += plain as usize;
                            for (&j, &x) in want.iter().zip(&got) {
                                // the selection among all of them, as the kernel did it
                                let mut all = moved.clone();
                                let y = crate::numerics::order::rank(&mut all, j, &mut Vec::new());
                                assert_eq!(
                                    x.to_bits(),
                                    y.to_bits(),
                                    "n {n} kind {kind}/{dkind} delta {delta} rank {j}"
                                );
                            }
                        }
                    }
                }
            }
        }
        // most ranks are found without the selection among all (zeros and wide moves are left to it)
        assert!(found * 2 > tried, "{found} of {tried}");
        assert_eq!(easy_found, easy);
    }

    /// The noise path as it was: each resample's moved values selected among in a copy.
    fn noise_stats_by_selection(v: &[f64], starts: &[i64], per_row: usize, ell: usize, nz: &Noise<'_>) -> Vec<f64> {
        let width = nz.var.len();
        let rows = starts.len() / per_row;
        let mut out = vec![0.0; 4 * rows];
        for row in 0..rows {
            let mut var: Vec<f64> =
                indices(starts, per_row, row, ell, width).map(|k| nz.var[k]).filter(|x| !x.is_nan()).collect();
            let mut m = 0.0;
            crate::numerics::order::one_row(&mut var, &[], &mut m, &mut []);
            let delta = numpy_max0(m) - nz.used;
            let vals: Vec<f64> = indices(starts, per_row, row, ell, width)
                .map(|k| {
                    let p = nz.pos[k];
                    if p < 0 {
                        f64::NAN
                    } else {
                        nz.dnoise[p as usize] * delta + v[p as usize]
                    }
                })
                .collect();
            let zeroed: Vec<f64> = vals.iter().map(|&x| if x.is_nan() { 0.0 } else { x }).collect();
            let mut buf: Vec<f64> = vals.iter().copied().filter(|x| !x.is_nan()).collect();
            let mean = pairwise_sum(&zeroed) / buf.len() as f64;
            let (mut med, mut q) = (0.0, [0.0; 2]);
            crate::numerics::order::one_row(&mut buf, &[0.05, 0.95], &mut med, &mut q);
            for (j, x) in [med, mean, q[0], q[1]].into_iter().enumerate() {
                out[j * rows + row] = x;
            }
        }
        out
    }

    #[test]
    fn noise_resamples_are_the_selections_bit_for_bit() {
        let mut rnd = lcg(5);
        for width in [3usize, 4, 5, 7, 60, 700] {
            for kind in 0..5 {
                for dkind in 0..4 {
                    // v holds most of the windows (the others gated out: pos -1)
                    let pos: Vec<i64> = {
                        let mut next = 0i64;
                        (0..width)
                            .map(|i| {
                                if i % 7 == 3 {
                                    -1
                                } else {
                                    next += 1;
                                    next - 1
                                }
                            })
                            .collect()
                    };
                    let n = pos.iter().filter(|&&p| p >= 0).count();
                    let v = values_of(kind, n, &mut rnd);
                    let dn = dnoise_of(dkind, n, &mut rnd);
                    let mut var: Vec<f64> = (0..width).map(|_| ((rnd() % 2001) as f64 - 1000.0) * 2e-6).collect();
                    if kind == 3 {
                        var[width / 2] = f64::NAN;
                    }
                    for used in [0.0, 3e-4, f64::NAN] {
                        let nz = Noise { var: &var, pos: &pos, dnoise: &dn, used };
                        let ell = (width as f64).cbrt().ceil() as usize;
                        let per_row = width.div_ceil(ell);
                        let rows = 40;
                        let starts: Vec<i64> =
                            (0..rows * per_row).map(|_| (rnd() % (width - ell + 1) as u64) as i64).collect();
                        let want = noise_stats_by_selection(&v, &starts, per_row, ell, &nz);
                        for threads in [1, 2] {
                            let mut got = vec![0.0; 4 * rows];
                            crate::parallel::run_with(threads, || {
                                resample_stats(&v, &starts, per_row, ell, Some(&nz), &mut got)
                            })
                            .unwrap()
                            .unwrap();
                            for (g, w) in got.iter().zip(&want) {
                                assert!(
                                    g.to_bits() == w.to_bits() || (g.is_nan() && w.is_nan()),
                                    "width {width} kind {kind}/{dkind} used {used}: {g} {w}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
