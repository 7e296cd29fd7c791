//! Streaming IIR filtering with second-order sections (docs/method.md 2).
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

/// One section over `K` equally long channel blocks, in lockstep: from `src`
/// into `dst` when `FROM_SRC`, else in place in `dst`.
///
/// First-order sections (b2 = a2 = 0, the default Butterworth design) take
/// a shorter dependency chain with the same bits. Their z1 is
/// b2 x - a2 y = +-0 while x and y are finite, and w + (+-0) == w for
/// every finite w != 0, so z1 only has to be added (in a cold branch that
/// the CPU predicts, off the chain) when w = b1 x - a1 y is 0 or not
/// finite. A non-finite x or y makes every later w non-finite (inf and NaN
/// never turn finite again in this recurrence), so that test also covers
/// them. The carried z1 enters through an exact first step and the last z1
/// is formed exactly, so chunking changes nothing.
#[inline(always)]
fn section_lockstep<const K: usize, const FROM_SRC: bool>(
    sec: &Section,
    src: &[&[f64]; K],
    dst: &mut [&mut [f64]; K],
    z: &mut [[f64; 2]; K],
) {
    let [b0, b1, b2, _, a1, a2] = *sec;
    let len = dst.iter().map(|r| r.len()).min().unwrap_or(0);
    let len = if FROM_SRC { src.iter().map(|r| r.len()).fold(len, usize::min) } else { len };
    if len == 0 {
        return;
    }
    // Equal lengths let the compiler drop the bounds checks in the loops.
    let src: [&[f64]; K] = std::array::from_fn(|c| if FROM_SRC { &src[c][..len] } else { &[][..] });
    let dst: [&mut [f64]; K] = std::array::from_fn(|c| {
        let row = std::mem::take(&mut dst[c]);
        &mut row[..len]
    });
    let load = |c: usize, t: usize, dst: &[&mut [f64]; K]| -> f64 {
        if FROM_SRC {
            src[c][t]
        } else {
            dst[c][t]
        }
    };
    let mut z0: [f64; K] = std::array::from_fn(|c| z[c][0]);
    let mut z1: [f64; K] = std::array::from_fn(|c| z[c][1]);
    if b2 == 0.0 && a2 == 0.0 {
        // Exact first step with the carried z1.
        let mut last = [(0.0, 0.0); K];
        for c in 0..K {
            let x = load(c, 0, &dst);
            let y = b0 * x + z0[c];
            z0[c] = (b1 * x - a1 * y) + z1[c];
            dst[c][0] = y;
            last[c] = (x, y);
        }
        for t in 1..len {
            for c in 0..K {
                let x = load(c, t, &dst);
                let y = b0 * x + z0[c];
                let w = b1 * x - a1 * y;
                z0[c] = if w != 0.0 && w.is_finite() { w } else { add_z1(w, b2, a2, last[c]) };
                dst[c][t] = y;
                last[c] = (x, y);
            }
        }
        for c in 0..K {
            let (x, y) = last[c];
            z1[c] = b2 * x - a2 * y;
        }
    } else {
        for t in 0..len {
            for c in 0..K {
                let x = load(c, t, &dst);
                let y = b0 * x + z0[c];
                z0[c] = (b1 * x - a1 * y) + z1[c];
                z1[c] = b2 * x - a2 * y;
                dst[c][t] = y;
            }
        }
    }
    for c in 0..K {
        z[c] = [z0[c], z1[c]];
    }
}

/// The full z0 update of a first-order section, (w) + (b2 x - a2 y), for the
/// rare samples where dropping the +-0 term could change a bit.
#[cold]
#[inline(never)]
fn add_z1(w: f64, b2: f64, a2: f64, (x, y): (f64, f64)) -> f64 {
    w + (b2 * x - a2 * y)
}

