//! The field encodings of Betaflight's blackbox format: how one value (or a group of 3, 4 or up to 8
//! values) is laid out in bytes. Every reader stops with [`Truncated`] at the end of the data instead
//! of reading past it, and with [`Malformed`] on byte patterns no encoder writes.

/// The data ended in the middle of a value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Truncated;

/// Why a value could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Malformed {
    /// The data ended in the middle of a value.
    Truncated,
    /// A variable-byte integer longer than the 5 bytes a 32-bit value needs.
    TooLong,
}

impl From<Truncated> for Malformed {
    fn from(_: Truncated) -> Malformed {
        Malformed::Truncated
    }
}

/// Encoding numbers as written in the `H Field X encoding` headers.
pub mod id {
    /// Signed variable byte (ZigZag, then unsigned VB).
    pub const SIGNED_VB: u8 = 0;
    /// Unsigned variable byte: 7 bits a byte, least significant first, high bit = more follow.
    pub const UNSIGNED_VB: u8 = 1;
    /// Negated 14-bit value as unsigned VB (battery voltage in old firmware).
    pub const NEG_14BIT: u8 = 3;
    /// Elias delta, unsigned (a bit stream; written by no Betaflight release).
    pub const ELIAS_DELTA_U32: u8 = 4;
    /// Elias delta, signed.
    pub const ELIAS_DELTA_S32: u8 = 5;
    /// Up to 8 fields: a header byte with one bit per non-zero field, then those as signed VB.
    pub const TAG8_8SVB: u8 = 6;
    /// 3 fields sharing a 2-bit size selector (2, 4, 6 bits or 1–4 bytes each).
    pub const TAG2_3S32: u8 = 7;
    /// 4 fields with 2 bits of size each (0, 4, 8 or 16 bits) in a header byte.
    pub const TAG8_4S16: u8 = 8;
    /// Nothing is written; the value is the prediction.
    pub const NULL: u8 = 9;
    /// 3 fields sharing a 2-bit selector (2-2-2, 5-5-4, 8-7-7 bits or 1–4 bytes each).
    pub const TAG2_3SVARIABLE: u8 = 10;
}

/// How many consecutive fields one read of `encoding` fills (the caller passes `available`, the number
/// of fields from here that share the encoding, for TAG8_8SVB).
pub fn group_size(encoding: u8, available: usize) -> usize {
    match encoding {
        id::TAG8_8SVB => available.clamp(1, 8),
        id::TAG2_3S32 | id::TAG2_3SVARIABLE => 3,
        id::TAG8_4S16 => 4,
        _ => 1,
    }
}

/// A read position in a byte slice.
#[derive(Debug, Clone)]
pub struct Cursor<'a> {
    data: &'a [u8],
    pos: usize,
}

impl<'a> Cursor<'a> {
    /// A cursor at `pos` of `data`.
    pub fn new(data: &'a [u8], pos: usize) -> Cursor<'a> {
        Cursor {
            data,
            pos: pos.min(data.len()),
        }
    }

    /// Byte offset of the next byte to read.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// True when every byte was read.
    pub fn at_end(&self) -> bool {
        self.pos >= self.data.len()
    }

    /// The next byte without consuming it.
    pub fn peek(&self) -> Option<u8> {
        self.data.get(self.pos).copied()
    }

    /// The next `n` bytes, consumed.
    pub fn bytes(&mut self, n: usize) -> Result<&'a [u8], Truncated> {
        let end = self.pos.checked_add(n).ok_or(Truncated)?;
        let s = self.data.get(self.pos..end).ok_or(Truncated)?;
        self.pos = end;
        Ok(s)
    }

    /// One byte.
    pub fn byte(&mut self) -> Result<u8, Truncated> {
        let b = self.peek().ok_or(Truncated)?;
        self.pos += 1;
        Ok(b)
    }

    /// Unsigned variable-byte integer (at most 5 bytes for 32 bits).
    pub fn unsigned_vb(&mut self) -> Result<u32, Malformed> {
        let mut value: u32 = 0;
        for i in 0..5 {
            let b = self.byte()?;
            value |= u32::from(b & 0x7F).wrapping_shl(7 * i);
            if b < 0x80 {
                return Ok(value);
            }
        }
        Err(Malformed::TooLong)
    }

    /// Signed variable-byte integer: ZigZag-folded unsigned VB.
    pub fn signed_vb(&mut self) -> Result<i32, Malformed> {
        Ok(zigzag(self.unsigned_vb()?))
    }

