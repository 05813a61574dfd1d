//! The scene file's schema: the TOML description as parsed (every table and key of
//! docs/scene-format.md, unknown keys refused), reading it, and the limits every scene is
//! held to (largest luminance and coordinate, memory per pixel).

use super::RenderSettings;
use crate::error::{SceneError, SceneResult};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Fixed-length arrays that refuse extra or missing elements: serde's own array impl reads the
/// first N elements and the TOML deserializer then drops the rest silently
/// (`resolution = [32, 32, 99]` was accepted).
mod exact {
    use serde::de::{Deserialize, Deserializer, Error};

    fn fixed<'de, D: Deserializer<'de>, T, const N: usize>(v: Vec<T>) -> Result<[T; N], D::Error> {
        let n = v.len();
        v.try_into()
            .map_err(|_| D::Error::invalid_length(n, &format!("exactly {N} numbers").as_str()))
    }

    pub fn array<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        fixed::<D, T, N>(Vec::deserialize(d)?)
    }

    pub fn option<'de, D, T, const N: usize>(d: D) -> Result<Option<[T; N]>, D::Error>
    where
        D: Deserializer<'de>,
        T: Deserialize<'de>,
    {
        Option::<Vec<T>>::deserialize(d)?
            .map(fixed::<D, T, N>)
            .transpose()
    }

    pub fn matrix4<'de, D>(d: D) -> Result<Option<[[f32; 4]; 4]>, D::Error>
    where
        D: Deserializer<'de>,
    {
        let Some(rows) = Option::<Vec<Vec<f32>>>::deserialize(d)? else {
            return Ok(None);
        };
        let rows: Vec<[f32; 4]> = rows
            .into_iter()
            .map(fixed::<D, f32, 4>)
            .collect::<Result<_, _>>()?;
        fixed::<D, [f32; 4], 4>(rows).map(Some)
    }
}

/// The parsed scene file, before any mesh is loaded. Command-line overrides are applied to it
/// before [`SceneDescription::build`].
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    /// `[camera]`.
    pub camera: CameraDesc,
    /// `[render]`.
    #[serde(default)]
    pub render: RenderDesc,
    /// `[[mesh]]` entries.
    #[serde(default, rename = "mesh")]
    pub meshes: Vec<MeshDesc>,
    /// `[materials.NAME]` overrides, by MTL material name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialOverride>,
    /// `[[light]]` entries.
    #[serde(default, rename = "light")]
    pub lights: Vec<LightDesc>,
    /// `[animation]`: makes the scene a sequence.
    #[serde(default)]
    pub animation: Option<AnimationDesc>,
    /// The scene file (set by [`SceneDescription::read`]).
    #[serde(skip)]
    pub path: PathBuf,
}

/// `[camera]`: a pinhole camera.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye position.
    #[serde(deserialize_with = "exact::array")]
    pub position: [f32; 3],
    /// Point looked at.
    #[serde(deserialize_with = "exact::array")]
    pub look_at: [f32; 3],
    /// Up vector (default +y).
    #[serde(default = "default_up")]
    #[serde(deserialize_with = "exact::array")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, in (0, 180).
    pub vfov_deg: f32,
    /// Width and height in pixels, each in 1..=65536.
    #[serde(deserialize_with = "exact::array")]
    pub resolution: [u32; 2],
    /// Thin-lens aperture radius, world units (default 0: a pinhole).
    pub aperture_radius: Option<f32>,
    /// Distance to the plane in focus along the view direction, world units (default: the
    /// distance from `position` to `look_at`).
    pub focus_distance: Option<f32>,
    /// `[[camera.keys]]`: keyframes; a missing value holds the previous key's (the first key's
    /// default to the table's own).
    #[serde(default)]
    pub keys: Vec<CameraKeyDesc>,
}

/// `[[camera.keys]]`: the camera at one time.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraKeyDesc {
    /// Time, seconds.
    pub time: f64,
    /// Eye position.
    #[serde(default, deserialize_with = "exact::option")]
    pub position: Option<[f32; 3]>,
    /// Point looked at.
    #[serde(default, deserialize_with = "exact::option")]
    pub look_at: Option<[f32; 3]>,
    /// Up vector.
    #[serde(default, deserialize_with = "exact::option")]
    pub up: Option<[f32; 3]>,
    /// Vertical field of view, degrees.
    pub vfov_deg: Option<f32>,
}

