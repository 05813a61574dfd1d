//! Reading the TOML scene description and its OBJ/MTL files.

use super::{RenderSettings, Scene, World};
use crate::animation::{
    AnimationSettings, CameraKey, CameraTrack, DEFAULT_SHUTTER, FrameTime, TransformKey,
    TransformTrack,
};
use crate::camera::Camera;
use crate::error::{SceneError, SceneResult};
use crate::geometry::{
    AlphaMask, Cutouts, Geometry, STATIC_INSTANCE, TriangleAttributes, Triangles,
};
use crate::light::Lights;
use crate::material::{ColorSource, Material, MaterialKind};
use crate::texture::{BumpKind, BumpMap, Texture, looks_like_normal_map};
use glam::{Mat3, Mat4, Quat, Vec2, Vec3};
use serde::Deserialize;
use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

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

    /// Loads the meshes, materials and textures and builds the BVH and light list.
    ///
    /// # Errors
    /// See [`Scene::load`].
    pub fn build(self) -> SceneResult<Scene> {
        let settings = self.settings();
        let camera = self.camera()?;
        if settings.spp == 0 {
            return Err(self.invalid("render.spp must be at least 1"));
        }
        if settings.max_depth == 0 {
            return Err(self.invalid("render.max_depth must be at least 1"));
        }
        if !(settings.luminance_scale.is_finite() && settings.luminance_scale > 0.0) {
            return Err(self.invalid(format!(
                "render.luminance_scale must be a positive number, got {}",
                settings.luminance_scale
            )));
        }
        let animation = self.animation()?;
        let camera_track = self.camera_track(animation.as_ref())?;
        let mut b = Builder {
            overridden: self.materials.keys().cloned().collect(),
            ..Default::default()
        };
        let tracks = self.add_meshes(&mut b, animation.as_ref())?;
        self.apply_material_overrides(&mut b)?;
        self.add_light_quads(&mut b)?;
        if b.tris.is_empty() {
            return Err(self.invalid("the scene has no geometry: add a [[mesh]] or a [[light]]"));
        }
        self.check_emission(&b, &settings)?;
        let other = super::lights::other_lights(&self, settings.luminance_scale)?;
        let radius = bounding_radius(&b.tris);
        let lights = Lights::build(
            &mut b.tris,
            &b.materials,
            &b.textures,
            other,
            radius,
            settings.light_sampler,
        )
        .ok_or_else(|| SceneError::NoLights {
            path: self.path.clone(),
        })?;
        let time_range = match animation {
            Some(a) => (
                a.frame(a.frame_start).open_s as f32,
                a.frame(a.frame_end).close_s as f32,
            ),
            None => (0.0, 0.0),
        };
        self.check_motion_extent(&b.tris, &tracks)?;
        let mut geometry = build_geometry(b.tris, tracks, time_range)
            .map_err(|msg| self.invalid(format!("building the BVH failed: {msg}")))?;
        geometry.set_cutouts(Some(Cutouts {
            by_material: b
                .materials
                .iter()
                .map(|m| m.cutout.unwrap_or(u32::MAX))
                .collect(),
            masks: b.masks,
        }));
        let scene = Scene {
            camera,
            settings,
            world: Arc::new(World {
                geometry,
                materials: b.materials,
                textures: b.textures,
                lights,
            }),
            path: self.path,
            animation,
            camera_track,
            frame: FrameTime::STILL,
        };
        match animation {
            Some(a) => scene.at_frame(a.frame_start),
            None => Ok(scene),
        }
    }

    /// Loads every `[[mesh]]` into `b`; returns the tracks of the moving ones (instance i has
    /// track i).
    fn add_meshes(
        &self,
        b: &mut Builder,
        animation: Option<&AnimationSettings>,
    ) -> SceneResult<Vec<TransformTrack>> {
        let base = self.path.parent().unwrap_or(Path::new("")).to_path_buf();
        let mut tracks = Vec::new();
        for (i, mesh) in self.meshes.iter().enumerate() {
            let xf = self.transform(i, mesh.transform.as_ref())?;
            let track = self.mesh_track(i, mesh, animation)?;
            let instance = match track {
                Some(_) => tracks.len() as u32,
                None => STATIC_INSTANCE,
            };
            let before = b.tris.len();
            let select = ObjectFilter {
                only: mesh.objects.as_deref(),
                exclude: &mesh.exclude_objects,
            };
            let obj = base.join(&mesh.file);
            if !obj.is_file() {
                return Err(self.invalid(format!(
                    "[[mesh]] #{}: cannot read {}: {}",
                    i + 1,
                    obj.display(),
                    if obj.exists() {
                        "not a file"
                    } else {
                        "file not found"
                    }
                )));
            }
            b.load_obj(&obj, xf, instance, &select)?;
            if let Some(track) = track
                && b.tris.len() > before
            {
                tracks.push(track);
            }
        }
        Ok(tracks)
    }

    /// Applies `[materials.NAME]` overrides.
    fn apply_material_overrides(&self, b: &mut Builder) -> SceneResult<()> {
        for (name, ov) in &self.materials {
            let Some(&idx) = b.material_index.get(name) else {
                let mut known: Vec<&String> = b.material_index.keys().collect();
                known.sort();
                return Err(self.invalid(format!(
                    "[materials.{name}]: no MTL material is named {name:?} (known: {known:?})"
                )));
            };
            let m = &mut b.materials[idx as usize];
            apply_override(m, ov)
                .map_err(|msg| self.invalid(format!("[materials.{name}]: {msg}")))?;
        }
        Ok(())
    }

    /// Adds every `[[light]]` quad as two emissive triangles with a material of its own.
    fn add_light_quads(&self, b: &mut Builder) -> SceneResult<()> {
        for (i, l) in self.lights.iter().enumerate() {
            match l {
                LightDesc::Quad {
                    corner,
                    edge1,
                    edge2,
                    radiance,
                } => {
                    let vals = corner.iter().chain(edge1).chain(edge2).chain(radiance);
                    if vals.clone().any(|v| !v.is_finite()) {
                        return Err(
                            self.invalid(format!("[[light]] #{}: values must be finite", i + 1))
                        );
                    }
                    if radiance.iter().any(|&v| v < 0.0) {
                        return Err(
                            self.invalid(format!("[[light]] #{}: radiance must be ≥ 0", i + 1))
                        );
                    }
                    let (c, e1, e2) = (Vec3::from(*corner), Vec3::from(*edge1), Vec3::from(*edge2));
                    let far = [c, c + e1, c + e2, c + e1 + e2]
                        .iter()
                        .any(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE);
                    if far {
                        return Err(self.invalid(format!(
                            "[[light]] #{}: corners beyond ±{MAX_COORDINATE:e}, where f32 \
                                 arithmetic overflows",
                            i + 1
                        )));
                    }
                    if e1.cross(e2).length() <= 0.0 {
                        return Err(self.invalid(format!(
                            "[[light]] #{}: edge1 and edge2 must span a non-zero area",
                            i + 1
                        )));
                    }
                    let mat = b.materials.len() as u32;
                    b.materials.push(Material {
                        name: format!("light#{}", i + 1),
                        kind: MaterialKind::Diffuse,
                        kd: ColorSource::Constant(Vec3::ZERO),
                        ks: ColorSource::Constant(Vec3::ZERO),
                        transmittance: Vec3::ONE,
                        emission: Some(ColorSource::Constant(Vec3::from(*radiance))),
                        cutout: None,
                        bump: None,
                    });
                    for p in [[c, c + e1, c + e1 + e2], [c, c + e1 + e2, c + e2]] {
                        b.tris.push(TriangleAttributes {
                            p,
                            n: None,
                            uv: [Vec2::ZERO; 3],
                            material: mat,
                            light: u32::MAX,
                            instance: STATIC_INSTANCE,
                        });
                    }
                }
                LightDesc::Environment { .. }
                | LightDesc::Sun { .. }
                | LightDesc::Point { .. }
                | LightDesc::Spot { .. } => {}
            }
        }
        Ok(())
    }

    /// Emitted radiance times the luminance scale must stay well inside f32 (an emitter of
    /// 3e38 overflowed only later, as "pixel (13, 4) is not finite" in the perception model).
    fn check_emission(&self, b: &Builder, settings: &RenderSettings) -> SceneResult<()> {
        let k = settings.luminance_scale as f64;
        if k > MAX_LUMINANCE_CD_M2 {
            return Err(self.invalid(format!(
                "render.luminance_scale = {k:e} cd/m² per unit exceeds {MAX_LUMINANCE_CD_M2:e}, \
                 where f32 image arithmetic overflows"
            )));
        }
        for m in &b.materials {
            let Some(e) = &m.emission else { continue };
            let peak = e.max(&b.textures).max_element() as f64;
            if !peak.is_finite() || peak * k > MAX_LUMINANCE_CD_M2 {
                return Err(self.invalid(format!(
                    "material {:?}: emission {peak:e} W·sr⁻¹·m⁻² × luminance_scale {k} is beyond \
                     {MAX_LUMINANCE_CD_M2:e} cd/m², where f32 image arithmetic overflows",
                    m.name
                )));
            }
        }
        Ok(())
    }

    /// Every moving mesh stays within ±[`MAX_COORDINATE`] at its keys.
    fn check_motion_extent(&self, tris: &Triangles, tracks: &[TransformTrack]) -> SceneResult<()> {
        for (i, track) in tracks.iter().enumerate() {
            for key in track.keys() {
                let m = track.at(key.time_s);
                let far = (0..tris.len())
                    .filter(|&k| tris.instance(k) == i as u32)
                    .flat_map(|k| tris.positions(k))
                    .map(|p| m.transform_point3(p))
                    .any(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE);
                if far {
                    return Err(self.invalid(format!(
                        "a moving mesh's key at {} s carries it beyond ±{MAX_COORDINATE:e}",
                        key.time_s
                    )));
                }
            }
        }
        Ok(())
    }

    /// `[animation]`, validated.
    fn animation(&self) -> SceneResult<Option<AnimationSettings>> {
        let Some(a) = &self.animation else {
            let keyed = self
                .meshes
                .iter()
                .position(|m| !m.keys.is_empty())
                .map(|i| format!("[[mesh]] #{}", i + 1))
                .or_else(|| (!self.camera.keys.is_empty()).then(|| "[camera]".to_string()));
            if let Some(who) = keyed {
                return Err(self.invalid(format!(
                    "{who} has keys but the scene has no [animation] table (fps and frames)"
                )));
            }
            return Ok(None);
        };
        if !(a.fps.is_finite() && a.fps > 0.0) {
            return Err(self.invalid(format!(
                "animation.fps must be a positive number, got {}",
                a.fps
            )));
        }
        let [first, last] = a.frames;
        if first > last {
            return Err(self.invalid(format!(
                "animation.frames = [{first}, {last}]: the first frame is after the last"
            )));
        }
        let shutter = a.shutter.unwrap_or(DEFAULT_SHUTTER);
        if !(0.0..=1.0).contains(&shutter) {
            return Err(self.invalid(format!(
                "animation.shutter must be in [0, 1] (a fraction of the frame), got {shutter}"
            )));
        }
        Ok(Some(AnimationSettings {
            fps: a.fps,
            frame_start: first,
            frame_end: last,
            shutter,
        }))
    }

    /// Checks that key times are finite and strictly increasing, and that every frame's instant
    /// lies within the keys (when there are two or more).
    fn check_key_times(
        &self,
        who: &str,
        times: &[f64],
        anim: Option<&AnimationSettings>,
    ) -> SceneResult<()> {
        for (k, &t) in times.iter().enumerate() {
            if !t.is_finite() {
                return Err(self.invalid(format!("{who} key {}: time must be finite", k + 1)));
            }
            if k > 0 && t <= times[k - 1] {
                return Err(self.invalid(format!(
                    "{who} key {} (time {t} s) is not after key {} (time {} s): key times must \
                     be strictly increasing, without duplicates",
                    k + 1,
                    k,
                    times[k - 1]
                )));
            }
        }
        if let (Some(a), [t0, .., t1]) = (anim, times) {
            let (f0, f1) = (a.frame(a.frame_start).time_s, a.frame(a.frame_end).time_s);
            if f0 < *t0 - 1e-9 || f1 > *t1 + 1e-9 {
                return Err(self.invalid(format!(
                    "frames {}-{} ({f0:.4}-{f1:.4} s at {} fps) fall outside the keys of {who} \
                     ({t0}-{t1} s)",
                    a.frame_start, a.frame_end, a.fps
                )));
            }
        }
        Ok(())
    }

    /// `[[camera.keys]]` as a track (missing values held from the previous key).
    fn camera_track(&self, anim: Option<&AnimationSettings>) -> SceneResult<Option<CameraTrack>> {
        let c = &self.camera;
        if c.keys.is_empty() {
            return Ok(None);
        }
        let times: Vec<f64> = c.keys.iter().map(|k| k.time).collect();
        self.check_key_times("[camera]", &times, anim)?;
        let mut prev = CameraKey {
            time_s: 0.0,
            position: c.position.into(),
            look_at: c.look_at.into(),
            up: c.up.into(),
            vfov_deg: c.vfov_deg,
        };
        let mut keys = Vec::with_capacity(c.keys.len());
        for (k, d) in c.keys.iter().enumerate() {
            let key = CameraKey {
                time_s: d.time as f32,
                position: d.position.map(Vec3::from).unwrap_or(prev.position),
                look_at: d.look_at.map(Vec3::from).unwrap_or(prev.look_at),
                up: d.up.map(Vec3::from).unwrap_or(prev.up),
                vfov_deg: d.vfov_deg.unwrap_or(prev.vfov_deg),
            };
            let vals = key
                .position
                .to_array()
                .into_iter()
                .chain(key.look_at.to_array());
            if vals.chain(key.up.to_array()).any(|v| !v.is_finite()) {
                return Err(self.invalid(format!("[camera] key {}: values must be finite", k + 1)));
            }
            if !(key.vfov_deg > 0.0 && key.vfov_deg < 180.0) {
                return Err(self.invalid(format!(
                    "[camera] key {}: vfov_deg must be in (0, 180) degrees, got {}",
                    k + 1,
                    key.vfov_deg
                )));
            }
            if Camera::from_key(&key, 1, 1).is_none() {
                return Err(self.invalid(format!(
                    "[camera] key {}: look_at must differ from position and not be parallel to up",
                    k + 1
                )));
            }
            keys.push(key);
            prev = key;
        }
        Ok(Some(CameraTrack::new(keys).expect("times checked")))
    }

    /// `[[mesh.keys]]` of mesh `i` as a track (missing values held from the previous key).
    fn mesh_track(
        &self,
        i: usize,
        mesh: &MeshDesc,
        anim: Option<&AnimationSettings>,
    ) -> SceneResult<Option<TransformTrack>> {
        if mesh.keys.is_empty() {
            return Ok(None);
        }
        let who = format!("[[mesh]] #{}", i + 1);
        let times: Vec<f64> = mesh.keys.iter().map(|k| k.time).collect();
        self.check_key_times(&who, &times, anim)?;
        let mut prev = TransformKey {
            time_s: 0.0,
            translate: Vec3::ZERO,
            rotate: Quat::IDENTITY,
            scale: Vec3::ONE,
        };
        let mut keys = Vec::with_capacity(mesh.keys.len());
        for (k, d) in mesh.keys.iter().enumerate() {
            let rotate = match d.rotate_deg {
                Some(r) => {
                    Quat::from_rotation_z(r[2].to_radians())
                        * Quat::from_rotation_y(r[1].to_radians())
                        * Quat::from_rotation_x(r[0].to_radians())
                }
                None => prev.rotate,
            };
            let scale = match &d.scale {
                None => prev.scale,
                Some(ScaleDesc::Uniform(s)) => Vec3::splat(*s),
                Some(ScaleDesc::PerAxis(s)) => Vec3::from(*s),
            };
            let key = TransformKey {
                time_s: d.time as f32,
                translate: d.translate.map(Vec3::from).unwrap_or(prev.translate),
                rotate,
                scale,
            };
            if !(key.translate.is_finite() && key.rotate.is_finite() && key.scale.is_finite()) {
                return Err(self.invalid(format!("{who} key {}: values must be finite", k + 1)));
            }
            if key.scale.abs().min_element() < 1e-6 {
                return Err(self.invalid(format!(
                    "{who} key {}: scale must be non-zero on every axis, got {}",
                    k + 1,
                    key.scale
                )));
            }
            keys.push(key);
            prev = key;
        }
        Ok(Some(TransformTrack::new(keys).expect("times checked")))
    }

    fn camera(&self) -> SceneResult<Camera> {
        let c = &self.camera;
        let [w, h] = c.resolution;
        if w == 0 || h == 0 || w > 65536 || h > 65536 {
            return Err(self.invalid(format!(
                "camera.resolution must be in 1..=65536 on both axes, got {w}×{h}"
            )));
        }
        check_memory(w, h).map_err(|m| self.invalid(m))?;
        if !(c.vfov_deg > 0.0 && c.vfov_deg < 180.0) {
            return Err(self.invalid(format!(
                "camera.vfov_deg must be in (0, 180) degrees, got {}",
                c.vfov_deg
            )));
        }
        let vals = c.position.iter().chain(&c.look_at).chain(&c.up);
        if vals.clone().any(|v| !v.is_finite()) {
            return Err(self.invalid("camera position, look_at and up must be finite"));
        }
        let aperture = c.aperture_radius.unwrap_or(0.0);
        if !(aperture.is_finite() && aperture >= 0.0) {
            return Err(self.invalid(format!(
                "camera.aperture_radius must be finite and ≥ 0, got {aperture}"
            )));
        }
        let to_target = Vec3::from(c.look_at) - Vec3::from(c.position);
        let focus = c.focus_distance.unwrap_or(to_target.length());
        if !(focus.is_finite() && focus > 0.0) {
            return Err(self.invalid(format!(
                "camera.focus_distance must be a positive distance, got {focus}"
            )));
        }
        Camera::look_at(
            c.position.into(),
            c.look_at.into(),
            c.up.into(),
            c.vfov_deg,
            w,
            h,
        )
        .map(|cam| cam.with_lens(aperture, focus))
        .ok_or_else(|| {
            self.invalid("camera: look_at must differ from position and not be parallel to up")
        })
    }

    fn transform(&self, mesh: usize, t: Option<&TransformDesc>) -> SceneResult<Mat4> {
        let Some(t) = t else {
            return Ok(Mat4::IDENTITY);
        };
        let key = format!("[[mesh]] #{} transform", mesh + 1);
        let m = if let Some(rows) = t.matrix {
            if t.scale.is_some() || t.rotate_deg.is_some() || t.translate.is_some() {
                return Err(self.invalid(format!(
                    "{key}: `matrix` cannot be combined with scale/rotate_deg/translate"
                )));
            }
            Mat4::from_cols_array_2d(&rows).transpose()
        } else {
            let s = match &t.scale {
                None => Vec3::ONE,
                Some(ScaleDesc::Uniform(s)) => Vec3::splat(*s),
                Some(ScaleDesc::PerAxis(s)) => Vec3::from(*s),
            };
            let r = t.rotate_deg.unwrap_or([0.0; 3]);
            let q = Quat::from_rotation_z(r[2].to_radians())
                * Quat::from_rotation_y(r[1].to_radians())
                * Quat::from_rotation_x(r[0].to_radians());
            Mat4::from_scale_rotation_translation(s, q, Vec3::from(t.translate.unwrap_or([0.0; 3])))
        };
        if !m.is_finite() || m.determinant() == 0.0 || !m.inverse().is_finite() {
            return Err(self.invalid(format!(
                "{key}: must be finite and invertible (a zero or non-finite scale, or a singular \
                 matrix)"
            )));
        }
        Ok(m)
    }
}

