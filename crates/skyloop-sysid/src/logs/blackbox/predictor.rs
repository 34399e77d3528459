//! The field predictors: the value a field is predicted to have, which the firmware subtracted before
//! encoding and the decoder adds back.

/// Predictor numbers as written in the `H Field X predictor` headers.
pub mod id {
    /// Zero: the value is logged as is.
    pub const ZERO: u8 = 0;
    /// The field's value in the previous frame.
    pub const PREVIOUS: u8 = 1;
    /// Straight line through the two previous frames: 2·prev − prev2.
    pub const STRAIGHT_LINE: u8 = 2;
    /// Mean of the two previous frames, truncated toward zero.
    pub const AVERAGE_2: u8 = 3;
    /// The `minthrottle` header.
    pub const MIN_THROTTLE: u8 = 4;
    /// `motor[0]` of the same frame.
    pub const MOTOR_0: u8 = 5;
    /// The previous value plus one plus the iterations skipped by the logging rate (`loopIteration`).
    pub const INCREMENT: u8 = 6;
    /// The GPS home coordinate (first such field: home latitude, second: home longitude).
    pub const HOME_COORD: u8 = 7;
    /// The constant 1500 (servo mid-point).
    pub const MID_1500: u8 = 8;
    /// The `vbatref` header.
    pub const VBAT_REF: u8 = 9;
    /// The `time` of the last main frame.
    pub const LAST_MAIN_TIME: u8 = 10;
    /// The first value of the `motorOutput` header ("minmotor").
    pub const MIN_MOTOR: u8 = 11;
}

/// What predictors can draw on besides the frame being decoded.
pub struct Context<'a> {
    /// The previous frame of the same kind (for a P-frame right after an I-frame: that I-frame).
    pub prev: Option<&'a [i64]>,
    /// The frame before `prev` (for the first P-frame after an I-frame: that I-frame again).
    pub prev2: Option<&'a [i64]>,
    /// Iterations the logging rate skipped since the last main frame.
    pub skipped: i64,
    /// `minthrottle` header.
    pub minthrottle: i64,
    /// `motorOutput` minimum.
    pub min_motor: i64,
    /// `vbatref` header.
    pub vbatref: i64,
    /// Time of the last main frame, µs.
    pub last_main_time: i64,
    /// Index of `motor[0]` in the frame, if it has one.
    pub motor0: Option<usize>,
    /// GPS home (latitude, longitude) from the last `H` frame.
    pub home: Option<[i64; 2]>,
}

/// A predictor needs something this frame does not have.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Missing {
    /// `motor[0]` (predictor 5) in a frame without it, or decoded after it.
    Motor0,
    /// The GPS home position (predictor 7) before any `H` frame.
    Home,
}

/// The prediction for field `index` (decoded so far: `current[..index]`), with `home_slot` the count of
/// earlier home-coordinate fields in the frame.
pub fn predict(
    predictor: u8,
    index: usize,
    current: &[i64],
    home_slot: usize,
    ctx: &Context<'_>,
) -> Result<i64, Missing> {
    let prev = ctx.prev.and_then(|p| p.get(index)).copied();
    let prev2 = ctx.prev2.and_then(|p| p.get(index)).copied().or(prev);
    Ok(match predictor {
        id::PREVIOUS => prev.unwrap_or(0),
        id::STRAIGHT_LINE => match (prev, prev2) {
            (Some(a), Some(b)) => a.wrapping_mul(2).wrapping_sub(b),
            _ => 0,
        },
        id::AVERAGE_2 => match (prev, prev2) {
            // Integer division truncates toward zero, as the firmware's C does.
            (Some(a), Some(b)) => a.wrapping_add(b) / 2,
            _ => 0,
        },
        id::MIN_THROTTLE => ctx.minthrottle,
        id::MOTOR_0 => match ctx.motor0 {
            Some(m) if m < index => current[m],
            _ => return Err(Missing::Motor0),
        },
        id::INCREMENT => prev.unwrap_or(-1).wrapping_add(1).wrapping_add(ctx.skipped),
        id::HOME_COORD => match ctx.home {
            Some(h) => h[home_slot.min(1)],
            None => return Err(Missing::Home),
        },
        id::MID_1500 => 1500,
        id::VBAT_REF => ctx.vbatref,
        id::LAST_MAIN_TIME => ctx.last_main_time,
        id::MIN_MOTOR => ctx.min_motor,
        _ => 0,
    })
}

/// A decoded value as the firmware's 32-bit field holds it: two's complement when `signed`, else
/// unsigned.
pub fn to_field_width(v: i64, signed: bool) -> i64 {
    if signed {
        i64::from(v as i32)
    } else {
        i64::from(v as u32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ctx<'a>(prev: Option<&'a [i64]>, prev2: Option<&'a [i64]>) -> Context<'a> {
        Context {
            prev,
            prev2,
            skipped: 7,
            minthrottle: 1070,
            min_motor: 158,
            vbatref: 2277,
            last_main_time: 1000,
            motor0: Some(0),
            home: None,
        }
    }

    #[test]
    fn predictions() {
        let p = [10i64, -3];
        let p2 = [4i64, -6];
        let c = ctx(Some(&p), Some(&p2));
        assert_eq!(predict(id::STRAIGHT_LINE, 0, &[], 0, &c), Ok(16));
        assert_eq!(predict(id::AVERAGE_2, 1, &[], 0, &c), Ok(-4)); // (-9)/2 truncated toward zero
        assert_eq!(predict(id::INCREMENT, 0, &[], 0, &c), Ok(18));
        assert_eq!(predict(id::MOTOR_0, 1, &[1234], 0, &c), Ok(1234));
        assert_eq!(predict(id::HOME_COORD, 0, &[], 0, &c), Err(Missing::Home));
        // The first P-frame after an I-frame: both history slots hold the I-frame.
        let c = ctx(Some(&p), Some(&p));
        assert_eq!(predict(id::STRAIGHT_LINE, 0, &[], 0, &c), Ok(10));
        assert_eq!(to_field_width(-1, false), 4294967295);
        assert_eq!(to_field_width(4294967295, true), -1);
    }
}
