//! Checks ULog records before px4-ulog sees them. px4-ulog 0.6 slices record payloads without bounds
//! checks (a parameter whose key length exceeds its record, a too-short flag-bits or add-logged
//! record, ...) and expands nested formats without limit, so a damaged or hostile file can make it
//! panic, overflow its stack or run out of memory. This pass walks the record framing itself and
//! finds where the file stops being safe to hand over; the reader feeds px4-ulog only the bytes
//! before that point and reports the rest as corrupt.

use std::collections::HashMap;

/// Largest number of flattened fields the format definitions may expand to (real logs: ~10⁴).
const MAX_FLAT_FIELDS: u64 = 1 << 20;
/// Deepest nesting of message types inside one another (real logs: 3).
const MAX_NESTING: usize = 16;

/// The byte ranges of the file that px4-ulog may read, in order: the primary section and the appended
/// data sections; plus why (and where) the file was cut short of its end, when it was.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SafeRanges {
    /// (start, end) byte offsets.
    pub ranges: Vec<(usize, usize)>,
    /// Offset and reason of the first record that is not safe, if any.
    pub cut: Option<(usize, String)>,
}

fn u16_at(b: &[u8], i: usize) -> Option<usize> {
    Some(usize::from(u16::from_le_bytes([*b.get(i)?, *b.get(i + 1)?])))
}

/// Why a record's payload `p` of type `t` would break the parser, if it would.
fn check_record(t: u8, p: &[u8]) -> Option<&'static str> {
    let n = p.len();
    let key_fits = |skip: usize| p.get(skip - 1).is_some_and(|&k| skip + usize::from(k) <= n);
    let ok = match t {
        b'B' => n >= 40,
        b'A' => n >= 3,
        b'D' | b'O' | b'R' => n >= 2,
        b'S' => n >= 8,
        b'L' => n >= 9,
        b'C' => n >= 11,
        b'I' | b'P' => n >= 1 && key_fits(1),
        b'M' | b'Q' => n >= 2 && key_fits(2),
        _ => true,
    };
    (!ok).then_some("record shorter than its type requires")
}

fn primitive(t: &str) -> bool {
    matches!(
        t,
        "int8_t"
            | "uint8_t"
            | "int16_t"
            | "uint16_t"
            | "int32_t"
            | "uint32_t"
            | "int64_t"
            | "uint64_t"
            | "float"
            | "double"
            | "bool"
            | "char"
    )
}

/// (type name, repeat count) of every field of a format record, keyed by message name.
fn parse_format(p: &[u8]) -> Option<(String, Vec<(String, u64)>)> {
    let s = std::str::from_utf8(p).ok()?;
    let (name, rest) = s.split_once(':')?;
    let fields = rest
        .split(';')
        .filter(|f| !f.is_empty())
        .filter_map(|f| {
            let ty = f.split(' ').next()?;
            match ty.split_once('[') {
                Some((base, n)) => Some((base.to_string(), n.trim_end_matches(']').parse().unwrap_or(1))),
                None => Some((ty.to_string(), 1)),
            }
        })
        .collect();
    Some((name.to_string(), fields))
}

/// Flattened field count of `name`, or `None` past the limits (too many, too deep, circular).
fn flat_count(
    name: &str,
    formats: &HashMap<String, Vec<(String, u64)>>,
    memo: &mut HashMap<String, u64>,
    depth: usize,
) -> Option<u64> {
    if let Some(&c) = memo.get(name) {
        return Some(c);
    }
    if depth > MAX_NESTING {
        return None;
    }
    let mut total: u64 = 0;
    for (ty, n) in formats.get(name).map(Vec::as_slice).unwrap_or(&[]) {
        let each = if primitive(ty) {
            1
        } else {
            flat_count(ty, formats, memo, depth + 1)?
        };
        total = total.checked_add(each.checked_mul(*n)?)?;
        if total > MAX_FLAT_FIELDS {
            return None;
        }
    }
    memo.insert(name.to_string(), total);
    Some(total)
}