fn check_unit_rgb(v: [f32; 3], key: &str) -> Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite() && (0.0..=1.0).contains(x)) {
        Ok(Vec3::from(v))
    } else {
        Err(format!("{key} must have components in [0, 1], got {v:?}"))
    }
}

fn apply_override(m: &mut Material, ov: &MaterialOverride) -> Result<(), String> {
    if let Some(kind) = ov.kind {
        m.kind = match kind {
            MaterialType::Diffuse => MaterialKind::Diffuse,
            MaterialType::Mirror => MaterialKind::Mirror,
            MaterialType::Glossy => MaterialKind::Glossy {
                alpha: match m.kind {
                    MaterialKind::Glossy { alpha } => alpha,
                    _ => 0.2,
                },
            },
            MaterialType::Dielectric => MaterialKind::Dielectric {
                ior: match m.kind {
                    MaterialKind::Dielectric { ior } => ior,
                    _ => 1.5,
                },
            },
        };
        if kind == MaterialType::Mirror && ov.reflectance.is_none() && m.ks.is_black() {
            m.ks = ColorSource::Constant(Vec3::ONE);
        }
    }
    if let Some(r) = ov.reflectance {
        let r = ColorSource::Constant(check_unit_rgb(r, "reflectance")?);
        if m.kind == MaterialKind::Mirror {
            m.ks = r;
        } else {
            m.kd = r;
        }
    }
    if let Some(s) = ov.specular {
        m.ks = ColorSource::Constant(check_unit_rgb(s, "specular")?);
    }
    if let Some(t) = ov.transmittance {
        m.transmittance = check_unit_rgb(t, "transmittance")?;
    }
    if let Some(a) = ov.alpha {
        if !(a > 0.0 && a <= 1.0) {
            return Err(format!("alpha must be in (0, 1], got {a}"));
        }
        match &mut m.kind {
            MaterialKind::Glossy { alpha } => *alpha = a,
            _ => return Err("alpha applies only to type = \"glossy\"".into()),
        }
    }
    if let Some(i) = ov.ior {
        if !(i.is_finite() && i > 0.0) {
            return Err(format!("ior must be a positive number, got {i}"));
        }
        match &mut m.kind {
            MaterialKind::Dielectric { ior } => *ior = i,
            _ => return Err("ior applies only to type = \"dielectric\"".into()),
        }
    }
    if let Some(e) = ov.emission {
        if e.iter().any(|x| !x.is_finite() || *x < 0.0) {
            return Err(format!("emission must be finite and ≥ 0, got {e:?}"));
        }
        m.emission = if e.iter().all(|&x| x == 0.0) {
            None
        } else {
            Some(ColorSource::Constant(Vec3::from(e)))
        };
    }
    Ok(())
}

