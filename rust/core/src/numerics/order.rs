//! Order statistics of the rows of a matrix, as NumPy computes them (issue 25).
//!
//! [`row_quantiles`] gives, per row and ignoring NaN, the median and the
//! percentiles NumPy's `nanmedian` and `nanpercentile` (method "linear")
//! give, bit for bit: the order statistics are the row's own values, the
//! median of an even count is NumPy's mean of the two middle values
//! (`0 + (0 + a + b)`, then / 2, as its sum reduction does) and the
//! interpolation is NumPy's `_lerp`. Rows are independent, so the thread
//! count never changes a result.

use crate::error::KernelError;
use rayon::prelude::*;

/// Per row of `x` (`rows` x `width`, row-major): the median into `median`
/// and, for each quantile fraction `qs[j]` (0..=1), the percentile into
/// `out[j * rows + row]`. A row without a non-NaN value gives NaN.
pub fn row_quantiles(
    x: &[f64],
    width: usize,
    qs: &[f64],
    median: &mut [f64],
    out: &mut [f64],
) -> Result<(), KernelError> {
    let rows = median.len();
    if x.len() != rows.checked_mul(width).ok_or_else(|| KernelError::Invalid("row_quantiles: too large".into()))? {
        return Err(KernelError::Invalid(format!("row_quantiles: {} values for {rows} rows of {width}", x.len())));
    }
    if out.len() != qs.len() * rows {
        return Err(KernelError::Invalid("row_quantiles: out must hold len(qs) x rows values".into()));
    }
    if qs.iter().any(|q| !(0.0..=1.0).contains(q)) {
        return Err(KernelError::Invalid("row_quantiles: quantiles must be in [0, 1]".into()));
    }
    let nq = qs.len();
    let stride = nq.max(1); // a row's slot in per_row (one unused value without quantiles)
    let mut per_row = vec![0.0; rows * stride];
    median.par_iter_mut().zip(per_row.par_chunks_mut(stride)).enumerate().for_each_init(
        Vec::new,
        |buf, (r, (m, o))| {
            let row = &x[r * width..(r + 1) * width];
            buf.clear();
            buf.extend(row.iter().copied().filter(|v| !v.is_nan()));
            one_row(buf, qs, m, &mut o[..nq]);
        },
    );
    for (r, o) in per_row.chunks(stride).enumerate() {
        for (j, v) in o[..nq].iter().enumerate() {
            out[j * rows + r] = *v;
        }
    }
    Ok(())
}

