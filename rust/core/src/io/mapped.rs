//! Windows of a recording whose channels are runs of little-endian f64 in
//! one file (a channels-first float64 `.npy`, say), read by the kernel
//! itself block by block, with no Python per chunk, so memory stays flat
//! whatever the recording's length.
//!
//! A block is a run of consecutive windows. Its samples of every channel
//! are read with `pread` into buffers each thread keeps from one block to
//! the next (small enough to stay in cache between the read and the
//! windows), its windows computed in order on one thread with the next
//! window prefetched. Blocks run in parallel (the calling thread and scoped
//! helpers, as many in all as the caller names) and are placed in order, so
//! the results are those of [`crate::numerics::windows::windows_stats`] on the same
//! samples, bit for bit.
//!
//! Reading, not memory-mapping: a file truncated or overwritten while it is
//! read gives an error (a short read), never a SIGBUS that kills the
//! process, as touching a mapped page past the end of a file does.
//!
//! Raw (DC-coupled) forces are high-passed on the way
//! ([`windows_stats_mapped_highpass`]): the filter runs through the blocks
//! in order, carrying its state, one block ahead of the windows, so that
//! filtering block b + 1 and computing the windows of block b run at the
//! same time on two threads.

use crate::error::KernelError;
use crate::numerics::iir::{self, Section};
use crate::numerics::windows::{windows_stats_serial, Channels, WindowOptions, WindowStats};
use std::fs::File;

const F64: u64 = std::mem::size_of::<f64>() as u64;

/// Where a channel's samples lie in the file.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// Sample 0 at this byte; the samples follow contiguously as little-endian f64.
    F64(u64),
    /// Any layout: runs of samples of one numeric type (see [`Extents`]).
    Extents(std::sync::Arc<Extents>),
}

impl From<u64> for Source {
    fn from(off: u64) -> Self {
        Source::F64(off)
    }
}

/// Where each channel's samples lie in the file.
#[derive(Debug, Clone, PartialEq)]
pub struct FileLayout {
    pub fx: Option<Source>,
    pub fy: Source,
    pub fz: Source,
    /// Auxiliary channel (current or shunt voltage), averaged per window.
    pub aux: Option<Source>,
    /// Samples per channel.
    pub n: usize,
}

impl FileLayout {
    fn sources(&self) -> [Option<&Source>; 4] {
        [self.fx.as_ref(), Some(&self.fy), Some(&self.fz), self.aux.as_ref()]
    }
}

/// Numeric types a channel's samples may be stored as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Num {
    I8,
    I16,
    I32,
    I64,
    U8,
    U16,
    U32,
    U64,
    F32,
    F64,
}

impl Num {
    /// Bytes per sample.
    pub fn width(self) -> u64 {
        match self {
            Num::I8 | Num::U8 => 1,
            Num::I16 | Num::U16 => 2,
            Num::I32 | Num::U32 | Num::F32 => 4,
            Num::I64 | Num::U64 | Num::F64 => 8,
        }
    }

    /// NumPy's name of the type ("i2", "f8", ...).
    pub fn name(self) -> &'static str {
        match self {
            Num::I8 => "i1",
            Num::I16 => "i2",
            Num::I32 => "i4",
            Num::I64 => "i8",
            Num::U8 => "u1",
            Num::U16 => "u2",
            Num::U32 => "u4",
            Num::U64 => "u8",
            Num::F32 => "f4",
            Num::F64 => "f8",
        }
    }

    /// The type of NumPy's name ("i2", "f8", ...).
    pub fn from_name(s: &str) -> Option<Num> {
        [Num::I8, Num::I16, Num::I32, Num::I64, Num::U8, Num::U16, Num::U32, Num::U64, Num::F32, Num::F64]
            .into_iter()
            .find(|n| n.name() == s)
    }
}

/// Runs of samples of a channel: samples `start .. start + count` lie at
/// `offset + i * stride`, inside the byte range `chunk` (the file's block
/// that holds them with other channels' samples: read once for all
/// channels when it is small); then, `reps` times in all, the next `count`
/// samples lie the same way `period` bytes further (segments of equal
/// layout one after another, as a logger writes them).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Extent {
    pub start: u64,
    pub count: u64,
    pub offset: u64,
    pub stride: u64,
    pub chunk: (u64, u64),
    pub reps: u64,
    pub period: u64,
}

impl Extent {
    /// One run (`reps` 1).
    pub fn single(count: u64, offset: u64, stride: u64, chunk: (u64, u64)) -> Self {
        Extent { start: 0, count, offset, stride, chunk, reps: 1, period: 0 }
    }

    /// Samples in all repetitions.
    pub fn total(&self) -> u64 {
        self.count.saturating_mul(self.reps)
    }

    /// Offset and chunk of repetition `r`.
    fn rep(&self, r: u64) -> (u64, (u64, u64)) {
        let d = r * self.period;
        (self.offset + d, (self.chunk.0 + d, self.chunk.1 + d))
    }
}

/// Scaling applied to the samples after conversion to f64, in order.
#[derive(Debug, Clone, PartialEq)]
pub enum Op {
    /// `x * slope + intercept`.
    Linear { slope: f64, intercept: f64 },
    /// `c[0] + x * (c[1] + x * (...))`, evaluated as NumPy's `polyval`
    /// (Horner, starting from `c[last] + x * 0`); no coefficients give 0.
    Poly(Vec<f64>),
}

/// A channel stored as extents of one numeric type and byte order, with
/// scaling: a TDMS channel (segments, interleaved rows, DAQmx raw
/// integers), an HDF5 dataset's chunks.
#[derive(Debug, Clone, PartialEq)]
pub struct Extents {
    pub num: Num,
    pub big_endian: bool,
    /// In order of `start`, from 0, without gaps.
    pub parts: Vec<Extent>,
    pub ops: Vec<Op>,
}

/// A chunk at most this long is read whole, once for all channels.
const SMALL_CHUNK: u64 = 1 << 20;
/// A chunk longer than this is not read whole for less than half of a channel's run in it (a read per channel
/// then costs less than the rest of the chunk's bytes).
const SHORT_CHUNK: u64 = 32 << 10;
/// Longest span of small chunks at a fixed distance read at once.
const SPAN_CAP: u64 = 4 << 20;