    /// NEG_14BIT: the negated 14-bit two's-complement value.
    pub fn neg_14bit(&mut self) -> Result<i32, Malformed> {
        Ok(-sign_extend(self.unsigned_vb()? & 0x3FFF, 14))
    }

    /// TAG8_8SVB for `count` fields (1..=8) into `out[..count]`. A group of one is a bare signed VB.
    pub fn tag8_8svb(&mut self, out: &mut [i64], count: usize) -> Result<(), Malformed> {
        let count = count.min(out.len()).min(8);
        if count == 1 {
            out[0] = i64::from(self.signed_vb()?);
            return Ok(());
        }
        let header = self.byte()?;
        for (i, v) in out.iter_mut().take(count).enumerate() {
            *v = if header & (1 << i) != 0 {
                i64::from(self.signed_vb()?)
            } else {
                0
            };
        }
        Ok(())
    }

    /// TAG2_3S32 into `out[..3]`.
    pub fn tag2_3s32(&mut self, out: &mut [i64; 3]) -> Result<(), Malformed> {
        let lead = self.byte()?;
        match lead >> 6 {
            0 => {
                for (i, v) in out.iter_mut().enumerate() {
                    *v = i64::from(sign_extend(u32::from(lead >> (4 - 2 * i)) & 0x3, 2));
                }
            }
            1 => {
                let b = self.byte()?;
                out[0] = i64::from(sign_extend(u32::from(lead & 0xF), 4));
                out[1] = i64::from(sign_extend(u32::from(b >> 4), 4));
                out[2] = i64::from(sign_extend(u32::from(b & 0xF), 4));
            }
            2 => {
                let b = self.bytes(2)?;
                out[0] = i64::from(sign_extend(u32::from(lead & 0x3F), 6));
                out[1] = i64::from(sign_extend(u32::from(b[0] & 0x3F), 6));
                out[2] = i64::from(sign_extend(u32::from(b[1] & 0x3F), 6));
            }
            _ => self.sized_fields(lead, out)?,
        }
        Ok(())
    }

    /// TAG2_3SVARIABLE into `out[..3]`: like TAG2_3S32, with 5-5-4 and 8-7-7 bit layouts packed most
    /// significant bit first after the selector.
    pub fn tag2_3svariable(&mut self, out: &mut [i64; 3]) -> Result<(), Malformed> {
        let lead = self.byte()?;
        match lead >> 6 {
            0 => {
                for (i, v) in out.iter_mut().enumerate() {
                    *v = i64::from(sign_extend(u32::from(lead >> (4 - 2 * i)) & 0x3, 2));
                }
            }
            1 => {
                let bits = (u32::from(lead & 0x3F) << 8) | u32::from(self.byte()?);
                out[0] = i64::from(sign_extend(bits >> 9, 5));
                out[1] = i64::from(sign_extend((bits >> 4) & 0x1F, 5));
                out[2] = i64::from(sign_extend(bits & 0xF, 4));
            }
            2 => {
                let b = self.bytes(2)?;
                let bits = (u32::from(lead & 0x3F) << 16) | (u32::from(b[0]) << 8) | u32::from(b[1]);
                out[0] = i64::from(sign_extend(bits >> 14, 8));
                out[1] = i64::from(sign_extend((bits >> 7) & 0x7F, 7));
                out[2] = i64::from(sign_extend(bits & 0x7F, 7));
            }
            _ => self.sized_fields(lead, out)?,
        }
        Ok(())
    }

    /// The byte-sized case shared by TAG2_3S32 and TAG2_3SVARIABLE: 2 bits per field (first field in
    /// the low bits) give 1–4 little-endian bytes, sign-extended.
    fn sized_fields(&mut self, lead: u8, out: &mut [i64; 3]) -> Result<(), Malformed> {
        for (i, v) in out.iter_mut().enumerate() {
            let n = usize::from((lead >> (2 * i)) & 0x3) + 1;
            let b = self.bytes(n)?;
            let raw = b.iter().rev().fold(0u32, |acc, &x| (acc << 8) | u32::from(x));
            *v = i64::from(sign_extend(raw, 8 * n as u32));
        }
        Ok(())
    }

