//! The two passes over a DataFlash file: [`definitions`] collects every FMT and FMTU (so a type's
//! instance field is known for all its messages), [`Decoder`] turns the messages into columns, and
//! records parameters and the firmware's banner.

use super::fields::{Layout, Storage};
use super::frame::{Def, Frame, Framer};

/// Most groups (instances) kept per message type; more are dropped with a note.
pub(crate) const MAX_INSTANCES: usize = 64;

/// A message type as its first FMT defines it.
pub(crate) struct TypeInfo {
    pub(crate) def: Def,
    /// The layout, or why the type cannot be decoded.
    pub(crate) layout: Result<Layout, String>,
    /// Index of the instance field (FMTU unit `#`).
    pub(crate) instance: Option<usize>,
}

impl TypeInfo {
    fn new(def: Def) -> TypeInfo {
        let layout = Layout::parse(&def.format, &def.labels).and_then(|l| {
            if l.payload_len + 3 == def.len {
                Ok(l)
            } else {
                Err(format!(
                    "its format '{}' needs {} bytes but FMT gives length {}",
                    def.format,
                    l.payload_len + 3,
                    def.len
                ))
            }
        });
        TypeInfo {
            def,
            layout,
            instance: None,
        }
    }
}

/// Pass 1: the first definition of every type, with the instance fields that FMTU messages name.
/// Returns the table and the number of FMT messages seen.
pub(crate) fn definitions(bytes: &[u8]) -> (Vec<Option<TypeInfo>>, usize) {
    let mut types: Vec<Option<TypeInfo>> = (0..256).map(|_| None).collect();
    let mut units: Vec<(u8, String)> = Vec::new();
    let mut fmts = 0usize;
    for frame in Framer::new(bytes) {
        match frame {
            Frame::Fmt { def, .. } => {
                fmts += 1;
                let slot = &mut types[usize::from(def.type_id)];
                if slot.is_none() {
                    *slot = Some(TypeInfo::new(def));
                }
            }
            Frame::Message { type_id, payload, .. } => {
                let Some(t) = &types[usize::from(type_id)] else {
                    continue;
                };
                let Ok(l) = &t.layout else { continue };
                if t.def.name != "FMTU" {
                    continue;
                }
                let of = l.index_of("FmtType").and_then(|k| l.number(k, payload));
                let ids = l.index_of("UnitIds").and_then(|k| l.text(k, payload));
                if let (Some(of), Some(ids)) = (of, ids) {
                    if (0.0..256.0).contains(&of) {
                        units.push((of as u8, ids));
                    }
                }
            }
        }
    }
    for (type_id, ids) in units {
        let Some(t) = types[usize::from(type_id)].as_mut() else {
            continue;
        };
        let Ok(l) = &t.layout else { continue };
        t.instance = ids.chars().position(|c| c == '#').filter(|&k| k < l.fields.len());
    }
    (types, fmts)
}

/// The columns of one message type and instance.
pub(crate) struct Builder {
    /// Group name: `NAME` or `NAME[k]`.
    pub(crate) name: String,
    pub(crate) channel_names: Vec<String>,
    pub(crate) time_us: Vec<u64>,
    pub(crate) cols: Vec<Vec<f64>>,
}

/// Per-type decoding state.
struct TypeState {
    /// Field index of the time stamp and µs per unit (TimeUS: 1, TimeMS: 1000).
    time: Option<(usize, u64)>,
    /// (instance suffix, index into the builders).
    instances: Vec<(String, usize)>,
    /// Messages of this type seen after a conflicting FMT (skipped).
    redefined: bool,
}

/// Pass 2: messages to columns, settings and counts of what was left out.
pub(crate) struct Decoder {
    pub(crate) types: Vec<Option<TypeInfo>>,
    state: Vec<Option<TypeState>>,
    pub(crate) builders: Vec<Builder>,
    /// PARM names and values, firmware banner and frame, in file order.
    pub(crate) settings: Vec<(String, String)>,
    /// Per type name: messages not kept (no time stamp, undecodable layout, redefined type).
    pub(crate) untimed: Vec<(String, usize)>,
    pub(crate) undecodable: Vec<(String, usize, String)>,
    pub(crate) redefined: Vec<(String, usize)>,
    pub(crate) dropped_instances: usize,
}

fn bump(list: &mut Vec<(String, usize)>, name: &str) {
    match list.iter_mut().find(|(n, _)| n == name) {
        Some((_, c)) => *c += 1,
        None => list.push((name.to_string(), 1)),
    }
}

/// Whether an MSG text is the firmware's version banner, e.g. "ArduCopter V4.5.7 (2a3dc4b7)".
pub(crate) fn is_firmware_banner(text: &str) -> bool {
    let mut words = text.split_whitespace();
    let (Some(first), Some(second)) = (words.next(), words.next()) else {
        return false;
    };
    let vehicle =
        first.starts_with("Ardu") || first.starts_with("APM:") || matches!(first, "Rover" | "AntennaTracker" | "Blimp");
    vehicle && second.starts_with('V') && second[1..].starts_with(|c: char| c.is_ascii_digit())
}