/// A texture reference from an MTL `map_*` statement: options and file name.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureSpec {
    /// File name (relative to the MTL file).
    pub file: String,
    /// `-mm base gain` (default 0, 1).
    pub base: f32,
    /// Gain from `-mm`.
    pub gain: f32,
    /// Bump multiplier `-bm` (default 1).
    pub bm: f32,
    /// Channel `-imfchan` (r, g, b, m, l, z), if given.
    pub imfchan: Option<char>,
}

/// Parses the argument of an MTL `map_*` statement: options (`-mm base gain`, `-bm mult` and
/// `-imfchan c` are honoured; `-o`, `-s`, `-t` (up to 3 numbers), `-blendu`, `-blendv`,
/// `-boost`, `-cc`, `-clamp`, `-texres` are skipped) followed by the file name. `None` when no file is named.
pub fn parse_texture_spec(s: &str) -> Option<TextureSpec> {
    let toks: Vec<&str> = s.split_whitespace().collect();
    let (mut base, mut gain, mut bm, mut imfchan) = (0.0, 1.0, 1.0, None);
    let mut i = 0;
    while i < toks.len() && toks[i].starts_with('-') && toks[i].len() > 1 {
        let opt = toks[i];
        i += 1;
        let is_num = |t: &&str| t.parse::<f32>().is_ok();
        match opt {
            "-mm" => {
                if let Some(b) = toks.get(i).and_then(|t| t.parse().ok()) {
                    base = b;
                    i += 1;
                }
                if let Some(g) = toks.get(i).and_then(|t| t.parse().ok()) {
                    gain = g;
                    i += 1;
                }
            }
            "-bm" => {
                if let Some(b) = toks.get(i).and_then(|t| t.parse().ok()) {
                    bm = b;
                    i += 1;
                }
            }
            "-imfchan" => {
                if let Some(c) = toks
                    .get(i)
                    .filter(|t| t.len() == 1)
                    .and_then(|t| t.chars().next())
                {
                    imfchan = Some(c);
                    i += 1;
                }
            }
            "-o" | "-s" | "-t" => {
                let mut k = 0;
                while k < 3 && toks.get(i).is_some_and(is_num) {
                    i += 1;
                    k += 1;
                }
            }
            _ => {
                // One-argument options.
                if i < toks.len() - 1 {
                    i += 1;
                }
            }
        }
    }
    if i >= toks.len() {
        return None;
    }
    Some(TextureSpec {
        file: toks[i..].join(" "),
        base,
        gain,
        bm,
        imfchan,
    })
}