    /// TAG8_4S16 (data version 2) into `out[..4]`: fields are packed as a nibble stream, most
    /// significant nibble first.
    pub fn tag8_4s16(&mut self, out: &mut [i64; 4]) -> Result<(), Malformed> {
        let selector = self.byte()?;
        // Nibble stream: `pending` holds the low nibble of the last byte when half of it is unread.
        let mut pending: Option<u8> = None;
        let mut next_nibble = |c: &mut Cursor<'a>| -> Result<u32, Truncated> {
            match pending.take() {
                Some(n) => Ok(u32::from(n)),
                None => {
                    let b = c.byte()?;
                    pending = Some(b & 0xF);
                    Ok(u32::from(b >> 4))
                }
            }
        };
        for (i, v) in out.iter_mut().enumerate() {
            let nibbles = match (selector >> (2 * i)) & 0x3 {
                0 => 0,
                1 => 1,
                2 => 2,
                _ => 4,
            };
            let mut raw = 0u32;
            for _ in 0..nibbles {
                raw = (raw << 4) | next_nibble(self)?;
            }
            *v = if nibbles == 0 {
                0
            } else {
                i64::from(sign_extend(raw, 4 * nibbles))
            };
        }
        Ok(())
    }
}

/// ZigZag decoding: 0, 1, 2, 3, ... → 0, -1, 1, -2, ...
pub fn zigzag(u: u32) -> i32 {
    ((u >> 1) as i32) ^ -((u & 1) as i32)
}

/// The low `bits` bits of `raw` as a two's-complement number (1 ≤ bits ≤ 32).
pub fn sign_extend(raw: u32, bits: u32) -> i32 {
    let bits = bits.clamp(1, 32);
    let shift = 32 - bits;
    ((raw << shift) as i32) >> shift
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variable_byte_examples_from_the_format_docs() {
        for (bytes, v) in [
            (&[0x01u8][..], 1u32),
            (&[0x7F], 127),
            (&[0x80, 0x01], 128),
            (&[0xA0, 0xB7, 0x01], 23456),
        ] {
            assert_eq!(Cursor::new(bytes, 0).unsigned_vb(), Ok(v));
        }
        assert_eq!(Cursor::new(&[0x80, 0x80], 0).unsigned_vb(), Err(Malformed::Truncated));
        assert_eq!(Cursor::new(&[0xFF; 6], 0).unsigned_vb(), Err(Malformed::TooLong));
        assert_eq!(zigzag(4294967294), 2147483647);
        assert_eq!(zigzag(4294967295), -2147483648);
        assert_eq!(zigzag(3), -2);
    }

    #[test]
    fn tagged_groups() {
        // The TAG8_8SVB example of the docs: 0, 0, 4, 0, 8 → 0b00010100, 0x04, 0x08 (ZigZag: 8, 16).
        let mut out = [0i64; 5];
        Cursor::new(&[0b0001_0100, 8, 16], 0).tag8_8svb(&mut out, 5).unwrap();
        assert_eq!(out, [0, 0, 4, 0, 8]);
        // TAG8_4S16 example: 13, 0, 4, 2 with sizes 8, 0, 4, 4 → 0b01010010, 0x0D, 0x42.
        let mut out = [0i64; 4];
        Cursor::new(&[0b0101_0010, 0x0D, 0x42], 0).tag8_4s16(&mut out).unwrap();
        assert_eq!(out, [13, 0, 4, 2]);
        // TAG2_3S32: 4-bit case 0100 AAAA BBBB CCCC with -1, 7, -8.
        let mut out = [0i64; 3];
        Cursor::new(&[0x4F, 0x78], 0).tag2_3s32(&mut out).unwrap();
        assert_eq!(out, [-1, 7, -8]);
        // Byte case: field sizes 1, 2, 4 bytes (selector bits 00, 01, 11) → -2, 300, -70000.
        let mut c = Cursor::new(&[0xC0 | 0b11_01_00, 0xFE, 0x2C, 0x01, 0x90, 0xEE, 0xFE, 0xFF], 0);
        c.tag2_3s32(&mut out).unwrap();
        assert_eq!(out, [-2, 300, -70000]);
        // TAG2_3SVARIABLE 5-5-4: 01 | 11111 | 00001 | 0111 → -1, 1, 7.
        let bits: u32 = (0b01 << 14) | (0b11111 << 9) | (0b00001 << 4) | 0b0111;
        Cursor::new(&[(bits >> 8) as u8, bits as u8], 0)
            .tag2_3svariable(&mut out)
            .unwrap();
        assert_eq!(out, [-1, 1, 7]);
        assert_eq!(
            Cursor::new(&[0x80, 1], 0).tag2_3s32(&mut out),
            Err(Malformed::Truncated)
        );
    }
}
