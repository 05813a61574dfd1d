//! Time: frames, the shutter, and keyframed camera and rigid-object motion.
//!
//! Times are in seconds. Frame `n` of a sequence at `fps` frames per second has its instant at
//! t_n = n / fps, and its shutter is open over [t_n − s/(2 fps), t_n + s/(2 fps)], centred on the
//! instant (Blender's default "center" motion-blur position), where s is the shutter interval as
//! a fraction of the frame (0.5, a 180° shutter, by default; 0 turns motion blur off).
//!
//! Keyframed quantities interpolate **piecewise linearly** between keys (translation, scale,
//! camera position, look-at point, up vector and field of view) and by **quaternion slerp**
//! along the shorter arc (rotation). Linear interpolation is exact for constant velocity, the
//! case the velocity map and the spatiovelocity CSF are about; before the first key and after
//! the last the value is held.

use crate::rng::mix64;
use glam::{Affine3A, Quat, Vec3};

/// The default shutter interval as a fraction of the frame: a 180° shutter.
pub const DEFAULT_SHUTTER: f64 = 0.5;

/// Stream key mixed with the frame index into a frame's seed.
const FRAME_SEED_KEY: u64 = 0x3C6E_F372_FE94_F82B;

/// The `[animation]` settings of a scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimationSettings {
    /// Frames per second (> 0).
    pub fps: f64,
    /// First frame of the sequence (inclusive).
    pub frame_start: i64,
    /// Last frame of the sequence (inclusive, ≥ `frame_start`).
    pub frame_end: i64,
    /// Shutter interval as a fraction of the frame, in [0, 1] (0: no motion blur).
    pub shutter: f64,
}

impl AnimationSettings {
    /// The timing of frame `index`.
    pub fn frame(&self, index: i64) -> FrameTime {
        let t = index as f64 / self.fps;
        let half = 0.5 * self.shutter / self.fps;
        FrameTime {
            index,
            time_s: t,
            open_s: t - half,
            close_s: t + half,
        }
    }

    /// Number of frames in the sequence.
    pub fn frame_count(&self) -> u64 {
        (self.frame_end - self.frame_start + 1).max(0) as u64
    }

    /// True when `index` lies in the sequence's frame range.
    pub fn contains(&self, index: i64) -> bool {
        (self.frame_start..=self.frame_end).contains(&index)
    }
}

/// The timing of one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameTime {
    /// Frame number (0 for a still).
    pub index: i64,
    /// The frame's instant, seconds: where the velocity map and the frame's camera are taken.
    pub time_s: f64,
    /// Shutter opening, seconds.
    pub open_s: f64,
    /// Shutter closing, seconds (equal to `open_s` without motion blur).
    pub close_s: f64,
}

impl FrameTime {
    /// A still: frame 0 at t = 0 with a closed shutter.
    pub const STILL: FrameTime = FrameTime {
        index: 0,
        time_s: 0.0,
        open_s: 0.0,
        close_s: 0.0,
    };

    /// True when the shutter is open for a non-zero time.
    pub fn has_motion_blur(&self) -> bool {
        self.close_s > self.open_s
    }

    /// The time of a camera sample with canonical random number `u` ∈ [0, 1): uniform over the
    /// shutter (a box shutter), or the frame's instant without motion blur.
    #[inline]
    pub fn sample_time(&self, u: f32) -> f32 {
        if self.has_motion_blur() {
            (self.open_s + (self.close_s - self.open_s) * u as f64) as f32
        } else {
            self.time_s as f32
        }
    }

    /// The seed of this frame's random streams under the render seed `seed`: frames are
    /// decorrelated, and each is reproducible alone.
    pub fn seed(&self, seed: u64) -> u64 {
        mix64(seed ^ mix64((self.index as u64) ^ FRAME_SEED_KEY))
    }
}

/// True for a non-empty sequence of strictly increasing key times.
fn strictly_increasing(times: impl Iterator<Item = f32>) -> bool {
    let mut prev: Option<f32> = None;
    for t in times {
        if prev.is_some_and(|p| t <= p) {
            return false;
        }
        prev = Some(t);
    }
    prev.is_some()
}