impl Decoder {
    pub(crate) fn new(types: Vec<Option<TypeInfo>>) -> Decoder {
        let state = types
            .iter()
            .map(|t| {
                let t = t.as_ref()?;
                let l = t.layout.as_ref().ok()?;
                let time = l
                    .index_of("TimeUS")
                    .map(|k| (k, 1))
                    .or_else(|| l.index_of("TimeMS").map(|k| (k, 1000)))
                    .filter(|&(k, _)| matches!(l.fields[k].ty.storage, Storage::U64 | Storage::U32 | Storage::I64));
                Some(TypeState {
                    time,
                    instances: Vec::new(),
                    redefined: false,
                })
            })
            .collect();
        Decoder {
            types,
            state,
            builders: Vec::new(),
            settings: Vec::new(),
            untimed: Vec::new(),
            undecodable: Vec::new(),
            redefined: Vec::new(),
            dropped_instances: 0,
        }
    }

    /// Takes one frame of pass 2.
    pub(crate) fn on_frame(&mut self, frame: Frame<'_>) {
        match frame {
            Frame::Fmt { def, .. } => {
                let id = usize::from(def.type_id);
                if let (Some(t), Some(s)) = (&self.types[id], &mut self.state[id]) {
                    if t.def != def {
                        s.redefined = true;
                    }
                }
            }
            Frame::Message { type_id, payload, .. } => self.on_message(type_id, payload),
        }
    }

    fn on_message(&mut self, type_id: u8, payload: &[u8]) {
        let id = usize::from(type_id);
        let Some(t) = &self.types[id] else { return };
        let layout = match &t.layout {
            Ok(l) => l,
            Err(why) => {
                match self.undecodable.iter_mut().find(|(n, _, _)| *n == t.def.name) {
                    Some((_, c, _)) => *c += 1,
                    None => self.undecodable.push((t.def.name.clone(), 1, why.clone())),
                }
                return;
            }
        };
        let Some(state) = self.state[id].as_mut() else { return };
        if state.redefined {
            bump(&mut self.redefined, &t.def.name);
            return;
        }
        self.settings
            .extend(special(&t.def.name, layout, payload, &self.settings));
        let Some((tk, per)) = state.time else {
            bump(&mut self.untimed, &t.def.name);
            return;
        };
        let Some(time_us) = layout.unsigned(tk, payload).and_then(|v| v.checked_mul(per)) else {
            return;
        };
        let suffix = t
            .instance
            .map(|k| instance_suffix(layout, k, payload))
            .unwrap_or_default();
        let b = match state.instances.iter().find(|(s, _)| *s == suffix) {
            Some(&(_, b)) => b,
            None if state.instances.len() >= MAX_INSTANCES => {
                self.dropped_instances += 1;
                return;
            }
            None => {
                let channel_names = layout.channel_names();
                self.builders.push(Builder {
                    name: format!("{}{suffix}", t.def.name),
                    cols: vec![Vec::new(); channel_names.len()],
                    channel_names,
                    time_us: Vec::new(),
                });
                state.instances.push((suffix, self.builders.len() - 1));
                self.builders.len() - 1
            }
        };
        let b = &mut self.builders[b];
        b.time_us.push(time_us);
        layout.push_row(payload, &mut b.cols);
    }
}

/// `""` for instance 0, `[k]` for a numeric instance k, `[text]` for a text instance made of
/// letters, digits and `_` (other text: `""`).
fn instance_suffix(l: &Layout, k: usize, payload: &[u8]) -> String {
    if let Some(v) = l.number(k, payload) {
        return if v == 0.0 || !v.is_finite() || v.fract() != 0.0 {
            String::new()
        } else {
            format!("[{v}]")
        };
    }
    match l.text(k, payload) {
        Some(s) if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') => format!("[{s}]"),
        _ => String::new(),
    }
}

/// The settings one message contributes: PARM → (Name, Value as text); MSG → the firmware banner
/// as `Firmware revision` and `Frame: X` as `Frame`; VER → its `FWS` string as `Firmware
/// revision` when no MSG gave one. `so_far` avoids repeating an unchanged banner.
fn special(name: &str, l: &Layout, payload: &[u8], so_far: &[(String, String)]) -> Option<(String, String)> {
    let field_text = |f: &str| l.index_of(f).and_then(|k| l.text(k, payload));
    let last = |key: &str| so_far.iter().rev().find(|(k, _)| k == key).map(|(_, v)| v.as_str());
    match name {
        "PARM" => {
            let k = l.index_of("Value")?;
            let v = l.number(k, payload)?;
            let text = if l.fields[k].ty.storage == Storage::F32 {
                // The value as the ground station shows it (0.135, not 0.13500000536441803).
                (v as f32).to_string()
            } else {
                v.to_string()
            };
            Some((field_text("Name")?, text))
        }
        "MSG" => {
            let m = field_text("Message")?;
            let (key, value) = if is_firmware_banner(&m) {
                ("Firmware revision", m.trim().to_string())
            } else if let Some(f) = m.strip_prefix("Frame:") {
                ("Frame", f.trim().to_string())
            } else {
                return None;
            };
            (last(key) != Some(value.as_str())).then(|| (key.to_string(), value))
        }
        "VER" => {
            let fws = field_text("FWS")?;
            (last("Firmware revision").is_none() && is_firmware_banner(&fws))
                .then(|| ("Firmware revision".to_string(), fws.trim().to_string()))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn banners() {
        assert!(is_firmware_banner("ArduCopter V4.5.7 (2a3dc4b7)"));
        assert!(is_firmware_banner("ArduPlane V4.3.0"));
        assert!(is_firmware_banner("APM:Copter V3.6.12 (abc)"));
        assert!(!is_firmware_banner("Frame: QUAD/X"));
        assert!(!is_firmware_banner("ArduCopter"));
        assert!(!is_firmware_banner("ArduCopter Vx"));
        assert!(!is_firmware_banner("ChibiOS: 6a85082c"));
    }
}
