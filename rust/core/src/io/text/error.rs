//! Why rows could not be parsed, and the reader's words for it: the one
//! place a text row's error is worded ([`Named`]'s `Display`; the Python
//! reader only puts the file's path before it).

use crate::error::KernelError;
use std::fmt;

/// Why rows could not be parsed.
#[derive(Clone, Debug, PartialEq)]
pub enum ParseError {
    /// A row with fewer fields than the columns need.
    Fields { line: u64, got: usize, need: usize },
    /// A field that is not a number: `col` indexes the columns asked for,
    /// `text` is the field without its surrounding whitespace.
    Number { line: u64, col: usize, text: Vec<u8> },
    /// The file ended `short` rows early (after line `line`).
    Eof { line: u64, short: u64 },
    /// The file cannot be read, or the call is malformed.
    Io(KernelError),
}

/// Characters of a field that a message quotes.
const QUOTED: usize = 40;

impl ParseError {
    /// The error in the reader's words, the columns asked for named by
    /// `columns` (each as the message quotes it: Python's `repr` of the
    /// channel's name); a column without a name is named by its index.
    pub fn named<'a>(&'a self, columns: &'a [String]) -> Named<'a> {
        Named { error: self, columns }
    }
}

/// A [`ParseError`] with the names of the columns asked for (see
/// [`ParseError::named`]).
pub struct Named<'a> {
    error: &'a ParseError,
    columns: &'a [String],
}

impl fmt::Display for Named<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.error {
            ParseError::Fields { line, got, need } => {
                write!(f, "line {line} has {got} fields, expected at least {need} (truncated or corrupt file)")
            }
            ParseError::Number { line, col, text } => {
                let field = repr_latin1(&text[..text.len().min(QUOTED)]);
                write!(f, "line {line}: {field} in ")?;
                match self.columns.get(*col) {
                    Some(name) => write!(f, "channel {name}")?,
                    None => write!(f, "column {col}")?,
                }
                write!(f, " is not a number (corrupt file?)")
            }
            ParseError::Eof { line, short } => write!(
                f,
                "file ended after line {line}, {short} data rows short (file changed or truncated since it was opened?)"
            ),
            ParseError::Io(e) => write!(f, "{e}"),
        }
    }
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.named(&[]).fmt(f)
    }
}

impl std::error::Error for ParseError {}

/// Bytes read as latin-1 text, quoted as Python's `repr` of that `str`
/// quotes it: in single quotes (double ones when the text holds a single
/// quote and no double one), the quote and the backslash escaped, `\t`,
/// `\n`, `\r` by name, the other bytes that are not printable (below 0x20,
/// 0x7f-0xa0 and the soft hyphen 0xad) as `\xhh`, every other byte as its
/// character.
fn repr_latin1(text: &[u8]) -> String {
    let quote = if text.contains(&b'\'') && !text.contains(&b'"') { '"' } else { '\'' };
    let mut out = String::with_capacity(text.len() + 2);
    out.push(quote);
    for &b in text {
        let c = char::from(b);
        match b {
            b'\\' => out.push_str("\\\\"),
            b'\t' => out.push_str("\\t"),
            b'\n' => out.push_str("\\n"),
            b'\r' => out.push_str("\\r"),
            _ if c == quote => {
                out.push('\\');
                out.push(c);
            }
            0x00..=0x1f | 0x7f..=0xa0 | 0xad => out.push_str(&format!("\\x{b:02x}")),
            _ => out.push(c),
        }
    }
    out.push(quote);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fields_are_quoted_as_python_repr_quotes_them() {
        // repr(bytes(range(256)).decode("latin-1")), as Python 3 writes it
        let all: Vec<u8> = (0..=255u8).collect();
        let want = concat!(
            r"'\x00\x01\x02\x03\x04\x05\x06\x07\x08\t\n\x0b\x0c\r\x0e\x0f\x10\x11\x12\x13\x14\x15\x16\x17",
            r"\x18\x19\x1a\x1b\x1c\x1d\x1e\x1f !",
            "\"",
            r"#$%&\'()*+,-./0123456789:;<=>?@ABCDEFGHIJKLMNOPQRSTUVWXYZ[\\]^_`abcdefghijklmnopqrstuvwxyz{|}~",
            r"\x7f\x80\x81\x82\x83\x84\x85\x86\x87\x88\x89\x8a\x8b\x8c\x8d\x8e\x8f\x90\x91\x92\x93\x94\x95",
            r"\x96\x97\x98\x99\x9a\x9b\x9c\x9d\x9e\x9f\xa0¡¢£¤¥¦§¨©ª«¬\xad®¯°±²³´µ¶·¸¹º»¼½¾¿ÀÁÂÃÄÅÆÇÈÉÊËÌÍÎÏÐÑ",
            "ÒÓÔÕÖ×ØÙÚÛÜÝÞßàáâãäåæçèéêëìíîïðñòóôõö÷øùúûüýþÿ'",
        );
        assert_eq!(repr_latin1(&all), want);
        assert_eq!(repr_latin1(b"it's"), "\"it's\"");
        assert_eq!(repr_latin1(b"a\"b"), "'a\"b'");
        assert_eq!(repr_latin1(b"x\\y"), r"'x\\y'");
        assert_eq!(repr_latin1(b""), "''");
    }

    #[test]
    fn messages_name_the_line_and_the_channel() {
        let e = ParseError::Number { line: 7, col: 1, text: [b"1.5x".as_slice(), &[b'9'; 50]].concat() };
        let names = ["'fy'".to_string(), "'Fz [N]'".to_string()];
        let nines = "9".repeat(36);
        assert_eq!(
            e.named(&names).to_string(),
            format!("line 7: '1.5x{nines}' in channel 'Fz [N]' is not a number (corrupt file?)")
        );
        assert_eq!(e.to_string(), format!("line 7: '1.5x{nines}' in column 1 is not a number (corrupt file?)"));
        assert_eq!(
            ParseError::Fields { line: 3, got: 2, need: 4 }.to_string(),
            "line 3 has 2 fields, expected at least 4 (truncated or corrupt file)"
        );
        assert_eq!(
            ParseError::Eof { line: 9, short: 5 }.to_string(),
            "file ended after line 9, 5 data rows short (file changed or truncated since it was opened?)"
        );
        let io = KernelError::Invalid("cannot read the file at byte 0: gone".into());
        assert_eq!(ParseError::Io(io).to_string(), "cannot read the file at byte 0: gone");
    }
}
