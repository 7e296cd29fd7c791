//! The segment index of an NI TDMS file, read natively: where each
//! channel's samples lie, as [`Extents`] the mapped kernel reads with
//! `pread` (no file position: safe from any number of threads).
//!
//! A TDMS file is a sequence of segments, each a 28-byte lead-in (tag
//! `TDSm`, table-of-contents flags, version, length of the segment and of
//! its metadata), the metadata (objects with their raw data index and
//! properties; incremental: an object list may continue the previous
//! segment's, an index may say "same as before") and the raw data: one or
//! more chunks, each holding every data object's values contiguously or
//! as interleaved rows, or DAQmx raw rows (scalers at byte offsets of a
//! row). Numeric types in both byte orders are read here; anything else
//! (strings, timestamps, booleans, DAQmx digital lines, mixed layouts) is
//! reported as a reason to read the file another way ([`Index::fallback`]).
//! Damage (a truncated file, an unfinished segment, metadata that does not
//! end where the data start, data that are no whole number of chunks, a
//! flipped interleaving flag) is an error naming the segment.

use crate::error::KernelError;
use crate::io::mapped::{read_bytes, Extent, Extents, Num};
use std::collections::HashMap;
use std::fs::File;
use std::rc::Rc;

const LEAD_IN: u64 = 28;
const TOC_META_DATA: u32 = 1 << 1;
const TOC_NEW_OBJ_LIST: u32 = 1 << 2;
const TOC_RAW_DATA: u32 = 1 << 3;
const TOC_INTERLEAVED: u32 = 1 << 5;
const TOC_BIG_ENDIAN: u32 = 1 << 6;
const TOC_DAQMX: u32 = 1 << 7;
const INCOMPLETE: u64 = u64::MAX;
const NO_DATA: u32 = 0xFFFF_FFFF;
const SAME_AS_PREVIOUS: u32 = 0;
const FORMAT_CHANGING_SCALER: u32 = 0x1269;
const DIGITAL_LINE_SCALER: u32 = 0x126A;
const STRING: u32 = 0x20;
const DAQMX_RAW: u32 = 0xFFFF_FFFF;
/// Key of a channel's own samples (not one DAQmx scaler's) in [`Channel::runs`].
pub const PLAIN: i64 = -1;

fn corrupt(msg: String) -> KernelError {
    KernelError::Invalid(msg)
}

/// Numeric type of a TDMS data type code; None for the others.
fn tdms_num(code: u32) -> Option<Num> {
    Some(match code {
        1 => Num::I8,
        2 => Num::I16,
        3 => Num::I32,
        4 => Num::I64,
        5 => Num::U8,
        6 => Num::U16,
        7 => Num::U32,
        8 => Num::U64,
        9 | 0x19 => Num::F32,
        10 | 0x1A => Num::F64,
        _ => return None,
    })
}

/// Size in bytes of values of a TDMS data type: Some(None) for strings
/// (sized by the index), None for codes that are no type.
fn tdms_size(code: u32) -> Option<Option<u64>> {
    if let Some(n) = tdms_num(code) {
        return Some(Some(n.width()));
    }
    Some(match code {
        0 => Some(0),     // void
        0x21 => Some(1),  // boolean
        0x44 => Some(16), // timestamp
        0x08000C => Some(8),
        0x10000D => Some(16),
        STRING => None,
        DAQMX_RAW => None,
        _ => return None,
    })
}

/// DAQmx scaler type codes (not the TDMS codes) and the TDMS code of the same type.
fn daqmx_num(code: u32) -> Option<(Num, u32)> {
    Some(match code {
        0 => (Num::U8, 5),
        1 => (Num::I8, 1),
        2 => (Num::U16, 6),
        3 => (Num::I16, 2),
        4 => (Num::U32, 7),
        5 => (Num::I32, 3),
        6 => (Num::U64, 8),
        7 => (Num::I64, 4),
        8 => (Num::F32, 9),
        9 => (Num::F64, 10),
        _ => return None,
    })
}

/// Sizes of the fixed-size property types; strings are length-prefixed.
fn prop_size(code: u32) -> Option<usize> {
    Some(match code {
        1 | 5 | 0x21 => 1,
        2 | 6 => 2,
        3 | 7 | 9 | 0x19 => 4,
        4 | 8 | 10 | 0x1A => 8,
        0x44 => 16,
        _ => return None,
    })
}

#[derive(Debug, Clone, PartialEq)]
struct Scaler {
    num: Option<(Num, u32)>,
    buffer: u32,
    byte_offset: u32,
    scale_id: u32,
}

#[derive(Debug, Clone, PartialEq)]
enum RawIndex {
    Plain { code: u32, nv: u64, data_size: u64 },
    Daqmx { code: u32, nv: u64, scalers: Vec<Scaler>, widths: Vec<u32>, digital: bool },
}

impl RawIndex {
    fn nv(&self) -> u64 {
        match self {
            RawIndex::Plain { nv, .. } | RawIndex::Daqmx { nv, .. } => *nv,
        }
    }
}

#[derive(Debug, Clone)]
struct SegObj {
    id: usize,
    has_data: bool,
    index: Option<Rc<RawIndex>>,
}

/// One object of the file (root, group or channel) as the whole file describes it.
#[derive(Debug, Default)]
pub struct Object {
    pub path: String,
    /// (name, TDMS type code, value bytes as stored, big-endian), latest value per name, in order of first appearance.
    pub properties: Vec<(String, u32, Vec<u8>, bool)>,
    /// TDMS data type code of its values (the first segment with data).
    pub code: Option<u32>,
    /// Values in all segments.
    pub n: u64,
    /// Its samples ([`PLAIN`]) or, for DAQmx raw data, each scaler's (by scale id).
    pub runs: Vec<(i64, Extents)>,
    /// Why its samples cannot be read here, if so.
    pub unsupported: Option<String>,
}

/// The index of a TDMS file.
#[derive(Debug, Default)]
pub struct Index {
    pub objects: Vec<Object>,
    pub segments: usize,
    /// What npTDMS would log as warnings (versions).
    pub warnings: Vec<String>,
    /// Why the file (as a whole) should be read another way, if so.
    pub fallback: Option<String>,
}

struct Meta<'a> {
    b: &'a [u8],
    p: usize,
    big: bool,
}

struct Overrun;

impl<'a> Meta<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], Overrun> {
        if n > self.b.len() - self.p {
            return Err(Overrun);
        }
        let s = &self.b[self.p..self.p + n];
        self.p += n;
        Ok(s)
    }
    fn u32(&mut self) -> Result<u32, Overrun> {
        let a: [u8; 4] = self.take(4)?.try_into().expect("4 bytes");
        Ok(if self.big { u32::from_be_bytes(a) } else { u32::from_le_bytes(a) })
    }
    fn u64(&mut self) -> Result<u64, Overrun> {
        let a: [u8; 8] = self.take(8)?.try_into().expect("8 bytes");
        Ok(if self.big { u64::from_be_bytes(a) } else { u64::from_le_bytes(a) })
    }
    fn string(&mut self) -> Result<&'a [u8], Overrun> {
        let n = self.u32()? as usize;
        self.take(n)
    }
}

/// A Python-like repr of a few bytes (`b'TDSm'`), for messages.
fn bytes_repr(b: &[u8]) -> String {
    let mut s = String::from("b'");
    for &c in b {
        match c {
            b'\\' => s.push_str("\\\\"),
            b'\'' => s.push_str("\\'"),
            b'\t' => s.push_str("\\t"),
            b'\n' => s.push_str("\\n"),
            b'\r' => s.push_str("\\r"),
            0x20..=0x7e => s.push(c as char),
            _ => s.push_str(&format!("\\x{c:02x}")),
        }
    }
    s.push('\'');
    s
}

/// Channel (group, name) of an object path `/'group'/'channel'` (quotes doubled inside), None for others.
pub fn channel_of(path: &str) -> Option<(String, String)> {
    let parts = path_components(path)?;
    match parts.as_slice() {
        [g, c] => Some((g.clone(), c.clone())),
        _ => None,
    }
}

