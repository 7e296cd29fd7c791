//! Many byte ranges of a file read into one buffer in one call (issue 38
//! point 2): the pre-pass reads 256 short pieces of each channel of a
//! `.npy`, which one `os.preadv` a piece from Python made cost more than
//! the statistics computed on them; a TDMS or HDF5 channel's pieces
//! (`Extents`) one call of `Extents.read` each.

use crate::files::PyExtents;
use crate::{bad, dup_fd, os_error, threads_of};
use numpy::{PyArray1, PyReadonlyArray1, PyReadwriteArray1};
use pyo3::prelude::*;
use tribodyn_core::io::mapped;

/// Pieces of at least this many bytes in all are split over threads (below, starting threads costs
/// more than the copies out of the page cache they share).
const PARALLEL_BYTES: usize = 1 << 21;

/// Fills `out` (a C-contiguous uint8 array: the bytes of the destination)
/// with byte ranges of the open file `fd` (duplicated for the call, left
/// open): range `k` is `lengths[k]` bytes from byte `offsets[k]`, placed
/// after range `k - 1`; the lengths add up to the size of `out`. Read with
/// `pread` without the GIL, on up to `threads` threads for large reads.
/// A range past the end of the file (one truncated since it was opened)
/// is a `ValueError` naming it; a failed read an `OSError`.
#[pyfunction]
#[pyo3(signature = (fd, out, offsets, lengths, *, threads=None))]
pub(crate) fn pread_ranges(
    py: Python<'_>,
    fd: i32,
    mut out: PyReadwriteArray1<'_, u8>,
    offsets: PyReadonlyArray1<'_, i64>,
    lengths: PyReadonlyArray1<'_, i64>,
    threads: Option<i64>,
) -> PyResult<()> {
    let threads = threads_of(threads)?;
    let offs = offsets.as_slice().map_err(|_| bad("offsets must be a C-contiguous int64 array"))?;
    let lens = lengths.as_slice().map_err(|_| bad("lengths must be a C-contiguous int64 array"))?;
    if offs.len() != lens.len() {
        return Err(bad(format!("{} offsets but {} lengths", offs.len(), lens.len())));
    }
    let mut plan = Vec::with_capacity(offs.len());
    let mut total = 0usize;
    for (&o, &l) in offs.iter().zip(lens) {
        let (Ok(o), Ok(l)) = (u64::try_from(o), usize::try_from(l)) else {
            return Err(bad(format!("a range needs an offset and a length >= 0, got ({o}, {l})")));
        };
        if o.checked_add(l as u64).is_none_or(|end| end > i64::MAX as u64) {
            return Err(bad(format!("the range of {l} bytes at {o} overflows")));
        }
        total = total.checked_add(l).ok_or_else(|| bad("the lengths overflow"))?;
        plan.push((o, l));
    }
    let dest = out.as_slice_mut().map_err(|_| bad("out must be a C-contiguous uint8 array"))?;
    if total != dest.len() {
        return Err(bad(format!("the ranges hold {total} bytes, out {}", dest.len())));
    }
    if total == 0 {
        return Ok(());
    }
    let file = dup_fd(fd)?;
    let got = py.detach(|| {
        prefault(dest);
        read_all(&file, &plan, dest, threads)
    });
    got.map_err(|(kind, msg)| if kind { bad(msg) } else { os_error(msg) })
}

/// Writes a byte of each page of `dest`: a page a fresh allocation has not touched yet is then faulted
/// in here, in user space, rather than inside a `pread` (where the fault costs several times more).
fn prefault(dest: &mut [u8]) {
    for b in dest.iter_mut().step_by(4096) {
        // SAFETY: `b` is a valid, exclusive reference; the volatile write keeps the store.
        unsafe { std::ptr::write_volatile(b, 0) };
    }
}

/// A byte range of the file: (offset, length).
type Range = (u64, usize);

/// An error: (past the end of the file, its words).
type ReadError = (bool, String);

