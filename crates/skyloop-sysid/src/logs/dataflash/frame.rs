//! Message framing: the `0xA3 0x95 <type>` header, each type's length from its FMT message,
//! resynchronisation after garbage and a clean stop at a truncated tail.

/// The two sync bytes that start every message.
pub const HEAD: [u8; 2] = [0xA3, 0x95];
/// The FMT message's type.
pub const FMT_TYPE: u8 = 128;
/// FMT's whole length: header 3 + type 1 + length 1 + name 4 + format 16 + labels 64.
pub const FMT_LEN: usize = 89;

/// One FMT message: the definition of a message type.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Def {
    pub(crate) type_id: u8,
    /// Whole message length including the 3-byte header, bytes.
    pub(crate) len: usize,
    pub(crate) name: String,
    pub(crate) format: String,
    pub(crate) labels: String,
}

fn text(b: &[u8]) -> String {
    let end = b.iter().position(|&c| c == 0).unwrap_or(b.len());
    String::from_utf8_lossy(&b[..end]).trim().to_string()
}

/// Parses an FMT payload (the 86 bytes after the header).
pub(crate) fn parse_fmt(p: &[u8]) -> Option<Def> {
    if p.len() < FMT_LEN - 3 {
        return None;
    }
    Some(Def {
        type_id: p[0],
        len: usize::from(p[1]),
        name: text(&p[2..6]),
        format: text(&p[6..22]),
        labels: text(&p[22..86]),
    })
}

/// What the framer found.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Frame<'a> {
    /// An FMT message (already applied to the framer's length table).
    Fmt { offset: usize, def: Def },
    /// Any other message of a defined type.
    Message {
        offset: usize,
        type_id: u8,
        payload: &'a [u8],
    },
}

/// Walks a file's messages. Bytes that do not start a message of a defined type are skipped up to
/// the next sync; a message running past the end of the file stops the walk (`truncated_at`).
pub(crate) struct Framer<'a> {
    bytes: &'a [u8],
    pos: usize,
    lens: [usize; 256],
    /// Bytes skipped while resynchronising.
    pub(crate) skipped: usize,
    /// Offset of an incomplete message at the end of the file.
    pub(crate) truncated_at: Option<usize>,
}

impl<'a> Framer<'a> {
    /// A framer at the start of `bytes`, knowing only FMT.
    pub(crate) fn new(bytes: &'a [u8]) -> Framer<'a> {
        let mut lens = [0usize; 256];
        lens[usize::from(FMT_TYPE)] = FMT_LEN;
        Framer {
            bytes,
            pos: 0,
            lens,
            skipped: 0,
            truncated_at: None,
        }
    }

    /// Moves past byte `pos` to the next sync (or the end), counting the skipped bytes.
    fn resync(&mut self) {
        let from = self.pos + 1;
        let next = self
            .bytes
            .get(from..)
            .and_then(|rest| rest.windows(2).position(|w| w == HEAD))
            .map_or(self.bytes.len(), |i| from + i);
        self.skipped += next - self.pos;
        self.pos = next;
    }
}

impl<'a> Iterator for Framer<'a> {
    type Item = Frame<'a>;

    fn next(&mut self) -> Option<Frame<'a>> {
        let n = self.bytes.len();
        while self.pos < n {
            let pos = self.pos;
            let rest = &self.bytes[pos..];
            if rest.len() < 3 {
                if HEAD.starts_with(rest) || rest.starts_with(&HEAD) {
                    self.truncated_at = Some(pos);
                } else {
                    self.skipped += rest.len();
                }
                self.pos = n;
                return None;
            }
            if rest[..2] != HEAD {
                self.resync();
                continue;
            }
            let type_id = rest[2];
            let len = self.lens[usize::from(type_id)];
            if len < 3 {
                // A type with no FMT yet (or a header that is really data): not a message.
                self.resync();
                continue;
            }
            if rest.len() < len {
                self.truncated_at = Some(pos);
                self.pos = n;
                return None;
            }
            self.pos = pos + len;
            let payload = &rest[3..len];
            if type_id == FMT_TYPE {
                let Some(def) = parse_fmt(payload) else { continue };
                // FMT's own length is fixed; a definition shorter than a header defines nothing.
                if def.type_id != FMT_TYPE && def.len >= 3 {
                    self.lens[usize::from(def.type_id)] = def.len;
                }
                return Some(Frame::Fmt { offset: pos, def });
            }
            return Some(Frame::Message {
                offset: pos,
                type_id,
                payload,
            });
        }
        None
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fmt_msg(type_id: u8, len: u8, name: &str, format: &str, labels: &str) -> Vec<u8> {
        let mut m = vec![0xA3, 0x95, FMT_TYPE, type_id, len];
        for (s, n) in [(name, 4), (format, 16), (labels, 64)] {
            let mut b = s.as_bytes().to_vec();
            b.resize(n, 0);
            m.extend(b);
        }
        m
    }

    #[test]
    fn skips_garbage_and_stops_at_a_truncated_tail() {
        let mut b = fmt_msg(130, 5, "TST", "BB", "A,B");
        b.extend([1, 2, 3]); // garbage
        b.extend([0xA3, 0x95, 130, 7, 8]);
        b.extend([0xA3, 0x95, 131, 9]); // undefined type: garbage
        b.extend([0xA3, 0x95, 130, 1]); // truncated
        let mut f = Framer::new(&b);
        let frames: Vec<Frame> = f.by_ref().collect();
        assert_eq!(frames.len(), 2);
        assert_eq!(
            frames[1],
            Frame::Message {
                offset: 92,
                type_id: 130,
                payload: &[7, 8]
            }
        );
        assert_eq!(f.skipped, 3 + 4);
        assert_eq!(f.truncated_at, Some(101));
    }
}
