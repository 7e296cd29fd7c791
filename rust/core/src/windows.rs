//! Per-window statistics of a recording, batched over windows
//! (METHOD.md 4-6): the hot loop of `tribodyn.analyze`.
//!
//! For each window [start, start + len) of the channels fy (friction), fz
//! (normal), optionally fx (axial) and an auxiliary channel (current or
//! shunt voltage), one task computes:
//! - the centred moments of (fz, fy) and the regression of fy on fz
//!   (Eqs. 6-8, via [`crate::regression::Moments`]);
//! - Pearson C_xy(0), C_xz(0), C_yz(0) (Eq. 1 at lag 0);
//! - the deadband |fz| < d (d in newtons, or k times the window's fz
//!   standard deviation) and the equal-width fz bins over [min fz, max fz]
//!   with the per-bin mean of s fy/fz (Eq. 5), and mu_a (fz <= -d) and
//!   mu_b (fz >= +d), sample-weighted;
//! - the mean of the auxiliary channel.
//!
//! Windows are independent, so they run in parallel; each window's result
//! depends only on its samples, never on the thread count or on how the
//! caller cut the recording into chunks.

use crate::error::KernelError;
use crate::regression::Moments;
use crate::sums::sum;
use rayon::prelude::*;

/// How the deadband is given (METHOD.md 4).
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
    /// Orientation s in {+1, -1}: mu = s * slope (METHOD.md 0).
    pub orientation: f64,
    pub deadband: Deadband,
    pub n_bins: usize,
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
}

fn pearson_from(sab: f64, saa: f64, sbb: f64) -> f64 {
    let d = (saa * sbb).sqrt();
    if d > 0.0 {
        (sab / d).clamp(-1.0, 1.0)
    } else {
        f64::NAN
    }
}

/// Moments of the pairs involving fx, centred two-pass on exact window means.
fn fx_pairs(fx: &[f64], fy: &[f64], fz: &[f64], my: f64, mz: f64, syy: f64, szz: f64) -> (f64, f64) {
    let mx = crate::sums::mean(fx);
    let (mut sxx, mut sxy, mut sxz) = (0.0, 0.0, 0.0);
    for ((a, b), c) in fx.iter().zip(fy).zip(fz) {
        let dx = a - mx;
        sxx += dx * dx;
        sxy += dx * (b - my);
        sxz += dx * (c - mz);
    }
    (pearson_from(sxy, sxx, syy), pearson_from(sxz, sxx, szz))
}