/// Components of an object path; None when malformed.
pub fn path_components(path: &str) -> Option<Vec<String>> {
    let mut out = Vec::new();
    let mut it = path.chars().peekable();
    while let Some(c) = it.next() {
        if c != '/' || it.next() != Some('\'') {
            return None;
        }
        let mut comp = String::new();
        loop {
            match it.next()? {
                '\'' if it.peek() == Some(&'\'') => {
                    it.next();
                    comp.push('\'');
                }
                '\'' => break,
                ch => comp.push(ch),
            }
        }
        out.push(comp);
    }
    (out.len() <= 2).then_some(out)
}

/// A run being built: (scale key, type, big-endian, extents).
type Run = (i64, Num, bool, Vec<Extent>);

#[allow(clippy::type_complexity)] // the layouts' key, named where it is built
struct Builder {
    objects: Vec<Object>,
    ids: HashMap<String, usize>,
    /// Latest segment object of each id (npTDMS's "previous segment objects").
    last: Vec<Option<SegObj>>,
    /// Per object, its runs being built: (key, num, big, parts).
    runs: Vec<Vec<Run>>,
    /// Per set of (object, values, type) of a segment: interleaved or not, where first seen.
    layouts: HashMap<Vec<(usize, u64, u32)>, (bool, String)>,
    fallback: Option<String>,
}

impl Builder {
    fn id(&mut self, path: &str) -> usize {
        if let Some(&i) = self.ids.get(path) {
            return i;
        }
        let i = self.objects.len();
        self.objects.push(Object { path: path.to_string(), ..Default::default() });
        self.runs.push(Vec::new());
        self.ids.insert(path.to_string(), i);
        i
    }

    fn set_last(&mut self, o: &SegObj) {
        if self.last.len() <= o.id {
            self.last.resize(o.id + 1, None);
        }
        self.last[o.id] = Some(o.clone());
    }

    fn fall(&mut self, why: String) {
        if self.fallback.is_none() {
            self.fallback = Some(why);
        }
    }

    fn unsupported(&mut self, id: usize, why: String) {
        let o = &mut self.objects[id];
        if o.unsupported.is_none() {
            o.unsupported = Some(why);
        }
    }

    /// Adds samples to a run of object `id` (merged with the last extent when they continue it).
    fn push(&mut self, id: usize, key: i64, num: Num, big: bool, e: Extent) {
        let runs = &mut self.runs[id];
        let r = match runs.iter_mut().position(|r| r.0 == key) {
            Some(i) => &mut runs[i],
            None => {
                runs.push((key, num, big, Vec::new()));
                runs.last_mut().expect("pushed")
            }
        };
        if r.1 != num || r.2 != big {
            let path = self.objects[id].path.clone();
            self.unsupported(id, format!("channel {path} changes its data type or byte order between segments"));
            return;
        }
        let start = r.3.last().map_or(0, |l| l.start + l.total());
        let e = Extent { start, ..e };
        if let Some(l) = r.3.last_mut() {
            // The samples continue the last run in the file (chunks of one segment, one after another).
            if l.reps == 1
                && l.stride == e.stride
                && l.offset + l.count * l.stride == e.offset
                && (l.chunk == e.chunk || l.chunk.1 == e.chunk.0)
            {
                l.count += e.count;
                l.chunk.1 = l.chunk.1.max(e.chunk.1);
                return;
            }
            // The same layout again, a fixed number of bytes further (segments of one size).
            let period = if l.reps == 1 { e.offset.checked_sub(l.offset) } else { Some(l.period) };
            if let Some(p) = period.filter(|&p| p > 0) {
                let d = l.reps * p;
                if l.count == e.count
                    && l.stride == e.stride
                    && e.offset == l.offset + d
                    && e.chunk == (l.chunk.0 + d, l.chunk.1 + d)
                {
                    l.period = p;
                    l.reps += 1;
                    return;
                }
            }
        }
        r.3.push(e);
    }
}

/// Reads the index of the TDMS file `file` (whose name, for messages, is
/// the caller's). Errors are corrupt or truncated files, with messages
/// naming the segment (1-based) and its byte position.
///
/// With `index_file` (the `.tdms_index` NI writes beside the data: the
/// same lead-ins, tagged `TDSh`, and metadata, without the data) the
/// metadata are read from it in one read instead of a read per segment;
/// each segment's lead-in in the data file must equal the index's. An
/// index that does not match, or that cannot be read, is ignored (the data
/// file is walked, with a warning saying so): it never changes the result.
pub fn read_index(file: &File, index_file: Option<&File>) -> Result<Index, KernelError> {
    if let Some(ix) = index_file {
        let len = ix.metadata().map(|m| m.len()).unwrap_or(0);
        let mut bytes = vec![0u8; len as usize];
        let why = match read_bytes(ix, 0, &mut bytes) {
            Ok(()) => match walk(file, Some(&bytes)) {
                Ok(idx) => return Ok(idx),
                Err(e) => e.to_string(),
            },
            Err(e) => e.to_string(),
        };
        let mut idx = walk(file, None)?;
        idx.warnings.push(format!("the .tdms_index file was not used ({why}); the data file's metadata were read"));
        return Ok(idx);
    }
    walk(file, None)
}

/// Whether `a` (from the index) and `b` (from the data file) are the same lead-in but for the tag.
fn same_lead_in(a: &[u8], b: &[u8]) -> bool {
    a.len() == b.len() && a.len() == LEAD_IN as usize && &a[..4] == b"TDSh" && &b[..4] == b"TDSm" && a[4..] == b[4..]
}

fn walk(file: &File, index: Option<&[u8]>) -> Result<Index, KernelError> {
    walk_with(file, index, true)
}

/// A segment, for messages: formatted only when one is made.
#[derive(Debug, Clone, Copy)]
struct Seg {
    number: usize,
    pos: u64,
}

impl std::fmt::Display for Seg {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "segment {} at byte {}", self.number, self.pos)
    }
}

/// The metadata last parsed: a segment whose metadata are the same bytes
/// (same table of contents, raw data offset) right after a segment with
/// this object list has this object list again (npTDMS's rules, applied
/// twice, give what they gave once: each object's header sets its fields
/// to values of its own, properties are set to the same values).
struct MetaMemo {
    toc: u32,
    raw_off: u64,
    bytes: Vec<u8>,
    objs: Rc<Vec<SegObj>>,
}

/// What placing a segment's data did to the index, its extents' offsets
/// from the segment's data: a segment with the same object list, table of
/// contents and data length does the same, its offsets further on (every
/// other effect of [`place_data`] is set once, and was).
#[derive(Default)]
struct Plan {
    /// Values added to objects (object, values).
    adds: Vec<(usize, u64)>,
    /// Extents pushed (object, key, type, big-endian, extent with offsets from the data's start).
    pushes: Vec<(usize, i64, Num, bool, Extent)>,
    /// More pushes than [`Plan::MAX`]: not replayed.
    full: bool,
}

impl Plan {
    const MAX: usize = 1024;

    fn add(&mut self, id: usize, n: u64) {
        self.adds.push((id, n));
    }

    /// Pushes `e` (of the data starting at `data_pos`) to `b` and notes it.
    fn push(&mut self, b: &mut Builder, data_pos: u64, push: (usize, i64, Num, bool, Extent)) {
        let (id, key, num, big, e) = push;
        b.push(id, key, num, big, e);
        if self.full {
            return;
        }
        if self.pushes.len() == Self::MAX {
            self.full = true;
            self.pushes = Vec::new();
            return;
        }
        let rel = Extent { offset: e.offset - data_pos, chunk: (e.chunk.0 - data_pos, e.chunk.1 - data_pos), ..e };
        self.pushes.push((id, key, num, big, rel));
    }

    /// Does again what was noted, for data starting at `data_pos`.
    fn replay(&self, b: &mut Builder, data_pos: u64) {
        for &(id, n) in &self.adds {
            let o = &mut b.objects[id].n;
            *o = o.saturating_add(n);
        }
        for &(id, key, num, big, e) in &self.pushes {
            let e = Extent { offset: e.offset + data_pos, chunk: (e.chunk.0 + data_pos, e.chunk.1 + data_pos), ..e };
            b.push(id, key, num, big, e);
        }
    }
}

