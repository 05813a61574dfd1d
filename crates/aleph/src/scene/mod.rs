//! Scenes: the TOML scene description, its OBJ/MTL meshes, and the loaded [`Scene`].
//!
//! The format is documented with a worked example in `docs/scene-format.md`. A skeleton:
//!
//! ```toml
//! [camera]
//! position = [0.0, 0.989, 3.883]   # eye, world units
//! look_at = [0.0, 0.989, 0.0]
//! up = [0.0, 1.0, 0.0]             # default +y
//! vfov_deg = 39.3077               # vertical field of view, degrees
//! resolution = [512, 512]          # width, height in pixels
//!
//! [render]                         # all optional
//! spp = 64                         # samples per pixel
//! max_depth = 64                   # maximum path length (bounces)
//! seed = 0
//! luminance_scale = 683.0          # cd/m² per unit of radiance
//!
//! [[mesh]]
//! file = "CornellBox-Original.obj" # relative to this file
//! transform = { scale = 1.0, rotate_deg = [0, 0, 0], translate = [0, 0, 0] }
//!
//! [materials.tallBox]              # override an MTL material by name
//! type = "mirror"
//! reflectance = [0.9, 0.9, 0.9]
//!
//! [[light]]                        # explicit area light (a one-sided quad)
//! type = "quad"
//! corner = [-0.25, 1.98, -0.25]
//! edge1 = [0.5, 0.0, 0.0]
//! edge2 = [0.0, 0.0, 0.5]          # emits towards edge1 × edge2
//! radiance = [17.0, 12.0, 4.0]     # W·sr⁻¹·m⁻²
//! ```

mod build;
mod lights;
mod obj;
mod schema;

pub use obj::{TextureSpec, parse_texture_spec};
pub use schema::*;

use crate::animation::{AnimationSettings, CameraTrack, FrameTime};
use crate::camera::Camera;
use crate::error::{SceneError, SceneResult};
use crate::geometry::Geometry;
use crate::light::Lights;
use crate::material::Material;
use crate::texture::Texture;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub use crate::sampler::SampleGenerator;

/// Key of the shutter-time stream (independent of the path's stream).
const TIME_STREAM_KEY: u64 = 0xBB67_AE85_84CA_A73B;

/// Key of the lens-sample stream.
const LENS_STREAM_KEY: u64 = 0x3C6E_F372_FE94_F82B;

/// Render settings from the scene's `[render]` table (command-line flags may override them).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    /// Samples per pixel (default 64).
    pub spp: u32,
    /// Maximum number of bounces of a path (default 64; with Russian roulette this is the
    /// converged solution, not a truncation of it).
    pub max_depth: u32,
    /// Seed of every random stream (default 0).
    pub seed: u64,
    /// cd/m² per unit of scene radiance (default 683, the luminous efficacy at 555 nm, which
    /// makes radiance in W·sr⁻¹·m⁻² map to physical luminance).
    pub luminance_scale: f32,
    /// How next-event estimation chooses a light (default: the light BVH).
    pub light_sampler: crate::light::LightSampler,
    /// Where a sample's random numbers come from (default: Owen-scrambled Sobol').
    pub sample_generator: SampleGenerator,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            spp: 64,
            max_depth: 64,
            seed: 0,
            luminance_scale: perception::photometry::LUMINOUS_EFFICACY_LM_PER_W,
            light_sampler: crate::light::LightSampler::Bvh,
            sample_generator: SampleGenerator::Sobol,
        }
    }
}

/// What a scene holds for all its frames: triangles with their BVH, materials, textures and
/// lights. It is built once by the loader and shared (behind an [`Arc`]) by every frame view
/// of the scene ([`Scene::at_frame`]); nothing changes it after loading.
pub struct World {
    /// Triangles and acceleration structure.
    pub geometry: Geometry,
    /// Materials, indexed by `TriangleAttributes::material`.
    pub materials: Vec<Material>,
    /// Textures, indexed by `ColorSource::Texture::id`.
    pub textures: Vec<Texture>,
    /// Emitters.
    pub lights: Lights,
}

/// A loaded scene at one frame: the shared [`World`] (reached through `Deref`, so
/// `scene.geometry` reads the world's), the camera's pose and the shutter of that frame, and
/// the render settings.
///
/// A scene is never moved from frame to frame: [`Scene::at_frame`] returns another view of the
/// same world, at the cost of a camera, so a frame's time is always passed in, never set.
#[derive(Clone)]
pub struct Scene {
    /// The camera, posed for [`Scene::frame`].
    pub camera: Camera,
    /// Render settings.
    pub settings: RenderSettings,
    /// Geometry, materials, textures and lights, shared by every frame view.
    pub world: Arc<World>,
    /// The scene file this came from.
    pub path: PathBuf,
    /// `[animation]`, if the scene is a sequence.
    pub animation: Option<AnimationSettings>,
    /// The camera's keys, if it moves (`camera` is then its pose at the current frame's
    /// instant).
    pub camera_track: Option<CameraTrack>,
    /// The frame this view renders ([`FrameTime::STILL`] for a still; a loaded animated scene
    /// is at its first frame).
    pub frame: FrameTime,
}

