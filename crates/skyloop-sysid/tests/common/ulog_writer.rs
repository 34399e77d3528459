//! A ULog writer for the tests, written from the ULog file format specification (PX4 docs, "ULog
//! File Format"), not from the reader: a 16-byte file header ("ULog" 0x01 0x12 0x35, version byte,
//! u64 time stamp µs), then records of `u16 msg_size` (payload bytes), `u8 msg_type` and the payload,
//! little-endian: 'B' flag bits (compat[8], incompat[8], appended_offsets u64[3]), 'F' format
//! (`name:type field;type field;...`), 'I' info and 'P' parameter (`u8 key_len`, key
//! `"<type> <name>"`, value), 'A' add_logged_message (`u8 multi_id`, `u16 msg_id`, name) and 'D' data
//! (`u16 msg_id`, then the fields as the format lays them out, the u64 time stamp first).
#![allow(dead_code)]

/// A field's value in a data message.
#[derive(Debug, Clone, PartialEq)]
pub enum F {
    /// `uint64_t`.
    U64(u64),
    /// `float` (one).
    F32(f32),
    /// `float[n]`.
    F32s(Vec<f32>),
    /// `bool`, `uint8_t` or padding bytes, as raw bytes.
    Bytes(Vec<u8>),
    /// `uint16_t`.
    U16(u16),
}

fn encode(f: &F) -> Vec<u8> {
    match f {
        F::U64(x) => x.to_le_bytes().to_vec(),
        F::F32(x) => x.to_le_bytes().to_vec(),
        F::F32s(v) => v.iter().flat_map(|x| x.to_le_bytes()).collect(),
        F::Bytes(b) => b.clone(),
        F::U16(x) => x.to_le_bytes().to_vec(),
    }
}

/// A log being written.
pub struct Writer {
    pub bytes: Vec<u8>,
    /// (message name, multi_id) → msg_id of the subscriptions added.
    subs: Vec<(String, u8, u16)>,
}

impl Writer {
    /// The file header (version 1, logger start `start_us`) and a flag-bits record with no flags
    /// and no appended data.
    pub fn new(start_us: u64) -> Writer {
        let mut bytes = b"ULog\x01\x12\x35".to_vec();
        bytes.push(1);
        bytes.extend(start_us.to_le_bytes());
        let mut w = Writer {
            bytes,
            subs: Vec::new(),
        };
        w.record(b'B', &[0u8; 40]);
        w
    }

    fn record(&mut self, t: u8, payload: &[u8]) {
        let n = u16::try_from(payload.len()).expect("a ULog record holds at most 65535 bytes");
        self.bytes.extend(n.to_le_bytes());
        self.bytes.push(t);
        self.bytes.extend_from_slice(payload);
    }

    /// An 'F' record: `fields` as "type name" pairs, e.g. `["uint64_t timestamp", "float[3] xyz"]`.
    pub fn format(&mut self, name: &str, fields: &[&str]) {
        let mut s = format!("{name}:");
        for f in fields {
            s.push_str(f);
            s.push(';');
        }
        self.record(b'F', s.as_bytes());
    }

    fn key_value(&mut self, t: u8, key: &str, value: &[u8]) {
        let mut p = vec![u8::try_from(key.len()).expect("key of at most 255 bytes")];
        p.extend_from_slice(key.as_bytes());
        p.extend_from_slice(value);
        self.record(t, &p);
    }

    /// An 'I' record `char[N] key` = `value`.
    pub fn info(&mut self, key: &str, value: &str) {
        self.key_value(b'I', &format!("char[{}] {key}", value.len()), value.as_bytes());
    }

    /// A 'P' record `float name`.
    pub fn param_f32(&mut self, name: &str, v: f32) {
        self.key_value(b'P', &format!("float {name}"), &v.to_le_bytes());
    }

    /// A 'P' record `int32_t name`.
    pub fn param_i32(&mut self, name: &str, v: i32) {
        self.key_value(b'P', &format!("int32_t {name}"), &v.to_le_bytes());
    }

    /// An 'A' record subscribing `name` instance `multi_id` as `msg_id`.
    pub fn add_logged(&mut self, name: &str, multi_id: u8, msg_id: u16) {
        let mut p = vec![multi_id];
        p.extend(msg_id.to_le_bytes());
        p.extend_from_slice(name.as_bytes());
        self.record(b'A', &p);
        self.subs.push((name.to_string(), multi_id, msg_id));
    }

    /// A 'D' record of subscription `msg_id`: the fields in the format's order (time stamp first).
    /// A `_padding` field that ends a format is not written (the specification: the logger leaves
    /// trailing padding out, so the record is shorter than the format by its size).
    pub fn data(&mut self, msg_id: u16, fields: &[F]) {
        assert!(self.subs.iter().any(|s| s.2 == msg_id), "msg_id {msg_id} not added");
        let mut p = msg_id.to_le_bytes().to_vec();
        for f in fields {
            p.extend(encode(f));
        }
        self.record(b'D', &p);
    }
}