/// The data last placed (see [`Plan`]).
struct PlaceMemo {
    objs: Rc<Vec<SegObj>>,
    toc: u32,
    total: u64,
    plan: Plan,
}

#[cfg(test)]
thread_local! {
    /// Segments of this thread's walks whose (metadata, data) were replayed.
    static REPLAYED: std::cell::Cell<(usize, usize)> = const { std::cell::Cell::new((0, 0)) };
}

/// The walk; `replay`: whether segments that repeat the one before are
/// placed by [`MetaMemo`] and [`Plan`] (false: each parsed and placed
/// afresh; the tests compare both).
fn walk_with(file: &File, index: Option<&[u8]>, replay: bool) -> Result<Index, KernelError> {
    let mut ipos = 0usize;
    let size = file.metadata().map_err(|e| corrupt(format!("cannot read the file's length: {e}")))?.len();
    let mut b = Builder {
        objects: Vec::new(),
        ids: HashMap::new(),
        last: Vec::new(),
        runs: Vec::new(),
        layouts: HashMap::new(),
        fallback: None,
    };
    let mut warnings = Vec::new();
    let mut version: Option<i32> = None;
    let mut prev: Option<Rc<Vec<SegObj>>> = None;
    let mut pos = 0u64;
    let mut count = 0usize;
    let mut window = Window { want: Window::FIRST, ..Default::default() };
    let mut meta_memo: Option<MetaMemo> = None;
    let mut place_memo: Option<PlaceMemo> = None;
    // Small segments (a logger's): lead-ins and metadata read through one
    // sequential window, not two small reads each (a cold file is then read
    // at disk speed, not seek by seek). Segments of a few KiB or more: only
    // their heads are read, lead-in and metadata in one read (as long as
    // the segment before's), for small segments with the kernel told to
    // read the file ahead (a warm file's data are then not copied at all, a
    // cold one still streams).
    let mut small = false;
    let mut peek = false;
    while pos < size {
        let number = count + 1;
        let seg = Seg { number, pos };
        if size - pos < LEAD_IN {
            return Err(corrupt(format!("truncated TDMS file ({} stray bytes after segment {count})", size - pos)));
        }
        let mode = if small && !peek { Mode::Window } else { Mode::Head { advise: small } };
        let mut lead = [0u8; LEAD_IN as usize];
        if index.is_some() {
            read_bytes(file, pos, &mut lead)?;
        } else {
            lead.copy_from_slice(window.get(file, pos, LEAD_IN as usize, size, mode)?);
        }
        if let Some(ix) = index {
            let il = ix.get(ipos..ipos + LEAD_IN as usize).unwrap_or(&[]);
            if !same_lead_in(il, &lead) {
                return Err(corrupt(format!("its segment {number} differs from the data file's")));
            }
        }
        if &lead[..4] != b"TDSm" {
            let what =
                if count == 0 { "not a TDMS file".to_string() } else { format!("corrupt TDMS file at byte {pos}") };
            return Err(corrupt(format!("{what} (bad segment tag {})", bytes_repr(&lead[..4]))));
        }
        let toc = u32::from_le_bytes(lead[4..8].try_into().expect("4"));
        let big = toc & TOC_BIG_ENDIAN != 0;
        let rd32 = |a: &[u8]| {
            let a: [u8; 4] = a.try_into().expect("4");
            if big {
                u32::from_be_bytes(a)
            } else {
                u32::from_le_bytes(a)
            }
        };
        let rd64 = |a: &[u8]| {
            let a: [u8; 8] = a.try_into().expect("8");
            if big {
                u64::from_be_bytes(a)
            } else {
                u64::from_le_bytes(a)
            }
        };
        let ver = rd32(&lead[8..12]) as i32;
        let next_off = rd64(&lead[12..20]);
        let raw_off = rd64(&lead[20..28]);
        match version {
            None => {
                if ver != 4712 && ver != 4713 {
                    warnings.push(format!("Unrecognised version number: {ver}"));
                }
                version = Some(ver);
            }
            Some(v) if v != ver => warnings.push(format!("Segment version mismatch, {ver} != {v}")),
            _ => {}
        }
        if next_off == INCOMPLETE {
            return Err(corrupt(format!("TDMS {seg} was never completed (writer aborted or file truncated)")));
        }
        let end = pos.checked_add(LEAD_IN).and_then(|p| p.checked_add(next_off));
        let end = match end {
            Some(e) if e <= size => e,
            _ => {
                let need = (pos as u128) + (LEAD_IN as u128) + (next_off as u128);
                return Err(corrupt(format!(
                    "truncated TDMS file: segment {number} needs {need} bytes, the file has {size}"
                )));
            }
        };
        if raw_off > next_off {
            return Err(corrupt(format!(
                "corrupt TDMS file: {seg}: raw data offset {raw_off} lies beyond the segment's end ({next_off} bytes)"
            )));
        }
        let data_pos = pos + LEAD_IN + raw_off;
        let objs: Rc<Vec<SegObj>> = if toc & TOC_META_DATA == 0 {
            if raw_off != 0 {
                return Err(corrupt(format!(
                    "corrupt TDMS file: {seg}: raw data offset {raw_off} in a segment without metadata"
                )));
            }
            match &prev {
                Some(p) => p.clone(),
                None => return Err(corrupt(
                    "cannot read TDMS metadata: kTocMetaData is not set for segment but there is no previous segment"
                        .into(),
                )),
            }
        } else {
            // Metadata are a few KiB; a (corrupt) offset of gigabytes is not read whole.
            let cap = raw_off.min(META_CAP);
            let meta: &[u8] = match index {
                Some(ix) => {
                    let from = ipos + LEAD_IN as usize;
                    let m = from.checked_add(cap as usize).and_then(|to| ix.get(from..to));
                    m.ok_or_else(|| corrupt(format!("its segment {number} is cut short")))?
                }
                None => window.get(file, pos + LEAD_IN, cap as usize, size, mode)?,
            };
            let repeated = meta_memo.as_ref().filter(|mm| {
                replay
                    && mm.toc == toc
                    && mm.raw_off == raw_off
                    && prev.as_ref().is_some_and(|p| Rc::ptr_eq(p, &mm.objs))
                    && mm.bytes == meta
            });
            match repeated {
                Some(mm) => {
                    #[cfg(test)]
                    REPLAYED.with(|r| r.set((r.get().0 + 1, r.get().1)));
                    mm.objs.clone()
                }
                None => {
                    let mut m = Meta { b: meta, p: 0, big };
                    let parsed = parse_metadata(&mut b, &mut m, toc, prev.as_deref());
                    let list = match parsed {
                        Err(ParseError::Overrun) if cap < raw_off => {
                            b.fall(format!("{seg}: more than {META_CAP} bytes of metadata"));
                            return finish(b, count + 1, warnings);
                        }
                        Err(ParseError::Overrun) => {
                            return Err(corrupt(format!(
                                "corrupt TDMS file: {seg}: its metadata runs past the raw data offset {raw_off} (corrupt segment header)"
                            )))
                        }
                        Err(ParseError::Fallback(why)) => {
                            b.fall(why);
                            return finish(b, count + 1, warnings);
                        }
                        Err(ParseError::Bad(msg)) => return Err(corrupt(format!("cannot read TDMS metadata: {msg}"))),
                        Ok(l) => l,
                    };
                    let used = m.p;
                    if used != raw_off as usize
                        && (meta[used..].iter().any(|&x| x != 0) || !zeros(file, pos + LEAD_IN + cap, raw_off - cap)?)
                    {
                        return Err(corrupt(format!(
                            "corrupt TDMS file: {seg}: raw data offset {raw_off} but the metadata ends after {used} bytes (corrupt segment header)"
                        )));
                    }
                    let list = Rc::new(list);
                    if replay && cap == raw_off {
                        let mut bytes = meta_memo.take().map(|mm| mm.bytes).unwrap_or_default();
                        bytes.clear();
                        bytes.extend_from_slice(meta);
                        meta_memo = Some(MetaMemo { toc, raw_off, bytes, objs: list.clone() });
                    }
                    list
                }
            }
        };
        if !prev.as_ref().is_some_and(|p| Rc::ptr_eq(p, &objs)) {
            for o in objs.iter() {
                b.set_last(o);
            }
        }
        let total = end - data_pos;
        let same = place_memo
            .as_ref()
            .filter(|pm| replay && !pm.plan.full && pm.toc == toc && pm.total == total && Rc::ptr_eq(&pm.objs, &objs));
        match same {
            Some(pm) => {
                #[cfg(test)]
                REPLAYED.with(|r| r.set((r.get().0, r.get().1 + 1)));
                pm.plan.replay(&mut b, data_pos)
            }
            None => {
                let mut plan = Plan::default();
                place_data(&mut b, &objs, toc, data_pos, end, seg, &mut plan)?;
                if replay {
                    place_memo = Some(PlaceMemo { objs: objs.clone(), toc, total, plan });
                }
            }
        }
        prev = Some(objs);
        count += 1;
        pos = end;
        small = index.is_none() && next_off < SMALL_SEGMENT;
        peek = next_off >= Window::PEEK_FROM;
        window.want = (LEAD_IN + raw_off).clamp(Window::PEEK, Window::WANT_MAX);
        ipos += (LEAD_IN + raw_off) as usize;
    }
    if index.is_some_and(|ix| ipos != ix.len()) {
        return Err(corrupt("it holds more segments than the data file".into()));
    }
    if count == 0 {
        return Err(corrupt("empty TDMS file".into()));
    }
    finish(b, count, warnings)
}