impl Extents {
    /// Samples of the channel.
    pub fn len(&self) -> u64 {
        self.parts.last().map_or(0, |e| e.start + e.total())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// One past the last byte the extents read.
    pub fn end(&self) -> u64 {
        let last = |e: &Extent| e.reps.saturating_sub(1).saturating_mul(e.period);
        self.parts.iter().map(|e| e.chunk.1.max(self.part_end(e)).saturating_add(last(e))).max().unwrap_or(0)
    }

    fn part_end(&self, e: &Extent) -> u64 {
        if e.count == 0 {
            e.offset
        } else {
            e.offset.saturating_add((e.count - 1).saturating_mul(e.stride)).saturating_add(self.num.width())
        }
    }

    /// Checks the extents are in order without gaps, lie inside their
    /// chunks (each sample inside its row), and end by byte `size`.
    pub fn check(&self, size: u64) -> Result<(), KernelError> {
        let mut next = 0u64;
        let w = self.num.width();
        for e in &self.parts {
            if e.start != next {
                return Err(invalid(format!("extent at sample {} does not follow sample {next}", e.start)));
            }
            let outside = e.stride < w
                || e.offset < e.chunk.0
                || self.part_end(e) > e.chunk.1
                || (e.stride > w && (e.offset - e.chunk.0) % e.stride + w > e.stride);
            if e.count > 0 && outside {
                return Err(invalid(format!("extent at byte {} lies outside its block", e.offset)));
            }
            let last_end =
                e.reps.checked_sub(1).and_then(|r| r.checked_mul(e.period)).and_then(|d| e.chunk.1.checked_add(d));
            if e.reps == 0 || last_end.is_none_or(|x| x > size) || e.chunk.0 > e.chunk.1 {
                return Err(invalid(format!(
                    "a channel's block {}..{} ({} times every {} bytes) runs past the file's {size} bytes",
                    e.chunk.0, e.chunk.1, e.reps, e.period
                )));
            }
            let total = e.count.checked_mul(e.reps);
            next =
                total.and_then(|t| e.start.checked_add(t)).ok_or_else(|| invalid("extent counts overflow".into()))?;
        }
        Ok(())
    }

    fn plain_f64(&self) -> bool {
        self.num == Num::F64 && !self.big_endian && self.ops.is_empty() && cfg!(target_endian = "little")
    }

    /// Whether its samples are stored as they are in memory (native f64, unscaled) in runs of consecutive
    /// samples (not interleaved with other channels'), so that the file's bytes can be read straight into a
    /// channel's buffer ([`Samples::read_direct`]).
    fn direct(&self) -> bool {
        self.plain_f64() && self.parts.iter().all(|e| e.stride == F64 || e.count <= 1)
    }

    /// The runs of samples [a, b) in the file, in order: `run(at, k)` for `k` samples at byte `at`.
    /// False (and no run) when the channel has fewer than `b` samples. Only for [`Extents::direct`] extents.
    fn runs(&self, a: u64, b: u64, mut run: impl FnMut(u64, u64)) -> bool {
        if b > self.len() {
            return false;
        }
        let mut i = self.parts.partition_point(|e| e.start + e.total() <= a);
        let mut pos = a;
        while pos < b {
            let e = &self.parts[i];
            if e.count == 0 || pos >= e.start + e.total() {
                i += 1;
                continue;
            }
            let (r, s) = ((pos - e.start) / e.count, (pos - e.start) % e.count);
            let k = (e.count - s).min(b - pos);
            run(e.rep(r).0 + s * e.stride, k);
            pos += k;
        }
        true
    }

    /// Samples [a, b) as f64, scaled, into `out` (cleared first). The
    /// extents must have passed [`Extents::check`] (for any size: a file
    /// shorter than they say is a read error here).
    pub fn read(
        &self,
        file: &File,
        a: u64,
        b: u64,
        out: &mut Vec<f64>,
        cache: &mut ByteCache,
    ) -> Result<(), KernelError> {
        out.clear();
        self.read_append(file, a, b, out, cache)
    }

    /// [`Extents::read`] appending to `out` (kept as it is).
    pub fn read_append(
        &self,
        file: &File,
        a: u64,
        b: u64,
        out: &mut Vec<f64>,
        cache: &mut ByteCache,
    ) -> Result<(), KernelError> {
        let first = out.len();
        if b <= a {
            return Ok(());
        }
        if b > self.len() {
            return Err(invalid(format!("samples {a}..{b} of a channel of {} samples", self.len())));
        }
        out.reserve((b - a) as usize);
        let mut i = self.parts.partition_point(|e| e.start + e.total() <= a);
        let mut pos = a;
        let w = self.num.width();
        while pos < b {
            let e = &self.parts[i];
            if e.count == 0 || pos >= e.start + e.total() {
                i += 1;
                continue;
            }
            let r = (pos - e.start) / e.count;
            let s = (pos - e.start) % e.count;
            let (offset, chunk) = e.rep(r);
            let k = (e.count - s).min(b - pos);
            // A chunk that holds this run alone (an HDF5 chunk, a segment of
            // one channel) is shared with nothing: read only the samples
            // asked for, not the whole chunk once per block that touches it.
            let own = e.stride == w && chunk.0 == offset && chunk.1 - chunk.0 == e.count * w;
            // Nor is a small chunk read whole for a short part of a run of its own: a window of 2 s from a
            // segment of 10 s reads its samples of each channel, not the segment's every channel.
            let short = e.stride == w && 2 * k < e.count && chunk.1 - chunk.0 > SHORT_CHUNK;
            if chunk.1 - chunk.0 <= SMALL_CHUNK && !own && !short {
                // The chunks of the repetitions this read goes on into lie at
                // a fixed distance (a logger's segments): when the bytes
                // between them are few, one read of the span serves them all.
                let len = chunk.1 - chunk.0;
                let last = ((b - 1 - e.start) / e.count).min(e.reps - 1);
                let gap = e.period.saturating_sub(len);
                let span = (last - r).saturating_mul(e.period).saturating_add(len);
                let span_end = if last > r && e.period >= len && gap <= len.max(4096) && span <= SPAN_CAP {
                    chunk.0 + span
                } else {
                    chunk.1
                };
                let bytes = cache.get_span(file, chunk.0, len, span_end)?;
                let from = (offset - chunk.0 + s * e.stride) as usize;
                decode(self.num, self.big_endian, &bytes[from..], e.stride as usize, k as usize, out);
            } else if self.plain_f64() && e.stride == F64 {
                let at = out.len();
                out.resize(at + k as usize, 0.0);
                read_f64s_into(file, offset + s * F64, &mut out[at..])?;
            } else {
                // Whole rows of an interleaved block (shared by its channels).
                let col = if e.stride > w { (offset - chunk.0) % e.stride } else { 0 };
                let lo = offset - col + s * e.stride;
                let bytes = cache.get(file, lo, k * e.stride)?;
                decode(self.num, self.big_endian, &bytes[col as usize..], e.stride as usize, k as usize, out);
            }
            pos += k;
        }
        let added = &mut out[first..];
        for op in &self.ops {
            match op {
                Op::Linear { slope, intercept } => added.iter_mut().for_each(|x| *x = *x * slope + intercept),
                Op::Poly(c) => match c.split_last() {
                    None => added.iter_mut().for_each(|x| *x = 0.0),
                    Some((last, rest)) => added.iter_mut().for_each(|x| {
                        let v = *x;
                        let mut acc = last + v * 0.0;
                        for ci in rest.iter().rev() {
                            acc = ci + acc * v;
                        }
                        *x = acc;
                    }),
                },
            }
        }
        Ok(())
    }
}

/// Appends `k` values of type `num` found every `stride` bytes from `bytes[0]` to `out`.
fn decode(num: Num, big: bool, bytes: &[u8], stride: usize, k: usize, out: &mut Vec<f64>) {
    if num == Num::F64 && !big && stride == F64 as usize && cfg!(target_endian = "little") {
        // Native f64 stored one after another: the bytes are the values (a
        // copy, not a conversion per value; same bits).
        let at = out.len();
        out.resize(at + k, 0.0);
        // SAFETY: the byte view covers exactly the k initialised f64 just
        // added, borrowed mutably; every byte pattern is a valid f64.
        let dst = unsafe { std::slice::from_raw_parts_mut(out[at..].as_mut_ptr() as *mut u8, k * F64 as usize) };
        dst.copy_from_slice(&bytes[..k * F64 as usize]);
        return;
    }
    macro_rules! conv {
        ($t:ty) => {{
            const W: usize = std::mem::size_of::<$t>();
            let get = |p: &[u8]| -> f64 {
                let a: [u8; W] = p[..W].try_into().expect("W bytes");
                (if big { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }) as f64
            };
            if stride == W {
                out.extend(bytes[..k * W].chunks_exact(W).map(get));
            } else {
                out.extend((0..k).map(|j| get(&bytes[j * stride..])));
            }
        }};
    }
    match num {
        Num::I8 => conv!(i8),
        Num::I16 => conv!(i16),
        Num::I32 => conv!(i32),
        Num::I64 => conv!(i64),
        Num::U8 => conv!(u8),
        Num::U16 => conv!(u16),
        Num::U32 => conv!(u32),
        Num::U64 => conv!(u64),
        Num::F32 => conv!(f32),
        Num::F64 => conv!(f64),
    }
}

/// Byte ranges read for one block of samples, kept until the next block
/// so the channels of one chunk (interleaved rows, a small segment) read
/// it once; their memory is reused from block to block.
#[derive(Default, Debug)]
pub struct ByteCache {
    entries: Vec<(u64, u64, Vec<u8>)>,
    used: usize,
}

impl ByteCache {
    /// Forgets the ranges read (keeps the memory).
    pub fn begin(&mut self) {
        self.used = 0;
    }

    /// Bytes [at, at + len) of the file: from a range read before in this
    /// block that holds them, else read now with the bytes up to `span_end`
    /// (at least `at + len`; the caller checked they lie in the file).
    fn get_span(&mut self, file: &File, at: u64, len: u64, span_end: u64) -> Result<&[u8], KernelError> {
        let end = at + len;
        if let Some(i) = self.entries[..self.used].iter().position(|e| e.0 <= at && end <= e.0 + e.1) {
            let from = (at - self.entries[i].0) as usize;
            return Ok(&self.entries[i].2[from..from + len as usize]);
        }
        if self.used == self.entries.len() {
            self.entries.push((0, 0, Vec::new()));
        }
        let total = span_end.max(end) - at;
        let slot = &mut self.entries[self.used];
        slot.2.resize(total as usize, 0);
        read_bytes(file, at, &mut slot.2)?;
        slot.0 = at;
        slot.1 = total;
        self.used += 1;
        Ok(&self.entries[self.used - 1].2[..len as usize])
    }

    fn get(&mut self, file: &File, at: u64, len: u64) -> Result<&[u8], KernelError> {
        self.get_span(file, at, len, at + len)
    }
}

/// Window k of the recording is samples [k * step, k * step + opt.len).
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    /// First window (index k) and one past the last.
    pub k0: usize,
    pub k1: usize,
    pub step: usize,
    /// Windows per block (one block is mapped and computed by one thread).
    pub block: usize,
}

fn invalid(msg: String) -> KernelError {
    KernelError::Invalid(msg)
}

