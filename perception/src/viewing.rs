//! Viewing conditions: how many pixels fall in a degree of visual angle, and the frame rate.
//!
//! # References
//! - Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images", Proc. ACM
//!   Comput. Graph. Interact. Tech. 3(2), §4: pixels per degree of a monitor of width w (m),
//!   resolution r (px) seen from distance d (m): ppd = d · (r / w) · π/180; the default
//!   0.7 m, 3840 px, 0.7 m gives 67.02 ppd.
//! - aleph's `docs/DESIGN.md` §3 for a field of view filled by the image:
//!   ppd = (W/2) / tan(FOV/2) · π/180 (pixels per degree at the image centre).

use crate::error::{PerceptionError, Result};

/// FLIP's default monitor width, m.
pub const DEFAULT_SCREEN_WIDTH_M: f64 = 0.7;
/// FLIP's default monitor resolution, pixels across.
pub const DEFAULT_SCREEN_WIDTH_PX: f64 = 3840.0;
/// FLIP's default viewing distance, m.
pub const DEFAULT_VIEWING_DISTANCE_M: f64 = 0.7;
/// Default frame rate for velocities, frames per second.
pub const DEFAULT_FPS: f64 = 24.0;

/// The most pixels per degree the viewer model takes: 1000, beyond eight times the grid the
/// eye's acuity limit needs (about 60 cycles per degree, so 120 pixels per degree at Nyquist).
/// Past it a pixel is invisible on its own, and filters sized in degrees (the adaptation
/// window, FLIP's spatial filters) grow with ppd for nothing.
pub const MAX_PPD: f64 = 1000.0;

/// The fewest pixels per degree the viewer model takes: 1e-6, a pixel a million degrees wide
/// (a 1-pixel image reaches it only within 0.001° of a 180° field of view). Below it the
/// single-precision models (FLIP's filters) lose the value to underflow.
pub const MIN_PPD: f64 = 1e-6;

/// The range of [`MIN_PPD`] and [`MAX_PPD`], in words.
const PPD_RANGE: &str = "[1e-6, 1000] pixels per degree: past 1000 a pixel is far below the \
                         eye's acuity (about 60 cycles per degree); below 1e-6 it is a million \
                         degrees wide";

fn ppd_in_range(name: &'static str, value: f64, ppd: f64) -> Result<()> {
    if (MIN_PPD..=MAX_PPD).contains(&ppd) {
        Ok(())
    } else {
        Err(PerceptionError::Parameter {
            name,
            value,
            range: PPD_RANGE,
        })
    }
}

/// How the image is seen.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewingConditions {
    /// Pixels per degree of visual angle (at the centre of the image).
    pub ppd: f64,
    /// Viewing distance, m (used by Daly's CSF; 0.7 by default).
    pub distance_m: f64,
    /// Frames per second, to turn velocities in pixels per frame into degrees per second.
    pub fps: f64,
}

impl Default for ViewingConditions {
    /// FLIP's default: a 0.7 m wide, 3840-pixel monitor seen from 0.7 m (67.02 ppd), 24 fps.
    fn default() -> Self {
        Self::from_display(
            DEFAULT_SCREEN_WIDTH_M,
            DEFAULT_VIEWING_DISTANCE_M,
            DEFAULT_SCREEN_WIDTH_PX,
        )
        .expect("defaults are valid")
    }
}

impl ViewingConditions {
    /// An image shown pixel for pixel on a display `screen_width_m` wide with
    /// `screen_width_px` pixels across, seen from `distance_m`: ppd = d (r/w) π/180 (FLIP).
    ///
    /// # Errors
    /// [`PerceptionError::Parameter`] if any argument is not a positive finite number, or the
    /// pixels per degree fall outside [[`MIN_PPD`], [`MAX_PPD`]].
    pub fn from_display(
        screen_width_m: f64,
        distance_m: f64,
        screen_width_px: f64,
    ) -> Result<Self> {
        positive("screen_width_m", screen_width_m)?;
        positive("distance_m", distance_m)?;
        positive("screen_width_px", screen_width_px)?;
        let ppd = distance_m * (screen_width_px / screen_width_m) * std::f64::consts::PI / 180.0;
        ppd_in_range("pixels per degree of the display", ppd, ppd)?;
        Ok(ViewingConditions {
            ppd,
            distance_m,
            fps: DEFAULT_FPS,
        })
    }

