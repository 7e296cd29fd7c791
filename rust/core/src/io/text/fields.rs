//! Python's rules for a line of a text file: its text, its fields (`split`)
//! and whether it is skipped or ends a run before its fields are looked at.

use super::number::{bytes_ws, str_ws, strip};
use super::Dialect;

/// The fields of a line (without its end), as Python's `split`.
pub(super) struct Fields<'a> {
    rest: Option<&'a [u8]>,
    delim: Option<u8>,
}

impl<'a> Fields<'a> {
    pub(super) fn new(line: &'a [u8], delim: Option<u8>) -> Self {
        Fields { rest: Some(line), delim }
    }
}

impl<'a> Iterator for Fields<'a> {
    type Item = &'a [u8];
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let rest = self.rest?;
        match self.delim {
            Some(d) => match memchr::memchr(d, rest) {
                Some(i) => {
                    self.rest = Some(&rest[i + 1..]);
                    Some(&rest[..i])
                }
                None => {
                    self.rest = None;
                    Some(rest)
                }
            },
            None => {
                let a = rest.iter().position(|&b| !str_ws(b));
                let Some(a) = a else {
                    self.rest = None;
                    return None;
                };
                let e = rest[a..].iter().position(|&b| str_ws(b)).map_or(rest.len(), |i| a + i);
                self.rest = Some(&rest[e..]);
                Some(&rest[a..e])
            }
        }
    }
}

/// A line's text: up to its `\n`, without trailing `\r`.
#[inline]
pub(super) fn text_of(line: &[u8]) -> &[u8] {
    let mut e = line.len();
    while e > 0 && (line[e - 1] == b'\r' || line[e - 1] == b'\n') {
        e -= 1;
    }
    &line[..e]
}

pub(super) enum Kind {
    Skip,
    Data,
    Other,
}

impl Dialect {
    /// Whether a line is skipped, or ends a run, before its fields are looked at.
    pub(super) fn classify(&self, text: &[u8]) -> Kind {
        let s = strip(text, bytes_ws);
        if s.is_empty() {
            return if self.skip_blank { Kind::Skip } else { Kind::Other };
        }
        if let Some(c) = &self.comment {
            if s.starts_with(c) {
                return Kind::Skip;
            }
        }
        if !self.skip_blank && text.iter().all(|&b| bytes_ws(b) || Some(b) == self.delim) {
            return Kind::Other; // an LVM line of separators only is blank too
        }
        Kind::Data
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_split_like_python() {
        let f: Vec<&[u8]> = Fields::new(b"a,,b,", Some(b',')).collect();
        assert_eq!(f, vec![&b"a"[..], b"", b"b", b""]);
        let f: Vec<&[u8]> = Fields::new(b"  1\t 2 \x0c3 ", None).collect();
        assert_eq!(f, vec![&b"1"[..], b"2", b"3"]);
        assert_eq!(Fields::new(b"   ", None).count(), 0);
        assert_eq!(Fields::new(b"", Some(b',')).count(), 1);
    }
}