/// Checks a layout and a grid against the file (done by every entry point;
/// public so that callers can check before they allocate for the results).
pub fn check(file: &File, layout: &FileLayout, grid: &Grid, opt: &WindowOptions) -> Result<(), KernelError> {
    if cfg!(target_endian = "big") && layout.sources().into_iter().flatten().any(|s| matches!(s, Source::F64(_))) {
        return Err(invalid("mapped files are read as little-endian f64: not on this machine".into()));
    }
    if grid.step == 0 || grid.block == 0 || opt.len == 0 {
        return Err(invalid("step, block and window length must be at least 1".into()));
    }
    if opt.n_bins == 0 || opt.n_bins > crate::numerics::windows::MAX_BINS {
        return Err(invalid(format!(
            "n_bins must be in [1, {}], got {}",
            crate::numerics::windows::MAX_BINS,
            opt.n_bins
        )));
    }
    if grid.k1 > grid.k0 {
        let last_end = (grid.k1 - 1).checked_mul(grid.step).and_then(|s| s.checked_add(opt.len));
        if last_end.is_none_or(|e| e > layout.n) {
            return Err(invalid(format!(
                "windows {}..{} of {} samples every {} run past the {} samples of the file",
                grid.k0, grid.k1, opt.len, grid.step, layout.n
            )));
        }
    }
    let size = file.metadata().map_err(|e| invalid(format!("cannot read the file's length: {e}")))?.len();
    for src in layout.sources().into_iter().flatten() {
        match src {
            Source::F64(off) => {
                let off = *off;
                if off % F64 != 0 {
                    return Err(invalid(format!("channel offset {off} is not a multiple of 8 bytes")));
                }
                let end = (layout.n as u64).checked_mul(F64).and_then(|b| b.checked_add(off));
                if end.is_none_or(|e| e > size) {
                    return Err(invalid(format!(
                        "a channel at byte {off} with {} samples runs past the file's {size} bytes",
                        layout.n
                    )));
                }
            }
            Source::Extents(ext) => {
                ext.check(size)?;
                if ext.len() < layout.n as u64 {
                    return Err(invalid(format!("a channel has {} samples, not {}", ext.len(), layout.n)));
                }
            }
        }
    }
    Ok(())
}

/// The samples [a, b) of a layout's channels, read into buffers that are
/// kept from one block to the next (fresh memory costs a page fault per
/// 4 KiB on its first touch).
#[derive(Default)]
struct Samples {
    /// fx, fy, fz, aux; empty where the layout has no such channel.
    bufs: [Vec<f64>; 4],
    present: [bool; 4],
    cache: ByteCache,
    /// The runs a direct read places, and a buffer for the bytes between them.
    pieces: Vec<Piece>,
    scratch: Vec<u8>,
    /// Read calls of the direct reads so far (for the tests).
    direct_reads: usize,
}

/// `n` samples at byte `at` of the file, for channel `ch`'s buffer from sample `dst` on.
#[derive(Debug, Clone, Copy)]
struct Piece {
    at: u64,
    ch: usize,
    dst: usize,
    n: usize,
}

/// Bytes between two runs of a direct read up to this many are read into a scratch buffer (the head of
/// a TDMS segment, a channel not asked for): a second read call costs more; longer ones split the read.
const DIRECT_GAP: u64 = 16 << 10;
/// Most buffers one `preadv` fills (Linux's `IOV_MAX`).
const IOV_MAX: usize = 1024;

impl Samples {
    /// Samples [a, b) of every channel (one window of b - a samples at a).
    fn read(&mut self, file: &File, layout: &FileLayout, a: usize, b: usize) -> Result<(), KernelError> {
        self.read_windows(file, layout, &[a], b - a)
    }

    /// The samples of the windows starting at `starts` (each `len` long), laid end to end: window j is
    /// samples [j len, (j + 1) len) of each buffer.
    fn read_windows(
        &mut self,
        file: &File,
        layout: &FileLayout,
        starts: &[usize],
        len: usize,
    ) -> Result<(), KernelError> {
        let direct = self.read_direct(file, layout, starts, len);
        self.read_rest(file, layout, starts, len, direct)
    }

    /// [`Samples::read_windows`] of the channels not in the mask `done` (bit i: channel i was read).
    fn read_rest(
        &mut self,
        file: &File,
        layout: &FileLayout,
        starts: &[usize],
        len: usize,
        done: u8,
    ) -> Result<(), KernelError> {
        self.cache.begin();
        for (i, src) in layout.sources().into_iter().enumerate() {
            self.present[i] = src.is_some();
            if done & (1 << i) != 0 {
                continue;
            }
            let buf = &mut self.bufs[i];
            match src {
                Some(Source::F64(off)) => {
                    buf.resize(starts.len() * len, 0.0);
                    for (j, &s) in starts.iter().enumerate() {
                        read_f64s_into(file, off + s as u64 * F64, &mut buf[j * len..(j + 1) * len])?;
                    }
                }
                Some(Source::Extents(ext)) => {
                    buf.clear();
                    for &s in starts {
                        ext.read_append(file, s as u64, (s + len) as u64, buf, &mut self.cache)?;
                    }
                }
                None => {}
            }
        }
        Ok(())
    }

    /// Reads the windows' samples of the channels whose extents are [`Extents::direct`] straight into
    /// their buffers, with no copy: the runs of all those channels sorted by their place in the file, each
    /// span of runs (the bytes between them, up to [`DIRECT_GAP`], into a scratch buffer) read with one
    /// `preadv` whose buffers are the runs' places in the channels' buffers. Returns the channels read
    /// (bit i: channel i); none when a read fails, so that the reads of [`Samples::read_rest`] give the
    /// error they always gave (a file truncated while it is read, say).
    fn read_direct(&mut self, file: &File, layout: &FileLayout, starts: &[usize], len: usize) -> u8 {
        let mut done = 0u8;
        self.pieces.clear();
        for (ch, src) in layout.sources().into_iter().enumerate() {
            let Some(Source::Extents(ext)) = src else { continue };
            if !ext.direct() {
                continue;
            }
            let pieces = &mut self.pieces;
            for (j, &s) in starts.iter().enumerate() {
                let mut dst = j * len;
                let whole = ext.runs(s as u64, (s + len) as u64, |at, k| {
                    let n = k as usize;
                    match pieces.last_mut() {
                        // the run goes on where the last one ended, in the file and in the buffer
                        Some(p) if p.ch == ch && p.dst + p.n == dst && p.at + p.n as u64 * F64 == at => p.n += n,
                        _ => pieces.push(Piece { at, ch, dst, n }),
                    }
                    dst += n;
                });
                if !whole {
                    return 0;
                }
            }
            self.bufs[ch].resize(starts.len() * len, 0.0);
            done |= 1 << ch;
        }
        if done == 0 {
            return 0;
        }
        self.pieces.sort_unstable_by_key(|p| p.at);
        self.scratch.resize(DIRECT_GAP as usize, 0);
        let scratch = IoBuf { base: self.scratch.as_mut_ptr(), len: 0 };
        let bases: [*mut f64; 4] = std::array::from_fn(|i| self.bufs[i].as_mut_ptr());
        let mut iov: Vec<IoBuf> = Vec::with_capacity(IOV_MAX.min(2 * self.pieces.len()));
        let (mut from, mut end) = (0u64, 0u64);
        for p in &self.pieces {
            let joins = !iov.is_empty() && p.at >= end && p.at - end <= DIRECT_GAP && iov.len() + 2 <= IOV_MAX;
            if !joins && !iov.is_empty() {
                self.direct_reads += 1;
                if !read_vectored_at(file, from, &mut iov) {
                    return 0;
                }
                iov.clear();
            }
            if iov.is_empty() {
                from = p.at;
            } else if p.at > end {
                iov.push(IoBuf { len: (p.at - end) as usize, ..scratch });
            }
            // SAFETY: `p.dst + p.n` is at most `starts.len() * len`, the length of channel `p.ch`'s buffer
            // (resized above and not touched until the reads are done): the run's place lies in it, and no
            // other piece's place overlaps it (each is a different sample of the windows).
            iov.push(IoBuf { base: unsafe { bases[p.ch].add(p.dst) }.cast::<u8>(), len: p.n * F64 as usize });
            end = p.at + (p.n as u64) * F64;
        }
        self.direct_reads += 1;
        if !read_vectored_at(file, from, &mut iov) {
            return 0;
        }
        done
    }

    /// Channel `i` (0 fx, 1 fy, 2 fz, 3 aux), None where the layout has none.
    fn get(&self, i: usize) -> Option<&[f64]> {
        self.present[i].then(|| self.bufs[i].as_slice())
    }
}

/// Fills `buf` with the little-endian f64 from byte `at` of `file`.
fn read_f64s_into(file: &File, at: u64, buf: &mut [f64]) -> Result<(), KernelError> {
    // SAFETY: the byte view covers exactly the initialised f64 of `buf`,
    // which it borrows mutably; every byte pattern is a valid f64.
    let bytes = unsafe { std::slice::from_raw_parts_mut(buf.as_mut_ptr() as *mut u8, std::mem::size_of_val(buf)) };
    read_bytes(file, at, bytes)
}

