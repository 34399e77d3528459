//! 3-vectors and unit quaternions (Hamilton, scalar first, body → NED world).

/// A 3-vector.
pub type V3 = [f64; 3];
/// A quaternion [w, x, y, z].
pub type Quat = [f64; 4];

/// a + b.
#[inline]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// a − b.
#[inline]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// k·a.
#[inline]
pub fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

/// a × b.
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// a · b.
#[inline]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Euclidean norm.
#[inline]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Rotates a body vector into the world frame: R(q)·v.
#[inline]
pub fn rotate(q: Quat, v: V3) -> V3 {
    let [w, x, y, z] = q;
    let u = [x, y, z];
    let t = scale(cross(u, v), 2.0);
    add(add(v, scale(t, w)), cross(u, t))
}

/// Rotates a world vector into the body frame: R(q)ᵀ·v.
#[inline]
pub fn rotate_inv(q: Quat, v: V3) -> V3 {
    rotate([q[0], -q[1], -q[2], -q[3]], v)
}

/// Hamilton product p ⊗ q.
#[inline]
pub fn qmul(p: Quat, q: Quat) -> Quat {
    [
        p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3],
        p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2],
        p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1],
        p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0],
    ]
}

/// q̇ = ½ q ⊗ [0, ω] for body rates ω (rad/s).
#[inline]
pub fn qdot(q: Quat, w: V3) -> Quat {
    let d = qmul(q, [0.0, w[0], w[1], w[2]]);
    [0.5 * d[0], 0.5 * d[1], 0.5 * d[2], 0.5 * d[3]]
}

/// Unit quaternion (a zero quaternion becomes identity).
#[inline]
pub fn qnormalize(q: Quat) -> Quat {
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if n > 0.0 {
        [q[0] / n, q[1] / n, q[2] / n, q[3] / n]
    } else {
        [1.0, 0.0, 0.0, 0.0]
    }
}

/// Quaternion from ZYX Euler angles roll φ, pitch θ, yaw ψ (rad).
pub fn from_euler(roll: f64, pitch: f64, yaw: f64) -> Quat {
    let (sr, cr) = (0.5 * roll).sin_cos();
    let (sp, cp) = (0.5 * pitch).sin_cos();
    let (sy, cy) = (0.5 * yaw).sin_cos();
    [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
}

/// ZYX Euler angles [roll, pitch, yaw] (rad) of a unit quaternion.
pub fn to_euler(q: Quat) -> V3 {
    let [w, x, y, z] = q;
    let roll = (2.0 * (w * x + y * z)).atan2(1.0 - 2.0 * (x * x + y * y));
    let pitch = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0).asin();
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    [roll, pitch, yaw]
}

/// True when |roll| or |pitch| of `to_euler(q)` exceeds a limit given as (cos, sin) of the angle (rad),
/// without inverse trig: the crash check runs every physics step.
#[inline]
pub fn tilt_exceeds(q: Quat, (cos_l, sin_l): (f64, f64)) -> bool {
    let [w, x, y, z] = q;
    let (sr, cr) = (2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y));
    // |atan2(sr, cr)| > L  ⇔  the direction (cr, sr) is more than L away from +x  ⇔  cr < cos L·|(cr, sr)|.
    let roll = cr < cos_l * (sr * sr + cr * cr).sqrt();
    let sp = (2.0 * (w * y - z * x)).clamp(-1.0, 1.0);
    // A limit of π/2 or more cannot be exceeded by pitch (asin ∈ [−π/2, π/2]).
    let pitch = cos_l > 0.0 && sp.abs() > sin_l;
    roll || pitch
}

/// exp of a rotation vector ξ (rad) as a unit quaternion.
pub fn qexp(xi: V3) -> Quat {
    let th = norm(xi);
    if th < 1e-12 {
        qnormalize([1.0, 0.5 * xi[0], 0.5 * xi[1], 0.5 * xi[2]])
    } else {
        let (s, c) = (0.5 * th).sin_cos();
        let k = s / th;
        [c, xi[0] * k, xi[1] * k, xi[2] * k]
    }
}

/// Rotation vector of a unit quaternion (shortest rotation), inverse of `qexp`.
pub fn qlog(q: Quat) -> V3 {
    let q = if q[0] < 0.0 { [-q[0], -q[1], -q[2], -q[3]] } else { q };
    let v = [q[1], q[2], q[3]];
    let s = norm(v);
    if s < 1e-12 {
        scale(v, 2.0)
    } else {
        scale(v, 2.0 * s.atan2(q[0]) / s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tilt_test_agrees_with_euler_angles() {
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
        };
        for limit in [0.3, 1.0, 1.4, 2.0] {
            let l = (f64::cos(limit), f64::sin(limit));
            let mut hits = 0;
            for _ in 0..20_000 {
                let q = qnormalize([next(), next(), next(), next()]);
                let e = to_euler(q);
                let want = e[0].abs() > limit || e[1].abs() > limit;
                assert_eq!(tilt_exceeds(q, l), want, "q {q:?} euler {e:?} limit {limit}");
                hits += want as usize;
            }
            assert!(
                hits > 100 && hits < 19_900,
                "limit {limit}: both outcomes exercised ({hits})"
            );
        }
    }
}