/// Statistics of one window.
pub fn window_stats(
    fx: Option<&[f64]>,
    fy: &[f64],
    fz: &[f64],
    aux: Option<&[f64]>,
    opt: &WindowOptions,
) -> WindowStats {
    let n = fz.len();
    let m = Moments::of(fz, fy).unwrap_or_default();
    let c_yz = pearson_from(m.sxy, m.sxx, m.syy);
    let (c_xy, c_xz) = match fx {
        Some(fx) if n >= 2 => fx_pairs(fx, fy, fz, m.mean_y, m.mean_x, m.syy, m.sxx),
        _ => (f64::NAN, f64::NAN),
    };
    let d = match opt.deadband {
        Deadband::Force(d) => d,
        Deadband::Sigma(k) => {
            if n >= 2 {
                k * (m.sxx / (n as f64 - 1.0)).sqrt()
            } else {
                f64::NAN
            }
        }
    };
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in fz {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    let nb = opt.n_bins;
    let mut cnt = vec![0u64; nb];
    let mut acc = vec![0.0f64; nb];
    let (mut sa, mut sb, mut na, mut nbb) = (0.0, 0.0, 0u64, 0u64);
    let span = hi - lo;
    let s = opt.orientation;
    if d.is_finite() {
        for (&y, &z) in fy.iter().zip(fz) {
            if !(z.abs() >= d) || z == 0.0 {
                continue;
            }
            let mu = s * y / z;
            // Bin index of Eq. 5's re-sorting: equal widths over [lo, hi].
            let k = if span > 0.0 { (((z - lo) / span) * nb as f64) as usize } else { 0 };
            let k = k.min(nb - 1);
            cnt[k] += 1;
            acc[k] += mu;
            if z <= -d {
                sa += mu;
                na += 1;
            } else if z >= d {
                sb += mu;
                nbb += 1;
            }
        }
    }
    let mean_or_nan = |s: f64, c: u64| if c > 0 { s / c as f64 } else { f64::NAN };
    let bin_cof = acc.iter().zip(&cnt).map(|(&a, &c)| mean_or_nan(a, c)).collect();
    let aux_mean = match aux {
        Some(a) if !a.is_empty() => sum(a) / a.len() as f64,
        _ => f64::NAN,
    };
    WindowStats {
        moments: m,
        c_xy,
        c_xz,
        c_yz,
        deadband: d,
        mu_a: mean_or_nan(sa, na),
        mu_b: mean_or_nan(sb, nbb),
        n_a: na,
        n_b: nbb,
        fz_min: if n > 0 { lo } else { f64::NAN },
        fz_max: if n > 0 { hi } else { f64::NAN },
        bin_count: cnt,
        bin_cof,
        aux_mean,
    }
}

/// Statistics of every window `[starts[k], starts[k] + opt.len)` of the
/// channels, in parallel, in the order of `starts`.
pub fn windows_stats(
    fx: Option<&[f64]>,
    fy: &[f64],
    fz: &[f64],
    aux: Option<&[f64]>,
    starts: &[usize],
    opt: &WindowOptions,
) -> Result<Vec<WindowStats>, KernelError> {
    let n = fz.len();
    crate::error::same_len("fy", fy, "fz", fz)?;
    if let Some(fx) = fx {
        crate::error::same_len("fx", fx, "fz", fz)?;
    }
    if let Some(a) = aux {
        crate::error::same_len("aux", a, "fz", fz)?;
    }
    if opt.n_bins == 0 {
        return Err(KernelError::Invalid("n_bins must be at least 1".into()));
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
    let at = |s: usize| s..s + opt.len;
    Ok(starts
        .par_iter()
        .map(|&s| {
            let r = at(s);
            window_stats(fx.map(|v| &v[r.clone()]), &fy[r.clone()], &fz[r.clone()], aux.map(|v| &v[r.clone()]), opt)
        })
        .collect())
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

    #[test]
    fn one_window_by_hand() {
        let (fx, fy, fz) = rig(2000);
        let opt = WindowOptions { len: 2000, orientation: -1.0, deadband: Deadband::Force(0.35), n_bins: 16 };
        let w = window_stats(Some(&fx), &fy, &fz, None, &opt);
        let fit = w.moments.fit();
        assert!((-fit.slope - 0.12).abs() < 2e-3);
        assert!(w.c_yz < -0.99);
        // Per-bin and sided means by a plain loop.
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
        assert!(w.aux_mean.is_nan());
    }

    #[test]
    fn batch_equals_single_and_is_checked() {
        let (fx, fy, fz) = rig(10_000);
        let opt = WindowOptions { len: 1000, orientation: 1.0, deadband: Deadband::Sigma(0.7), n_bins: 8 };
        let starts = [0usize, 1000, 4321, 9000];
        let all = windows_stats(Some(&fx), &fy, &fz, Some(&fx), &starts, &opt).unwrap();
        for (s, w) in starts.iter().zip(&all) {
            let r = *s..*s + 1000;
            let one = window_stats(Some(&fx[r.clone()]), &fy[r.clone()], &fz[r.clone()], Some(&fx[r.clone()]), &opt);
            assert_eq!(format!("{one:?}"), format!("{w:?}"));
        }
        assert!(windows_stats(None, &fy, &fz, None, &[9500], &opt).is_err());
        assert!(windows_stats(None, &fy[..10], &fz, None, &[0], &opt).is_err());
    }

    #[test]
    fn deadband_excluding_everything_gives_nan() {
        let (_, fy, fz) = rig(500);
        let opt = WindowOptions { len: 500, orientation: 1.0, deadband: Deadband::Force(1e9), n_bins: 4 };
        let w = window_stats(None, &fy, &fz, None, &opt);
        assert!(w.mu_a.is_nan() && w.mu_b.is_nan());
        assert!(w.bin_cof.iter().all(|v| v.is_nan()));
    }
}