/// Fills `bytes` from byte `at` of `file` (pread: no shared file position,
/// so any number of threads may read one file).
#[cfg(unix)]
pub(crate) fn read_bytes(file: &File, at: u64, bytes: &mut [u8]) -> Result<(), KernelError> {
    use std::os::unix::fs::FileExt;
    file.read_exact_at(bytes, at).map_err(|e| {
        let end = at + bytes.len() as u64;
        if e.kind() == std::io::ErrorKind::UnexpectedEof {
            invalid(format!("the file ends before byte {end}: it was truncated while it was read"))
        } else {
            invalid(format!("cannot read bytes {at}..{end} of the file: {e}"))
        }
    })
}

/// A buffer of a vectored read: the C `struct iovec`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
struct IoBuf {
    base: *mut u8,
    len: usize,
}

/// Fills the buffers `iov` in order with the bytes of `file` from byte `at` on (vectored reads; the
/// buffers are advanced past what each read placed). False when a read fails or the file ends first.
fn read_vectored_at(file: &File, at: u64, iov: &mut [IoBuf]) -> bool {
    fill_vectored(at, iov, |at, iov| preadv(file, at, iov))
}

/// Fills the buffers `iov` with `read(at, iov)` (a vectored read placing bytes from byte `at` on into the
/// buffers in order, returning how many it placed), again from where it stopped until every buffer is
/// full: a read may place fewer bytes than asked. False when a read fails or places none (the file's end).
fn fill_vectored(
    mut at: u64,
    mut iov: &mut [IoBuf],
    mut read: impl FnMut(u64, &[IoBuf]) -> std::io::Result<usize>,
) -> bool {
    while let Some(first) = iov.iter().position(|b| b.len > 0) {
        iov = &mut iov[first..];
        let mut got = match read(at, iov) {
            Ok(0) => return false,
            Ok(got) => got,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(_) => return false,
        };
        at += got as u64;
        for b in iov.iter_mut() {
            let k = got.min(b.len);
            // SAFETY: `k` is at most the buffer's length: the advanced pointer stays in (or one past) it.
            b.base = unsafe { b.base.add(k) };
            b.len -= k;
            got -= k;
            if got == 0 {
                break;
            }
        }
        if got > 0 {
            return false; // more bytes than asked for: no read does that
        }
    }
    true
}

/// One `preadv` of `iov` from byte `at` of `file` (the buffers must be valid for writes).
#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
fn preadv(file: &File, at: u64, iov: &[IoBuf]) -> std::io::Result<usize> {
    use std::os::unix::io::AsRawFd;
    extern "C" {
        fn preadv(fd: i32, iov: *const IoBuf, iovcnt: i32, offset: i64) -> isize;
    }
    let (Ok(offset), Ok(count)) = (i64::try_from(at), i32::try_from(iov.len().min(IOV_MAX))) else {
        return Err(std::io::ErrorKind::InvalidInput.into());
    };
    // SAFETY: the kernel writes at most `len` bytes at each `base`, buffers the caller made valid for writes
    // and does not touch during the call; `iov` outlives the call.
    let got = unsafe { preadv(file.as_raw_fd(), iov.as_ptr(), count, offset) };
    usize::try_from(got).map_err(|_| std::io::Error::last_os_error())
}

/// A `pread` of the first buffer (no `preadv` here): the caller reads again for the rest.
#[cfg(all(unix, not(all(target_os = "linux", target_pointer_width = "64"))))]
fn preadv(file: &File, at: u64, iov: &[IoBuf]) -> std::io::Result<usize> {
    use std::os::unix::fs::FileExt;
    let Some(b) = iov.first() else { return Ok(0) };
    // SAFETY: the caller made the buffer valid for writes of `len` bytes and does not touch it meanwhile.
    let buf = unsafe { std::slice::from_raw_parts_mut(b.base, b.len) };
    file.read_at(buf, at)
}

#[cfg(not(unix))]
fn preadv(_file: &File, _at: u64, _iov: &[IoBuf]) -> std::io::Result<usize> {
    Err(std::io::ErrorKind::Unsupported.into())
}

#[cfg(not(unix))]
pub(crate) fn read_bytes(_file: &File, _at: u64, _bytes: &mut [u8]) -> Result<(), KernelError> {
    Err(invalid("reading a file's samples directly needs a Unix system".into()))
}

fn block(
    file: &File,
    layout: &FileLayout,
    grid: &Grid,
    opt: &WindowOptions,
    b: usize,
    samples: &mut Samples,
) -> Result<Vec<WindowStats>, KernelError> {
    let kb = grid.k0 + b * grid.block;
    let ke = (kb + grid.block).min(grid.k1);
    let a = kb * grid.step;
    let e = (ke - 1) * grid.step + opt.len;
    let alone = windows_alone(grid.step, opt.len);
    let starts: Vec<usize> = if alone {
        // the gaps between the windows are not read: the windows' samples end to end
        let at: Vec<usize> = (kb..ke).map(|k| k * grid.step).collect();
        samples.read_windows(file, layout, &at, opt.len)?;
        (0..at.len()).map(|j| j * opt.len).collect()
    } else {
        samples.read(file, layout, a, e)?;
        (kb..ke).map(|k| k * grid.step - a).collect()
    };
    let sl = |i: usize| samples.get(i);
    let (fy, fz) = (sl(1).unwrap_or(&[]), sl(2).unwrap_or(&[]));
    let ch = Channels { fx: sl(0), fy, fz, aux: sl(3), raw: None };
    windows_stats_serial(&ch, &starts, opt).map_err(|err| match err {
        KernelError::NonFinite { channel, sample: Some(s), window } if alone => {
            // back from the windows end to end to the file's samples
            let at = (kb + s / opt.len) * grid.step + s % opt.len;
            KernelError::NonFinite { channel, sample: Some(at), window }
        }
        KernelError::NonFinite { .. } => err.shifted(a),
        other => invalid(format!("{other} (block of samples {a}..{e})")),
    })
}

/// Gaps between the windows of at least this many samples are not read: each window's samples are read
/// alone (below it, one read of a block's whole span costs less than a read per window and channel).
pub const ALONE_GAP: usize = 2048;

/// Whether the windows of a grid of `step` and length `len` are read alone, their gaps skipped
/// (a default 2 s window every 10 s reads a fifth of the samples, not the whole span of a block).
pub fn windows_alone(step: usize, len: usize) -> bool {
    step >= len.saturating_add(ALONE_GAP)
}

/// Statistics of windows `grid.k0 .. grid.k1` of the channels in `file`,
/// in order, computed on `threads` threads, a block of `grid.block`
/// windows per task.
pub fn windows_stats_mapped(
    file: &File,
    layout: &FileLayout,
    grid: &Grid,
    opt: &WindowOptions,
    threads: usize,
) -> Result<Vec<WindowStats>, KernelError> {
    let parts = std::sync::Mutex::new(Vec::new());
    windows_stats_mapped_each(file, layout, grid, opt, threads, &|first, stats| {
        parts.lock().unwrap_or_else(|e| e.into_inner()).push((first, stats));
    })?;
    let mut parts = parts.into_inner().unwrap_or_else(|e| e.into_inner());
    parts.sort_by_key(|p| p.0);
    Ok(parts.into_iter().flat_map(|p| p.1).collect())
}

/// [`windows_stats_mapped`] handing each block's windows to `sink` as soon
/// as they are computed, on the thread that computed them:
/// `sink(first, stats)` with `first` the index (from 0 at `grid.k0`) of
/// `stats[0]`. Blocks arrive in any order; the caller places them. Nothing
/// is kept here, so the memory of a block's results is reused by the next.
pub fn windows_stats_mapped_each<F>(
    file: &File,
    layout: &FileLayout,
    grid: &Grid,
    opt: &WindowOptions,
    threads: usize,
    sink: &F,
) -> Result<(), KernelError>
where
    F: Fn(usize, Vec<WindowStats>) + Sync,
{
    check(file, layout, grid, opt)?;
    crate::parallel::check_threads(threads)?;
    if grid.k1 <= grid.k0 {
        return Ok(());
    }
    let blocks = (grid.k1 - grid.k0).div_ceil(grid.block);
    for_each_block(blocks, threads, |b, samples: &mut Samples| {
        sink(b * grid.block, block(file, layout, grid, opt, b, samples)?);
        Ok(())
    })
}

