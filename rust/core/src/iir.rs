//! Streaming IIR filtering with second-order sections (METHOD.md 2).
//!
//! The recurrence is transposed direct form II per section, written with the
//! same operations in the same order as `scipy.signal.sosfilt`:
//!
//! ```text
//! y      = b0 x + z0
//! z0'    = (b1 x - a1 y) + z1
//! z1'    =  b2 x - a2 y
//! ```
//!
//! State is one `[z0, z1]` pair per section per channel, carried between
//! calls, so filtering a signal in chunks of any sizes gives bitwise the
//! same output as one call. The recursion is latency-bound (each sample
//! waits for the previous one), so several channels are run in lockstep in
//! one loop: their chains are independent and the CPU overlaps them.

use crate::error::KernelError;
use rayon::prelude::*;

/// One second-order section `[b0, b1, b2, a0, a1, a2]` with a0 == 1.
pub type Section = [f64; 6];

/// Checks an SOS matrix: at least one section, finite, a0 == 1.
pub fn validate_sos(sos: &[Section]) -> Result<(), KernelError> {
    if sos.is_empty() {
        return Err(KernelError::Invalid("sos must have at least one section".into()));
    }
    for (k, s) in sos.iter().enumerate() {
        if s.iter().any(|v| !v.is_finite()) {
            return Err(KernelError::Invalid(format!("sos section {k} has a non-finite coefficient")));
        }
        if s[3] != 1.0 {
            return Err(KernelError::Invalid(format!("sos section {k} must have a0 = 1, got {}", s[3])));
        }
    }
    Ok(())
}

/// Samples per block: each section runs over a block that stays in cache.
/// Running section after section over a block is the same arithmetic as
/// sample after sample through all sections, so blocking changes nothing.
const BLOCK: usize = 2048;

/// Most channels run in lockstep on one thread.
const MAX_LOCKSTEP: usize = 4;

/// One section over `K` equally long channel blocks, in lockstep, in place.
fn section_lockstep<const K: usize>(sec: &Section, rows: &mut [&mut [f64]], z: &mut [[f64; 2]; K]) {
    let [b0, b1, b2, _, a1, a2] = *sec;
    let len = rows.iter().map(|r| r.len()).min().unwrap_or(0);
    let mut z0 = [0.0; K];
    let mut z1 = [0.0; K];
    for c in 0..K {
        z0[c] = z[c][0];
        z1[c] = z[c][1];
    }
    for t in 0..len {
        for c in 0..K {
            let x = rows[c][t];
            let y = b0 * x + z0[c];
            z0[c] = (b1 * x - a1 * y) + z1[c];
            z1[c] = b2 * x - a2 * y;
            rows[c][t] = y;
        }
    }
    for c in 0..K {
        z[c] = [z0[c], z1[c]];
    }
}

/// Filters a group of up to [`MAX_LOCKSTEP`] channels in place.
/// `rows[c]` is channel c, `state[c]` its `n_sections` state pairs.
fn filter_group(sos: &[Section], rows: &mut [&mut [f64]], state: &mut [&mut [[f64; 2]]]) {
    fn run<const K: usize>(sos: &[Section], rows: &mut [&mut [f64]], state: &mut [&mut [[f64; 2]]]) {
        let n = rows.iter().map(|r| r.len()).min().unwrap_or(0);
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            let mut block: Vec<&mut [f64]> = rows.iter_mut().map(|r| &mut r[start..end]).collect();
            for (s, sec) in sos.iter().enumerate() {
                let mut z = [[0.0; 2]; K];
                for c in 0..K {
                    z[c] = state[c][s];
                }
                section_lockstep::<K>(sec, &mut block, &mut z);
                for c in 0..K {
                    state[c][s] = z[c];
                }
            }
            start = end;
        }
    }
    match rows.len() {
        0 => {}
        1 => run::<1>(sos, rows, state),
        2 => run::<2>(sos, rows, state),
        3 => run::<3>(sos, rows, state),
        _ => run::<4>(sos, rows, state),
    }
}

/// Filters `channels` rows of `n` samples stored row-major in `data`, in
/// place, carrying `state` (`channels * n_sections` pairs, row-major).
/// Channels are split into lockstep groups spread over the thread pool.
pub fn sosfilt_inplace(
    sos: &[Section],
    data: &mut [f64],
    channels: usize,
    state: &mut [[f64; 2]],
) -> Result<(), KernelError> {
    validate_sos(sos)?;
    if channels == 0 {
        return Err(KernelError::Invalid("channels must be at least 1".into()));
    }
    if data.len() % channels != 0 {
        return Err(KernelError::Invalid(format!(
            "data length {} is not a multiple of the channel count {channels}",
            data.len()
        )));
    }
    let ns = sos.len();
    if state.len() != channels * ns {
        return Err(KernelError::Invalid(format!(
            "state must hold {channels} x {ns} section states, got {}",
            state.len()
        )));
    }
    let n = data.len() / channels;
    if n == 0 {
        return Ok(());
    }
    let threads = crate::parallel::threads().max(1);
    let group = channels.div_ceil(threads).clamp(1, MAX_LOCKSTEP);
    let mut rows: Vec<&mut [f64]> = data.chunks_mut(n).collect();
    let mut states: Vec<&mut [[f64; 2]]> = state.chunks_mut(ns).collect();
    let work = |(r, s): (&mut [&mut [f64]], &mut [&mut [[f64; 2]]])| filter_group(sos, r, s);
    if channels <= group {
        work((&mut rows, &mut states));
    } else {
        rows.par_chunks_mut(group).zip(states.par_chunks_mut(group)).for_each(work);
    }
    Ok(())
}