/// Segments shorter than this are walked through a [`Window`] (with the file advised read ahead, or in windows).
const SMALL_SEGMENT: u64 = 64 << 10;

/// How [`Window::get`] reads what it does not hold.
#[derive(Debug, Clone, Copy)]
enum Mode {
    /// [`Window::want`] bytes (at least those asked for); `advise`: the kernel is asked to read the file
    /// [`Window::LEN`] ahead.
    Head { advise: bool },
    /// [`Window::LEN`] bytes, the next segments' heads with them.
    Window,
}

/// Bytes of the file read at the segments' heads (a segment's lead-in and
/// metadata in one read), or in large sequential pieces.
#[derive(Default)]
struct Window {
    buf: Vec<u8>,
    at: u64,
    /// The file is advised read ahead up to this byte.
    advised: u64,
    /// Bytes read at a segment's head: its lead-in and as much metadata as the segment before had.
    want: u64,
    /// A head was not in the kernel's cache (or the kernel could not say): the file is advised read
    /// ahead from then on. Until then, the file being cached, it is not (advising a cached file costs a
    /// lookup per page: a quarter of the walk of a warm file).
    cold: bool,
}

impl Window {
    const LEN: u64 = 4 << 20;
    /// Least bytes read at a segment's head.
    const PEEK: u64 = 64;
    /// Bytes read at the first segment's head.
    const FIRST: u64 = 4 << 10;
    /// Most bytes read at a segment's head unasked (longer metadata: a second read).
    const WANT_MAX: u64 = 64 << 10;
    /// Segments at least this long (the one before) are read by their heads.
    const PEEK_FROM: u64 = 4 << 10;

    /// Bytes [pos, pos + n) of the file of `size` bytes (the caller checked they lie inside it).
    fn get(&mut self, file: &File, pos: u64, n: usize, size: u64, mode: Mode) -> Result<&[u8], KernelError> {
        let end = pos + n as u64;
        if pos < self.at || end > self.at + self.buf.len() as u64 {
            let len = match mode {
                Mode::Head { .. } => (n as u64).max(self.want),
                Mode::Window => (n as u64).max(Self::LEN),
            }
            .min(size - pos);
            self.buf.resize(len as usize, 0);
            let mut cached = false;
            if let Mode::Head { advise: true } = mode {
                if !self.cold {
                    cached = read_cached(file, pos, &mut self.buf);
                    self.cold = !cached;
                }
                if self.cold && end + Self::LEN > self.advised {
                    let from = self.advised.max(pos);
                    let to = (pos + 2 * Self::LEN).min(size);
                    if to > from {
                        advise_willneed(file, from, to - from);
                    }
                    self.advised = to;
                }
            }
            if !cached && read_bytes(file, pos, &mut self.buf).is_err() {
                // The file shrank while read: the error of the bytes asked for (or them, if they are still there).
                self.buf.truncate(n);
                self.at = u64::MAX;
                read_bytes(file, pos, &mut self.buf)?;
            }
            self.at = pos;
        }
        let from = (pos - self.at) as usize;
        Ok(&self.buf[from..from + n])
    }
}

/// Asks the kernel to read bytes [at, at + len) of `file` into its cache in
/// the background (`posix_fadvise(POSIX_FADV_WILLNEED)`): a hint, its
/// failure ignored; it changes no byte read.
#[cfg(all(target_os = "linux", target_pointer_width = "64"))]
fn advise_willneed(file: &File, at: u64, len: u64) {
    use std::os::unix::io::AsRawFd;
    extern "C" {
        fn posix_fadvise(fd: i32, offset: i64, len: i64, advice: i32) -> i32;
    }
    const POSIX_FADV_WILLNEED: i32 = 3;
    if let (Ok(at), Ok(len)) = (i64::try_from(at), i64::try_from(len)) {
        // SAFETY: a hint on a descriptor `file` keeps open; it touches no memory of this process.
        unsafe {
            posix_fadvise(file.as_raw_fd(), at, len, POSIX_FADV_WILLNEED);
        }
    }
}

#[cfg(not(all(target_os = "linux", target_pointer_width = "64")))]
fn advise_willneed(_file: &File, _at: u64, _len: u64) {}

/// Fills `buf` from byte `at` of `file` if the kernel holds those bytes in
/// its cache (`preadv2` with `RWF_NOWAIT`: no wait for the disk); false
/// when it does not, or holds part of them, or cannot say (an older
/// kernel, a file system without it): then the caller reads them.
#[cfg(all(target_os = "linux", target_pointer_width = "64", any(target_arch = "x86_64", target_arch = "aarch64")))]
fn read_cached(file: &File, at: u64, buf: &mut [u8]) -> bool {
    use std::os::unix::io::AsRawFd;
    #[repr(C)]
    struct IoVec {
        base: *mut u8,
        len: usize,
    }
    extern "C" {
        fn syscall(number: i64, ...) -> i64;
    }
    // The system call itself: glibc's preadv2 wrapper is younger than the oldest glibc wheels are built for.
    #[cfg(target_arch = "x86_64")]
    const SYS_PREADV2: i64 = 327;
    #[cfg(target_arch = "aarch64")]
    const SYS_PREADV2: i64 = 286;
    const RWF_NOWAIT: i64 = 8;
    let Ok(offset) = i64::try_from(at) else { return false };
    let iov = IoVec { base: buf.as_mut_ptr(), len: buf.len() };
    // SAFETY: the kernel writes at most `iov.len` bytes at `iov.base`, which is `buf`, borrowed mutably for
    // the call; `iov` outlives it; the offset's high half (0) is ignored on 64-bit targets.
    let got = unsafe {
        syscall(SYS_PREADV2, i64::from(file.as_raw_fd()), &iov as *const IoVec as i64, 1i64, offset, 0i64, RWF_NOWAIT)
    };
    usize::try_from(got).is_ok_and(|g| g == buf.len())
}

#[cfg(not(all(
    target_os = "linux",
    target_pointer_width = "64",
    any(target_arch = "x86_64", target_arch = "aarch64")
)))]
fn read_cached(_file: &File, _at: u64, _buf: &mut [u8]) -> bool {
    false
}

/// Largest metadata read whole (beyond it the file is left to npTDMS).
const META_CAP: u64 = 16 << 20;

/// Whether the `n` bytes of `file` from `at` are all zero (padding), read 1 MiB at a time.
fn zeros(file: &File, mut at: u64, mut n: u64) -> Result<bool, KernelError> {
    let mut buf = vec![0u8; n.min(1 << 20) as usize];
    while n > 0 {
        let k = n.min(buf.len() as u64) as usize;
        read_bytes(file, at, &mut buf[..k])?;
        if buf[..k].iter().any(|&x| x != 0) {
            return Ok(false);
        }
        at += k as u64;
        n -= k as u64;
    }
    Ok(true)
}

