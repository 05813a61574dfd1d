use super::BsdfSample;
use glam::Vec3;

/// Ideal specular reflection: a delta lobe in the mirror direction with reflectance R.
#[derive(Clone, Copy, Debug)]
pub struct Mirror {
    /// Reflectance per RGB channel, each in [0, 1].
    pub reflectance: Vec3,
}

impl Mirror {
    /// The mirror direction (−wo.x, −wo.y, wo.z), chosen with probability 1.
    #[inline]
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = Vec3::new(-wo.x, -wo.y, wo.z);
        Some(BsdfSample {
            f: self.reflectance / wi.z,
            wi,
            pdf: 1.0,
            delta: true,
            eta: 1.0,
        })
    }
}