impl std::ops::Deref for Scene {
    type Target = World;
    fn deref(&self) -> &World {
        &self.world
    }
}

impl Scene {
    /// Loads a scene from a TOML file (see the module docs and `docs/scene-format.md`).
    ///
    /// # Errors
    /// A [`crate::error::SceneError`] naming the file and the problem: unreadable or malformed
    /// scene, unknown key, missing or invalid OBJ/MTL/texture, NaN or infinite vertex data, zero
    /// resolution, no light.
    pub fn load(path: &Path) -> SceneResult<Scene> {
        SceneDescription::read(path)?.build()
    }

    /// The seed of the current frame's random streams: the render seed for a still, and the
    /// render seed mixed with the frame number in a sequence ([`FrameTime::seed`]).
    pub fn frame_seed(&self) -> u64 {
        match self.animation {
            Some(_) => self.frame.seed(self.settings.seed),
            None => self.settings.seed,
        }
    }

    /// The same scene at frame `index`: its shutter, its seed and its camera's pose. The view
    /// shares this one's world; `self` is unchanged.
    ///
    /// # Errors
    /// [`SceneError::Invalid`] if the scene has no `[animation]` (and `index` is not 0) or
    /// `index` is outside its frame range.
    pub fn at_frame(&self, index: i64) -> SceneResult<Scene> {
        let invalid = |message: String| SceneError::Invalid {
            path: self.path.clone(),
            message,
        };
        let Some(anim) = self.animation else {
            if index == 0 {
                return Ok(self.clone());
            }
            return Err(invalid(format!(
                "frame {index}: the scene is a still (it has no [animation] table)"
            )));
        };
        if !anim.contains(index) {
            return Err(invalid(format!(
                "frame {index} is outside the scene's frame range {}-{}",
                anim.frame_start, anim.frame_end
            )));
        }
        let mut view = self.clone();
        view.frame = anim.frame(index);
        if let Some(track) = &self.camera_track {
            let (lens, focus) = (self.camera.lens_radius, self.camera.focus_distance);
            view.camera = Camera::from_key(
                &track.at(view.frame.time_s as f32),
                self.camera.width,
                self.camera.height,
            )
            .map(|c| c.with_lens(lens, focus))
            .ok_or_else(|| {
                invalid(format!(
                    "frame {index}: the camera's look direction is zero or parallel to up"
                ))
            })?;
        }
        Ok(view)
    }

    /// The camera at scene time `time` (seconds): the keyed pose for a moving camera, else the
    /// scene's camera.
    #[inline]
    pub fn camera_at(&self, time: f32) -> std::borrow::Cow<'_, Camera> {
        match &self.camera_track {
            Some(track) if time != self.frame.time_s as f32 => {
                match Camera::from_key(&track.at(time), self.camera.width, self.camera.height) {
                    Some(c) => std::borrow::Cow::Owned(
                        c.with_lens(self.camera.lens_radius, self.camera.focus_distance),
                    ),
                    None => std::borrow::Cow::Borrowed(&self.camera),
                }
            }
            _ => std::borrow::Cow::Borrowed(&self.camera),
        }
    }

    /// The time of sample `sample_index` of pixel `pixel_index` in the current frame: uniform
    /// over the shutter from a stream of its own (so the path's random numbers are the same
    /// with and without motion blur), or the frame's instant.
    #[inline]
    pub fn sample_time(&self, seed: u64, pixel_index: u64, sample_index: u64) -> f32 {
        if !self.frame.has_motion_blur() {
            return self.frame.time_s as f32;
        }
        let u = crate::rng::Rng::for_sample(seed ^ TIME_STREAM_KEY, pixel_index, sample_index)
            .uniform();
        self.frame.sample_time(u)
    }

    /// The primary ray of sample `sample_index` of pixel (x, y) = `pixel_index` at sub-pixel
    /// offset `u` and time `time`: through the lens point drawn from a stream of its own when
    /// the camera has an aperture (so the path's random numbers are the same with and without
    /// depth of field), else through the pinhole.
    #[inline]
    pub fn camera_ray(
        &self,
        seed: u64,
        (x, y): (u32, u32),
        sample_index: u64,
        u: glam::Vec2,
        time: f32,
    ) -> crate::geometry::Ray {
        let cam = self.camera_at(time);
        if cam.lens_radius <= 0.0 {
            return cam.generate_ray(x, y, u, time);
        }
        let index = y as u64 * self.camera.width as u64 + x as u64;
        let lens =
            crate::rng::Rng::for_sample(seed ^ LENS_STREAM_KEY, index, sample_index).uniform2();
        cam.generate_ray_lens(x, y, u, lens, time)
    }

    /// Builds a scene from an already parsed (and possibly overridden) description.
    ///
    /// # Errors
    /// As [`Scene::load`].
    pub fn load_description(desc: SceneDescription) -> SceneResult<Scene> {
        desc.build()
    }
}