/// Locates `t` among increasing key times: the segment index `i` (keys i and i+1) and the
/// fraction in [0, 1] along it, or the held end key (`i`, 0) outside the range.
fn locate(times: impl ExactSizeIterator<Item = f32> + Clone, t: f32) -> (usize, f32) {
    let n = times.len();
    let first = times.clone().next().unwrap_or(0.0);
    if n < 2 || t <= first {
        return (0, 0.0);
    }
    let mut prev = first;
    for (i, ti) in times.enumerate().skip(1) {
        if t < ti {
            return (i - 1, ((t - prev) / (ti - prev)).clamp(0.0, 1.0));
        }
        prev = ti;
    }
    (n - 1, 0.0)
}

/// One key of a rigid transform: scale, then rotation, then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransformKey {
    /// Time, seconds.
    pub time_s: f32,
    /// Translation.
    pub translate: Vec3,
    /// Rotation (unit quaternion).
    pub rotate: Quat,
    /// Per-axis scale (non-zero).
    pub scale: Vec3,
}

/// A keyframed rigid transform (with scale): at least one key, times strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct TransformTrack {
    keys: Vec<TransformKey>,
}

impl TransformTrack {
    /// A track from keys sorted by strictly increasing time. `None` if `keys` is empty or
    /// unsorted (the scene loader reports which key).
    pub fn new(keys: Vec<TransformKey>) -> Option<TransformTrack> {
        strictly_increasing(keys.iter().map(|k| k.time_s)).then_some(TransformTrack { keys })
    }

    /// The keys.
    pub fn keys(&self) -> &[TransformKey] {
        &self.keys
    }

    /// The transform at time `t` (seconds): translation and scale linear, rotation slerp.
    #[inline]
    pub fn at(&self, t: f32) -> Affine3A {
        let (i, f) = locate(self.keys.iter().map(|k| k.time_s), t);
        let a = &self.keys[i];
        if f == 0.0 {
            return Affine3A::from_scale_rotation_translation(a.scale, a.rotate, a.translate);
        }
        let b = &self.keys[i + 1];
        Affine3A::from_scale_rotation_translation(
            a.scale.lerp(b.scale, f),
            slerp_short(a.rotate, b.rotate, f),
            a.translate.lerp(b.translate, f),
        )
    }
}

/// Slerp along the shorter of the two arcs between `a` and `b`.
#[inline]
pub fn slerp_short(a: Quat, b: Quat, f: f32) -> Quat {
    let b = if a.dot(b) < 0.0 { -b } else { b };
    a.slerp(b, f).normalize()
}

/// One key of the camera.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraKey {
    /// Time, seconds.
    pub time_s: f32,
    /// Eye position.
    pub position: Vec3,
    /// Point looked at.
    pub look_at: Vec3,
    /// Up vector.
    pub up: Vec3,
    /// Vertical field of view, degrees.
    pub vfov_deg: f32,
}

/// A keyframed camera: at least one key, times strictly increasing.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraTrack {
    keys: Vec<CameraKey>,
}

impl CameraTrack {
    /// A track from keys sorted by strictly increasing time; `None` if empty or unsorted.
    pub fn new(keys: Vec<CameraKey>) -> Option<CameraTrack> {
        strictly_increasing(keys.iter().map(|k| k.time_s)).then_some(CameraTrack { keys })
    }

    /// The keys.
    pub fn keys(&self) -> &[CameraKey] {
        &self.keys
    }