/// Steady-state initial conditions for a unit step (scipy's `sosfilt_zi`):
/// the state each section holds after a constant input forever. Multiply by
/// the first sample to start a DC-coupled signal without a transient.
pub fn sosfilt_zi(sos: &[Section]) -> Result<Vec<[f64; 2]>, KernelError> {
    validate_sos(sos)?;
    let mut zi = Vec::with_capacity(sos.len());
    let mut scale = 1.0; // DC gain of the sections before this one
    for &[b0, b1, b2, _, a1, a2] in sos {
        // Steady state of one section for a constant input u: y = g u with
        // g = (b0+b1+b2)/(1+a1+a2); z1 = (b2 - a2 g) u, z0 = y - b0 u.
        let den = 1.0 + a1 + a2;
        if den == 0.0 {
            return Err(KernelError::Invalid("sos has a pole at z = 1: no steady state exists".into()));
        }
        let g = (b0 + b1 + b2) / den;
        let z1 = b2 - a2 * g;
        let z0 = (b1 - a1 * g) + z1;
        zi.push([scale * z0, scale * z1]);
        scale *= g;
    }
    Ok(zi)
}

#[cfg(test)]
mod tests {
    use super::*;

    // Butterworth order 2 high-pass, fc = 0.1 Hz at 1 kHz, from scipy.
    const HP2: Section = [0.999555802071375, -1.99911160414275, 0.999555802071375, 1.0, -1.9991114067771, 0.999111801508402];

    fn reference(sos: &[Section], x: &[f64], state: &mut [[f64; 2]]) -> Vec<f64> {
        x.iter()
            .map(|&v| {
                let mut u = v;
                for (s, sec) in sos.iter().enumerate() {
                    let y = sec[0] * u + state[s][0];
                    state[s][0] = (sec[1] * u - sec[4] * y) + state[s][1];
                    state[s][1] = sec[2] * u - sec[5] * y;
                    u = y;
                }
                u
            })
            .collect()
    }

    fn signal(n: usize) -> Vec<f64> {
        (0..n).map(|i| (i as f64 * 0.37).sin() + 0.01 * i as f64 + 3.0).collect()
    }

    #[test]
    fn matches_per_sample_recurrence_and_chunks() {
        let sos = [HP2, [0.5, 0.1, 0.0, 1.0, -0.3, 0.0]];
        let x = signal(8000);
        let mut s_ref = vec![[0.0; 2]; 2];
        let want = reference(&sos, &x, &mut s_ref);
        for channels in 1..=6 {
            let mut data: Vec<f64> = (0..channels).flat_map(|_| x.clone()).collect();
            let mut state = vec![[0.0; 2]; 2 * channels];
            sosfilt_inplace(&sos, &mut data, channels, &mut state).unwrap();
            for c in 0..channels {
                assert_eq!(&data[c * 8000..(c + 1) * 8000], &want[..]);
                assert_eq!(&state[c * 2..c * 2 + 2], &s_ref[..]);
            }
        }
        // Chunks of odd sizes, state carried: bitwise the same.
        let mut state = vec![[0.0; 2]; 2];
        let mut out = Vec::new();
        let mut start = 0;
        for len in [0usize, 1, 7, 2047, 2048, 2049, 1] {
            let mut chunk = x[start..start + len].to_vec();
            sosfilt_inplace(&sos, &mut chunk, 1, &mut state).unwrap();
            out.extend(chunk);
            start += len;
        }
        let mut rest = x[start..].to_vec();
        sosfilt_inplace(&sos, &mut rest, 1, &mut state).unwrap();
        out.extend(rest);
        assert_eq!(out, want);
    }

    #[test]
    fn steady_state_removes_dc_transient() {
        let sos = [HP2];
        let x = vec![5.0; 3000];
        let mut state: Vec<[f64; 2]> = sosfilt_zi(&sos).unwrap().iter().map(|z| [z[0] * 5.0, z[1] * 5.0]).collect();
        let mut y = x.clone();
        sosfilt_inplace(&sos, &mut y, 1, &mut state).unwrap();
        assert!(y.iter().all(|v| v.abs() < 1e-9), "max {}", y.iter().fold(0.0f64, |a, b| a.max(b.abs())));
    }

    #[test]
    fn bad_sos_and_shapes_are_errors() {
        let mut d = vec![0.0; 10];
        let mut st = vec![[0.0; 2]; 1];
        assert!(sosfilt_inplace(&[], &mut d, 1, &mut st).is_err());
        assert!(sosfilt_inplace(&[[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]], &mut d, 1, &mut st).is_err());
        assert!(sosfilt_inplace(&[HP2], &mut d, 3, &mut st).is_err());
        assert!(sosfilt_inplace(&[HP2], &mut d, 2, &mut st).is_err());
        assert!(sosfilt_zi(&[[1.0, 0.0, 0.0, 1.0, -1.0, 0.0]]).is_err());
    }
}