fn finish(mut b: Builder, segments: usize, warnings: Vec<String>) -> Result<Index, KernelError> {
    let runs = std::mem::take(&mut b.runs);
    for (o, rs) in b.objects.iter_mut().zip(runs) {
        o.runs = rs
            .into_iter()
            .map(|(k, num, big, parts)| (k, Extents { num, big_endian: big, parts, ops: Vec::new() }))
            .collect();
    }
    Ok(Index { objects: b.objects, segments, warnings, fallback: b.fallback })
}

enum ParseError {
    Overrun,
    Bad(String),
    Fallback(String),
}

impl From<Overrun> for ParseError {
    fn from(_: Overrun) -> Self {
        ParseError::Overrun
    }
}

/// Parses one segment's metadata (npTDMS's rules for incremental metadata); returns its object list.
fn parse_metadata(
    b: &mut Builder,
    m: &mut Meta<'_>,
    toc: u32,
    prev: Option<&Vec<SegObj>>,
) -> Result<Vec<SegObj>, ParseError> {
    let continues = toc & TOC_NEW_OBJ_LIST == 0 && prev.is_some();
    let mut list: Vec<SegObj> = if continues { prev.cloned().unwrap_or_default() } else { Vec::new() };
    let mut existing: HashMap<usize, usize> =
        if continues { list.iter().enumerate().map(|(i, o)| (o.id, i)).collect() } else { HashMap::new() };
    let n_obj = m.u32()?;
    for _ in 0..n_obj {
        let raw_path = m.string()?;
        let path = match std::str::from_utf8(raw_path) {
            Ok(p) => p.to_string(),
            Err(_) => return Err(ParseError::Fallback("an object path is not UTF-8".into())),
        };
        let header = m.u32()?;
        let id = b.id(&path);
        let read_new =
            |m: &mut Meta<'_>| -> Result<Rc<RawIndex>, ParseError> { Ok(Rc::new(read_raw_index(m, header)?)) };
        if let Some(&i) = existing.get(&id) {
            match header {
                NO_DATA => list[i].has_data = false,
                SAME_AS_PREVIOUS => list[i].has_data = true,
                _ => list[i] = SegObj { id, has_data: true, index: Some(read_new(m)?) },
            }
        } else if let Some(last) = b.last.get(id).and_then(|l| l.clone()) {
            let o = match header {
                NO_DATA => SegObj { has_data: false, ..last },
                SAME_AS_PREVIOUS => SegObj { has_data: true, ..last },
                _ => SegObj { id, has_data: true, index: Some(read_new(m)?) },
            };
            existing.insert(id, list.len());
            list.push(o);
        } else {
            let o = match header {
                SAME_AS_PREVIOUS => {
                    return Err(ParseError::Bad(format!(
                        "Raw data index for {path} says to reuse previous structure, but we have not seen this object before"
                    )))
                }
                NO_DATA => SegObj { id, has_data: false, index: None },
                _ => SegObj { id, has_data: true, index: Some(read_new(m)?) },
            };
            existing.insert(id, list.len());
            list.push(o);
        }
        let n_props = m.u32()?;
        for _ in 0..n_props {
            let name = m.string()?;
            let name = String::from_utf8_lossy(name).into_owned();
            let code = m.u32()?;
            let value = if code == STRING {
                m.string()?.to_vec()
            } else if let Some(sz) = prop_size(code) {
                m.take(sz)?.to_vec()
            } else {
                return Err(ParseError::Fallback(format!("a property of type 0x{code:x} (not read natively)")));
            };
            let props = &mut b.objects[id].properties;
            match props.iter_mut().find(|p| p.0 == name) {
                Some(p) => *p = (name, code, value, m.big),
                None => props.push((name, code, value, m.big)),
            }
        }
    }
    Ok(list)
}

fn read_raw_index(m: &mut Meta<'_>, header: u32) -> Result<RawIndex, ParseError> {
    if header == FORMAT_CHANGING_SCALER || header == DIGITAL_LINE_SCALER {
        let code = m.u32()?;
        if tdms_size(code).is_none() {
            return Err(ParseError::Bad(format!("Unrecognised data type: {code}")));
        }
        let dim = m.u32()?;
        let nv = m.u64()?;
        let n_scalers = m.u32()?;
        if dim != 1 {
            return Err(ParseError::Bad("Data dimension is not 1".into()));
        }
        let digital = header == DIGITAL_LINE_SCALER;
        let mut scalers = Vec::new();
        for _ in 0..n_scalers {
            let tcode = m.u32()?;
            let buffer = m.u32()?;
            let byte_offset = m.u32()?;
            if digital {
                m.take(1)?;
            } else {
                m.u32()?;
            }
            let scale_id = m.u32()?;
            if tcode != 0xFFFF_FFFF && daqmx_num(tcode).is_none() {
                return Err(ParseError::Bad(format!("unknown DAQmx scaler data type {tcode}")));
            }
            scalers.push(Scaler { num: daqmx_num(tcode), buffer, byte_offset, scale_id });
        }
        if code != DAQMX_RAW && (scalers.len() != 1 || scalers[0].num.map(|x| x.1) != Some(code)) {
            return Err(ParseError::Bad("DAQmx scaler data type differs from the channel's".into()));
        }
        let n_widths = m.u32()?;
        let widths = (0..n_widths).map(|_| m.u32()).collect::<Result<Vec<_>, _>>()?;
        return Ok(RawIndex::Daqmx { code, nv, scalers, widths, digital });
    }
    let code = m.u32()?;
    let dim = m.u32()?;
    let nv = m.u64()?;
    let size = match tdms_size(code) {
        None => return Err(ParseError::Bad("Unrecognised data type".into())),
        Some(s) => s,
    };
    if code == STRING {
        let total = m.u64()?;
        return Err(ParseError::Fallback(format!("string data ({total} bytes), read by npTDMS")));
    }
    if size.is_none() {
        return Err(ParseError::Bad(format!("Unsupported data type: 0x{code:x}")));
    }
    if code == 0 && nv != 0 {
        return Err(ParseError::Bad("Void data only supported for empty segments".into()));
    }
    if dim != 1 {
        return Err(ParseError::Bad("Data dimension is not 1".into()));
    }
    let data_size = if nv == 0 { 0 } else { nv.checked_mul(size.unwrap_or(0)).ok_or(ParseError::Overrun)? };
    Ok(RawIndex::Plain { code, nv, data_size })
}

