//! Windows of a recording whose channels are runs of little-endian f64 in
//! one file (a channels-first float64 `.npy`, say), read through memory
//! maps block by block: the kernel reads the page cache directly, with no
//! copy, and each thread maps one block at a time, so memory stays flat
//! whatever the recording's length.
//!
//! A block is a run of consecutive windows. Its samples of every channel
//! are mapped with `MAP_POPULATE` (the pages entered in one call, not
//! faulted one by one), its windows computed in order on one thread with
//! the next window prefetched, and the maps dropped. Blocks run in parallel
//! on the kernel pool and are joined in order, so the results are those of
//! [`crate::windows::windows_stats`] on the same samples, bit for bit.
//!
//! The file must not shrink while it is read: touching a mapped page past
//! the end of a file kills the process (SIGBUS), as with any memory map.
//! Its length is checked before each block is mapped.

use crate::error::KernelError;
use crate::windows::{windows_stats_serial, Channels, WindowOptions, WindowStats};
use memmap2::{Mmap, MmapOptions};
use rayon::prelude::*;
use std::fs::File;

const F64: u64 = std::mem::size_of::<f64>() as u64;

/// Where each channel's sample 0 lies in the file, in bytes; a channel's
/// samples follow it contiguously as little-endian f64.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FileLayout {
    pub fx: Option<u64>,
    pub fy: u64,
    pub fz: u64,
    /// Auxiliary channel (current or shunt voltage), averaged per window.
    pub aux: Option<u64>,
    /// Samples per channel.
    pub n: usize,
}

impl FileLayout {
    fn offsets(&self) -> [Option<u64>; 4] {
        [self.fx, Some(self.fy), Some(self.fz), self.aux]
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

fn check(file: &File, layout: &FileLayout, grid: &Grid, opt: &WindowOptions) -> Result<(), KernelError> {
    if cfg!(target_endian = "big") {
        return Err(invalid("mapped files are read as little-endian f64: not on this machine".into()));
    }
    if grid.step == 0 || grid.block == 0 || opt.len == 0 {
        return Err(invalid("step, block and window length must be at least 1".into()));
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
    for off in layout.offsets().into_iter().flatten() {
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
    Ok(())
}

/// Samples [a, b) of the channel whose sample 0 is at byte `off`, mapped.
fn map(file: &File, off: u64, a: usize, b: usize) -> Result<Mmap, KernelError> {
    let start = off + a as u64 * F64;
    let len = (b - a) * F64 as usize;
    let size = file.metadata().map_err(|e| invalid(format!("cannot read the file's length: {e}")))?.len();
    if start + len as u64 > size {
        return Err(invalid(format!("the file shrank to {size} bytes while it was read")));
    }
    // SAFETY: a read-only map of a range checked to lie inside the file;
    // the module docs state the one condition left to the caller (the file
    // must not shrink meanwhile).
    unsafe { MmapOptions::new().offset(start).len(len).populate().map(file) }
        .map_err(|e| invalid(format!("cannot map bytes {start}..{} of the file: {e}", start + len as u64)))
}

fn as_f64(m: &Mmap) -> &[f64] {
    let bytes: &[u8] = m;
    // The offset and the page-aligned base make the start 8-byte aligned
    // (checked), and every byte pattern is a valid f64.
    assert_eq!(bytes.as_ptr() as usize % std::mem::align_of::<f64>(), 0, "f64 alignment of a mapped channel");
    // SAFETY: aligned (above), len / 8 values inside the map, which
    // outlives the slice (borrowed from it).
    unsafe { std::slice::from_raw_parts(bytes.as_ptr() as *const f64, bytes.len() / 8) }
}

fn block(file: &File, layout: &FileLayout, grid: &Grid, opt: &WindowOptions, b: usize) -> Result<Vec<WindowStats>, KernelError> {
    let kb = grid.k0 + b * grid.block;
    let ke = (kb + grid.block).min(grid.k1);
    let a = kb * grid.step;
    let e = (ke - 1) * grid.step + opt.len;
    let maps: Vec<Option<Mmap>> =
        layout.offsets().iter().map(|o| o.map(|off| map(file, off, a, e)).transpose()).collect::<Result<_, _>>()?;
    let sl = |i: usize| maps[i].as_ref().map(as_f64);
    let (fy, fz) = (sl(1).unwrap_or(&[]), sl(2).unwrap_or(&[]));
    let ch = Channels { fx: sl(0), fy, fz, aux: sl(3), raw: None };
    let starts: Vec<usize> = (kb..ke).map(|k| k * grid.step - a).collect();
    windows_stats_serial(&ch, &starts, opt).map_err(|err| invalid(format!("{err} (block of samples {a}..{e})")))
}

/// Statistics of windows `grid.k0 .. grid.k1` of the channels in `file`,
/// in order, computed in parallel on the current pool, a block of
/// `grid.block` windows per task.
pub fn windows_stats_mapped(file: &File, layout: &FileLayout, grid: &Grid, opt: &WindowOptions) -> Result<Vec<WindowStats>, KernelError> {
    check(file, layout, grid, opt)?;
    if grid.k1 <= grid.k0 {
        return Ok(Vec::new());
    }
    let blocks = (grid.k1 - grid.k0).div_ceil(grid.block);
    let parts: Vec<Vec<WindowStats>> =
        (0..blocks).into_par_iter().map(|b| block(file, layout, grid, opt, b)).collect::<Result<_, _>>()?;
    Ok(parts.into_iter().flatten().collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::windows::{windows_stats, Deadband};
    use std::io::Write;

    fn temp_file(bytes: &[u8]) -> (std::path::PathBuf, File) {
        let path = std::env::temp_dir().join(format!("tribodyn-mapped-{}-{}", std::process::id(), bytes.len()));
        std::fs::File::create(&path).unwrap().write_all(bytes).unwrap();
        let f = File::open(&path).unwrap();
        (path, f)
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
        let layout = FileLayout { fx: Some(128), fy: 128 + row, fz: 128 + 2 * row, aux: Some(128 + 3 * row), n };
        let opt = WindowOptions { len: 300, orientation: 1.0, deadband: Deadband::Force(0.1), n_bins: 8 };
        let step = 250;
        let k1 = (n - opt.len) / step + 1;
        let ch = Channels { fx: Some(&fx), fy: &fy, fz: &fz, aux: Some(&aux), raw: None };
        let starts: Vec<usize> = (3..k1).map(|k| k * step).collect();
        let want = windows_stats(&ch, &starts, &opt).unwrap();
        for block in [1, 7, 1000] {
            let got = windows_stats_mapped(&file, &layout, &Grid { k0: 3, k1, step, block }, &opt).unwrap();
            assert_eq!(format!("{got:?}"), format!("{want:?}"), "block {block}");
        }
        // Bad layouts are errors, not panics.
        let past = FileLayout { n: n + 1, ..layout };
        assert!(windows_stats_mapped(&file, &past, &Grid { k0: 0, k1: 1, step, block: 4 }, &opt).is_err());
        let odd = FileLayout { fy: 129, ..layout };
        assert!(windows_stats_mapped(&file, &odd, &Grid { k0: 0, k1: 1, step, block: 4 }, &opt).is_err());
        assert!(windows_stats_mapped(&file, &layout, &Grid { k0: 0, k1: k1 + 1, step, block: 4 }, &opt).is_err());
        std::fs::remove_file(path).unwrap();
    }
}