/// Runs `f(0, s) .. f(blocks - 1, s)` on `threads` threads: the calling
/// thread and `threads - 1` scoped helpers, each taking the next block from
/// a shared counter and passing its own state `s` (buffers it reuses). The caller starts at once (a pool would first have to
/// wake a sleeping worker, which on a virtual machine can cost as much as
/// a short recording's whole analysis), and blocks are handed out one at a
/// time, so the threads finish together. After an error no new block is
/// started; the error of the lowest failed block is returned.
fn for_each_block<S, F>(blocks: usize, threads: usize, f: F) -> Result<(), KernelError>
where
    S: Default,
    F: Fn(usize, &mut S) -> Result<(), KernelError> + Sync,
{
    use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let failed: std::sync::Mutex<Option<(usize, KernelError)>> = std::sync::Mutex::new(None);
    let work = || {
        let mut state = S::default();
        while !stop.load(Ordering::Relaxed) {
            let b = next.fetch_add(1, Ordering::Relaxed);
            if b >= blocks {
                break;
            }
            if let Err(e) = f(b, &mut state) {
                stop.store(true, Ordering::Relaxed);
                let mut slot = failed.lock().unwrap_or_else(|p| p.into_inner());
                if slot.as_ref().is_none_or(|(k, _)| b < *k) {
                    *slot = Some((b, e));
                }
            }
        }
    };
    let helpers = threads.clamp(1, blocks.max(1)) - 1;
    std::thread::scope(|s| {
        for _ in 0..helpers {
            s.spawn(work);
        }
        work();
    });
    match failed.into_inner().unwrap_or_else(|p| p.into_inner()) {
        Some((_, e)) => Err(e),
        None => Ok(()),
    }
}

/// How raw forces are high-passed before the windows (see
/// [`windows_stats_mapped_highpass`]).
#[derive(Debug, Clone)]
pub struct HighPass<'a> {
    pub sos: &'a [Section],
    /// Initial state per section for a unit input: each force channel
    /// starts at `zi * x[origin]` (the steady state of its first sample,
    /// as `tribodyn.HighPass(init="steady")`).
    pub zi: &'a [[f64; 2]],
    /// Sample where filtering starts (at or before the first window).
    pub origin: usize,
}

/// One block of the high-pass pipeline: its raw samples and filtered forces.
#[derive(Default)]
struct Filtered {
    /// Samples [from, to) of the recording.
    from: usize,
    raw: Samples,
    forces: Vec<Vec<f64>>,
}

/// Reads samples [from, to) into `buf`'s raw samples and filters the
/// forces, carrying `state`, into its `forces` (the buffers of an earlier
/// block, reused: fresh ones would cost a page fault per 4 KiB on first
/// touch).
#[allow(clippy::too_many_arguments)]
fn filter_block(
    file: &File,
    layout: &FileLayout,
    hp: &HighPass<'_>,
    from: usize,
    to: usize,
    state: &mut [Vec<[f64; 2]>],
    buf: Filtered,
) -> Result<Filtered, KernelError> {
    let Filtered { mut raw, mut forces, .. } = buf;
    raw.read(file, layout, from, to)?;
    let src: Vec<&[f64]> = (0..3).filter_map(|i| raw.get(i)).collect();
    forces.resize_with(src.len(), Vec::new);
    for (buf, s) in forces.iter_mut().zip(&src) {
        // Every sample is overwritten by the filter; only a length change
        // (the last block) writes zeros first.
        buf.resize(s.len(), 0.0);
    }
    if from == hp.origin {
        for (st, x) in state.iter_mut().zip(&src) {
            for (z, zi) in st.iter_mut().zip(hp.zi) {
                *z = [zi[0] * x[0], zi[1] * x[0]];
            }
        }
    }
    let mut outs: Vec<&mut [f64]> = forces.iter_mut().map(|v| v.as_mut_slice()).collect();
    let mut states: Vec<&mut [[f64; 2]]> = state.iter_mut().map(|v| v.as_mut_slice()).collect();
    if !iir::filter_rows(hp.sos, &src, &mut outs, &mut states) {
        return Err(first_non_finite(layout, &src, from));
    }
    drop(src);
    Ok(Filtered { from, raw, forces })
}