/// `[animation]`: the sequence's timing.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AnimationDesc {
    /// Frames per second, > 0.
    pub fps: f64,
    /// First and last frame, inclusive.
    #[serde(deserialize_with = "exact::array")]
    pub frames: [i64; 2],
    /// Shutter interval as a fraction of the frame, in [0, 1] (default 0.5, a 180° shutter;
    /// 0: no motion blur).
    pub shutter: Option<f64>,
}

/// `[[mesh.keys]]`: the mesh's motion at one time, applied after its `transform`: scale, then
/// rotation, then translation. A missing value holds the previous key's (identity for the
/// first key).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformKeyDesc {
    /// Time, seconds.
    pub time: f64,
    /// Translation.
    #[serde(default, deserialize_with = "exact::option")]
    pub translate: Option<[f32; 3]>,
    /// Rotations about x, then y, then z, degrees.
    #[serde(default, deserialize_with = "exact::option")]
    pub rotate_deg: Option<[f32; 3]>,
    /// Uniform or per-axis scale.
    pub scale: Option<ScaleDesc>,
}

fn default_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

/// `[render]`: sampling settings; every key is optional.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RenderDesc {
    /// Samples per pixel.
    pub spp: Option<u32>,
    /// Maximum path depth.
    pub max_depth: Option<u32>,
    /// Random seed.
    pub seed: Option<u64>,
    /// cd/m² per unit radiance.
    pub luminance_scale: Option<f32>,
    /// "bvh" (default) or "power".
    pub light_sampler: Option<crate::light::LightSampler>,
    /// "sobol" (default) or "independent".
    pub sample_generator: Option<super::SampleGenerator>,
}

/// `[[mesh]]`: an OBJ file and an optional transform.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    /// OBJ path, relative to the scene file.
    pub file: PathBuf,
    /// Object-to-world transform.
    #[serde(default)]
    pub transform: Option<TransformDesc>,
    /// Keyframed rigid motion after `transform` (needs `[animation]`).
    #[serde(default)]
    pub keys: Vec<TransformKeyDesc>,
    /// Only these OBJ objects/groups (by `o`/`g` name); default: all.
    #[serde(default)]
    pub objects: Option<Vec<String>>,
    /// Leave out these OBJ objects/groups.
    #[serde(default)]
    pub exclude_objects: Vec<String>,
}

/// A transform: scale, then rotations about x, y, z (degrees), then translation; or a full
/// row-major 4×4 `matrix` instead.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    /// Uniform (number) or per-axis (array) scale.
    pub scale: Option<ScaleDesc>,
    /// Rotations about x, then y, then z, in degrees.
    #[serde(default, deserialize_with = "exact::option")]
    pub rotate_deg: Option<[f32; 3]>,
    /// Translation.
    #[serde(default, deserialize_with = "exact::option")]
    pub translate: Option<[f32; 3]>,
    /// Row-major 4×4 matrix (exclusive with the other keys).
    #[serde(default, deserialize_with = "exact::matrix4")]
    pub matrix: Option<[[f32; 4]; 4]>,
}

/// A scale factor.
#[derive(Clone, Debug, Deserialize)]
#[serde(untagged)]
pub enum ScaleDesc {
    /// Same factor on every axis.
    Uniform(f32),
    /// Per-axis factors.
    PerAxis(#[serde(deserialize_with = "exact::array")] [f32; 3]),
}

/// Material class names in overrides.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "lowercase")]
pub enum MaterialType {
    /// Lambertian.
    Diffuse,
    /// Ideal specular.
    Mirror,
    /// Lambert + GGX.
    Glossy,
    /// Smooth dielectric.
    Dielectric,
}

/// `[materials.NAME]`: replaces parts of an MTL material.
#[derive(Clone, Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialOverride {
    /// New class.
    #[serde(rename = "type")]
    pub kind: Option<MaterialType>,
    /// Diffuse reflectance (diffuse, glossy) or mirror reflectance (mirror), [0,1] each.
    #[serde(default, deserialize_with = "exact::option")]
    pub reflectance: Option<[f32; 3]>,
    /// Specular reflectance of the glossy lobe, [0,1] each.
    #[serde(default, deserialize_with = "exact::option")]
    pub specular: Option<[f32; 3]>,
    /// GGX α of the glossy lobe, in (0, 1].
    pub alpha: Option<f32>,
    /// Index of refraction of a dielectric, > 0.
    pub ior: Option<f32>,
    /// Transmission filter of a dielectric, [0,1] each.
    #[serde(default, deserialize_with = "exact::option")]
    pub transmittance: Option<[f32; 3]>,
    /// Emitted radiance, W·sr⁻¹·m⁻², ≥ 0 each (all zero removes emission).
    #[serde(default, deserialize_with = "exact::option")]
    pub emission: Option<[f32; 3]>,
}

