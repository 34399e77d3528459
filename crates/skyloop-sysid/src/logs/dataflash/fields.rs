//! DataFlash field types: the FMT message's format characters, their sizes and how a value is
//! decoded, and a message type's layout (field names, offsets, types).
//!
//! Format characters (ArduPilot's `LogStructure.h` documentation), all little-endian:
//!
//! | char | stored as | value |
//! |---|---|---|
//! | `b` `B` `h` `H` `i` `I` `q` `Q` | int8, uint8, int16, uint16, int32, uint32, int64, uint64 | as stored |
//! | `f` `d` `g` | float32, float64, float16 | as stored |
//! | `M` | uint8 | flight-mode number, as stored |
//! | `c` `C` | int16, uint16 | stored / 100 |
//! | `e` `E` | int32, uint32 | stored / 100 |
//! | `L` | int32 | latitude/longitude, stored / 1e7 (degrees) |
//! | `n` `N` `Z` | char\[4\], char\[16\], char\[64\] | text (NUL-terminated) |
//! | `a` | int16\[32\] | 32 values, as stored |
//!
//! The scaling of `c C e E L` divides by 100 and 1e7 (not multiply by 0.01, 1e-7), as pymavlink
//! does, so the values agree bit for bit. Integers wider than 53 bits lose precision in f64.

/// How a field's bytes are stored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Storage {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F16,
    F32,
    F64,
    /// Text of this many bytes.
    Text(usize),
    /// int16\[32\].
    I16Array,
}

impl Storage {
    /// Size in the payload, bytes.
    pub(crate) fn size(self) -> usize {
        match self {
            Storage::I8 | Storage::U8 => 1,
            Storage::I16 | Storage::U16 | Storage::F16 => 2,
            Storage::I32 | Storage::U32 | Storage::F32 => 4,
            Storage::I64 | Storage::U64 | Storage::F64 => 8,
            Storage::Text(n) => n,
            Storage::I16Array => 64,
        }
    }
}

/// One format character: storage and the divisor applied to the stored number (1 for none).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct FieldType {
    pub(crate) letter: char,
    pub(crate) storage: Storage,
    pub(crate) divisor: f64,
}

/// The field type of a format character, `None` for an unknown one.
pub(crate) fn field_type(letter: char) -> Option<FieldType> {
    use Storage::*;
    let (storage, divisor) = match letter {
        'b' => (I8, 1.0),
        'B' | 'M' => (U8, 1.0),
        'h' => (I16, 1.0),
        'H' => (U16, 1.0),
        'i' => (I32, 1.0),
        'I' => (U32, 1.0),
        'q' => (I64, 1.0),
        'Q' => (U64, 1.0),
        'g' => (F16, 1.0),
        'f' => (F32, 1.0),
        'd' => (F64, 1.0),
        'c' => (I16, 100.0),
        'C' => (U16, 100.0),
        'e' => (I32, 100.0),
        'E' => (U32, 100.0),
        'L' => (I32, 1e7),
        'n' => (Text(4), 1.0),
        'N' => (Text(16), 1.0),
        'Z' => (Text(64), 1.0),
        'a' => (I16Array, 1.0),
        _ => return None,
    };
    Some(FieldType {
        letter,
        storage,
        divisor,
    })
}

/// IEEE 754 half precision to f64.
fn f16_to_f64(bits: u16) -> f64 {
    let sign = if bits & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((bits >> 10) & 0x1f);
    let frac = f64::from(bits & 0x3ff);
    sign * match exp {
        0 => frac * 2f64.powi(-24),
        31 if frac == 0.0 => f64::INFINITY,
        31 => f64::NAN,
        _ => (1.0 + frac / 1024.0) * 2f64.powi(exp - 15),
    }
}

fn array<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut a = [0u8; N];
    a.copy_from_slice(&b[..N]);
    a
}

/// The stored number of a numeric field at the start of `b` (which holds at least its size),
/// before scaling.
fn stored(storage: Storage, b: &[u8]) -> f64 {
    use Storage::*;
    match storage {
        I8 => f64::from(b[0] as i8),
        U8 => f64::from(b[0]),
        I16 => f64::from(i16::from_le_bytes(array(b))),
        U16 => f64::from(u16::from_le_bytes(array(b))),
        I32 => f64::from(i32::from_le_bytes(array(b))),
        U32 => f64::from(u32::from_le_bytes(array(b))),
        I64 => i64::from_le_bytes(array(b)) as f64,
        U64 => u64::from_le_bytes(array(b)) as f64,
        F16 => f16_to_f64(u16::from_le_bytes(array(b))),
        F32 => f64::from(f32::from_le_bytes(array(b))),
        F64 => f64::from_le_bytes(array(b)),
        Text(_) | I16Array => f64::NAN,
    }
}

/// One field of a message type.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Field {
    /// Label from the FMT message.
    pub(crate) name: String,
    pub(crate) ty: FieldType,
    /// Offset in the payload (after the 3-byte header), bytes.
    pub(crate) offset: usize,
}

/// A message type's payload layout.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Layout {
    pub(crate) fields: Vec<Field>,
    /// Sum of the field sizes, bytes.
    pub(crate) payload_len: usize,
}