    /// The camera's pose at time `t` (seconds), every quantity linear between keys.
    #[inline]
    pub fn at(&self, t: f32) -> CameraKey {
        let (i, f) = locate(self.keys.iter().map(|k| k.time_s), t);
        let a = self.keys[i];
        if f == 0.0 {
            return CameraKey { time_s: t, ..a };
        }
        let b = &self.keys[i + 1];
        CameraKey {
            time_s: t,
            position: a.position.lerp(b.position, f),
            look_at: a.look_at.lerp(b.look_at, f),
            up: a.up.lerp(b.up, f),
            vfov_deg: a.vfov_deg + (b.vfov_deg - a.vfov_deg) * f,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(t: f32, x: f32, deg: f32) -> TransformKey {
        TransformKey {
            time_s: t,
            translate: Vec3::new(x, 0.0, 0.0),
            rotate: Quat::from_rotation_y(deg.to_radians()),
            scale: Vec3::ONE,
        }
    }

    #[test]
    fn transform_track_is_exact_at_keys_and_slerps_between() {
        let tr = TransformTrack::new(vec![key(0.0, 0.0, 0.0), key(1.0, 2.0, 90.0)]).unwrap();
        // Exact at keys, held outside.
        let p = Vec3::new(1.0, 0.0, 0.0);
        assert!((tr.at(0.0).transform_point3(p) - p).length() < 1e-6);
        let at1 = tr.at(1.0).transform_point3(p);
        assert!((at1 - Vec3::new(2.0, 0.0, -1.0)).length() < 1e-6, "{at1}");
        assert_eq!(tr.at(5.0), tr.at(1.0));
        assert_eq!(tr.at(-5.0), tr.at(0.0));
        // Midpoint: half the translation, half the angle (45°) — the slerp midpoint, which
        // keeps the point on the unit circle (a linear blend of matrices would shrink it).
        let mid = tr.at(0.5).transform_point3(p) - Vec3::new(1.0, 0.0, 0.0);
        let h = std::f32::consts::FRAC_1_SQRT_2;
        assert!((mid - Vec3::new(h, 0.0, -h)).length() < 1e-6, "{mid}");
        // Quarter: 22.5°.
        let q = tr.at(0.25).transform_point3(p) - Vec3::new(0.5, 0.0, 0.0);
        let a = 22.5f32.to_radians();
        assert!(
            (q - Vec3::new(a.cos(), 0.0, -a.sin())).length() < 1e-6,
            "{q}"
        );
    }

    #[test]
    fn slerp_takes_the_short_arc() {
        let a = Quat::from_rotation_y(0.0);
        let b = -Quat::from_rotation_y(90f32.to_radians()); // same rotation, other hemisphere
        let m = slerp_short(a, b, 0.5);
        let want = Quat::from_rotation_y(45f32.to_radians());
        assert!(m.dot(want).abs() > 1.0 - 1e-6);
    }

    #[test]
    fn unsorted_or_duplicate_keys_are_rejected() {
        assert!(TransformTrack::new(vec![key(1.0, 0.0, 0.0), key(0.5, 0.0, 0.0)]).is_none());
        assert!(TransformTrack::new(vec![key(1.0, 0.0, 0.0), key(1.0, 0.0, 0.0)]).is_none());
        assert!(TransformTrack::new(vec![]).is_none());
    }

    #[test]
    fn frames_and_shutter() {
        let a = AnimationSettings {
            fps: 24.0,
            frame_start: 1,
            frame_end: 48,
            shutter: 0.5,
        };
        let f = a.frame(12);
        assert!((f.time_s - 0.5).abs() < 1e-12);
        assert!((f.close_s - f.open_s - 0.5 / 24.0).abs() < 1e-12);
        assert!(((f.open_s + f.close_s) / 2.0 - f.time_s).abs() < 1e-12);
        assert_eq!(f.sample_time(0.0), f.open_s as f32);
        assert_eq!(a.frame_count(), 48);
        let still = AnimationSettings { shutter: 0.0, ..a }.frame(12);
        assert!(!still.has_motion_blur());
        assert_eq!(still.sample_time(0.7), 0.5);
        assert_ne!(a.frame(1).seed(0), a.frame(2).seed(0));
        assert_eq!(a.frame(1).seed(0), a.frame(1).seed(0));
    }

    #[test]
    fn camera_track_interpolates_linearly() {
        let k = |t: f32, x: f32, fov: f32| CameraKey {
            time_s: t,
            position: Vec3::new(x, 0.0, 0.0),
            look_at: Vec3::new(x, 0.0, -1.0),
            up: Vec3::Y,
            vfov_deg: fov,
        };
        let c = CameraTrack::new(vec![k(0.0, 0.0, 30.0), k(2.0, 4.0, 50.0)]).unwrap();
        let m = c.at(0.5);
        assert!((m.position.x - 1.0).abs() < 1e-6 && (m.vfov_deg - 35.0).abs() < 1e-5);
    }
}