/// The safe byte ranges of a ULog file.
pub fn safe_ranges(bytes: &[u8]) -> SafeRanges {
    let len = bytes.len();
    // The flag-bits record, first after the 16-byte file header, holds up to three appended offsets.
    let mut appended: Vec<usize> = Vec::new();
    if bytes.get(18) == Some(&b'B') && u16_at(bytes, 16).is_some_and(|n| n >= 40) && len >= 19 + 40 {
        for k in 0..3 {
            let at = 19 + 16 + 8 * k;
            let mut o = [0u8; 8];
            o.copy_from_slice(&bytes[at..at + 8]);
            let off = u64::from_le_bytes(o);
            if off != 0 {
                appended.push(usize::try_from(off).unwrap_or(usize::MAX).min(len));
            }
        }
    }
    let mut bounds = vec![(16.min(len), appended.first().copied().unwrap_or(len))];
    for (i, &a) in appended.iter().enumerate() {
        bounds.push((a, appended.get(i + 1).copied().unwrap_or(len)));
    }
    let mut formats: HashMap<String, Vec<(String, u64)>> = HashMap::new();
    let mut formats_checked = false;
    let mut ranges = Vec::new();
    for (si, &(start, end)) in bounds.iter().enumerate() {
        // The parser reads the primary section from the file's first byte (the header).
        let first = if si == 0 { 0 } else { start };
        if end < start {
            ranges.push((first, first));
            continue;
        }
        let mut pos = start;
        while pos + 3 <= end {
            let size = u16_at(bytes, pos).unwrap_or(0);
            let t = bytes[pos + 2];
            if pos + 3 + size > end {
                break; // cut mid-record: px4-ulog reports the truncation itself
            }
            let payload = &bytes[pos + 3..pos + 3 + size];
            let mut bad = check_record(t, payload).map(str::to_string);
            if t == b'F' {
                if let Some((name, fields)) = parse_format(payload) {
                    formats.insert(name, fields);
                }
            } else if !formats_checked && matches!(t, b'A' | b'D' | b'L' | b'C' | b'O' | b'S' | b'R') {
                // The first data-section record makes px4-ulog flatten every format.
                formats_checked = true;
                let mut memo = HashMap::new();
                let names: Vec<String> = formats.keys().cloned().collect();
                let mut total: u64 = 0;
                for n in &names {
                    match flat_count(n, &formats, &mut memo, 0) {
                        Some(c) => total = total.saturating_add(c),
                        None => total = u64::MAX,
                    }
                }
                if total > MAX_FLAT_FIELDS {
                    bad = Some(format!(
                        "format definitions nest deeper than {MAX_NESTING} levels or expand to more than {MAX_FLAT_FIELDS} fields"
                    ));
                }
            }
            if let Some(why) = bad {
                ranges.push((first, pos));
                return SafeRanges {
                    ranges,
                    cut: Some((pos, why)),
                };
            }
            pos += 3 + size;
        }
        ranges.push((first, end));
    }
    SafeRanges { ranges, cut: None }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rec(t: u8, p: &[u8]) -> Vec<u8> {
        let mut v = (p.len() as u16).to_le_bytes().to_vec();
        v.push(t);
        v.extend_from_slice(p);
        v
    }

    #[test]
    fn cuts_before_records_px4_ulog_would_slice_past() {
        let mut f = b"ULog\x01\x12\x35\x01".to_vec();
        f.extend_from_slice(&0u64.to_le_bytes());
        f.extend(rec(b'B', &[0; 40]));
        f.extend(rec(b'F', b"t:uint64_t timestamp;"));
        let good = f.len();
        f.extend(rec(b'P', &[200, b'x'])); // key length 200 in a 2-byte record
        let s = safe_ranges(&f);
        assert_eq!(s.ranges, vec![(0, good)]);
        assert_eq!(s.cut.map(|c| c.0), Some(good));
        // Exponential nesting is refused before px4-ulog expands it.
        let mut f = f[..good].to_vec();
        f.extend(rec(b'F', b"a:uint8_t[255] x;"));
        f.extend(rec(b'F', b"b:a[255] x;"));
        f.extend(rec(b'F', b"c:b[255] x;"));
        let at = f.len();
        f.extend(rec(b'A', &[0, 0, 0, b'c']));
        assert_eq!(safe_ranges(&f).cut.map(|c| c.0), Some(at));
    }
}