/// The value of rank `k` of `v` (ascending), selecting within the part of
/// `v` between the ranks already fixed in `fixed` (ascending positions
/// whose values are in place, everything before them smaller or equal).
pub(crate) fn rank(v: &mut [f64], k: usize, fixed: &mut Vec<usize>) -> f64 {
    if fixed.binary_search(&k).is_ok() {
        return v[k];
    }
    let at = fixed.partition_point(|&p| p < k);
    let lo = if at == 0 { 0 } else { fixed[at - 1] + 1 };
    let hi = if at == fixed.len() { v.len() } else { fixed[at] };
    v[lo..hi].select_nth_unstable_by(k - lo, |a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    fixed.insert(at, k);
    v[k]
}

pub(crate) fn one_row(v: &mut [f64], qs: &[f64], median: &mut f64, out: &mut [f64]) {
    let k = v.len();
    let mut fixed: Vec<usize> = Vec::with_capacity(8);
    from_ranks(k, qs, median, out, |j| rank(v, j, &mut fixed));
}

/// The median and the quantiles `qs` of `k` values whose value of rank j (ascending) `value(j)` gives,
/// with NumPy's arithmetic (see [`row_quantiles`]); NaN for k = 0. The ranks asked are h = k / 2 (and
/// h - 1 for an even k), then each quantile's two neighbours, in that order.
pub(crate) fn from_ranks(k: usize, qs: &[f64], median: &mut f64, out: &mut [f64], mut value: impl FnMut(usize) -> f64) {
    if k == 0 {
        *median = f64::NAN;
        out.iter_mut().for_each(|o| *o = f64::NAN);
        return;
    }
    let h = k / 2;
    let hi = value(h);
    *median = if k % 2 == 1 { median_of(k, hi, hi) } else { median_of(k, value(h - 1), hi) };
    for (o, &q) in out.iter_mut().zip(qs) {
        // numpy.quantile, method "linear": _get_indexes, _get_gamma, _lerp
        let (p, n, g) = quantile_ranks(k, q);
        let a = value(p);
        let b = value(n);
        *o = lerp(a, b, g);
    }
}

/// NumPy's median of `k` > 0 values whose value of rank k / 2 is `hi` and, for an even k, of rank
/// k / 2 - 1 `lo` (its mean of the two middle values; `lo` unused for an odd k).
pub(crate) fn median_of(k: usize, lo: f64, hi: f64) -> f64 {
    if k % 2 == 1 {
        (0.0 + (0.0 + hi)) / 1.0
    } else {
        (0.0 + ((0.0 + lo) + hi)) / 2.0
    }
}

/// NumPy's `_lerp` of the values `a` and `b` of a "linear" quantile's two ranks, by its weight `g`.
pub(crate) fn lerp(a: f64, b: f64, g: f64) -> f64 {
    let diff = b - a;
    if g >= 0.5 {
        b - diff * (1.0 - g)
    } else {
        a + diff * g
    }
}

/// The two ranks NumPy's "linear" quantile `q` of `k` values interpolates between, and its weight.
pub(crate) fn quantile_ranks(k: usize, q: f64) -> (usize, usize, f64) {
    let vi = (k as f64 - 1.0) * q;
    let prev = vi.floor();
    if vi >= k as f64 - 1.0 {
        (k - 1, k - 1, vi + 1.0)
    } else {
        (prev as usize, prev as usize + 1, vi - prev)
    }
}

/// Arrays up to this many values are selected in a copy of the whole (as `tribodyn._order._SMALL`).
const SMALL: usize = 1 << 15;
/// Largest size of the strided sample that brackets the wanted ranks (`tribodyn._order._SAMPLE`); a
/// shorter array takes about n^(2/3) values (at least [`SAMPLE_MIN`]), as Floyd and Rivest advise: the
/// pre-pass's 2^16-value samples sort 1.6k values instead of 16k (issue 38 point 2).
const SAMPLE: usize = 1 << 14;
/// Smallest size of the strided sample.
const SAMPLE_MIN: usize = 1 << 10;

fn cmp(a: &f64, b: &f64) -> std::cmp::Ordering {
    a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal)
}

