//! Local maxima and their topographic prominence (docs/method.md 6g).
//!
//! [`find_peaks`] returns what `scipy.signal.find_peaks(x, prominence=p,
//! wlen=w)` returns, index for index: a peak is a sample (or the middle of
//! a flat plateau, rounded down) above its left neighbour and above the
//! first different sample to its right, never the first or last sample; its
//! prominence is its height above the higher of the lowest points on each
//! side, each searched from the peak outwards until a higher sample or the
//! edge of the window of `w` samples centred on it (`w / 2` each side); a
//! peak is kept when `p <= prominence`. The comparisons are SciPy's, so an
//! infinite sample works as a wall (the stick-slip search puts +inf between
//! runs) and a NaN compares false as it does there.
//!
//! It is here so that an analysis does not import `scipy.signal` (about two
//! seconds per process on a small machine) for one function; the parity test
//! is `tests/kernels/test_peaks.py`.

/// Indices of the local maxima of `x` (plateau midpoints), ascending.
pub fn local_maxima(x: &[f64]) -> Vec<usize> {
    let n = x.len();
    let mut out = Vec::new();
    if n < 3 {
        return out;
    }
    let last = n - 1;
    let mut i = 1;
    while i < last {
        if x[i - 1] < x[i] {
            let mut ahead = i + 1;
            while ahead < last && x[ahead] == x[i] {
                ahead += 1;
            }
            if x[ahead] < x[i] {
                out.push((i + ahead - 1) / 2);
                i = ahead;
            }
        }
        i += 1;
    }
    out
}

/// `v <= top` as SciPy's loop condition reads it: false for a NaN on either side.
fn not_above(v: f64, top: f64) -> bool {
    matches!(v.partial_cmp(&top), Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal))
}

/// The prominence of the peak at `peak`, searched within `wlen / 2` samples
/// each side when `wlen >= 2` (else to the array's ends).
pub fn prominence(x: &[f64], peak: usize, wlen: usize) -> f64 {
    let (mut lo, mut hi) = (0usize, x.len() - 1);
    if wlen >= 2 {
        lo = lo.max(peak.saturating_sub(wlen / 2));
        hi = hi.min(peak.saturating_add(wlen / 2));
    }
    let top = x[peak];
    let mut left_min = top;
    let mut i = peak;
    loop {
        if !not_above(x[i], top) {
            break;
        }
        if x[i] < left_min {
            left_min = x[i];
        }
        if i == lo {
            break;
        }
        i -= 1;
    }
    let mut right_min = top;
    for &v in &x[peak..=hi] {
        if !not_above(v, top) {
            break;
        }
        if v < right_min {
            right_min = v;
        }
    }
    top - left_min.max(right_min)
}

/// The local maxima of `x` whose prominence (within `wlen` samples) is at
/// least `min_prominence`, ascending.
pub fn find_peaks(x: &[f64], min_prominence: f64, wlen: usize) -> Vec<usize> {
    local_maxima(x).into_iter().filter(|&p| min_prominence <= prominence(x, p, wlen)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plateaus_edges_and_walls() {
        // a plateau's middle (rounded down), never an edge, a plateau that rises again is no peak
        assert_eq!(local_maxima(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0]), vec![2]);
        assert_eq!(local_maxima(&[2.0, 1.0, 3.0]), Vec::<usize>::new());
        assert_eq!(local_maxima(&[0.0, 1.0, 1.0, 2.0, 0.0]), vec![3]);
        assert_eq!(local_maxima(&[0.0, 1.0]), Vec::<usize>::new());
        // prominence: height above the higher of the two bases
        let x = [0.0, 3.0, 1.0, 2.0, 0.5, f64::INFINITY, 0.0, 1.0, 0.0];
        assert_eq!(local_maxima(&x), vec![1, 3, 5, 7]);
        assert_eq!(prominence(&x, 3, 0), 1.0);
        assert_eq!(prominence(&x, 1, 0), 2.5); // the wall stops the right search at 0.5
        assert_eq!(prominence(&x, 7, 0), 1.0); // the wall stops the left search too
        assert_eq!(find_peaks(&x, 1.5, 0), vec![1, 5]);
        // a window of 3 sees one sample each side
        let y = [0.0, 5.0, 4.0, 4.5, 4.0, 5.0, 0.0];
        assert_eq!(prominence(&y, 3, 3), 0.5);
        assert_eq!(prominence(&y, 1, 3), 1.0);
        assert_eq!(prominence(&y, 1, 0), 5.0);
    }
}
