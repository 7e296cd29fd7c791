//! The lagged sums of the instrument's lag profile (docs/method.md 3b).
//!
//! Per window of fy (y) and fz (z), both divided by a common scale and
//! centred on the window's own mean: A(L) = sum_t z_t z_{t-L} and
//! C(L) = sum_t y_t z_{t-L} (t >= L) for L = 0..=max_lag, by real FFTs
//! zero-padded to a 2^a 3^b 5^c length m >= n + max_lag + 1, so that no lag
//! wraps round. `tribodyn.pipeline.instrument.lag_profile` takes the medians
//! and sums over the windows.
//!
//! Each window is transformed on its own (two forward FFTs, the two cross
//! spectra, two inverse FFTs): its sums do not depend on the others or on
//! the thread count. The FFT's rounding error is about eps log2(m) times
//! sqrt(E_y E_z) per lag (the test compares with direct sums).

use crate::error::KernelError;
use crate::numerics::correlation::plans;
use crate::numerics::sums::mean;
use rayon::prelude::*;
use realfft::num_complex::Complex;
use realfft::{ComplexToReal, RealToComplex};

/// The smallest 2^a 3^b 5^c >= `at_least` (>= 1): the profile's FFT length.
pub fn fft_length(at_least: usize) -> usize {
    smooth_length(at_least, true)
}

/// The smallest 2^a 3^b (with `fives`, 2^a 3^b 5^c) >= `need` (>= 1): a length the FFT is fast at (also
/// the correlation's, without fives).
pub(crate) fn smooth_length(need: usize, fives: bool) -> usize {
    let need = need.max(1);
    let mut best = need.next_power_of_two();
    let mut p5 = 1usize;
    while p5 < best {
        let mut p35 = p5;
        while p35 < best {
            let mut q = p35;
            while q < need {
                q *= 2;
            }
            best = best.min(q);
            p35 *= 3;
        }
        if !fives {
            break;
        }
        p5 *= 5;
    }
    best
}

/// Scratch of one thread: the padded signals, their spectra and the FFTs' own scratch.
struct Scratch {
    y: Vec<f64>,
    z: Vec<f64>,
    sy: Vec<Complex<f64>>,
    sz: Vec<Complex<f64>>,
    work: Vec<Complex<f64>>,
}

impl Scratch {
    fn new(m: usize, fwd: &dyn RealToComplex<f64>, inv: &dyn ComplexToReal<f64>) -> Scratch {
        let spec = m / 2 + 1;
        let work = fwd.get_scratch_len().max(inv.get_scratch_len());
        Scratch {
            y: vec![0.0; m],
            z: vec![0.0; m],
            sy: vec![Complex::new(0.0, 0.0); spec],
            sz: vec![Complex::new(0.0, 0.0); spec],
            work: vec![Complex::new(0.0, 0.0); work],
        }
    }
}

/// (A, C), each `windows * (max_lag + 1)` values, window by window: the lagged sums of the windows of `n`
/// samples laid end to end in `y` and `z` (equal lengths, a multiple of `n`), divided by `scale` (> 0) and
/// centred. The windows run on the current pool's threads; the result does not depend on their number.
pub fn lagged_sums(
    y: &[f64],
    z: &[f64],
    n: usize,
    max_lag: usize,
    scale: f64,
) -> Result<(Vec<f64>, Vec<f64>), KernelError> {
    if n == 0 || y.len() != z.len() || y.len() % n != 0 {
        return Err(KernelError::Invalid(format!(
            "y and z must hold whole windows of n samples each, got n = {n}, {} and {} values",
            y.len(),
            z.len()
        )));
    }
    if max_lag >= n {
        return Err(KernelError::LagOutOfRange { max_lag, n });
    }
    if !(scale.is_finite() && scale > 0.0) {
        return Err(KernelError::Invalid(format!("scale must be finite and > 0, got {scale}")));
    }
    let k = y.len() / n;
    let w = max_lag + 1;
    let m = fft_length(n + max_lag + 1);
    let (fwd, inv) = plans(m);
    let mut a = vec![0.0; k * w];
    let mut c = vec![0.0; k * w];
    let run = |s: &mut Scratch, j: usize, aj: &mut [f64], cj: &mut [f64]| -> Result<(), KernelError> {
        window(&*fwd, &*inv, s, &y[j * n..(j + 1) * n], &z[j * n..(j + 1) * n], scale, aj, cj)
    };
    if crate::parallel::current() > 1 && k > 1 {
        a.par_chunks_mut(w)
            .zip(c.par_chunks_mut(w))
            .enumerate()
            .try_for_each_init(|| Scratch::new(m, &*fwd, &*inv), |s, (j, (aj, cj))| run(s, j, aj, cj))?;
    } else {
        let mut s = Scratch::new(m, &*fwd, &*inv);
        for (j, (aj, cj)) in a.chunks_mut(w).zip(c.chunks_mut(w)).enumerate() {
            run(&mut s, j, aj, cj)?;
        }
    }
    Ok((a, c))
}