/// Reads every range of `plan` into `dest` in turn, split into byte-balanced groups of ranges on
/// `threads` threads when the whole is large.
fn read_all(file: &std::fs::File, plan: &[Range], dest: &mut [u8], threads: usize) -> Result<(), ReadError> {
    let groups = if dest.len() >= PARALLEL_BYTES { threads.min(plan.len()).max(1) } else { 1 };
    if groups == 1 {
        return read_group(file, plan, dest);
    }
    // Cut the plan where the bytes read so far pass each k / groups of the whole.
    let per = dest.len().div_ceil(groups);
    let mut parts: Vec<(&[Range], &mut [u8])> = Vec::with_capacity(groups);
    let (mut rest_plan, mut rest) = (plan, dest);
    while !rest_plan.is_empty() {
        let (mut k, mut bytes) = (0, 0usize);
        let last = parts.len() + 1 == groups; // the last group takes the rest: never more groups than threads
        while k < rest_plan.len() && (last || bytes < per || k == 0) {
            bytes += rest_plan[k].1;
            k += 1;
        }
        let (p, q) = rest_plan.split_at(k);
        let (a, b) = std::mem::take(&mut rest).split_at_mut(bytes);
        parts.push((p, a));
        rest_plan = q;
        rest = b;
    }
    let mut parts = parts.into_iter();
    let first = parts.next();
    std::thread::scope(|s| {
        let handles: Vec<_> = parts.map(|(p, d)| s.spawn(move || read_group(file, p, d))).collect();
        let mine = first.map_or(Ok(()), |(p, d)| read_group(file, p, d));
        let theirs =
            handles.into_iter().map(|h| h.join().unwrap_or_else(|_| Err((false, "a read thread failed".into()))));
        std::iter::once(mine).chain(theirs).collect::<Result<(), ReadError>>()
    })
}

fn read_group(file: &std::fs::File, plan: &[Range], dest: &mut [u8]) -> Result<(), ReadError> {
    let mut at = 0usize;
    for &(offset, len) in plan {
        read_at(file, offset, &mut dest[at..at + len])?;
        at += len;
    }
    Ok(())
}

#[cfg(unix)]
fn read_at(file: &std::fs::File, offset: u64, bytes: &mut [u8]) -> Result<(), ReadError> {
    use std::os::unix::fs::FileExt;
    file.read_exact_at(bytes, offset).map_err(|e| {
        let end = offset + bytes.len() as u64;
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            (true, format!("the file ends before byte {end} (truncated since it was opened?)"))
        } else {
            (false, format!("cannot read bytes {offset}..{end} of the file: {e}"))
        }
    })
}

#[cfg(not(unix))]
fn read_at(_file: &std::fs::File, _offset: u64, _bytes: &mut [u8]) -> Result<(), ReadError> {
    Err((false, "reading a file's ranges directly needs a Unix system".into()))
}

/// Samples `[a, b)` of every `(a, b)` in `ranges` of the channel described by `extents` (any numeric
/// type, segments, interleaved rows, scaling), concatenated as float64: what `Extents.read` gives for
/// each range, in one call from the open file `fd` (duplicated for the call, left open), without the
/// GIL, one byte cache (and its memory) shared by the ranges, only the bytes of each range read. A range it cannot read (past the
/// channel's end, a file truncated since) is a `ValueError` starting "a:b: ".
#[pyfunction]
pub(crate) fn extents_read_ranges<'py>(
    py: Python<'py>,
    extents: &Bound<'py, PyExtents>,
    fd: i32,
    ranges: Vec<(u64, u64)>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    // A run of one channel's contiguous samples (not interleaved) is described as its own chunk: a piece
    // is then read alone, not with the whole chunk of the channels it shares (a TDMS segment, up to
    // 1 MiB) as a block of windows reads it: the same bytes, so the same values.
    let mut inner = (*extents.get().inner).clone();
    let w = inner.num.width();
    for e in inner.parts.iter_mut().filter(|e| e.stride == w) {
        e.chunk = (e.offset, e.offset.saturating_add(e.count.saturating_mul(w)));
    }
    let file = dup_fd(fd)?;
    let got = py.detach(move || {
        let total = ranges.iter().map(|&(a, b)| b.saturating_sub(a)).sum::<u64>();
        let mut out = Vec::with_capacity(usize::try_from(total).unwrap_or(0).min(1 << 24));
        let mut cache = mapped::ByteCache::default();
        for &(a, b) in &ranges {
            cache.begin();
            inner.read_append(&file, a, b, &mut out, &mut cache).map_err(|e| format!("{a}:{b}: {e}"))?;
        }
        Ok::<_, String>(out)
    });
    Ok(PyArray1::from_vec(py, got.map_err(bad)?))
}