/// Places the data of one segment's objects: their extents.
fn place_data(
    b: &mut Builder,
    objs: &[SegObj],
    toc: u32,
    data_pos: u64,
    end: u64,
    seg: Seg,
    plan: &mut Plan,
) -> Result<(), KernelError> {
    if let Some(o) = objs.iter().find(|o| o.has_data && o.index.is_none()) {
        // Its first index said "no data", a later one "as before" (npTDMS fails reading its values).
        let path = &b.objects[o.id].path;
        return Err(corrupt(format!(
            "corrupt TDMS file: {seg}: the data of {path} are said to lie as before, but no segment before gave them a layout"
        )));
    }
    let data: Vec<&SegObj> = objs.iter().filter(|o| o.has_data).collect();
    let idx = |o: &SegObj| -> Rc<RawIndex> { o.index.clone().expect("objects with data have an index") };
    let n_daqmx = data.iter().filter(|o| matches!(*idx(o), RawIndex::Daqmx { .. })).count();
    let total = end - data_pos;
    if n_daqmx > 0 && n_daqmx != data.len() {
        return Err(corrupt("cannot read TDMS metadata: Cannot read mixed DAQmx and non-DAQmx data".into()));
    }
    let daqmx = n_daqmx > 0;
    // Chunk size and, for DAQmx, the buffers' (values, width).
    let mut dims: Vec<(u64, u64)> = Vec::new();
    let chunk: u64 = if daqmx {
        for o in &data {
            if let RawIndex::Daqmx { nv, scalers, widths, .. } = &*idx(o) {
                if dims.is_empty() {
                    dims = widths.iter().map(|&w| (0, w as u64)).collect();
                } else if dims.len() != widths.len() || dims.iter().zip(widths).any(|(d, &w)| d.1 != w as u64) {
                    return Err(corrupt(format!(
                        "corrupt TDMS file: {seg}: DAQmx raw data widths differ between channels"
                    )));
                }
                for s in scalers {
                    let d = dims.get_mut(s.buffer as usize).ok_or_else(|| {
                        corrupt(format!(
                            "corrupt TDMS file: {seg}: DAQmx scaler of raw buffer {} of {}",
                            s.buffer,
                            widths.len()
                        ))
                    })?;
                    d.0 = d.0.max(*nv);
                }
            }
        }
        dims.iter().try_fold(0u64, |a, d| d.0.checked_mul(d.1).and_then(|x| x.checked_add(a)))
    } else {
        data.iter().try_fold(0u64, |a, o| match &*idx(o) {
            RawIndex::Plain { data_size, .. } => a.checked_add(*data_size),
            RawIndex::Daqmx { .. } => None,
        })
    }
    .ok_or_else(|| corrupt(format!("corrupt TDMS file: {seg}: chunk size overflows")))?;
    if chunk == 0 {
        if total != 0 {
            return Err(corrupt(format!(
                "cannot read TDMS metadata: Zero channel data size but data length based on segment offset is {total}."
            )));
        }
        return Ok(());
    }
    if total % chunk != 0 {
        return Err(corrupt(format!(
            "corrupt TDMS file: {seg}: its {total} bytes of data are not a whole number of chunks of {chunk} bytes (segment header inconsistent with its channels)"
        )));
    }
    let n_chunks = total / chunk;
    for o in &data {
        let add = idx(o).nv().saturating_mul(n_chunks);
        let n = &mut b.objects[o.id].n;
        *n = n.saturating_add(add);
        plan.add(o.id, add);
        let code = match &*idx(o) {
            RawIndex::Plain { code, .. } | RawIndex::Daqmx { code, .. } => *code,
        };
        match b.objects[o.id].code {
            None => b.objects[o.id].code = Some(code),
            Some(c) if c != code => {
                b.fall(format!("the data type of {} changes between segments", b.objects[o.id].path))
            }
            _ => {}
        }
    }
    if n_chunks == 0 {
        return Ok(());
    }
    if toc & TOC_RAW_DATA == 0 {
        b.fall(format!("{seg} holds data without the raw-data flag"));
        return Ok(());
    }
    let big = toc & TOC_BIG_ENDIAN != 0;
    let interleaved = toc & TOC_INTERLEAVED != 0;
    if !daqmx && data.len() >= 2 && toc & TOC_DAQMX == 0 {
        let key: Vec<(usize, u64, u32)> = data
            .iter()
            .map(|o| match &*idx(o) {
                RawIndex::Plain { code, nv, .. } => (o.id, *nv, *code),
                RawIndex::Daqmx { .. } => (o.id, 0, 0),
            })
            .collect();
        let (first, first_where) = b.layouts.entry(key).or_insert_with(|| (interleaved, seg.to_string()));
        if *first != interleaved {
            let how = |x: bool| if x { "interleaved" } else { "contiguous" };
            return Err(corrupt(format!(
                "corrupt TDMS file: {seg} declares {} data but {first_where} holds the same channels {} (corrupt table of contents)",
                how(interleaved),
                how(*first)
            )));
        }
    }
    if daqmx {
        let mut buf_off = Vec::new();
        let mut acc = 0u64;
        for d in &dims {
            buf_off.push(acc);
            acc += d.0 * d.1;
        }
        for o in &data {
            let ri = idx(o);
            let RawIndex::Daqmx { code, nv, scalers, digital, .. } = &*ri else { continue };
            if *digital {
                b.unsupported(o.id, "DAQmx digital line scaler".into());
                continue;
            }
            for s in scalers {
                let (rows, width) = dims[s.buffer as usize];
                let Some((num, _)) = s.num else {
                    b.unsupported(o.id, "DAQmx timestamp scaler".into());
                    continue;
                };
                if rows != *nv || s.byte_offset as u64 + num.width() > width {
                    b.unsupported(o.id, "DAQmx scaler layout not read natively".into());
                    continue;
                }
                let key = if *code == DAQMX_RAW { s.scale_id as i64 } else { PLAIN };
                for c in 0..n_chunks {
                    let base = data_pos + c * chunk + buf_off[s.buffer as usize];
                    let e = Extent::single(rows, base + s.byte_offset as u64, width, (base, base + rows * width));
                    plan.push(b, data_pos, (o.id, key, num, big, e));
                }
            }
        }
        return Ok(());
    }
    let nums: Vec<Option<Num>> = data
        .iter()
        .map(|o| match &*idx(o) {
            RawIndex::Plain { code, .. } => tdms_num(*code),
            RawIndex::Daqmx { .. } => None,
        })
        .collect();
    if let Some(i) = nums.iter().position(|n| n.is_none()) {
        let o = data[i];
        let p = &b.objects[o.id].path;
        if interleaved || channel_of(p).is_none() {
            b.fall(format!("non-numeric data of {p}"));
        } else {
            let p = p.clone();
            b.unsupported(o.id, format!("non-numeric data of {p}"));
        }
    }
    if interleaved {
        let nv0 = idx(data[0]).nv();
        if data.iter().any(|o| idx(o).nv() != nv0) {
            b.fall(format!("{seg}: interleaved channels of different lengths"));
            return Ok(());
        }
        let width: u64 = nums.iter().map(|n| n.map_or(0, |x| x.width())).sum();
        let rows = nv0 * n_chunks;
        let mut col = 0;
        for (o, num) in data.iter().zip(&nums) {
            let Some(num) = *num else { continue };
            let e = Extent::single(rows, data_pos + col, width, (data_pos, end));
            plan.push(b, data_pos, (o.id, PLAIN, num, big, e));
            col += num.width();
        }
        return Ok(());
    }
    for c in 0..n_chunks {
        let base = data_pos + c * chunk;
        let mut acc = 0u64;
        for (o, num) in data.iter().zip(&nums) {
            let ri = idx(o);
            let RawIndex::Plain { nv, data_size, .. } = &*ri else { continue };
            if let Some(num) = num {
                if *nv > 0 {
                    let e = Extent::single(*nv, base + acc, num.width(), (base, base + chunk));
                    plan.push(b, data_pos, (o.id, PLAIN, *num, big, e));
                }
            }
            acc += data_size;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths() {
        assert_eq!(channel_of("/'g'/'c'"), Some(("g".into(), "c".into())));
        assert_eq!(channel_of("/'g''s'/'c'"), Some(("g's".into(), "c".into())));
        assert_eq!(channel_of("/'g'"), None);
        assert_eq!(path_components("/"), None.or(Some(vec![])).filter(|_| false).or(path_components("/")));
        assert_eq!(channel_of("/'g'/'c"), None);
        assert_eq!(channel_of("/'g'/'c'x"), None);
    }

    fn lead(toc: u32, next: u64, raw: u64) -> Vec<u8> {
        let mut v = b"TDSm".to_vec();
        v.extend(toc.to_le_bytes());
        v.extend(4713u32.to_le_bytes());
        v.extend(next.to_le_bytes());
        v.extend(raw.to_le_bytes());
        v
    }

    fn s(x: &str) -> Vec<u8> {
        let mut v = (x.len() as u32).to_le_bytes().to_vec();
        v.extend(x.as_bytes());
        v
    }

    #[test]
    fn interleaved_i16_and_contiguous_f64() {
        // Segment 1: two i16 channels, interleaved, 3 values; segment 2: same objects, contiguous... no: same
        // list reused (no metadata), interleaved again.
        let mut meta = 2u32.to_le_bytes().to_vec();
        for name in ["/'g'/'a'", "/'g'/'b'"] {
            meta.extend(s(name));
            meta.extend(20u32.to_le_bytes());
            meta.extend(2u32.to_le_bytes());
            meta.extend(1u32.to_le_bytes());
            meta.extend(3u64.to_le_bytes());
            meta.extend(0u32.to_le_bytes());
        }
        let data: Vec<u8> = (0i16..6).flat_map(|x| x.to_le_bytes()).collect();
        let toc = TOC_META_DATA | TOC_NEW_OBJ_LIST | TOC_RAW_DATA | TOC_INTERLEAVED;
        let mut file = lead(toc, (meta.len() + data.len()) as u64, meta.len() as u64);
        file.extend(&meta);
        file.extend(&data);
        file.extend(lead(TOC_RAW_DATA | TOC_INTERLEAVED, data.len() as u64, 0));
        file.extend(&data);
        let path = std::env::temp_dir().join(format!("tribodyn-tdms-{}", std::process::id()));
        std::fs::write(&path, &file).unwrap();
        let f = File::open(&path).unwrap();
        let idx = read_index(&f, None).unwrap();
        assert!(idx.fallback.is_none());
        assert_eq!(idx.segments, 2);
        let a = &idx.objects[0];
        assert_eq!(a.n, 6);
        let ext = &a.runs[0].1;
        let mut out = Vec::new();
        let mut cache = crate::io::mapped::ByteCache::default();
        ext.read(&f, 0, 6, &mut out, &mut cache).unwrap();
        assert_eq!(out, vec![0.0, 2.0, 4.0, 0.0, 2.0, 4.0]);
        let mut scaled = idx.objects[1].runs[0].1.clone();
        scaled.ops = vec![crate::io::mapped::Op::Linear { slope: 2.0, intercept: 1.0 }];
        scaled.read(&f, 1, 5, &mut out, &mut cache).unwrap();
        assert_eq!(out, vec![7.0, 11.0, 3.0, 7.0]);
        // Truncated: an error naming the segment.
        std::fs::write(&path, &file[..file.len() - 1]).unwrap();
        let f = File::open(&path).unwrap();
        let e = read_index(&f, None).unwrap_err().to_string();
        assert!(e.contains("segment 2 needs"), "{e}");
        std::fs::remove_file(path).unwrap();
    }

    /// A raw data index of an object in a test segment.
    enum Ix {
        NoData,
        Same,
        /// (type code, values)
        New(u32, u64),
    }

    /// A test object: path, index, float64 properties, string properties.
    type Obj<'a> = (&'a str, Ix, &'a [(&'a str, f64)], &'a [(&'a str, &'a str)]);

    /// Metadata of objects.
    fn meta(objs: &[Obj<'_>]) -> Vec<u8> {
        let mut m = (objs.len() as u32).to_le_bytes().to_vec();
        for (path, ix, props, strings) in objs {
            m.extend(s(path));
            match ix {
                Ix::NoData => m.extend(NO_DATA.to_le_bytes()),
                Ix::Same => m.extend(SAME_AS_PREVIOUS.to_le_bytes()),
                Ix::New(code, nv) => {
                    m.extend(20u32.to_le_bytes());
                    m.extend(code.to_le_bytes());
                    m.extend(1u32.to_le_bytes());
                    m.extend(nv.to_le_bytes());
                }
            }
            m.extend(((props.len() + strings.len()) as u32).to_le_bytes());
            for (k, v) in props.iter() {
                m.extend(s(k));
                m.extend(10u32.to_le_bytes());
                m.extend(v.to_le_bytes());
            }
            for (k, v) in strings.iter() {
                m.extend(s(k));
                m.extend(STRING.to_le_bytes());
                m.extend(s(v));
            }
        }
        m
    }

    fn segment(toc: u32, meta: &[u8], data: &[u8]) -> Vec<u8> {
        let mut v = lead(toc, (meta.len() + data.len()) as u64, meta.len() as u64);
        v.extend(meta);
        v.extend(data);
        v
    }

    /// The `.tdms_index` NI would write beside `file`: its lead-ins (tagged `TDSh`) and metadata.
    fn index_of(file: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut pos = 0;
        while pos < file.len() {
            let next = u64::from_le_bytes(file[pos + 12..pos + 20].try_into().unwrap()) as usize;
            let raw = u64::from_le_bytes(file[pos + 20..pos + 28].try_into().unwrap()) as usize;
            out.extend(b"TDSh");
            out.extend(&file[pos + 4..pos + 28 + raw]);
            pos += 28 + next;
        }
        out
    }

    struct Temp(std::path::PathBuf);

    impl Temp {
        fn new(name: &str, bytes: &[u8]) -> (Temp, File) {
            let path = std::env::temp_dir().join(format!("tribodyn-tdms-{}-{name}", std::process::id()));
            std::fs::write(&path, bytes).unwrap();
            let f = File::open(&path).unwrap();
            (Temp(path), f)
        }
    }

    impl Drop for Temp {
        fn drop(&mut self) {
            let _ = std::fs::remove_file(&self.0);
        }
    }

    /// The walk's result, as text (the index's every field, or the error's message).
    fn walked(f: &File, index: Option<&[u8]>, replay: bool) -> String {
        format!("{:?}", walk_with(f, index, replay).map_err(|e| e.to_string()))
    }

    const DATA: u32 = TOC_META_DATA | TOC_RAW_DATA;
    const NEW_LIST: u32 = TOC_META_DATA | TOC_NEW_OBJ_LIST | TOC_RAW_DATA;

    /// A logger's file: `n` segments of 4 float64 channels of `nv` values each, the metadata restated in
    /// every segment (npTDMS's writer), then segments that change the object list, the layout, a property.
    fn logger_file(n: usize, nv: u64) -> Vec<u8> {
        let chans = ["/'g'/'fx'", "/'g'/'fy'", "/'g'/'fz'", "/'g'/'i'"];
        let block: Vec<u8> = (0..4 * nv).flat_map(|x| (x as f64).to_le_bytes()).collect();
        let mut first = vec![("/", Ix::NoData, &[][..], &[("creator", "test")][..]), ("/'g'", Ix::NoData, &[], &[])];
        first.extend(chans.iter().map(|c| (*c, Ix::New(10, nv), &[("wf_increment", 0.001)][..], &[][..])));
        let mut file = segment(NEW_LIST, &meta(&first), &block);
        let again: Vec<_> = chans.iter().map(|c| (*c, Ix::New(10, nv), &[][..], &[][..])).collect();
        for _ in 1..n {
            file.extend(segment(NEW_LIST, &meta(&again), &block));
        }
        // No metadata: the list before.
        for _ in 0..5 {
            file.extend(segment(TOC_RAW_DATA, &[], &block));
        }
        // Two chunks a segment.
        for _ in 0..5 {
            file.extend(segment(NEW_LIST, &meta(&again), &[&block[..], &block[..]].concat()));
        }
        // The list continued: fx as before, a new int16 channel, fy without data (4 segments, the same bytes).
        let more = meta(&[
            ("/'g'/'fx'", Ix::Same, &[], &[]),
            ("/'g'/'n'", Ix::New(2, 8), &[], &[]),
            ("/'g'/'fy'", Ix::NoData, &[], &[]),
        ]);
        let data: Vec<u8> = [&block[..3 * nv as usize * 8], &[7u8; 16][..]].concat();
        for _ in 0..4 {
            file.extend(segment(DATA, &more, &data));
        }
        // Interleaved, then a property that changes in every segment.
        let two = |p: f64| {
            meta(&[("/'g'/'fx'", Ix::New(10, 3), &[("p", p)][..], &[][..]), ("/'g'/'i'", Ix::New(10, 3), &[], &[])])
        };
        for k in 0..6 {
            file.extend(segment(NEW_LIST | TOC_INTERLEAVED, &two((k / 3) as f64), &block[..48]));
        }
        file
    }

    #[test]
    fn replayed_segments_index_as_parsed_ones() {
        let bytes = logger_file(300, 50);
        let (_t, f) = Temp::new("replay", &bytes);
        REPLAYED.with(|r| r.set((0, 0)));
        let fast = walked(&f, None, true);
        // Metadata as the segment before's: segments 3-300, the 5 of two chunks (after the segments without
        // metadata, the list the same), 3 of 4 continued lists, 2 + 2 interleaved. Data as the segment
        // before's: the same less the first of each table of contents or data length, the 4 without metadata.
        let replays = (298 + 5 + 3 + 2 + 2, 298 + 4 + 4 + 3 + 2 + 2);
        assert_eq!(REPLAYED.with(|r| r.get()), replays);
        assert!(fast == walked(&f, None, false), "replayed and parsed segments differ");
        assert_eq!(REPLAYED.with(|r| r.get()), replays, "none when not asked");
        let ix = index_of(&bytes);
        assert!(walked(&f, Some(&ix), true) == fast, "with the .tdms_index");
        assert!(walked(&f, Some(&ix), false) == fast, "with the .tdms_index, parsed");
        let idx = walk_with(&f, None, true).unwrap();
        assert_eq!(idx.segments, 300 + 5 + 5 + 4 + 6);
        assert!(idx.fallback.is_none() && idx.warnings.is_empty());
        let fx = &idx.objects[2];
        assert_eq!(fx.path, "/'g'/'fx'");
        assert_eq!(fx.n, 300 * 50 + 5 * 50 + 5 * 100 + 4 * 50 + 6 * 3);
        assert_eq!(fx.properties.iter().find(|p| p.0 == "p").map(|p| p.2.clone()), Some(1f64.to_le_bytes().to_vec()));
        // The 300 segments of one layout are one extent repeated.
        let first = 28 + u64::from_le_bytes(bytes[12..20].try_into().unwrap());
        let step = 28 + u64::from_le_bytes(bytes[first as usize + 12..first as usize + 20].try_into().unwrap());
        let parts = &fx.runs[0].1.parts;
        assert_eq!((parts[0].count, parts[0].reps, parts[0].period), (50, 300, step));
        let fy = &idx.objects[3];
        assert_eq!(fy.n, 300 * 50 + 5 * 50 + 5 * 100);
        assert_eq!(idx.objects[6].path, "/'g'/'n'");
        assert_eq!(idx.objects[6].n, 4 * 8);
        // The values of fx read back: the first segment's and the interleaved segments'.
        let mut out = Vec::new();
        let mut cache = crate::io::mapped::ByteCache::default();
        fx.runs[0].1.read(&f, 0, 3, &mut out, &mut cache).unwrap();
        assert_eq!(out, vec![0.0, 1.0, 2.0]);
        fx.runs[0].1.read(&f, fx.n - 3, fx.n, &mut out, &mut cache).unwrap();
        assert_eq!(out, vec![0.0, 2.0, 4.0]);
    }

    #[test]
    fn a_damaged_segment_among_repeated_ones_is_still_found() {
        let bytes = logger_file(40, 20);
        let first = 28 + u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
        let step = 28 + u64::from_le_bytes(bytes[first + 12..first + 20].try_into().unwrap()) as usize;
        // Segment 31's first object's value count: the data are then no whole number of chunks.
        let mut bad = bytes.clone();
        let at = first + 29 * step + 28 + 4 + 4 + "/'g'/'fx'".len() + 4 + 4 + 4;
        bad[at] = 21;
        let (_t, f) = Temp::new("damaged", &bad);
        let e = walked(&f, None, true);
        assert!(e == walked(&f, None, false));
        let pos = first + 29 * step;
        assert!(e.contains(&format!("corrupt TDMS file: segment 31 at byte {pos}: its 640 bytes of data")), "{e}");
        // A flipped interleaving flag in segment 12.
        let mut bad = bytes.clone();
        bad[first + 10 * step + 4] |= TOC_INTERLEAVED as u8;
        let (_t, f) = Temp::new("flipped", &bad);
        let e = walked(&f, None, true);
        assert!(e == walked(&f, None, false));
        assert!(
            e.contains("segment 12 at byte") && e.contains("declares interleaved data but segment 1 at byte 0"),
            "{e}"
        );
    }

    #[test]
    fn metadata_longer_than_the_read_at_its_head() {
        // Segments of 8 KiB (heads read with the file advised), of 100 KiB (heads alone) and of 100 bytes
        // (a window): after a short metadata, a long one (3 KiB, then 80 KiB: more than a head's read).
        for data_len in [8 << 10, 100 << 10, 96] {
            let data = vec![0u8; data_len];
            let nv = (data_len / 8) as u64;
            let short = meta(&[("/'g'/'a'", Ix::New(10, nv), &[], &[])]);
            let mut file = segment(NEW_LIST, &short, &data);
            file.extend(segment(NEW_LIST, &short, &data));
            let long_a = "x".repeat(3000);
            let long_b = "y".repeat(80 << 10);
            for text in [&long_a, &long_b] {
                let long = meta(&[("/'g'/'a'", Ix::Same, &[], &[("note", text.as_str())])]);
                file.extend(segment(DATA, &long, &data));
                file.extend(segment(DATA, &short, &data));
            }
            let (_t, f) = Temp::new("long", &file);
            assert!(walked(&f, None, true) == walked(&f, None, false), "segments of {data_len} bytes");
            let idx = walk_with(&f, None, true).unwrap();
            let a = &idx.objects[0];
            assert_eq!(a.n, 6 * nv);
            assert_eq!(a.properties.len(), 1);
            assert!(a.properties[0].2 == long_b.as_bytes());
        }
    }

    #[test]
    fn a_file_ending_inside_a_lead_in_or_a_segment() {
        let m = meta(&[("/'g'/'a'", Ix::New(10, 1000), &[], &[])]);
        let one = segment(NEW_LIST, &m, &[0u8; 8000]);
        let mut file = one.clone();
        file.extend(&one[..10]);
        let (_t, f) = Temp::new("lead", &file);
        assert_eq!(walked(&f, None, true), "Err(\"truncated TDMS file (10 stray bytes after segment 1)\")");
        file.extend(&one[10..200]);
        let (_t, f) = Temp::new("cut", &file);
        let need = 2 * one.len();
        let e = format!("Err(\"truncated TDMS file: segment 2 needs {need} bytes, the file has {}\")", file.len());
        assert_eq!(walked(&f, None, true), e);
    }

    #[test]
    fn data_as_before_without_a_layout_before_is_an_error() {
        // The first index says "no data", the next "as before": there was no layout (this panicked).
        let mut file = segment(NEW_LIST, &meta(&[("/'g'/'a'", Ix::NoData, &[], &[])]), &[]);
        file.extend(segment(DATA, &meta(&[("/'g'/'a'", Ix::Same, &[], &[])]), &[0u8; 16]));
        let (_t, f) = Temp::new("nolayout", &file);
        assert_eq!(
            walked(&f, None, true),
            "Err(\"corrupt TDMS file: segment 2 at byte 52: the data of /'g'/'a' are said to lie as before, but no segment before gave them a layout\")"
        );
    }

    #[test]
    fn heads_read_as_pread_reads_them() {
        let bytes: Vec<u8> = (0..20_000u32).map(|x| (x * 7 % 251) as u8).collect();
        let (_t, f) = Temp::new("window", &bytes);
        let mut buf = vec![0u8; 600];
        if read_cached(&f, 1000, &mut buf) {
            assert_eq!(buf, &bytes[1000..1600]);
        }
        assert!(!read_cached(&f, 19_900, &mut buf), "a short read is no read");
        for mode in [Mode::Head { advise: true }, Mode::Head { advise: false }, Mode::Window] {
            let mut w = Window { want: 64, ..Default::default() };
            assert_eq!(w.get(&f, 100, 28, 20_000, mode).unwrap(), &bytes[100..128]);
            assert_eq!(w.get(&f, 128, 3000, 20_000, mode).unwrap(), &bytes[128..3128]);
            assert_eq!(w.get(&f, 5000, 28, 20_000, mode).unwrap(), &bytes[5000..5028]);
            // The file shorter than when its length was taken: the bytes asked for, while they are there...
            let mut w = Window { want: 4096, ..Default::default() };
            assert_eq!(w.get(&f, 19_000, 28, 30_000, mode).unwrap(), &bytes[19_000..19_028]);
            // ...else the error of those bytes.
            let e = w.get(&f, 19_990, 28, 30_000, mode).unwrap_err().to_string();
            assert_eq!(e, "the file ends before byte 20018: it was truncated while it was read");
        }
    }
}