/// The values of ranks `ks` (0-based, ascending) of `x` (with `centre`: of `|x - centre|`), exactly,
/// or None when `x` holds NaN.
///
/// A long array is bracketed as `tribodyn._order.order_stats` does it (Floyd and Rivest 1975): a
/// strided sample is sorted, the ranks' neighbourhood in it gives two values `lo` and `hi`, one pass
/// counts the values below `lo` and keeps those within `[lo, hi]`, and the ranks are selected among
/// the few kept; a bracket that misses (an unusual ordering) falls back to a selection in a copy of
/// the whole. The order statistics are values of the array, so any exact selection gives the same
/// ones. With `centre` the deviations are computed on the fly (no temporary array: the robust SD's
/// median absolute deviation).
pub fn select_ranks(x: &[f64], ks: &[usize], centre: Option<f64>) -> Result<Option<Vec<f64>>, KernelError> {
    let n = x.len();
    if let Some(k) = ks.iter().find(|&&k| k >= n) {
        return Err(KernelError::Invalid(format!("select_ranks: rank {k} of {n} values")));
    }
    let pieces = crate::parallel::current().min(n / (1 << 16)).max(1);
    let size = n.div_ceil(pieces).max(1);
    let has_nan = || {
        use rayon::prelude::*;
        x.par_chunks(size).any(|p| p.iter().fold(false, |nan, v| nan | v.is_nan()))
    };
    if centre.is_some_and(|c| !c.is_finite()) || has_nan() {
        return Ok(None);
    }
    if ks.is_empty() {
        return Ok(Some(Vec::new()));
    }
    let value = |v: f64| match centre {
        Some(c) => (v - c).abs(),
        None => v,
    };
    let (kmin, kmax) = (*ks.iter().min().unwrap_or(&0), *ks.iter().max().unwrap_or(&0));
    let whole = || -> Vec<f64> {
        let mut v: Vec<f64> = x.iter().map(|&v| value(v)).collect();
        let mut fixed = Vec::with_capacity(ks.len());
        ks.iter().map(|&k| rank(&mut v, k, &mut fixed)).collect()
    };
    if n <= SMALL {
        return Ok(Some(whole()));
    }
    let want = ((n as f64).powf(2.0 / 3.0) as usize).clamp(SAMPLE_MIN, SAMPLE);
    let step = (n / want).max(1);
    let mut sample: Vec<f64> = x.iter().step_by(step).map(|&v| value(v)).collect();
    sample.sort_unstable_by(cmp);
    let m = sample.len() as f64;
    let margin = 3.0 * m.sqrt() + 8.0;
    let lo_j = (kmin as f64 / n as f64 * m - margin) as i64; // Python's int(): toward zero
    let hi_j = (kmax as f64 / n as f64 * m + margin).ceil() as i64;
    if lo_j <= 0 && hi_j >= m as i64 - 1 {
        return Ok(Some(whole()));
    }
    let lo = if lo_j > 0 { sample[lo_j as usize] } else { f64::NEG_INFINITY };
    let hi = if hi_j < m as i64 - 1 { sample[hi_j as usize] } else { f64::INFINITY };
    // The pass that counts the values below the bracket and keeps those inside it, over fixed pieces
    // (one per thread of the pool it runs on), kept in the pieces' order: the kept values are the same
    // multiset whatever the thread count, and a selection among them gives the same order statistics.
    let parts: Vec<(usize, Vec<f64>)> = {
        use rayon::prelude::*;
        x.par_chunks(size).map(|piece| bracket(piece, lo, hi, &value)).collect()
    };
    let below: usize = parts.iter().map(|p| p.0).sum();
    let mut inside: Vec<f64> = Vec::with_capacity(parts.iter().map(|p| p.1.len()).sum());
    for (_, kept) in parts {
        inside.extend_from_slice(&kept);
    }
    let kept = inside.len();
    if kmin < below || kmax - below >= kept {
        return Ok(Some(whole()));
    }
    let mut fixed = Vec::with_capacity(ks.len());
    Ok(Some(ks.iter().map(|&k| rank(&mut inside, k - below, &mut fixed)).collect()))
}

/// (values of `x` below `lo`, the values within `[lo, hi]` in their order), of `value(v)` for each `v`.
fn bracket(x: &[f64], lo: f64, hi: f64, value: &(impl Fn(f64) -> f64 + Sync)) -> (usize, Vec<f64>) {
    // Branch-free: every value is written at the end of the kept ones, which grows only when it is
    // inside the bracket (the allocation is virtual; only the kept values' pages are touched).
    let mut below = 0usize;
    let mut inside: Vec<f64> = Vec::with_capacity(x.len());
    let buf = inside.spare_capacity_mut();
    let mut kept = 0usize;
    for &v in x {
        let v = value(v);
        below += (v < lo) as usize;
        buf[kept].write(v);
        kept += ((v >= lo) & (v <= hi)) as usize;
    }
    // SAFETY: the first `kept` slots were written by the loop (each kept value at its slot).
    unsafe { inside.set_len(kept) };
    (below, inside)
}