/// The distinct names given by `usemtl` lines of an OBJ file, in order of appearance.
fn usemtl_names(obj: &[u8]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for line in obj.split(|&c| c == b'\n') {
        let line = String::from_utf8_lossy(line);
        if let Some(rest) = line.trim_start().strip_prefix("usemtl") {
            let n = rest.trim();
            if !n.is_empty()
                && rest.starts_with(char::is_whitespace)
                && !names.iter().any(|x| x == n)
            {
                names.push(n.to_string());
            }
        }
    }
    names
}

/// MTL statements aleph reads (see `docs/scene-format.md`); everything else is reported.
const MTL_READ: &[&str] = &[
    "Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "illum", "map_Kd", "map_Ks", "map_Ke", "map_d",
    "bump", "map_bump", "map_Bump", "norm",
];

/// Reports once, on stderr, the MTL statements of `materials` that aleph ignores, with how many
/// materials give each (`Ka`/`map_Ka`: a path tracer computes ambient light; `Tf`: a
/// transmission weight in Blender's importer, ignored by three.js, so aleph's glass is clear
/// unless `[materials.NAME] transmittance` tints it; `map_Ns`, `Pr`, …: not supported).
fn warn_ignored_mtl(mtl: &Path, materials: &[tobj::Material]) {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for m in materials {
        let mut seen: Vec<&str> = Vec::new();
        if m.ambient.is_some() {
            seen.push("Ka");
        }
        if m.ambient_texture.is_some() {
            seen.push("map_Ka");
        }
        if m.shininess_texture.is_some() {
            seen.push("map_Ns");
        }
        for k in m.unknown_param.keys() {
            if !k.starts_with('#') && !MTL_READ.contains(&k.as_str()) {
                seen.push(k);
            }
        }
        for k in seen {
            *counts.entry(k.to_string()).or_default() += 1;
        }
    }
    if !counts.is_empty() {
        let list: Vec<String> = counts.iter().map(|(k, n)| format!("{k} ({n})")).collect();
        eprintln!(
            "warning: {}: ignored MTL statements (materials giving each): {}; see \
             docs/scene-format.md",
            mtl.display(),
            list.join(", ")
        );
    }
}