/// Filters a group of up to [`MAX_LOCKSTEP`] channels in place.
/// `rows[c]` is channel c, `state[c]` its `n_sections` state pairs. With
/// `src`, the first section reads `src[c]` and writes `rows[c]` (so the
/// output is written once, by the thread that filters it, and the copy
/// rides along the latency-bound recursion); returns whether every input
/// sample was finite (in place: whether the final state is).
fn filter_group(
    sos: &[Section],
    src: Option<&[&[f64]]>,
    rows: &mut [&mut [f64]],
    state: &mut [&mut [[f64; 2]]],
) -> bool {
    fn run<const K: usize>(
        sos: &[Section],
        src: Option<&[&[f64]]>,
        rows: &mut [&mut [f64]],
        state: &mut [&mut [[f64; 2]]],
    ) -> bool {
        let n = rows.iter().map(|r| r.len()).min().unwrap_or(0);
        let n = src.map_or(n, |s| s.iter().map(|r| r.len()).fold(n, usize::min));
        let mut start = 0;
        while start < n {
            let end = (start + BLOCK).min(n);
            for (s, sec) in sos.iter().enumerate() {
                let mut z: [[f64; 2]; K] = std::array::from_fn(|c| state[c][s]);
                let mut it = rows.iter_mut();
                let mut dst: [&mut [f64]; K] = std::array::from_fn(|_| match it.next() {
                    Some(r) => &mut r[start..end],
                    None => Default::default(),
                });
                match src {
                    Some(src) if s == 0 => {
                        let blk: [&[f64]; K] = std::array::from_fn(|c| src.get(c).map_or(&[][..], |r| &r[start..end]));
                        section_lockstep::<K, true>(sec, &blk, &mut dst, &mut z);
                    }
                    _ => section_lockstep::<K, false>(sec, &[&[]; K], &mut dst, &mut z),
                }
                for c in 0..K {
                    state[c][s] = z[c];
                }
            }
            start = end;
        }
        // A NaN or inf in the input leaves the first section's z0 non-finite
        // for good; a finite z0 proves the input finite. Otherwise (also on
        // overflow) look at the input itself.
        let settled = state.iter().all(|s| s.first().is_none_or(|z| z[0].is_finite()));
        settled || src.is_none_or(|src| src.iter().all(|r| crate::numerics::sums::all_finite(&r[..n])))
    }
    match rows.len() {
        0 => true,
        1 => run::<1>(sos, src, rows, state),
        2 => run::<2>(sos, src, rows, state),
        3 => run::<3>(sos, src, rows, state),
        _ => run::<4>(sos, src, rows, state),
    }
}

/// Filters up to four channels `src[c]` into `out[c]` on the calling
/// thread, carrying `state[c]` (its `n_sections` pairs): the same bits as
/// [`sosfilt_into`]. Returns whether every input sample was finite.
pub(crate) fn filter_rows(
    sos: &[Section],
    src: &[&[f64]],
    out: &mut [&mut [f64]],
    state: &mut [&mut [[f64; 2]]],
) -> bool {
    debug_assert!(src.len() == out.len() && out.len() == state.len() && out.len() <= MAX_LOCKSTEP);
    filter_group(sos, Some(src), out, state)
}

/// Checks the shapes shared by [`sosfilt_inplace`] and [`sosfilt_into`];
/// returns the samples per channel.
fn check_shapes(sos: &[Section], len: usize, channels: usize, state: &[[f64; 2]]) -> Result<usize, KernelError> {
    validate_sos(sos)?;
    if channels == 0 {
        return Err(KernelError::Invalid("channels must be at least 1".into()));
    }
    if len % channels != 0 {
        return Err(KernelError::Invalid(format!(
            "data length {len} is not a multiple of the channel count {channels}"
        )));
    }
    let ns = sos.len();
    if state.len() != channels * ns {
        return Err(KernelError::Invalid(format!(
            "state must hold {channels} x {ns} section states, got {}",
            state.len()
        )));
    }
    Ok(len / channels)
}

/// Samples (all channels together) below which filtering stays on the
/// calling thread: entering the pool costs more than a short chunk.
const SERIAL_SAMPLES: usize = 1 << 16;

/// Whether filtering `channels` rows of `n` samples on `threads` threads
/// uses a pool; when not, callers need not enter one.
pub fn uses_threads(n: usize, channels: usize, threads: usize) -> bool {
    channels > 1 && n.saturating_mul(channels) >= SERIAL_SAMPLES && threads > 1
}

