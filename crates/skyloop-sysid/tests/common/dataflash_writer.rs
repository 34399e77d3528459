//! A DataFlash (`.bin`) writer for the tests, written from ArduPilot's description of the format
//! (not from the reader): `0xA3 0x95 <type>` then the payload laid out by the type's FMT message,
//! little-endian, FMT being type 128 with (type u8, length u8, name char[4], format char[16],
//! labels char[64]).
#![allow(dead_code)]

/// A value to store in one field.
#[derive(Debug, Clone, PartialEq)]
pub enum V {
    /// Any numeric field: stored as the format character says (scaled fields take the stored
    /// integer: for `c`, 1234 means 12.34).
    N(f64),
    /// An integer stored exactly (for 64-bit fields).
    I(i128),
    /// Text for `n N Z`.
    T(String),
    /// The 32 values of an `a` field.
    A(Vec<i16>),
}

/// Size of a format character's field, bytes.
pub fn size(c: char) -> usize {
    match c {
        'b' | 'B' | 'M' => 1,
        'h' | 'H' | 'c' | 'C' | 'g' => 2,
        'i' | 'I' | 'e' | 'E' | 'L' | 'f' => 4,
        'q' | 'Q' | 'd' => 8,
        'n' => 4,
        'N' => 16,
        'Z' | 'a' => 64,
        _ => panic!("no format character {c}"),
    }
}

fn half(x: f64) -> u16 {
    // Only what the tests store: 0, ±1, ±2, 0.5, 1.5 and the like (exact halves).
    if x == 0.0 {
        return 0;
    }
    let sign = if x < 0.0 { 0x8000 } else { 0 };
    let a = x.abs();
    let e = a.log2().floor() as i32;
    let frac = ((a / 2f64.powi(e) - 1.0) * 1024.0).round() as u16;
    sign | (((e + 15) as u16) << 10) | frac
}

/// Encodes one field.
pub fn encode(c: char, v: &V) -> Vec<u8> {
    let n = match v {
        V::N(x) => *x as i128,
        V::I(i) => *i,
        _ => 0,
    };
    let x = match v {
        V::N(x) => *x,
        V::I(i) => *i as f64,
        _ => 0.0,
    };
    match (c, v) {
        ('n' | 'N' | 'Z', V::T(s)) => {
            let mut b = s.as_bytes().to_vec();
            b.resize(size(c), 0);
            b
        }
        ('a', V::A(a)) => {
            let mut b: Vec<u8> = a.iter().flat_map(|x| x.to_le_bytes()).collect();
            b.resize(64, 0);
            b
        }
        ('b', _) => (n as i8).to_le_bytes().to_vec(),
        ('B' | 'M', _) => (n as u8).to_le_bytes().to_vec(),
        ('h' | 'c', _) => (n as i16).to_le_bytes().to_vec(),
        ('H' | 'C', _) => (n as u16).to_le_bytes().to_vec(),
        ('i' | 'e' | 'L', _) => (n as i32).to_le_bytes().to_vec(),
        ('I' | 'E', _) => (n as u32).to_le_bytes().to_vec(),
        ('q', _) => (n as i64).to_le_bytes().to_vec(),
        ('Q', _) => (n as u64).to_le_bytes().to_vec(),
        ('f', _) => (x as f32).to_le_bytes().to_vec(),
        ('d', _) => x.to_le_bytes().to_vec(),
        ('g', _) => half(x).to_le_bytes().to_vec(),
        _ => panic!("value {v:?} does not fit format {c}"),
    }
}

/// A log being written.
#[derive(Default)]
pub struct Writer {
    pub bytes: Vec<u8>,
    types: Vec<(u8, String, String)>,
}

fn padded(s: &str, n: usize) -> Vec<u8> {
    let mut b = s.as_bytes().to_vec();
    b.resize(n, 0);
    b
}

impl Writer {
    /// A log that starts with FMT's own definition, as ArduPilot's do.
    pub fn new() -> Writer {
        let mut w = Writer::default();
        w.define(128, "FMT", "BBnNZ", "Type,Length,Name,Format,Columns");
        w
    }

    /// Writes an FMT message for `type_id`.
    pub fn define(&mut self, type_id: u8, name: &str, format: &str, labels: &str) {
        assert!(
            format.len() <= 16 && labels.len() <= 64 && name.len() <= 4,
            "{name}: FMT holds 16 format characters"
        );
        let len = 3 + format.chars().map(size).sum::<usize>();
        self.bytes.extend([0xA3, 0x95, 128, type_id, len as u8]);
        self.bytes.extend(padded(name, 4));
        self.bytes.extend(padded(format, 16));
        self.bytes.extend(padded(labels, 64));
        self.types.retain(|(t, _, _)| *t != type_id);
        self.types.push((type_id, name.to_string(), format.to_string()));
    }

    /// Writes a message of the type named `name`.
    pub fn msg(&mut self, name: &str, values: &[V]) {
        let (t, _, f) = self
            .types
            .iter()
            .find(|(_, n, _)| n == name)
            .unwrap_or_else(|| panic!("{name} not defined"))
            .clone();
        assert_eq!(f.chars().count(), values.len(), "{name}");
        self.bytes.extend([0xA3, 0x95, t]);
        for (c, v) in f.chars().zip(values) {
            self.bytes.extend(encode(c, v));
        }
    }

    /// Defines FMTU (type 129), UNIT (130) and MULT (131) as ArduPilot does.
    pub fn define_units(&mut self) {
        self.define(129, "FMTU", "QBNN", "TimeUS,FmtType,UnitIds,MultIds");
        self.define(130, "UNIT", "QbZ", "TimeUS,Id,Label");
        self.define(131, "MULT", "Qbd", "TimeUS,Id,Mult");
    }

    /// An FMTU message for `type_id`.
    pub fn units(&mut self, time_us: u64, type_id: u8, unit_ids: &str, mult_ids: &str) {
        self.msg(
            "FMTU",
            &[
                V::I(time_us as i128),
                V::N(type_id as f64),
                V::T(unit_ids.into()),
                V::T(mult_ids.into()),
            ],
        );
    }
}