/// Half the diagonal of the box around every vertex (rest-space positions for moving meshes):
/// the radius of a sphere that holds the scene, for the power of lights at infinity.
fn bounding_radius(tris: &Triangles) -> f32 {
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for p in (0..tris.len()).flat_map(|i| tris.positions(i)) {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    if lo.x > hi.x {
        return 1.0;
    }
    0.5 * (hi - lo).length()
}

/// Builds the BVHs, turning a panic inside the BVH library into an error (the scene is
/// validated first, so this is a last line of defence, silent on stderr).
fn build_geometry(
    tris: Triangles,
    tracks: Vec<TransformTrack>,
    time_range: (f32, f32),
) -> Result<Geometry, String> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let r = std::panic::catch_unwind(move || Geometry::with_instances(tris, tracks, time_range));
    std::panic::set_hook(hook);
    r.map_err(|e| {
        e.downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| e.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "a panic in the BVH builder".into())
    })
}

/// Which objects of an OBJ file a `[[mesh]]` takes.
struct ObjectFilter<'a> {
    only: Option<&'a [String]>,
    exclude: &'a [String],
}

impl ObjectFilter<'_> {
    fn keeps(&self, name: &str) -> bool {
        self.only.is_none_or(|o| o.iter().any(|n| n == name))
            && !self.exclude.iter().any(|n| n == name)
    }

    /// Every name given must exist in the file.
    fn check(&self, models: &[tobj::Model]) -> Result<(), String> {
        let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
        let given = self.only.unwrap_or(&[]).iter().chain(self.exclude);
        for n in given {
            if !names.contains(&n.as_str()) {
                return Err(format!(
                    "no object or group is named {n:?} (the file has {names:?})"
                ));
            }
        }
        Ok(())
    }
}

#[derive(Default)]
struct Builder {
    tris: Triangles,
    materials: Vec<Material>,
    material_index: HashMap<String, u32>,
    textures: Vec<Texture>,
    texture_index: HashMap<PathBuf, u32>,
    /// Non-colour textures (bump and normal maps), by file, into `textures`.
    data_index: HashMap<PathBuf, u32>,
    masks: Vec<AlphaMask>,
    mask_index: HashMap<(PathBuf, Option<char>), u32>,
    default_material: Option<u32>,
    /// Material names the scene file overrides (`[materials.NAME]`): a `usemtl` stub of one of
    /// these is what the user asked for, not worth a warning.
    overridden: std::collections::HashSet<String>,
}

impl Builder {
    fn texture(&mut self, dir: &Path, spec: &str) -> SceneResult<Option<ColorSource>> {
        let Some(spec) = parse_texture_spec(spec) else {
            return Ok(None);
        };
        let path = dir.join(spec.file.replace('\\', "/"));
        let id = match self.texture_index.get(&path) {
            Some(&id) => id,
            None => {
                let t = Texture::load(&path)?;
                let id = self.textures.len() as u32;
                self.textures.push(t);
                self.texture_index.insert(path, id);
                id
            }
        };
        Ok(Some(ColorSource::Texture {
            id,
            base: spec.base,
            gain: spec.gain,
        }))
    }