/// `[[light]]`: an explicit emitter.
#[derive(Clone, Debug, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum LightDesc {
    /// A one-sided parallelogram `corner + s·edge1 + t·edge2`, s, t ∈ [0,1], emitting towards
    /// edge1 × edge2.
    Quad {
        /// One corner.
        #[serde(deserialize_with = "exact::array")]
        corner: [f32; 3],
        /// First edge.
        #[serde(deserialize_with = "exact::array")]
        edge1: [f32; 3],
        /// Second edge.
        #[serde(deserialize_with = "exact::array")]
        edge2: [f32; 3],
        /// Emitted radiance, W·sr⁻¹·m⁻².
        #[serde(deserialize_with = "exact::array")]
        radiance: [f32; 3],
    },
    /// Light from every direction at infinity: a constant `radiance`, or an equirectangular HDR
    /// `file` (`.hdr` or `.exr`, relative to the scene file) times `strength`, turned by
    /// `rotate_deg` about +y (mapping as Mitsuba 3's `envmap`: see
    /// [`crate::light::Environment`]). At most one per scene.
    Environment {
        /// Equirectangular image (exclusive with `radiance`).
        file: Option<PathBuf>,
        /// Constant radiance, W·sr⁻¹·m⁻² (exclusive with `file`).
        #[serde(default, deserialize_with = "exact::option")]
        radiance: Option<[f32; 3]>,
        /// Multiplier of the image's values (default 1).
        strength: Option<f32>,
        /// Rotation about +y, degrees (default 0).
        rotate_deg: Option<f32>,
    },
    /// A distant disc light (the sun): `direction` points towards it; `irradiance` (W·m⁻²) is
    /// what it gives a surface facing it; `angular_diameter_deg` defaults to the real sun's
    /// 0.53°.
    Sun {
        /// Direction towards the sun (any non-zero length).
        #[serde(deserialize_with = "exact::array")]
        direction: [f32; 3],
        /// Irradiance on a surface facing the sun, W·m⁻², ≥ 0 each.
        #[serde(deserialize_with = "exact::array")]
        irradiance: [f32; 3],
        /// Angular diameter, degrees, in (0, 180).
        angular_diameter_deg: Option<f32>,
    },
    /// A point light of radiant `intensity` (W·sr⁻¹) at `position`.
    Point {
        /// Position.
        #[serde(deserialize_with = "exact::array")]
        position: [f32; 3],
        /// Radiant intensity, W·sr⁻¹, ≥ 0 each.
        #[serde(deserialize_with = "exact::array")]
        intensity: [f32; 3],
    },
    /// A spot light at `position` aimed at `look_at`: full `intensity` (W·sr⁻¹) within
    /// `cone_angle_deg − cone_delta_deg` of its axis, falling smoothly to zero at
    /// `cone_angle_deg` (defaults 30° and 5°, as pbrt's spot light).
    Spot {
        /// Position.
        #[serde(deserialize_with = "exact::array")]
        position: [f32; 3],
        /// Point on the axis.
        #[serde(deserialize_with = "exact::array")]
        look_at: [f32; 3],
        /// Radiant intensity on the axis, W·sr⁻¹, ≥ 0 each.
        #[serde(deserialize_with = "exact::array")]
        intensity: [f32; 3],
        /// Half-angle of the cone, degrees, in (0, 180).
        cone_angle_deg: Option<f32>,
        /// Width of the falloff at the cone's edge, degrees, in [0, cone_angle_deg].
        cone_delta_deg: Option<f32>,
    },
}

