//! Reading a text file's bytes: `pread` from any offset, and the whole lines
//! that start in a range of bytes (a scan's piece).

use super::PIECE;
use crate::error::KernelError;
use std::fs::File;

/// Reads up to `buf.len()` bytes from byte `at` (fewer at the file's end).
#[cfg(unix)]
pub(super) fn read_some(file: &File, at: u64, buf: &mut [u8]) -> Result<usize, KernelError> {
    use std::os::unix::fs::FileExt;
    let mut got = 0;
    while got < buf.len() {
        match file.read_at(&mut buf[got..], at + got as u64) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(KernelError::Invalid(format!("cannot read the file at byte {at}: {e}"))),
        }
    }
    Ok(got)
}

#[cfg(not(unix))]
pub(super) fn read_some(_file: &File, _at: u64, _buf: &mut [u8]) -> Result<usize, KernelError> {
    Err(KernelError::Invalid("reading text natively needs a Unix system".into()))
}

/// The whole lines that start in bytes `[lo, hi)` of a file of `size`
/// bytes: the offset of the first and the buffer from which they are read
/// (`buf[skip..]`). The first line starts at `lo` when `at_start`, else after
/// the first `\n` from `lo - 1`; the last runs on past `hi` to its `\n`, and
/// a last line of the file without one is left out (the reader's to judge).
/// So consecutive ranges share no line and miss none, and each is read by
/// the thread that scans it.
pub(super) fn lines_in(
    file: &File,
    lo: u64,
    hi: u64,
    at_start: bool,
    size: u64,
) -> Result<(u64, Vec<u8>, usize), KernelError> {
    let from = if at_start { lo } else { lo - 1 };
    let mut buf = vec![0u8; (hi - from) as usize];
    let got = read_some(file, from, &mut buf)?;
    buf.truncate(got);
    let skip = if at_start {
        0
    } else {
        match memchr::memchr(b'\n', &buf) {
            Some(i) => i + 1,
            None => return Ok((hi, Vec::new(), 0)),
        }
    };
    if from + skip as u64 >= hi {
        return Ok((hi, Vec::new(), 0)); // inside a line that started before lo
    }
    // the last line that starts before hi ends at the first `\n` from byte hi - 1
    let mut search = ((hi - 1 - from) as usize).max(skip);
    let mut more = 1usize << 12; // a line's rest: small reads, doubling for long lines
    loop {
        if let Some(j) = memchr::memchr(b'\n', &buf[search.min(buf.len())..]) {
            buf.truncate(search + j + 1);
            break;
        }
        let at = from + buf.len() as u64;
        let old = buf.len();
        if at < size {
            buf.resize(old + more.min((size - at) as usize), 0);
            more = (2 * more).min(PIECE);
            let got = read_some(file, at, &mut buf[old..])?;
            buf.truncate(old + got);
            if got > 0 {
                search = old;
                continue;
            }
        }
        // the file ends without a last `\n`: whole lines only
        let end = memchr::memrchr(b'\n', &buf[skip..]).map_or(skip, |i| skip + i + 1);
        buf.truncate(end);
        break;
    }
    Ok((from + skip as u64, buf, skip))
}