    /// The cut-out mask of an MTL `map_d` argument: the `-imfchan` channel if given, else the
    /// image's alpha channel if it has one, else its luminance (values as stored, no sRGB
    /// decoding).
    fn mask(&mut self, dir: &Path, spec: &str) -> SceneResult<Option<u32>> {
        let Some(spec) = parse_texture_spec(spec) else {
            return Ok(None);
        };
        let path = dir.join(spec.file.replace('\\', "/"));
        let key = (path.clone(), spec.imfchan);
        if let Some(&id) = self.mask_index.get(&key) {
            return Ok(Some(id));
        }
        let err = |message: String| SceneError::Texture {
            path: path.clone(),
            message,
        };
        let img = image::ImageReader::open(&path)
            .map_err(|e| err(e.to_string()))?
            .with_guessed_format()
            .map_err(|e| err(e.to_string()))?
            .decode()
            .map_err(|e| err(e.to_string()))?;
        let has_alpha = img.color().has_alpha();
        let rgba = img.into_rgba32f();
        let (w, h) = (rgba.width() as usize, rgba.height() as usize);
        let coverage: Vec<f32> = rgba
            .pixels()
            .map(|p| {
                let [r, g, b, a] = p.0;
                match spec.imfchan {
                    Some('r') => r,
                    Some('g') => g,
                    Some('b') => b,
                    Some('l') | Some('z') => 0.2126 * r + 0.7152 * g + 0.0722 * b,
                    _ if has_alpha => a,
                    _ => 0.2126 * r + 0.7152 * g + 0.0722 * b,
                }
            })
            .collect();
        let mask =
            AlphaMask::new(w, h, &coverage).ok_or_else(|| err("image has zero size".into()))?;
        let id = self.masks.len() as u32;
        self.masks.push(mask);
        self.mask_index.insert(key, id);
        Ok(Some(id))
    }

    /// A bump (`normal = false`: height map unless the image is a normal map) or normal map.
    fn bump(&mut self, dir: &Path, spec: &str, normal: bool) -> SceneResult<Option<BumpMap>> {
        let Some(spec) = parse_texture_spec(spec) else {
            return Ok(None);
        };
        let path = dir.join(spec.file.replace('\\', "/"));
        let id = match self.data_index.get(&path) {
            Some(&id) => id,
            None => {
                let t = Texture::load_data(&path)?;
                let id = self.textures.len() as u32;
                self.textures.push(t);
                self.data_index.insert(path, id);
                id
            }
        };
        let is_normal = normal || looks_like_normal_map(&self.textures[id as usize]);
        let kind = if is_normal {
            BumpKind::Normal
        } else {
            BumpKind::Height { scale: spec.bm }
        };
        Ok(Some(BumpMap { texture: id, kind }))
    }

    fn convert_material(
        &mut self,
        m: &tobj::Material,
        dir: &Path,
        mtl: &Path,
    ) -> SceneResult<Material> {
        let rgb = |v: Option<[f32; 3]>| v.map(Vec3::from).unwrap_or(Vec3::ZERO);
        let kd_c = rgb(m.diffuse);
        let ks_c = rgb(m.specular);
        let ke_c = rgb(m.emissive);
        let bad = [kd_c, ks_c, ke_c]
            .iter()
            .any(|v| !v.is_finite() || v.min_element() < 0.0);
        if bad {
            return Err(SceneError::Mtl {
                path: mtl.to_path_buf(),
                message: format!(
                    "material {:?}: Kd, Ks and Ke must be finite and ≥ 0",
                    m.name
                ),
            });
        }
        let kd = match &m.diffuse_texture {
            Some(t) => self.texture(dir, t)?.unwrap_or(ColorSource::Constant(kd_c)),
            None => ColorSource::Constant(kd_c),
        };
        let ks = match &m.specular_texture {
            Some(t) => self.texture(dir, t)?.unwrap_or(ColorSource::Constant(ks_c)),
            None => ColorSource::Constant(ks_c),
        };
        // tobj has no field for map_Ke; it lands in unknown_param.
        let emission = match m.unknown_param.get("map_Ke") {
            Some(t) => match self.texture(dir, t)? {
                Some(ColorSource::Texture { id, base, gain }) => {
                    // Ke multiplies the texture; fold a grey Ke into the gain.
                    let k = if ke_c.max_element() > 0.0 {
                        ke_c.max_element()
                    } else {
                        1.0
                    };
                    Some(ColorSource::Texture {
                        id,
                        base: base * k,
                        gain: gain * k,
                    })
                }
                _ => None,
            },
            None if ke_c.max_element() > 0.0 => Some(ColorSource::Constant(ke_c)),
            None => None,
        };
        let illum = m.illumination_model.unwrap_or(2);
        let tr: f32 = m
            .unknown_param
            .get("Tr")
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(0.0);
        let dissolve = m.dissolve.unwrap_or(1.0);
        let ns = m.shininess.unwrap_or(0.0);
        let has_ks = ks_c.max_element() > 0.0 || m.specular_texture.is_some();
        let kind = if matches!(illum, 4 | 6 | 7 | 9) || dissolve < 1.0 || tr > 0.0 {
            let ior = m
                .optical_density
                .filter(|n| *n > 0.0 && n.is_finite())
                .unwrap_or(1.5);
            MaterialKind::Dielectric { ior }
        } else if matches!(illum, 5 | 8) || (has_ks && ns >= 10_000.0) {
            MaterialKind::Mirror
        } else if has_ks {
            MaterialKind::Glossy {
                alpha: Material::alpha_from_ns(ns),
            }
        } else {
            MaterialKind::Diffuse
        };
        let ks = if kind == MaterialKind::Mirror && ks.is_black() {
            ColorSource::Constant(Vec3::ONE)
        } else {
            ks
        };
        let cutout = match &m.dissolve_texture {
            Some(t) => self.mask(dir, t)?,
            None => None,
        };
        let bump = match (m.unknown_param.get("norm"), &m.normal_texture) {
            (Some(t), _) => self.bump(dir, t, true)?,
            (None, Some(t)) => self.bump(dir, t, false)?,
            (None, None) => None,
        };
        Ok(Material {
            name: m.name.clone(),
            kind,
            kd,
            ks,
            transmittance: Vec3::ONE,
            emission,
            cutout,
            bump,
        })
    }