/// Channels are split into lockstep groups spread over the thread pool.
fn filter_channels(
    sos: &[Section],
    src: Option<&[f64]>,
    data: &mut [f64],
    n: usize,
    channels: usize,
    state: &mut [[f64; 2]],
) -> bool {
    if n == 0 {
        return true;
    }
    let ns = sos.len();
    // The pool the caller entered (1 outside every pool).
    let par = uses_threads(n, channels, crate::parallel::current());
    let threads = if par { crate::parallel::current() } else { 1 };
    let group = channels.div_ceil(threads).clamp(1, MAX_LOCKSTEP);
    let mut rows: Vec<&mut [f64]> = data.chunks_mut(n).collect();
    let mut states: Vec<&mut [[f64; 2]]> = state.chunks_mut(ns).collect();
    let src_rows: Vec<&[f64]> = src.map(|s| s.chunks(n).collect()).unwrap_or_default();
    let src_groups: Vec<Option<&[&[f64]]>> =
        if src.is_some() { src_rows.chunks(group).map(Some).collect() } else { vec![None; channels.div_ceil(group)] };
    if channels <= group {
        filter_group(sos, src_groups[0], &mut rows, &mut states)
    } else if !par {
        let mut finite = true;
        for ((r, s), src) in rows.chunks_mut(group).zip(states.chunks_mut(group)).zip(src_groups) {
            finite &= filter_group(sos, src, r, s);
        }
        finite
    } else {
        rows.par_chunks_mut(group)
            .zip(states.par_chunks_mut(group))
            .zip(src_groups.into_par_iter())
            .map(|((r, s), src)| filter_group(sos, src, r, s))
            .reduce(|| true, |a, b| a && b)
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
    let n = check_shapes(sos, data.len(), channels, state)?;
    filter_channels(sos, None, data, n, channels, state);
    Ok(())
}

/// Filters `src` into `out` (both `channels` rows of `n` samples,
/// row-major), carrying `state` like [`sosfilt_inplace`], with the same
/// bits. Returns whether every input sample was finite, checked on the way
/// at no extra pass over memory. Each thread copies the rows it filters,
/// block by block, so a fresh output is first touched by that thread and
/// stays in cache between the copy and the recursion.
pub fn sosfilt_into(
    sos: &[Section],
    src: &[f64],
    out: &mut [f64],
    channels: usize,
    state: &mut [[f64; 2]],
) -> Result<bool, KernelError> {
    if src.len() != out.len() {
        return Err(KernelError::LengthMismatch { a: "src", b: "out", len_a: src.len(), len_b: out.len() });
    }
    let n = check_shapes(sos, out.len(), channels, state)?;
    Ok(filter_channels(sos, Some(src), out, n, channels, state))
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
    const HP2: Section =
        [0.999555802071375, -1.99911160414275, 0.999555802071375, 1.0, -1.9991114067771, 0.999111801508402];

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
    fn into_matches_inplace_and_flags_non_finite() {
        let sos = [HP2, [0.5, 0.1, 0.0, 1.0, -0.3, 0.0]];
        let x = signal(5001);
        for channels in 1..=5 {
            let src: Vec<f64> = (0..channels).flat_map(|c| x.iter().map(move |v| v * (c + 1) as f64)).collect();
            let mut a = src.clone();
            let mut sa = vec![[0.1, -0.2]; 2 * channels];
            sosfilt_inplace(&sos, &mut a, channels, &mut sa).unwrap();
            let mut b = vec![0.0; src.len()];
            let mut sb = vec![[0.1, -0.2]; 2 * channels];
            assert!(sosfilt_into(&sos, &src, &mut b, channels, &mut sb).unwrap());
            assert_eq!(a, b);
            assert_eq!(sa, sb);
        }
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for at in [0usize, 3, 2047, 2048, 5000] {
                let mut src: Vec<f64> = x.iter().chain(&x).copied().collect();
                src[5001 + at] = bad;
                let mut out = vec![0.0; src.len()];
                let mut st = vec![[0.0; 2]; 4];
                assert!(!sosfilt_into(&sos, &src, &mut out, 2, &mut st).unwrap());
            }
        }
        let mut out = vec![0.0; 3];
        assert!(sosfilt_into(&sos, &x[..4], &mut out, 1, &mut [[0.0; 2]; 2]).is_err());
    }

    #[test]
    fn first_order_shortcut_keeps_every_bit() {
        // Butterworth order 1 (b2 = a2 = 0) and a first-order section with
        // a2 = -0.0; inputs with signed zeros, runs of zeros, inf and NaN.
        let hp1: Section = [0.9996859, -0.9996859, 0.0, 1.0, -0.9993718, 0.0];
        let odd: Section = [-0.25, 0.5, -0.0, 1.0, 0.5, -0.0];
        let mut x = signal(6000);
        for (i, v) in x.iter_mut().enumerate() {
            match i % 997 {
                0..=40 => *v = 0.0,
                41..=60 => *v = -0.0,
                61 => *v = -1e-300,
                _ => {}
            }
        }
        let mut with_bad = x.clone();
        with_bad[3000] = f64::INFINITY;
        with_bad[4000] = f64::NAN;
        with_bad[5000] = f64::NEG_INFINITY;
        let same = |a: &[f64], b: &[f64], what: &str| {
            assert_eq!(a.len(), b.len());
            // Bitwise, signed zeros and infinities included; any NaN matches
            // any NaN (x86 keeps the payload of whichever operand the
            // compiler put first, which not even scipy fixes).
            let differ = |p: f64, q: f64| !(p.is_nan() && q.is_nan()) && p.to_bits() != q.to_bits();
            if let Some(i) = (0..a.len()).find(|&i| differ(a[i], b[i])) {
                panic!("{what}: first difference at {i}: {:e} vs {:e} (input {:e})", a[i], b[i], x[i]);
            }
        };
        for sos in [vec![hp1], vec![odd], vec![hp1, odd], vec![HP2, hp1]] {
            for input in [&x, &with_bad] {
                for init in [[0.3, -0.7], [-0.0, -0.0], [0.0, 0.0]] {
                    let mut s_ref = vec![init; sos.len()];
                    let want = reference(&sos, input, &mut s_ref);
                    for channels in [1usize, 3] {
                        let src: Vec<f64> = (0..channels).flat_map(|_| input.iter().copied()).collect();
                        let mut out = vec![0.0; src.len()];
                        let mut st = vec![init; sos.len() * channels];
                        sosfilt_into(&sos, &src, &mut out, channels, &mut st).unwrap();
                        let mut inplace = src.clone();
                        let mut st2 = vec![init; sos.len() * channels];
                        sosfilt_inplace(&sos, &mut inplace, channels, &mut st2).unwrap();
                        for c in 0..channels {
                            let what = format!("{sos:?} init {init:?} channels {channels} bad {}", input[3000]);
                            same(&out[c * 6000..(c + 1) * 6000], &want, &format!("into {what}"));
                            same(&inplace[c * 6000..(c + 1) * 6000], &want, &format!("inplace {what}"));
                        }
                        let flat = |s: &[[f64; 2]]| {
                            s.iter().flatten().map(|f| if f.is_nan() { 0 } else { f.to_bits() }).collect::<Vec<u64>>()
                        };
                        assert_eq!(flat(&st[..sos.len()]), flat(&s_ref));
                        assert_eq!(flat(&st2[..sos.len()]), flat(&s_ref));
                    }
                    // Chunks of odd sizes (each starts with the carried state).
                    let mut st = vec![init; sos.len()];
                    let mut out = Vec::new();
                    let mut start = 0;
                    for len in [1usize, 2, 40, 2047, 2049, 1851, 10] {
                        let mut chunk = vec![0.0; len];
                        sosfilt_into(&sos, &input[start..start + len], &mut chunk, 1, &mut st).unwrap();
                        out.extend(chunk);
                        start += len;
                    }
                    same(&out, &want, &format!("chunks {sos:?} init {init:?}"));
                }
            }
        }
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