/// NumPy's `histogram(x, bins=edges.len() - 1, range=(edges[0], edges[last]))` of uniform `edges`
/// (from `np.linspace`), bit for bit: values outside the range are left out, a value's bin is
/// `(x - first) / (last - first) * bins` truncated, moved by one where that lands beside the edges
/// (NumPy's correction within an ULP of an edge), and the last bin holds its right edge.
pub fn histogram_uniform(x: &[f64], edges: &[f64]) -> Result<Vec<i64>, KernelError> {
    if edges.len() < 2 {
        return Err(KernelError::Invalid("histogram_uniform: at least two edges".into()));
    }
    let bins = edges.len() - 1;
    let (first, last) = (edges[0], edges[bins]);
    let denom = last - first;
    let mut counts = vec![0i64; bins];
    for &v in x {
        if !(v >= first && v <= last) {
            continue;
        }
        let mut i = (((v - first) / denom) * bins as f64) as usize;
        if i == bins {
            i -= 1;
        }
        if v < edges[i] {
            i -= 1;
        } else if v >= edges[i + 1] && i != bins - 1 {
            i += 1;
        }
        counts[i] += 1;
    }
    Ok(counts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn odd_even_nan_and_empty_rows() {
        let nan = f64::NAN;
        let x = [3.0, 1.0, 2.0, nan, 4.0, nan, 1.0, 2.5, nan, nan, nan, nan];
        let mut med = [0.0; 3];
        let mut out = [0.0; 6];
        row_quantiles(&x, 4, &[0.0, 1.0], &mut med, &mut out).unwrap();
        assert_eq!(med[0], 2.0);
        assert_eq!(med[1], 2.5);
        assert!(med[2].is_nan());
        assert_eq!(&out[..2], &[1.0, 1.0]);
        assert_eq!(&out[3..5], &[3.0, 4.0]);
        assert!(out[2].is_nan() && out[5].is_nan());
        let mut only = [0.0; 3];
        row_quantiles(&x, 4, &[], &mut only, &mut []).unwrap();
        assert_eq!(only[..2], med[..2]);
        assert!(row_quantiles(&x, 5, &[0.5], &mut med, &mut out[..3]).is_err());
        assert!(row_quantiles(&x, 4, &[1.5], &mut med, &mut out[..3]).is_err());
    }

    #[test]
    fn select_ranks_is_exact() {
        let n = 100_003usize;
        let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % n) as f64 * 0.5 - 3.0).collect();
        let mut s = x.clone();
        s.sort_by(cmp);
        for ks in [vec![0], vec![n / 2 - 1, n / 2], vec![n - 1], vec![17, 95_000]] {
            let got = select_ranks(&x, &ks, None).unwrap().unwrap();
            let want: Vec<f64> = ks.iter().map(|&k| s[k]).collect();
            assert_eq!(got, want);
        }
        let mut y = x.clone();
        y[500] = f64::NAN;
        assert!(select_ranks(&y, &[3], None).unwrap().is_none());
        assert!(select_ranks(&x, &[n], None).is_err());
        let mut d: Vec<f64> = x.iter().map(|v| (v - 1.25).abs()).collect();
        d.sort_by(cmp);
        assert_eq!(select_ranks(&x, &[n / 2], Some(1.25)).unwrap().unwrap(), vec![d[n / 2]]);
    }

    #[test]
    fn select_ranks_is_exact_at_every_sample_size() {
        // a sample of n^(2/3) values between SAMPLE_MIN and SAMPLE brackets the ranks: quantised values
        // (many ties), a sorted and a reversed run, with and without a centre
        for n in [SMALL + 1, 65_536, 100_000, 1 << 17] {
            let noisy: Vec<f64> = (0..n).map(|i| (((i * 2_654_435_761usize) % 1009) as f64 - 500.0) * 0.25).collect();
            let sorted: Vec<f64> = (0..n).map(|i| i as f64).collect();
            let reversed: Vec<f64> = (0..n).rev().map(|i| i as f64 * 0.5).collect();
            for x in [noisy, sorted, reversed] {
                for centre in [None, Some(3.3)] {
                    let value = |v: f64| centre.map_or(v, |c| (v - c).abs());
                    let mut s: Vec<f64> = x.iter().map(|&v| value(v)).collect();
                    s.sort_by(cmp);
                    for ks in [vec![n / 2 - 1, n / 2], vec![0, n - 1], vec![n / 20, 19 * n / 20]] {
                        let got = select_ranks(&x, &ks, centre).unwrap().unwrap();
                        assert_eq!(got, ks.iter().map(|&k| s[k]).collect::<Vec<_>>(), "n {n} ks {ks:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn histogram_counts_every_value_in_range() {
        let edges: Vec<f64> = (0..=4).map(|i| i as f64 * 0.25).collect();
        let x = [0.0, 0.25, 0.3, 0.74999, 0.75, 1.0, 1.5, -0.1];
        assert_eq!(histogram_uniform(&x, &edges).unwrap(), vec![1, 2, 1, 2]);
    }
}
