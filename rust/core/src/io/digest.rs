//! The SHA-256 of an input file, read and hashed in steps of a caller's size (`sha2`, RustCrypto's
//! implementation; SHA-NI where the CPU has it).
//!
//! Why not Python's `hashlib` in a thread: it takes the GIL back after each block, and behind a thread
//! that holds the GIL (the command line drawing its figures with Matplotlib) each block waits up to the
//! interpreter's switch interval (5 ms) for it: a 1.15 GB input hashed in 1 MiB blocks took 4-10 s instead
//! of 1.2 s beside a busy Python thread on two vCPUs (issue 38 point 3). A step here runs without the GIL
//! (the binding releases it) and the caller may stop between steps.

use sha2::{Digest, Sha256};
use std::fs::File;
use std::io::{ErrorKind, Read};
use std::path::Path;

/// Bytes read per `read` call within a step (one buffer, reused).
const BLOCK: usize = 1 << 20;

/// A file being hashed: [`FileDigest::advance`] hashes up to a given count of its next bytes.
pub struct FileDigest {
    file: File,
    hasher: Sha256,
    buf: Vec<u8>,
    done: bool,
    bytes: u64,
}

impl FileDigest {
    /// Opens `path` for hashing (nothing read yet).
    pub fn open(path: &Path) -> std::io::Result<Self> {
        Ok(FileDigest { file: File::open(path)?, hasher: Sha256::new(), buf: Vec::new(), done: false, bytes: 0 })
    }

    /// Hashes up to `max_bytes` (at least one block) more bytes of the file; true once the file's end
    /// was reached (the digest is then whole). Interrupted reads are retried.
    pub fn advance(&mut self, max_bytes: u64) -> std::io::Result<bool> {
        if self.done {
            return Ok(true);
        }
        if self.buf.is_empty() {
            self.buf = vec![0u8; BLOCK];
        }
        let mut left = max_bytes.max(1);
        while left > 0 {
            let want = (BLOCK as u64).min(left) as usize;
            let k = match self.file.read(&mut self.buf[..want]) {
                Ok(k) => k,
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if k == 0 {
                self.done = true;
                self.buf = Vec::new();
                return Ok(true);
            }
            self.hasher.update(&self.buf[..k]);
            self.bytes += k as u64;
            left -= k as u64;
        }
        Ok(false)
    }

    /// Bytes hashed so far.
    pub fn bytes(&self) -> u64 {
        self.bytes
    }

    /// The lowercase hex digest of the bytes hashed so far (of the whole file once `advance` said so).
    pub fn hex(&self) -> String {
        let out = self.hasher.clone().finalize();
        out.iter().map(|b| format!("{b:02x}")).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn digest_of(data: &[u8], step: u64) -> String {
        let dir = std::env::temp_dir().join(format!("tribodyn-digest-{}-{}-{step}", std::process::id(), data.len()));
        std::fs::File::create(&dir).unwrap().write_all(data).unwrap();
        let mut d = FileDigest::open(&dir).unwrap();
        let mut steps = 0;
        while !d.advance(step).unwrap() {
            steps += 1;
            assert!(steps < 1_000_000);
        }
        assert_eq!(d.bytes(), data.len() as u64);
        std::fs::remove_file(&dir).unwrap();
        d.hex()
    }

    #[test]
    fn known_digests() {
        // FIPS 180-2 examples
        assert_eq!(digest_of(b"", 1), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
        assert_eq!(digest_of(b"abc", 1), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
        let long = b"abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";
        assert_eq!(digest_of(long, 7), "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
    }

    #[test]
    fn the_step_size_never_changes_the_digest() {
        let data: Vec<u8> = (0..(3 * BLOCK + 17)).map(|i| (i * 31 % 251) as u8).collect();
        let whole = digest_of(&data, u64::MAX);
        for step in [4095u64, BLOCK as u64 - 1, BLOCK as u64, BLOCK as u64 + 1, 2 * BLOCK as u64] {
            assert_eq!(digest_of(&data, step), whole, "step {step}");
        }
    }

    #[test]
    fn a_missing_file_is_an_error() {
        assert!(FileDigest::open(Path::new("/nonexistent/tribodyn-no-such-file")).is_err());
    }
}