/// One window's A and C (see [`lagged_sums`]).
#[allow(clippy::too_many_arguments)]
fn window(
    fwd: &dyn RealToComplex<f64>,
    inv: &dyn ComplexToReal<f64>,
    s: &mut Scratch,
    y: &[f64],
    z: &[f64],
    scale: f64,
    a: &mut [f64],
    c: &mut [f64],
) -> Result<(), KernelError> {
    let n = y.len();
    for (dst, src) in [(&mut s.y, y), (&mut s.z, z)] {
        for (d, &v) in dst.iter_mut().zip(src) {
            *d = v / scale;
        }
        let mu = mean(&dst[..n]);
        dst[..n].iter_mut().for_each(|d| *d -= mu);
        dst[n..].fill(0.0);
    }
    let fft_err = |e: realfft::FftError| KernelError::Invalid(format!("FFT failed: {e}"));
    fwd.process_with_scratch(&mut s.y, &mut s.sy, &mut s.work).map_err(fft_err)?;
    fwd.process_with_scratch(&mut s.z, &mut s.sz, &mut s.work).map_err(fft_err)?;
    for (py, pz) in s.sy.iter_mut().zip(s.sz.iter_mut()) {
        let cz = pz.conj();
        *py *= cz;
        *pz *= cz;
    }
    // A real signal's spectrum has real first and last (even m) bins; the products keep them real up to
    // rounding, which the inverse transform requires exactly.
    for spec in [&mut s.sy, &mut s.sz] {
        spec[0].im = 0.0;
        if s.y.len() % 2 == 0 {
            let last = spec.len() - 1;
            spec[last].im = 0.0;
        }
    }
    inv.process_with_scratch(&mut s.sy, &mut s.y, &mut s.work).map_err(fft_err)?;
    inv.process_with_scratch(&mut s.sz, &mut s.z, &mut s.work).map_err(fft_err)?;
    let norm = 1.0 / s.y.len() as f64;
    for (l, (ca, cc)) in a.iter_mut().zip(c.iter_mut()).enumerate() {
        *cc = s.y[l] * norm;
        *ca = s.z[l] * norm;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn direct(y: &[f64], z: &[f64], max_lag: usize, scale: f64) -> (Vec<f64>, Vec<f64>) {
        let n = y.len();
        let my = y.iter().map(|v| v / scale).sum::<f64>() / n as f64;
        let mz = z.iter().map(|v| v / scale).sum::<f64>() / n as f64;
        let yc: Vec<f64> = y.iter().map(|v| v / scale - my).collect();
        let zc: Vec<f64> = z.iter().map(|v| v / scale - mz).collect();
        let mut a = vec![0.0; max_lag + 1];
        let mut c = vec![0.0; max_lag + 1];
        for l in 0..=max_lag {
            for t in l..n {
                a[l] += zc[t] * zc[t - l];
                c[l] += yc[t] * zc[t - l];
            }
        }
        (a, c)
    }

    #[test]
    fn lagged_sums_are_the_direct_sums_at_any_thread_count() {
        let (n, k, max_lag) = (157usize, 5usize, 78usize);
        let mut state = 12345u64;
        let mut rnd = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
        };
        let z: Vec<f64> = (0..n * k).map(|i| 5.0 + rnd() + 0.3 * (i as f64 / 3.0).sin()).collect();
        let y: Vec<f64> = z.iter().enumerate().map(|(i, v)| 0.1 * v + 0.05 * rnd() + (i % 7) as f64 * 1e-3).collect();
        let one = crate::parallel::run_with(1, || lagged_sums(&y, &z, n, max_lag, 7.0)).unwrap().unwrap();
        let two = crate::parallel::run_with(2, || lagged_sums(&y, &z, n, max_lag, 7.0)).unwrap().unwrap();
        assert_eq!(
            one.0.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            two.0.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        assert_eq!(
            one.1.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
            two.1.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
        );
        for j in 0..k {
            let (a, c) = direct(&y[j * n..(j + 1) * n], &z[j * n..(j + 1) * n], max_lag, 7.0);
            for l in 0..=max_lag {
                assert!((one.0[j * (max_lag + 1) + l] - a[l]).abs() < 1e-12 * (1.0 + a[0].abs()));
                assert!((one.1[j * (max_lag + 1) + l] - c[l]).abs() < 1e-12 * (1.0 + a[0].abs()));
            }
        }
    }

    #[test]
    fn bad_shapes_are_errors_not_panics() {
        assert!(lagged_sums(&[1.0; 10], &[1.0; 9], 5, 2, 1.0).is_err());
        assert!(lagged_sums(&[1.0; 10], &[1.0; 10], 3, 2, 1.0).is_err());
        assert!(lagged_sums(&[1.0; 10], &[1.0; 10], 5, 5, 1.0).is_err());
        assert!(lagged_sums(&[1.0; 10], &[1.0; 10], 0, 0, 1.0).is_err());
        assert!(lagged_sums(&[1.0; 10], &[1.0; 10], 5, 2, 0.0).is_err());
        assert!(lagged_sums(&[], &[], 5, 2, 1.0).unwrap().0.is_empty());
    }

    #[test]
    fn smooth_lengths_are_the_next_smooth_numbers() {
        let smooth = |n: usize, fives: bool| {
            (n..).find(|&m| {
                let mut r = m;
                for p in [2, 3, 5] {
                    if p == 5 && !fives {
                        break;
                    }
                    while r % p == 0 {
                        r /= p;
                    }
                }
                r == 1
            })
        };
        for n in 1..5000 {
            assert_eq!(Some(smooth_length(n, true)), smooth(n, true), "{n}");
            assert_eq!(Some(smooth_length(n, false)), smooth(n, false), "{n}");
        }
    }

    #[test]
    fn fft_length_is_the_next_2_3_5_smooth_number() {
        assert_eq!(fft_length(3000), 3000);
        assert_eq!(fft_length(3001), 3072);
        assert_eq!(fft_length(1), 1);
        assert_eq!(fft_length(7), 8);
        assert_eq!(fft_length(11), 12);
    }
}