/// The first NaN or inf of the raw forces `src` (fx if present, fy, fz)
/// that start at sample `from`, by sample and then channel.
fn first_non_finite(layout: &FileLayout, src: &[&[f64]], from: usize) -> KernelError {
    let names: &[&'static str] = if layout.fx.is_some() { &["fx", "fy", "fz"] } else { &["fy", "fz"] };
    let n = src.first().map_or(0, |c| c.len());
    for i in 0..n {
        for (name, c) in names.iter().zip(src) {
            if !c[i].is_finite() {
                return KernelError::NonFinite { channel: name, sample: Some(from + i), window: false };
            }
        }
    }
    invalid(format!("the high-pass filter diverged in samples from {from}"))
}

/// The windows of one filtered block.
fn filtered_windows(
    f: &Filtered,
    layout: &FileLayout,
    ks: std::ops::Range<usize>,
    step: usize,
    opt: &WindowOptions,
) -> Result<Vec<WindowStats>, KernelError> {
    let raw = |i: usize| f.raw.get(i);
    let x = usize::from(layout.fx.is_some());
    let ch = Channels {
        fx: layout.fx.as_ref().map(|_| f.forces[0].as_slice()),
        fy: &f.forces[x],
        fz: &f.forces[x + 1],
        aux: raw(3),
        raw: Some((raw(1).unwrap_or(&[]), raw(2).unwrap_or(&[]))),
    };
    let starts: Vec<usize> = ks.clone().map(|k| k * step - f.from).collect();
    // In parallel: the thread that filters the next block joins in when it is done.
    crate::numerics::windows::windows_stats(&ch, &starts, opt).map_err(|err| match err {
        KernelError::NonFinite { .. } => err.shifted(f.from),
        other => invalid(format!("{other} (block from sample {})", f.from)),
    })
}

/// Statistics of windows `grid.k0 .. grid.k1` of raw forces high-passed
/// from sample `hp.origin` on (state carried across blocks, bitwise as one
/// call of the filter), with the classical COF of the raw forces. Needs
/// `grid.step >= opt.len` (windows that do not overlap), so each block's
/// windows lie in its own filtered samples.
pub fn windows_stats_mapped_highpass(
    file: &File,
    layout: &FileLayout,
    grid: &Grid,
    opt: &WindowOptions,
    hp: &HighPass<'_>,
) -> Result<Vec<WindowStats>, KernelError> {
    let out = std::sync::Mutex::new(Vec::with_capacity(grid.k1.saturating_sub(grid.k0)));
    windows_stats_mapped_highpass_each(file, layout, grid, opt, hp, &|_, stats| {
        out.lock().unwrap_or_else(|e| e.into_inner()).extend(stats);
    })?;
    Ok(out.into_inner().unwrap_or_else(|e| e.into_inner()))
}

/// [`windows_stats_mapped_highpass`] handing each block's windows to `sink`
/// (as [`windows_stats_mapped_each`]; here the blocks arrive in order).
pub fn windows_stats_mapped_highpass_each<F>(
    file: &File,
    layout: &FileLayout,
    grid: &Grid,
    opt: &WindowOptions,
    hp: &HighPass<'_>,
    sink: &F,
) -> Result<(), KernelError>
where
    F: Fn(usize, Vec<WindowStats>) + Sync,
{
    check(file, layout, grid, opt)?;
    iir::validate_sos(hp.sos)?;
    if hp.zi.len() != hp.sos.len() {
        return Err(invalid(format!("zi must hold {} section states, got {}", hp.sos.len(), hp.zi.len())));
    }
    if grid.step < opt.len {
        return Err(invalid("the high-passed file path needs windows that do not overlap (step >= length)".into()));
    }
    if grid.k1 <= grid.k0 {
        return Ok(());
    }
    if hp.origin > grid.k0 * grid.step {
        return Err(invalid(format!("filtering starts at sample {} after the first window", hp.origin)));
    }
    let blocks = (grid.k1 - grid.k0).div_ceil(grid.block);
    let ks = |b: usize| (grid.k0 + b * grid.block)..(grid.k0 + (b + 1) * grid.block).min(grid.k1);
    // Block b filters [F_b, F_{b+1}): F_0 = origin, F_b = start of its first
    // window, the last ends with the last window.
    let bound = |b: usize| {
        if b == 0 {
            hp.origin
        } else if b == blocks {
            (grid.k1 - 1) * grid.step + opt.len
        } else {
            ks(b).start * grid.step
        }
    };
    let forces = 2 + usize::from(layout.fx.is_some()); // fx (if any), fy, fz
    let mut state: Vec<Vec<[f64; 2]>> = vec![vec![[0.0; 2]; hp.sos.len()]; forces];
    let mut cur = filter_block(file, layout, hp, bound(0), bound(1), &mut state, Filtered::default())?;
    let mut spare = Filtered::default();
    for b in 0..blocks {
        // Filter the next block while this one's windows are computed.
        let bufs = std::mem::take(&mut spare);
        let (next, stats) = rayon::join(
            || {
                (b + 1 < blocks)
                    .then(|| filter_block(file, layout, hp, bound(b + 1), bound(b + 2), &mut state, bufs))
                    .transpose()
            },
            || filtered_windows(&cur, layout, ks(b), grid.step, opt),
        );
        sink(b * grid.block, stats?);
        match next? {
            Some(n) => spare = std::mem::replace(&mut cur, n),
            None => break,
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::numerics::windows::{windows_stats, Deadband};
    use std::io::Write;

    fn temp_file(bytes: &[u8]) -> (std::path::PathBuf, File) {
        let path = std::env::temp_dir().join(format!("tribodyn-mapped-{}-{}", std::process::id(), bytes.len()));
        std::fs::File::create(&path).unwrap().write_all(bytes).unwrap();
        let f = File::open(&path).unwrap();
        (path, f)
    }

    #[test]
    fn chunks_of_one_channel_are_read_only_where_asked() {
        // A channel in chunks of 1000 samples stored out of order (an HDF5
        // dataset's), as little-endian f64 and as big-endian i16.
        let n = 4500u64;
        let order = [3u64, 0, 4, 1, 2];
        let chunk = 1000u64;
        for (num, big, w) in [(Num::F64, false, 8u64), (Num::I16, true, 2)] {
            let mut bytes = vec![0u8; 64];
            let mut parts = vec![(0u64, 0u64); order.len()];
            for &c in &order {
                let off = bytes.len() as u64;
                let count = chunk.min(n - c * chunk);
                parts[c as usize] = (count, off);
                for i in c * chunk..c * chunk + count {
                    let v = (i % 977) as i16 - 400;
                    match num {
                        Num::F64 => bytes.extend((v as f64).to_le_bytes()),
                        _ => bytes.extend(v.to_be_bytes()),
                    }
                }
                bytes.extend([0xAAu8; 24]); // another object's bytes between chunks
            }
            let (path, file) = temp_file(&bytes);
            let mut start = 0;
            let ext = Extents {
                num,
                big_endian: big,
                parts: parts
                    .iter()
                    .map(|&(count, off)| {
                        let e = Extent { start, ..Extent::single(count, off, w, (off, off + count * w)) };
                        start += count;
                        e
                    })
                    .collect(),
                ops: Vec::new(),
            };
            ext.check(bytes.len() as u64).unwrap();
            for (a, b) in [(0, n), (10, 20), (990, 1010), (250, 3750), (4499, 4500)] {
                let mut out = Vec::new();
                let mut cache = ByteCache::default();
                cache.begin();
                ext.read(&file, a, b, &mut out, &mut cache).unwrap();
                let want: Vec<f64> = (a..b).map(|i| ((i % 977) as i16 - 400) as f64).collect();
                assert_eq!(out, want, "{num:?} {a}..{b}");
                let held: usize = cache.entries[..cache.used].iter().map(|e| e.2.len()).sum();
                assert!(held as u64 <= (b - a) * w, "{num:?} {a}..{b}: {held} bytes read for {} samples", b - a);
            }
            std::fs::remove_file(path).unwrap();
        }
    }

    /// A file of `lead` bytes, then `segs` segments of a `head`-byte head and `per` samples of channel A, then
    /// `per` of B (`val(channel, sample)`: f64, or big-endian i32 with `Num::I32`), and each channel's Extents.
    fn two_channel_segments(
        lead: u64,
        (segs, per, head): (u64, u64, u64),
        num: Num,
        val: impl Fn(u64, u64) -> f64,
    ) -> (Vec<u8>, [Extents; 2]) {
        let mut bytes = vec![0xEEu8; lead as usize];
        for sgm in 0..segs {
            bytes.extend(vec![0x55u8; head as usize]);
            for ch in 0..2 {
                for j in 0..per {
                    let v = val(ch, sgm * per + j);
                    match num {
                        Num::F64 => bytes.extend(v.to_le_bytes()),
                        _ => bytes.extend((v as i32).to_be_bytes()),
                    }
                }
            }
        }
        let (first, w) = (lead + head, num.width());
        let len = 2 * per * w;
        let ext = |ch: u64| Extents {
            num,
            big_endian: num != Num::F64,
            parts: vec![Extent {
                start: 0,
                count: per,
                offset: first + ch * per * w,
                stride: w,
                chunk: (first, first + len),
                reps: segs,
                period: head + len,
            }],
            ops: Vec::new(),
        };
        (bytes, [ext(0), ext(1)])
    }

    #[test]
    fn a_short_part_of_a_channels_run_in_a_shared_chunk_is_read_alone() {
        // 6 segments: a 40-byte head, then 5000 samples of channel A and 5000 of B (one chunk, both channels)
        let (segs, per, head) = (6u64, 5000u64, 40u64);
        for (num, w) in [(Num::F64, 8u64), (Num::I32, 4)] {
            let (bytes, exts) = two_channel_segments(0, (segs, per, head), num, |ch, i| (ch * 100_000 + i) as f64);
            let (path, file) = temp_file(&bytes);
            let len = 2 * per * w;
            for (ch, e) in (0..2u64).zip(exts) {
                e.check(bytes.len() as u64).unwrap();
                for (a, b) in [(2100u64, 2300u64), (4999, 5001), (0, 400)] {
                    let (mut out, mut cache) = (Vec::new(), ByteCache::default());
                    cache.begin();
                    e.read(&file, a, b, &mut out, &mut cache).unwrap();
                    let want: Vec<f64> = (a..b).map(|i| (ch * 100_000 + i) as f64).collect();
                    assert_eq!(out, want, "{num:?} channel {ch} {a}..{b}");
                    let held: u64 = cache.entries[..cache.used].iter().map(|x| x.2.len() as u64).sum();
                    assert!(held <= (b - a) * w, "{num:?} {a}..{b}: {held} bytes held, not the segment's {len}");
                }
                // most of a run: the chunk is read once for both channels (kept for the other)
                let (mut out, mut cache) = (Vec::new(), ByteCache::default());
                cache.begin();
                e.read(&file, 5500, 9900, &mut out, &mut cache).unwrap();
                assert_eq!(out.len(), 4400);
                if num != Num::F64 || ch == 0 {
                    let held: u64 = cache.entries[..cache.used].iter().map(|x| x.2.len() as u64).sum();
                    assert_eq!(held, len, "{num:?} channel {ch}: the whole chunk");
                }
            }
            std::fs::remove_file(path).unwrap();
        }
    }

    #[test]
    fn windows_far_apart_are_read_alone_with_the_same_bits() {
        let n = 40_000;
        let mut fz: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() + 0.2 * (i as f64 * 1.7).cos()).collect();
        let fy: Vec<f64> = fz.iter().enumerate().map(|(i, z)| -0.15 * z + 0.02 * (i as f64 * 3.1).sin()).collect();
        let fx: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let aux: Vec<f64> = (0..n).map(|i| 4.0 + (i as f64 * 0.01).sin()).collect();
        let opt = WindowOptions {
            len: 700,
            orientation: 1.0,
            deadband: Deadband::Force(0.1),
            n_bins: 8,
            ext: Default::default(),
        };
        let step = opt.len + ALONE_GAP + 13;
        assert!(windows_alone(step, opt.len) && !windows_alone(opt.len + ALONE_GAP - 1, opt.len));
        let k1 = (n - opt.len) / step + 1;
        let starts: Vec<usize> = (1..k1).map(|k| k * step).collect();
        // a NaN in a gap is never read; one in window 5 is that window's error, as in memory
        fz[5 * step - 3] = f64::NAN;
        let run = |fz: &[f64], aux_scale: f64| {
            let mut bytes = vec![0u8; 64];
            for ch in [&fx[..], &fy[..], fz] {
                bytes.extend(ch.iter().flat_map(|v| v.to_le_bytes()));
            }
            let aux_at = bytes.len() as u64;
            bytes.extend(aux.iter().flat_map(|v| (v / aux_scale).to_le_bytes())); // aux through Extents, scaled back
            let (path, file) = temp_file(&bytes);
            let row = (n * 8) as u64;
            let aux_ext = Extents {
                num: Num::F64,
                big_endian: false,
                parts: vec![Extent::single(n as u64, aux_at, 8, (aux_at, aux_at + row))],
                ops: vec![Op::Linear { slope: aux_scale, intercept: 0.0 }],
            };
            let layout = FileLayout {
                fx: Some(Source::F64(64)),
                fy: Source::F64(64 + row),
                fz: Source::F64(64 + 2 * row),
                aux: Some(Source::Extents(std::sync::Arc::new(aux_ext))),
                n,
            };
            let got: Vec<_> = [1usize, 3, 100]
                .iter()
                .map(|&block| windows_stats_mapped(&file, &layout, &Grid { k0: 1, k1, step, block }, &opt, 2))
                .collect();
            std::fs::remove_file(path).unwrap();
            got
        };
        let scaled: Vec<f64> = aux.iter().map(|v| (v / 2.0) * 2.0).collect();
        let ch = Channels { fx: Some(&fx), fy: &fy, fz: &fz, aux: Some(&scaled), raw: None };
        let want = windows_stats(&ch, &starts, &opt).unwrap();
        for got in run(&fz, 2.0) {
            assert_eq!(format!("{:?}", got.unwrap()), format!("{want:?}"));
        }
        fz[5 * step + 11] = f64::NAN;
        let ch = Channels { fx: Some(&fx), fy: &fy, fz: &fz, aux: Some(&scaled), raw: None };
        let want = windows_stats(&ch, &starts, &opt).unwrap_err();
        assert_eq!(want, KernelError::NonFinite { channel: "fz", sample: Some(5 * step), window: true });
        for got in run(&fz, 2.0) {
            assert_eq!(got.unwrap_err(), want);
        }
    }

    #[test]
    fn segments_at_a_fixed_distance_are_read_in_one_span() {
        // 40 segments of a 100-byte head, then 30 samples of channel A and
        // 30 of channel B (f64; B also as big-endian i32 in a second file).
        let (segs, per, head) = (40u64, 30u64, 100u64);
        let val = |ch: u64, i: u64| (ch * 10_000 + i) as f64 * 0.5 - 77.0;
        for num in [Num::F64, Num::I32] {
            let (bytes, [a_ext, b_ext]) = two_channel_segments(16, (segs, per, head), num, val);
            let (path, file) = temp_file(&bytes);
            a_ext.check(bytes.len() as u64).unwrap();
            let exact = |v: f64| if num == Num::F64 { v } else { (v as i32) as f64 };
            for (a, b) in [(0, segs * per), (5, 65), (29, 31), (1100, 1200), (0, 1)] {
                let mut cache = ByteCache::default();
                cache.begin();
                let (mut xa, mut xb) = (Vec::new(), Vec::new());
                a_ext.read(&file, a, b, &mut xa, &mut cache).unwrap();
                b_ext.read(&file, a, b, &mut xb, &mut cache).unwrap();
                assert_eq!(xa, (a..b).map(|i| exact(val(0, i))).collect::<Vec<_>>(), "{num:?} A {a}..{b}");
                assert_eq!(xb, (a..b).map(|i| exact(val(1, i))).collect::<Vec<_>>(), "{num:?} B {a}..{b}");
                assert_eq!(cache.used, 1, "{num:?} {a}..{b}: one read for both channels and every segment");
            }
            std::fs::remove_file(path).unwrap();
        }
    }

    #[test]
    fn same_bits_as_the_in_memory_kernel() {
        let n = 10_007;
        let fz: Vec<f64> = (0..n).map(|i| (i as f64 * 0.37).sin() + 0.2 * (i as f64 * 1.7).cos()).collect();
        let fy: Vec<f64> = fz.iter().enumerate().map(|(i, z)| -0.15 * z + 0.02 * (i as f64 * 3.1).sin()).collect();
        let fx: Vec<f64> = (0..n).map(|i| (i as f64 * 0.11).cos()).collect();
        let aux: Vec<f64> = (0..n).map(|i| 4.0 + (i as f64 * 0.01).sin()).collect();
        // A 128-byte header, then the channels one after another.
        let mut bytes = vec![0u8; 128];
        for ch in [&fx, &fy, &fz, &aux] {
            bytes.extend(ch.iter().flat_map(|v| v.to_le_bytes()));
        }
        let (path, file) = temp_file(&bytes);
        let row = (n * 8) as u64;
        let layout = FileLayout {
            fx: Some(Source::F64(128)),
            fy: Source::F64(128 + row),
            fz: Source::F64(128 + 2 * row),
            aux: Some(Source::F64(128 + 3 * row)),
            n,
        };
        let opt = WindowOptions {
            len: 300,
            orientation: 1.0,
            deadband: Deadband::Force(0.1),
            n_bins: 8,
            ext: Default::default(),
        };
        let step = 250;
        let k1 = (n - opt.len) / step + 1;
        let ch = Channels { fx: Some(&fx), fy: &fy, fz: &fz, aux: Some(&aux), raw: None };
        let starts: Vec<usize> = (3..k1).map(|k| k * step).collect();
        let want = windows_stats(&ch, &starts, &opt).unwrap();
        for block in [1, 7, 1000] {
            let got = windows_stats_mapped(&file, &layout, &Grid { k0: 3, k1, step, block }, &opt, 2).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "block {block}");
        }
        // Bad layouts are errors, not panics.
        let past = FileLayout { n: n + 1, ..layout.clone() };
        assert!(windows_stats_mapped(&file, &past, &Grid { k0: 0, k1: 1, step, block: 4 }, &opt, 2).is_err());
        let odd = FileLayout { fy: Source::F64(129), ..layout.clone() };
        assert!(windows_stats_mapped(&file, &odd, &Grid { k0: 0, k1: 1, step, block: 4 }, &opt, 2).is_err());
        assert!(windows_stats_mapped(&file, &layout, &Grid { k0: 0, k1: k1 + 1, step, block: 4 }, &opt, 2).is_err());
        std::fs::remove_file(path).unwrap();
    }

    #[test]
    fn highpass_path_matches_filter_then_kernel() {
        let n = 9_001;
        let fz: Vec<f64> = (0..n).map(|i| 20.0 + (i as f64 * 0.37).sin() + 0.001 * i as f64).collect();
        let fy: Vec<f64> = fz.iter().enumerate().map(|(i, z)| -0.15 * z + 0.02 * (i as f64 * 3.1).sin()).collect();
        let aux: Vec<f64> = (0..n).map(|i| 4.0 + (i as f64 * 0.01).sin()).collect();
        let mut bytes = vec![0u8; 64];
        for ch in [&fy, &fz, &aux] {
            bytes.extend(ch.iter().flat_map(|v| v.to_le_bytes()));
        }
        let (path, file) = temp_file(&bytes);
        let row = (n * 8) as u64;
        let layout = FileLayout {
            fx: None,
            fy: Source::F64(64),
            fz: Source::F64(64 + row),
            aux: Some(Source::F64(64 + 2 * row)),
            n,
        };
        let sos: Vec<Section> = vec![[0.9997, -0.9997, 0.0, 1.0, -0.9994, 0.0]];
        let zi = crate::numerics::iir::sosfilt_zi(&sos).unwrap();
        let opt = WindowOptions {
            len: 400,
            orientation: 1.0,
            deadband: Deadband::Force(0.1),
            n_bins: 8,
            ext: Default::default(),
        };
        let (step, origin) = (450, 7);
        let k0 = 1;
        let k1 = (n - opt.len) / step + 1;
        // By hand: filter [origin, n) in one call, then the kernel.
        let mut state: Vec<[f64; 2]> =
            [fy[origin], fz[origin]].iter().flat_map(|&x0| zi.iter().map(move |z| [z[0] * x0, z[1] * x0])).collect();
        let src: Vec<f64> = fy[origin..].iter().chain(&fz[origin..]).copied().collect();
        let mut filt = vec![0.0; src.len()];
        crate::numerics::iir::sosfilt_into(&sos, &src, &mut filt, 2, &mut state).unwrap();
        let m = n - origin;
        let ch = Channels {
            fx: None,
            fy: &filt[..m],
            fz: &filt[m..],
            aux: Some(&aux[origin..]),
            raw: Some((&fy[origin..], &fz[origin..])),
        };
        let starts: Vec<usize> = (k0..k1).map(|k| k * step - origin).collect();
        let want = windows_stats(&ch, &starts, &opt).unwrap();
        let hp = HighPass { sos: &sos, zi: &zi, origin };
        for block in [1, 3, 100] {
            let got = windows_stats_mapped_highpass(&file, &layout, &Grid { k0, k1, step, block }, &opt, &hp).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "block {block}");
        }
        let overlap = Grid { k0, k1, step: 100, block: 4 };
        assert!(windows_stats_mapped_highpass(&file, &layout, &overlap, &opt, &hp).is_err());
        std::fs::remove_file(path).unwrap();
    }
}