    fn load_obj(
        &mut self,
        path: &Path,
        xf: Mat4,
        instance: u32,
        select: &ObjectFilter,
    ) -> SceneResult<()> {
        let obj_err = |message: String| SceneError::Obj {
            path: path.to_path_buf(),
            message,
        };
        let text = std::fs::read(path).map_err(|source| SceneError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        check_vertex_lines(&text).map_err(obj_err)?;
        let dir = path.parent().unwrap_or(Path::new("")).to_path_buf();
        let mtl_failure: RefCell<Option<(PathBuf, String)>> = RefCell::new(None);
        let mtl_paths: RefCell<Vec<PathBuf>> = RefCell::new(Vec::new());
        let opts = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let used = usemtl_names(&text);
        let stubs: RefCell<Vec<String>> = RefCell::new(Vec::new());
        let (models, materials) = tobj::load_obj_buf(&mut text.as_slice(), &opts, |name| {
            let full = dir.join(name);
            mtl_paths.borrow_mut().push(full.clone());
            let (r, msg) = load_mtl_checked(&full);
            if let Some(msg) = msg {
                mtl_failure.borrow_mut().get_or_insert((full.clone(), msg));
            }
            // A `usemtl` that names no MTL material gets a grey stub of that name, so that it is
            // reported and `[materials.NAME]` can replace it.
            r.map(|(mut mats, mut map)| {
                for n in &used {
                    if !map.contains_key(n) {
                        map.insert(n.clone(), mats.len());
                        mats.push(tobj::Material {
                            name: n.clone(),
                            diffuse: Some([0.8; 3]),
                            ..Default::default()
                        });
                        stubs.borrow_mut().push(n.clone());
                    }
                }
                (mats, map)
            })
        })
        .map_err(|e| obj_err(format!("{e}")))?;
        if let Some((p, message)) = mtl_failure.into_inner() {
            let obj = path.file_name().map(|n| n.to_string_lossy().to_string());
            return Err(SceneError::Mtl {
                path: p,
                message: format!("{message} (named by {})", obj.unwrap_or_default()),
            });
        }
        let mtl_path = mtl_paths
            .into_inner()
            .first()
            .cloned()
            .unwrap_or_else(|| path.to_path_buf());
        let mtl_dir = mtl_path.parent().unwrap_or(Path::new("")).to_path_buf();
        let materials = materials.unwrap_or_default();
        let stubs: Vec<String> = stubs
            .into_inner()
            .into_iter()
            .filter(|n| !self.overridden.contains(n))
            .collect();
        if !stubs.is_empty() {
            eprintln!(
                "warning: {}: usemtl names no material of {} for {:?}: shown as grey 0.8 \
                 (override with [materials.NAME])",
                path.display(),
                mtl_path.display(),
                stubs
            );
        }
        warn_ignored_mtl(&mtl_path, &materials);
        let mut local_to_global = Vec::with_capacity(materials.len());
        for m in &materials {
            let mat = self.convert_material(m, &mtl_dir, &mtl_path)?;
            let idx = self.materials.len() as u32;
            self.material_index.insert(m.name.clone(), idx);
            self.materials.push(mat);
            local_to_global.push(idx);
        }
        let normal_xf = Mat3::from_mat4(xf).inverse().transpose();
        select.check(&models).map_err(obj_err)?;
        for model in models.iter().filter(|m| select.keeps(&m.name)) {
            let material = match model.mesh.material_id {
                Some(id) if id < local_to_global.len() => local_to_global[id],
                _ => self.default_material(),
            };
            self.add_model(model, (xf, normal_xf), material, instance)
                .map_err(obj_err)?;
        }
        Ok(())
    }

    /// Appends the triangles of one OBJ model (positions through `xf.0`, normals through
    /// `xf.1`) with material `material`. Errors name the object and face.
    fn add_model(
        &mut self,
        model: &tobj::Model,
        (xf, normal_xf): (Mat4, Mat3),
        material: u32,
        instance: u32,
    ) -> Result<(), String> {
        let mesh = &model.mesh;
        let pos = |i: u32| -> Vec3 {
            let i = i as usize * 3;
            xf.transform_point3(Vec3::new(
                mesh.positions[i],
                mesh.positions[i + 1],
                mesh.positions[i + 2],
            ))
        };
        let has_n = mesh.normals.len() == mesh.positions.len() && !mesh.normals.is_empty();
        let has_uv =
            mesh.texcoords.len() / 2 == mesh.positions.len() / 3 && !mesh.texcoords.is_empty();
        self.tris.reserve(mesh.indices.len() / 3, has_n, has_uv);
        for (f, idx) in mesh.indices.chunks_exact(3).enumerate() {
            let p = [pos(idx[0]), pos(idx[1]), pos(idx[2])];
            if p.iter().any(|v| !v.is_finite()) {
                return Err(format!(
                    "object {:?}, face {}: vertex position is NaN or infinite",
                    model.name,
                    f + 1
                ));
            }
            if p.iter().any(|v| v.abs().max_element() > MAX_COORDINATE) {
                return Err(format!(
                    "object {:?}, face {}: a vertex lies beyond ±{MAX_COORDINATE:e} (after the \
                     transform), where f32 arithmetic overflows",
                    model.name,
                    f + 1
                ));
            }
            let n = if has_n {
                let nn = |i: u32| {
                    let i = i as usize * 3;
                    (normal_xf
                        * Vec3::new(mesh.normals[i], mesh.normals[i + 1], mesh.normals[i + 2]))
                    .normalize_or_zero()
                };
                let n = [nn(idx[0]), nn(idx[1]), nn(idx[2])];
                if n.iter().all(|v| v.is_finite() && *v != Vec3::ZERO) {
                    Some(n)
                } else {
                    None
                }
            } else {
                None
            };
            let uv = if has_uv {
                let t = |i: u32| {
                    let i = i as usize * 2;
                    Vec2::new(mesh.texcoords[i], mesh.texcoords[i + 1])
                };
                let uv = [t(idx[0]), t(idx[1]), t(idx[2])];
                if uv.iter().any(|v| !v.is_finite()) {
                    return Err(format!(
                        "object {:?}, face {}: texture coordinate is NaN or infinite",
                        model.name,
                        f + 1
                    ));
                }
                uv
            } else {
                [Vec2::ZERO; 3]
            };
            self.tris.push(TriangleAttributes {
                p,
                n,
                uv,
                material,
                light: u32::MAX,
                instance,
            });
        }
        Ok(())
    }

    fn default_material(&mut self) -> u32 {
        *self.default_material.get_or_insert_with(|| {
            self.materials.push(Material {
                name: "(default)".into(),
                kind: MaterialKind::Diffuse,
                kd: ColorSource::Constant(Vec3::splat(0.8)),
                ks: ColorSource::Constant(Vec3::ZERO),
                transmittance: Vec3::ONE,
                emission: None,
                cutout: None,
                bump: None,
            });
            self.materials.len() as u32 - 1
        })
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

/// Refuses a resolution whose render would not fit in the available memory, with both figures.
fn check_memory(w: u32, h: u32) -> Result<(), String> {
    let need = w as u64 * h as u64 * RENDER_BYTES_PER_PIXEL;
    match available_memory() {
        Some(avail) if need > avail => Err(format!(
            "camera.resolution {w}×{h} needs about {:.1} GiB to render ({RENDER_BYTES_PER_PIXEL} \
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

/// Reads and parses one MTL file for tobj, validated by [`normalize_mtl`]; on failure also the
/// message for the user.
fn load_mtl_checked(full: &Path) -> (tobj::MTLLoadResult, Option<String>) {
    let text = match std::fs::read(full) {
        Ok(t) => t,
        Err(e) => {
            let msg = if full.exists() {
                format!("cannot read: {e}")
            } else {
                "file not found".to_string()
            };
            return (Err(tobj::LoadError::OpenFileFailed), Some(msg));
        }
    };
    match normalize_mtl(&text) {
        Err(msg) => (Err(tobj::LoadError::MaterialParseError), Some(msg)),
        Ok(t) => {
            let r = tobj::load_mtl_buf(&mut t.as_bytes());
            let msg = r.as_ref().err().map(|e| format!("{e}"));
            (r, msg)
        }
    }
}

/// Validates an MTL file and returns its text in the form tobj parses without panicking: the
/// colour statements `Ka`, `Kd`, `Ks`, `Ke` take 1 number (a grey, which the MTL specification
/// expands to three) or 3 (more are ignored, as tobj does; `#` starts a comment), and anything
/// else is a located error (tobj 4 panics on two).
fn normalize_mtl(bytes: &[u8]) -> Result<String, String> {
    let text = String::from_utf8_lossy(bytes);
    let mut out = String::with_capacity(text.len());
    for (lineno, line) in text.lines().enumerate() {
        let content = line.split('#').next().unwrap_or("");
        let mut toks = content.split_whitespace();
        let kw = toks.next().unwrap_or("");
        if matches!(kw, "Ka" | "Kd" | "Ks" | "Ke") {
            let vals: Vec<&str> = toks.collect();
            let nums: Vec<f32> = vals.iter().map_while(|t| t.parse().ok()).collect();
            let fixed = match (vals.len(), nums.len()) {
                (1, 1) => format!("{kw} {} {} {}", nums[0], nums[0], nums[0]),
                (_, n) if n >= 3 => content.trim().to_string(),
                _ => {
                    return Err(format!(
                        "line {}: `{}`: {kw} takes 1 or 3 numbers",
                        lineno + 1,
                        line.trim()
                    ));
                }
            };
            out.push_str(&fixed);
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    Ok(out)
}

/// Checks every `v`/`vn`/`vt` line for non-finite numbers so the error can name the line.
fn check_vertex_lines(text: &[u8]) -> Result<(), String> {
    for (lineno, line) in text.split(|&c| c == b'\n').enumerate() {
        let line = String::from_utf8_lossy(line);
        let mut toks = line.split_whitespace();
        let Some(kw) = toks.next() else { continue };
        if !matches!(kw, "v" | "vn" | "vt") {
            continue;
        }
        for t in toks {
            if let Ok(x) = t.parse::<f32>()
                && !x.is_finite()
            {
                return Err(format!(
                    "line {}: `{kw}` has a NaN or infinite value ({t})",
                    lineno + 1
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn texture_spec_options() {
        let s = parse_texture_spec("-mm 0 0.4 screen.png").unwrap();
        assert_eq!(
            s,
            TextureSpec {
                file: "screen.png".into(),
                base: 0.0,
                gain: 0.4,
                bm: 1.0,
                imfchan: None,
            }
        );
        let s = parse_texture_spec("-s 1 1 1 -bm 0.5 my tex.png").unwrap();
        assert_eq!(s.file, "my tex.png");
        assert_eq!(s.bm, 0.5);
        let s = parse_texture_spec("-imfchan m -clamp on alpha.png").unwrap();
        assert_eq!((s.imfchan, s.file.as_str()), (Some('m'), "alpha.png"));
        assert_eq!(parse_texture_spec("wall.png").unwrap().file, "wall.png");
        assert!(parse_texture_spec("").is_none());
    }

    #[test]
    fn vertex_line_check_names_the_line() {
        let e = check_vertex_lines(b"# x\nv 0 0 0\nv 1 nan 0\n").unwrap_err();
        assert!(e.contains("line 3"), "{e}");
        assert!(check_vertex_lines(b"v 1 2 3\nvt 0.5 0.5\n").is_ok());
    }

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
