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
fn rank(v: &mut [f64], k: usize, fixed: &mut Vec<usize>) -> f64 {
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

fn one_row(v: &mut [f64], qs: &[f64], median: &mut f64, out: &mut [f64]) {
    let k = v.len();
    if k == 0 {
        *median = f64::NAN;
        out.iter_mut().for_each(|o| *o = f64::NAN);
        return;
    }
    let mut fixed: Vec<usize> = Vec::with_capacity(8);
    let h = k / 2;
    let hi = rank(v, h, &mut fixed);
    *median = if k % 2 == 1 {
        (0.0 + (0.0 + hi)) / 1.0
    } else {
        let lo = rank(v, h - 1, &mut fixed);
        (0.0 + ((0.0 + lo) + hi)) / 2.0
    };
    for (o, &q) in out.iter_mut().zip(qs) {
        // numpy.quantile, method "linear": _get_indexes, _get_gamma, _lerp
        let vi = (k as f64 - 1.0) * q;
        let prev = vi.floor();
        let (p, n, g) =
            if vi >= k as f64 - 1.0 { (k - 1, k - 1, vi + 1.0) } else { (prev as usize, prev as usize + 1, vi - prev) };
        let a = rank(v, p, &mut fixed);
        let b = rank(v, n, &mut fixed);
        let diff = b - a;
        *o = if g >= 0.5 { b - diff * (1.0 - g) } else { a + diff * g };
    }
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
}