    /// An image `width_px` wide that fills a horizontal field of view of `hfov_deg`:
    /// ppd = (W/2)/tan(FOV/2) · π/180.
    ///
    /// # Errors
    /// [`PerceptionError::Parameter`] if the field of view is not in (0, 180) degrees or the
    /// width is not positive; [`PerceptionError::FieldOfView`] if its pixels per degree fall
    /// outside [[`MIN_PPD`], [`MAX_PPD`]].
    pub fn from_fov(hfov_deg: f64, width_px: f64) -> Result<Self> {
        if !(hfov_deg > 0.0 && hfov_deg < 180.0) {
            return Err(PerceptionError::Parameter {
                name: "field of view (degrees)",
                value: hfov_deg,
                range: "(0, 180)",
            });
        }
        positive("width_px", width_px)?;
        let half = (hfov_deg / 2.0).to_radians();
        let ppd = (width_px / 2.0) / half.tan() * std::f64::consts::PI / 180.0;
        if !(MIN_PPD..=MAX_PPD).contains(&ppd) {
            return Err(PerceptionError::FieldOfView {
                fov_deg: hfov_deg,
                width_px,
                ppd,
                range: PPD_RANGE,
            });
        }
        Ok(ViewingConditions {
            ppd,
            distance_m: DEFAULT_VIEWING_DISTANCE_M,
            fps: DEFAULT_FPS,
        })
    }

    /// The same conditions for another pixel density (a viewer nearer or farther, another
    /// display).
    ///
    /// # Errors
    /// [`PerceptionError::Parameter`] if `ppd` is not in [[`MIN_PPD`], [`MAX_PPD`]].
    pub fn with_ppd(mut self, ppd: f64) -> Result<Self> {
        ppd_in_range("pixels per degree", ppd, ppd)?;
        self.ppd = ppd;
        Ok(self)
    }

    /// The same conditions at another frame rate.
    ///
    /// # Errors
    /// [`PerceptionError::Parameter`] if `fps` is not positive and finite.
    pub fn with_fps(mut self, fps: f64) -> Result<Self> {
        positive("fps", fps)?;
        self.fps = fps;
        Ok(self)
    }

    /// Nyquist frequency of the pixel grid, cycles per degree: ppd / 2.
    pub fn nyquist_cpd(&self) -> f64 {
        self.ppd / 2.0
    }

    /// Image velocity in degrees per second for a motion of `px_per_frame` pixels per frame:
    /// v = |d| · fps / ppd.
    pub fn velocity_deg_s(&self, px_per_frame: f64) -> f64 {
        px_per_frame.abs() * self.fps / self.ppd
    }
}

fn positive(name: &'static str, v: f64) -> Result<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(PerceptionError::Parameter {
            name,
            value: v,
            range: "a positive finite number",
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_per_degree_match_published_values() {
        // FLIP paper §4: 0.7 m, 3840 px, 0.7 m → 67.02 ppd.
        assert!((ViewingConditions::default().ppd - 67.02).abs() < 0.01);
        // `docs/DESIGN.md` §3 [calc]: 45°, 1024 px → 21.57; 60°, 1920 px → 29.02.
        assert!((ViewingConditions::from_fov(45.0, 1024.0).unwrap().ppd - 21.57).abs() < 0.01);
        assert!((ViewingConditions::from_fov(60.0, 1920.0).unwrap().ppd - 29.02).abs() < 0.01);
        assert!(ViewingConditions::from_fov(0.0, 100.0).is_err());
        assert!(ViewingConditions::from_fov(180.0, 100.0).is_err());
        assert!(ViewingConditions::from_fov(f64::NAN, 100.0).is_err());
    }

    #[test]
    fn velocity_conversion() {
        let v = ViewingConditions::from_fov(45.0, 1024.0)
            .unwrap()
            .with_fps(30.0)
            .unwrap();
        // 10 px/frame at 30 fps over 21.57 ppd = 13.91 deg/s.
        assert!((v.velocity_deg_s(10.0) - 300.0 / v.ppd).abs() < 1e-12);
    }
}