#[cfg(test)]
mod direct_tests {
    use super::*;
    use std::sync::Arc;

    /// `segs` segments of a `head`-byte head, then `per[c]` samples of each channel c in turn (f64), and
    /// each channel's extents, in a file named `name`; sample i of channel c is `val(c, i)`.
    fn segments(name: &str, segs: u64, per: &[u64], head: u64) -> (Temp, File, Vec<Arc<Extents>>) {
        let mut bytes = vec![0xEEu8; 24];
        let mut parts: Vec<Vec<Extent>> = vec![Vec::new(); per.len()];
        let mut next = vec![0u64; per.len()];
        for _ in 0..segs {
            bytes.extend(vec![0x55u8; head as usize]);
            let chunk = (bytes.len() as u64, bytes.len() as u64 + per.iter().sum::<u64>() * 8);
            for (c, &k) in per.iter().enumerate() {
                let at = bytes.len() as u64;
                bytes.extend((next[c]..next[c] + k).flat_map(|i| val(c, i).to_le_bytes()));
                parts[c].push(Extent { start: next[c], ..Extent::single(k, at, 8, chunk) });
                next[c] += k;
            }
        }
        let path = std::env::temp_dir().join(format!("tribodyn-direct-{}-{name}", std::process::id()));
        std::fs::write(&path, &bytes).unwrap();
        let file = File::open(&path).unwrap();
        let exts = parts
            .into_iter()
            .map(|parts| Arc::new(Extents { num: Num::F64, big_endian: false, parts, ops: Vec::new() }))
            .collect();
        (Temp(path), file, exts)
    }