impl Layout {
    /// The layout of format string `format` with comma-separated `labels`; a label missing for a
    /// format character is named `field{k}`. Refused: an unknown format character.
    pub(crate) fn parse(format: &str, labels: &str) -> Result<Layout, String> {
        let names: Vec<&str> = if labels.is_empty() {
            Vec::new()
        } else {
            labels.split(',').collect()
        };
        let mut fields = Vec::with_capacity(format.len());
        let mut offset = 0usize;
        for (k, c) in format.chars().enumerate() {
            let ty = field_type(c).ok_or_else(|| format!("unknown format character '{}'", c.escape_default()))?;
            let name = match names.get(k).map(|n| n.trim()) {
                Some(n) if !n.is_empty() => n.to_string(),
                _ => format!("field{k}"),
            };
            fields.push(Field { name, ty, offset });
            offset += ty.storage.size();
        }
        Ok(Layout {
            fields,
            payload_len: offset,
        })
    }

    /// Index of the field labelled `name`.
    pub(crate) fn index_of(&self, name: &str) -> Option<usize> {
        self.fields.iter().position(|f| f.name == name)
    }

    /// The value of numeric field `k` (scaled per its format character); `None` for a text or
    /// array field or a payload too short.
    pub(crate) fn number(&self, k: usize, payload: &[u8]) -> Option<f64> {
        let f = self.fields.get(k)?;
        if matches!(f.ty.storage, Storage::Text(_) | Storage::I16Array) {
            return None;
        }
        let b = payload.get(f.offset..f.offset + f.ty.storage.size())?;
        let v = stored(f.ty.storage, b);
        Some(if f.ty.divisor == 1.0 { v } else { v / f.ty.divisor })
    }

    /// The raw unsigned value of integer field `k` (for time stamps: exact beyond 2^53).
    pub(crate) fn unsigned(&self, k: usize, payload: &[u8]) -> Option<u64> {
        let f = self.fields.get(k)?;
        let b = payload.get(f.offset..f.offset + f.ty.storage.size())?;
        match f.ty.storage {
            Storage::U64 | Storage::I64 => Some(u64::from_le_bytes(array(b))),
            Storage::U32 | Storage::I32 => Some(u64::from(u32::from_le_bytes(array(b)))),
            _ => None,
        }
    }

    /// The text of a text field `k` (up to its first NUL; invalid UTF-8 replaced).
    pub(crate) fn text(&self, k: usize, payload: &[u8]) -> Option<String> {
        let f = self.fields.get(k)?;
        let Storage::Text(n) = f.ty.storage else { return None };
        let b = payload.get(f.offset..f.offset + n)?;
        let end = b.iter().position(|&c| c == 0).unwrap_or(n);
        Some(String::from_utf8_lossy(&b[..end]).into_owned())
    }

    /// Channel names of the numeric fields in payload order, an `a` field as `name[0]`..`name[31]`;
    /// text fields have none.
    pub(crate) fn channel_names(&self) -> Vec<String> {
        let mut out = Vec::new();
        for f in &self.fields {
            match f.ty.storage {
                Storage::Text(_) => {}
                Storage::I16Array => out.extend((0..32).map(|i| format!("{}[{i}]", f.name))),
                _ => out.push(f.name.clone()),
            }
        }
        out
    }

    /// Appends one message's values to `cols` (one column per [`Layout::channel_names`] entry);
    /// `payload` holds at least `payload_len` bytes.
    pub(crate) fn push_row(&self, payload: &[u8], cols: &mut [Vec<f64>]) {
        let mut c = 0;
        for (k, f) in self.fields.iter().enumerate() {
            match f.ty.storage {
                Storage::Text(_) => {}
                Storage::I16Array => {
                    for i in 0..32 {
                        let at = f.offset + 2 * i;
                        let v = payload.get(at..at + 2).map_or(f64::NAN, |b| stored(Storage::I16, b));
                        if let Some(col) = cols.get_mut(c) {
                            col.push(v);
                        }
                        c += 1;
                    }
                }
                _ => {
                    if let Some(col) = cols.get_mut(c) {
                        col.push(self.number(k, payload).unwrap_or(f64::NAN));
                    }
                    c += 1;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn half_floats() {
        assert_eq!(f16_to_f64(0x3c00), 1.0);
        assert_eq!(f16_to_f64(0xc000), -2.0);
        assert_eq!(f16_to_f64(0x7bff), 65504.0);
        assert_eq!(f16_to_f64(0x0001), 2f64.powi(-24));
        assert!(f16_to_f64(0x7e00).is_nan());
        assert_eq!(f16_to_f64(0xfc00), f64::NEG_INFINITY);
    }

    #[test]
    fn layout_offsets_names_and_unknown_letters() {
        let l = Layout::parse("QBcLaZ", "TimeUS,I,Alt").unwrap();
        let off: Vec<usize> = l.fields.iter().map(|f| f.offset).collect();
        assert_eq!(off, vec![0, 8, 9, 11, 15, 79]);
        assert_eq!(l.payload_len, 143);
        assert_eq!(l.fields[3].name, "field3");
        assert_eq!(l.channel_names().len(), 4 + 32);
        assert!(Layout::parse("Qx", "a,b").unwrap_err().contains("'x'"));
    }
}
