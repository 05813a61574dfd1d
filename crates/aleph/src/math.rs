//! Small geometric helpers shared by the renderer: the shading [`Frame`], reflection and
//! refraction, RGB luminance, and a cache prefetch hint.

use glam::Vec3;

/// An orthonormal frame (s, t, n). Local coordinates have the normal along +z, so a BSDF only
/// ever sees cos θ = `w.z` (pbrt-v4's `BSDF::RenderToLocal`).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// Normal (unit length).
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit normal `n` (Duff et al. 2017, "Building an Orthonormal Basis,
    /// Revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// World → local.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn from_local(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Mirror reflection of `wo` about the normal `n` (both pointing away from the surface).
#[inline]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Refraction of `wo` through a surface with normal `n` (on the side of `wo`) and relative index
/// `eta` = η_transmitted / η_incident. Returns `None` on total internal reflection.
#[inline]
pub fn refract(wo: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = wo.dot(n);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wo / eta + (cos_i / eta - cos_t) * n)
}

/// Relative luminance of linear Rec.709 RGB (ITU-R BT.709: 0.2126, 0.7152, 0.0722), the same
/// weights as [`perception::photometry::luminance`].
#[inline]
pub fn luminance(rgb: Vec3) -> f32 {
    perception::photometry::luminance(rgb.x, rgb.y, rgb.z)
}

/// |v| that does not overflow: glam's `length` squares the components, which is infinite in f32
/// beyond about 1.8e19 (a triangle's cross product at scene scales of 1e10). Bit-identical to
/// `length` whenever that is finite.
#[inline]
pub fn robust_length(v: Vec3) -> f32 {
    let l = v.length();
    if l.is_finite() {
        return l;
    }
    let m = v.abs().max_element();
    if !m.is_finite() || m == 0.0 {
        return l;
    }
    (v / m).length() * m
}

/// v / |v| (zero for a zero or non-finite vector) that does not overflow; bit-identical to
/// `normalize_or_zero` whenever that is non-zero.
#[inline]
pub fn robust_normalize(v: Vec3) -> Vec3 {
    let n = v.normalize_or_zero();
    if n != Vec3::ZERO {
        return n;
    }
    let m = v.abs().max_element();
    if !m.is_finite() || m == 0.0 {
        return Vec3::ZERO;
    }
    (v / m).normalize_or_zero()
}

/// Asks the CPU to start loading the cache line holding `x` into every cache level (x86-64's
/// `prefetcht0`; nothing elsewhere). Only a hint: nothing observable changes, only when a later
/// read of `x` finds it.
#[inline]
pub(crate) fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is only a hint, and its address is a live reference's.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (x as *const T).cast(),
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::Rng;
    use crate::sampling::square_to_uniform_sphere;

    #[test]
    fn frame_is_orthonormal_and_round_trips() {
        let mut rng = Rng::new(9, 9);
        for _ in 0..1000 {
            let n = square_to_uniform_sphere(rng.uniform2());
            let f = Frame::from_normal(n);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.length() - 1.0).abs() < 1e-5 && (f.t.length() - 1.0).abs() < 1e-5);
            let v = square_to_uniform_sphere(rng.uniform2());
            assert!((f.from_local(f.to_local(v)) - v).length() < 1e-5);
            assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        }
    }

    #[test]
    fn refraction_obeys_snell() {
        let n = Vec3::Z;
        let wo = Vec3::new(0.6, 0.0, 0.8);
        let wt = refract(wo, n, 1.5).unwrap();
        let sin_i = 0.6;
        let sin_t = (wt.x * wt.x + wt.y * wt.y).sqrt() / wt.length();
        assert!((sin_i - 1.5 * sin_t).abs() < 1e-5);
        assert!(wt.z < 0.0);
        // Total internal reflection leaving glass at a grazing angle.
        assert!(refract(Vec3::new(0.9, 0.0, 0.4359).normalize(), n, 1.0 / 1.5).is_none());
    }
}