impl SceneDescription {
    /// Reads and parses a scene file (no meshes are loaded yet).
    ///
    /// # Errors
    /// [`SceneError::Io`] if unreadable, [`SceneError::Toml`] if malformed or with an unknown
    /// key (the message gives line and column).
    pub fn read(path: &Path) -> SceneResult<SceneDescription> {
        let text = std::fs::read_to_string(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses scene TOML `text`; `path` is used for messages and relative file names.
    pub fn parse(text: &str, path: &Path) -> SceneResult<SceneDescription> {
        let mut desc: SceneDescription = toml::from_str(text).map_err(|e| SceneError::Toml {
            path: path.to_path_buf(),
            message: e.to_string().trim_end().to_string(),
        })?;
        desc.path = path.to_path_buf();
        Ok(desc)
    }

    /// The settings, with defaults filled in.
    pub fn settings(&self) -> RenderSettings {
        let d = RenderSettings::default();
        RenderSettings {
            spp: self.render.spp.unwrap_or(d.spp),
            max_depth: self.render.max_depth.unwrap_or(d.max_depth),
            seed: self.render.seed.unwrap_or(d.seed),
            luminance_scale: self.render.luminance_scale.unwrap_or(d.luminance_scale),
            light_sampler: self.render.light_sampler.unwrap_or(d.light_sampler),
            sample_generator: self.render.sample_generator.unwrap_or(d.sample_generator),
        }
    }

    pub(super) fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.clone(),
            message: message.into(),
        }
    }
}

/// Peak memory of a render per pixel, bytes (film, half-buffers, the perception model's images
/// and FFT canvases). Measured as the slope of peak RSS between 1024² and 2048² renders: 183 B
/// for the perceptual sampler, 114 B for uniform, before the film's sums became exact pairs
/// (+56 B per pixel: 239 and 170 B); rounded up. Scene data (BVH, textures) comes on top.
pub const RENDER_BYTES_PER_PIXEL: u64 = 250;

/// Memory the system can give now, bytes (`MemAvailable` of /proc/meminfo); `None` where it
/// cannot be read.
fn available_memory() -> Option<u64> {
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = info.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses an image size outside 1..=65536 on either axis or whose render would not fit in
/// the available memory ([`check_memory`]); the message starts with the size, for the caller
/// to prefix with where it came from (`camera.resolution`, `--resolution`).
///
/// # Errors
/// The message.
pub fn check_resolution(w: u32, h: u32) -> Result<(), String> {
    if w == 0 || h == 0 || w > 65536 || h > 65536 {
        return Err(format!("{w}×{h} is outside 1..=65536 on an axis"));
    }
    check_memory(w, h)
}

/// Refuses a resolution whose render would not fit in the available memory, with both figures.
///
/// # Errors
/// The message naming the resolution, the bytes its render needs and the bytes available.
pub fn check_memory(w: u32, h: u32) -> Result<(), String> {
    let need = w as u64 * h as u64 * RENDER_BYTES_PER_PIXEL;
    match available_memory() {
        Some(avail) if need > avail => Err(format!(
            "{w}×{h} needs about {:.1} GiB to render ({RENDER_BYTES_PER_PIXEL} \
             bytes per pixel), more than the {:.1} GiB of memory available",
            need as f64 / (1u64 << 30) as f64,
            avail as f64 / (1u64 << 30) as f64
        )),
        _ => Ok(()),
    }
}

/// Largest luminance (emitted radiance × `luminance_scale`) accepted, cd/m²: the sun's disc is
/// 1.6e9; this leaves room for sums and squares of samples in f32 and f64 buffers.
pub const MAX_LUMINANCE_CD_M2: f64 = 1e20;

/// Largest coordinate magnitude accepted anywhere in a scene, world units. Beyond it f32
/// arithmetic in the BVH build overflows (obvhs panicked at ±3e38 and on 1e30-sized lights);
/// 1e15 leaves every physically sensible unit, from nanometres to light years, room.
pub const MAX_COORDINATE: f32 = 1e15;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_keys_are_errors() {
        let text =
            "[camera]\nposition=[0,0,0]\nlook_at=[0,0,-1]\nvfov_deg=40\nresolution=[4,4]\nfoo=1\n";
        let e = SceneDescription::parse(text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("x.toml") && e.contains("foo"), "{e}");
        let text = "[camera]\nposition=[0,0,0]\nlook_at=[0,0,-1]\nvfov_deg=40\nresolution=[4,4]\n\
                    [[light]]\ntype=\"quad\"\ncorner=[0,0,0]\nedge1=[1,0,0]\nedge2=[0,1,0]\nradiance=[1,1,1]\nbogus=2\n";
        let e = SceneDescription::parse(text, Path::new("x.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("bogus"), "{e}");
    }
}