    fn val(c: usize, i: u64) -> f64 {
        c as f64 * 1e6 + i as f64 + 0.25
    }

    struct Temp(std::path::PathBuf);

    impl Drop for Temp {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    fn layout(
        fx: Option<&Arc<Extents>>,
        fy: &Arc<Extents>,
        fz: &Arc<Extents>,
        aux: Option<&Arc<Extents>>,
    ) -> FileLayout {
        let src = |e: &Arc<Extents>| Source::Extents(Arc::clone(e));
        FileLayout { fx: fx.map(src), fy: src(fy), fz: src(fz), aux: aux.map(src), n: fy.len() as usize }
    }

    /// The windows of `layout` at `starts` read directly and as before: (direct buffers, read calls, before's).
    fn both(file: &File, layout: &FileLayout, starts: &[usize], len: usize) -> (Vec<Vec<f64>>, usize, Vec<Vec<f64>>) {
        let mut s = Samples::default();
        s.read_windows(file, layout, starts, len).unwrap();
        let mut old = Samples::default();
        old.read_rest(file, layout, starts, len, 0).unwrap();
        let get = |s: &Samples| (0..4).map(|i| s.get(i).map_or(Vec::new(), |x| x.to_vec())).collect();
        (get(&s), s.direct_reads, get(&old))
    }

    fn want(c: usize, starts: &[usize], len: usize) -> Vec<f64> {
        starts.iter().flat_map(|&s| (s..s + len).map(|i| val(c, i as u64))).collect()
    }

    #[test]
    fn spans_across_segments_and_a_channel_not_asked_for() {
        // 50 segments of 3 channels of 30 samples; B is not asked for (its runs and the heads go to scratch)
        let (_t, f, e) = segments("across", 50, &[30, 30, 30], 100);
        let lay = layout(None, &e[0], &e[2], None);
        for (starts, len) in [(vec![5usize, 100, 370], 25usize), (vec![0], 1500), (vec![29, 59, 89], 2)] {
            let (got, reads, old) = both(&f, &lay, &starts, len);
            assert_eq!(got, old, "{starts:?}");
            assert_eq!((&got[1], &got[2]), (&want(0, &starts, len), &want(2, &starts, len)), "{starts:?}");
            assert!(got[0].is_empty() && got[3].is_empty());
            assert_eq!(reads, 1, "{starts:?}: one read for every run of both channels");
        }
        // every channel, fx and aux too, and the same channel in two roles (its runs overlap: read apart)
        let lay = layout(Some(&e[1]), &e[0], &e[0], Some(&e[2]));
        let (got, reads, old) = both(&f, &lay, &[7, 700], 40);
        assert_eq!(got, old);
        assert_eq!(got, [1, 0, 0, 2].map(|c| want(c, &[7, 700], 40)));
        assert!(reads >= 2, "{reads}");
    }

    #[test]
    fn long_gaps_and_more_runs_than_iov_max_split_the_read() {
        // a channel not asked for of 3000 samples (24 KB) between the ones asked for
        let (_t, f, e) = segments("gap", 6, &[10, 3000, 10], 40);
        let lay = layout(None, &e[0], &e[2], None);
        let (got, reads, old) = both(&f, &lay, &[0], 60);
        assert_eq!(got, old);
        assert_eq!((&got[1], &got[2]), (&want(0, &[0], 60), &want(2, &[0], 60)));
        // split where B lies (longer than DIRECT_GAP), not at the heads: A0 | C0 A1 | ... | C4 A5 | C5
        assert_eq!(reads, 7, "split at the runs of B");
        // 700 segments of 2 channels of 4 samples: 2100 buffers (runs and heads) in all, at most 1024 a read
        let (_t, f, e) = segments("iov", 700, &[4, 4], 20);
        let lay = layout(None, &e[0], &e[1], None);
        let (got, reads, old) = both(&f, &lay, &[0], 2800);
        assert_eq!(got, old);
        assert_eq!((&got[1], &got[2]), (&want(0, &[0], 2800), &want(1, &[0], 2800)));
        assert_eq!(reads, 3, "2100 buffers: 3 reads of at most {IOV_MAX}");
    }

    #[test]
    fn other_layouts_are_read_as_before() {
        let (_t, f, e) = segments("other", 8, &[50, 50], 64);
        let scaled = Arc::new(Extents { ops: vec![Op::Linear { slope: 2.0, intercept: 1.0 }], ..(*e[1]).clone() });
        let big = Arc::new(Extents { big_endian: true, ..(*e[1]).clone() });
        for other in [&scaled, &big] {
            let lay = layout(None, &e[0], other, None);
            let (got, reads, old) = both(&f, &lay, &[3, 200], 100);
            assert_eq!(got, old);
            assert_eq!(got[1], want(0, &[3, 200], 100));
            assert_eq!(reads, 1, "fy read directly, fz as before");
        }
        let lay = layout(None, &scaled, &big, None);
        assert_eq!(both(&f, &lay, &[3], 100).1, 0, "nothing read directly");
    }

    #[test]
    fn reads_that_stop_short_go_on_and_the_files_end_fails() {
        let src: Vec<u8> = (0..200u8).collect();
        let (mut a, mut b, mut gap) = (vec![0u8; 50], vec![0u8; 70], [0u8; 16]);
        let mut calls = 0;
        let mut iov = [
            IoBuf { base: a.as_mut_ptr(), len: 50 },
            IoBuf { base: gap.as_mut_ptr(), len: 16 },
            IoBuf { base: b.as_mut_ptr(), len: 70 },
        ];
        // at most 7 bytes a read, and an interrupted read now and then
        let ok = fill_vectored(10, &mut iov, |at, iov| {
            calls += 1;
            if calls % 5 == 0 {
                return Err(std::io::ErrorKind::Interrupted.into());
            }
            let mut at = at as usize;
            let mut placed = 0;
            for buf in iov {
                let k = buf.len.min(7 - placed).min(src.len() - at);
                // SAFETY: the test's buffers, `k` at most their length
                unsafe { std::ptr::copy_nonoverlapping(src[at..].as_ptr(), buf.base, k) };
                (placed, at) = (placed + k, at + k);
                if placed == 7 || at == src.len() {
                    break;
                }
            }
            Ok(placed)
        });
        assert!(ok && calls > 136 / 7);
        assert_eq!((&a[..], &b[..]), (&src[10..60], &src[76..146]));
        // the source ends first: a read places nothing, which fails
        let mut iov = [IoBuf { base: a.as_mut_ptr(), len: 50 }];
        let mut left = 30;
        assert!(!fill_vectored(0, &mut iov, |_, iov| {
            let k = left.min(iov[0].len).min(20);
            left -= k;
            Ok(k)
        }));
        let mut iov = [IoBuf { base: a.as_mut_ptr(), len: 50 }];
        assert!(!fill_vectored(0, &mut iov, |_, _| Err(std::io::ErrorKind::Other.into())));
    }

    #[test]
    fn a_file_truncated_while_read_gives_the_error_it_gave() {
        let (t, f, e) = segments("cut", 20, &[100, 100, 100], 50);
        let lay = layout(Some(&e[1]), &e[0], &e[2], None);
        let size = f.metadata().unwrap().len();
        let g = Grid { k0: 0, k1: 1, step: 10, block: 1 };
        let deadband = crate::numerics::windows::Deadband::Force(0.1);
        let opt = WindowOptions { len: 10, orientation: 1.0, deadband, n_bins: 8, ext: Default::default() };
        check(&f, &lay, &g, &opt).unwrap();
        std::fs::OpenOptions::new().write(true).open(&t.0).unwrap().set_len(size - 3000).unwrap();
        let mut s = Samples::default();
        let err = s.read_windows(&f, &lay, &[0, 1000], 990).unwrap_err();
        assert_eq!(s.direct_reads, 1);
        let mut old = Samples::default();
        assert_eq!(err, old.read_rest(&f, &lay, &[0, 1000], 990, 0).unwrap_err());
        assert!(err.to_string().contains("truncated while it was read"), "{err}");
    }
}
