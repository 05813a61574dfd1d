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

mod loader;

pub use loader::{SceneDescription, parse_texture_spec};

use crate::camera::Camera;
use crate::error::SceneResult;
use crate::geometry::Geometry;
use crate::light::Lights;
use crate::material::Material;
use crate::texture::Texture;
use std::path::{Path, PathBuf};

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
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            spp: 64,
            max_depth: 64,
            seed: 0,
            luminance_scale: perception::photometry::LUMINOUS_EFFICACY_LM_PER_W,
        }
    }
}

/// A loaded scene: geometry with its BVH, materials, textures, lights, camera and settings.
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// Render settings.
    pub settings: RenderSettings,
    /// Triangles and acceleration structure.
    pub geometry: Geometry,
    /// Materials, indexed by `TriangleAttributes::material`.
    pub materials: Vec<Material>,
    /// Textures, indexed by `ColorSource::Texture::id`.
    pub textures: Vec<Texture>,
    /// Emitters.
    pub lights: Lights,
    /// The scene file this came from.
    pub path: PathBuf,
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

    /// The seed of the current frame's random streams: the render seed for a still.
    pub fn frame_seed(&self) -> u64 {
        self.settings.seed
    }

    /// Builds a scene from an already parsed (and possibly overridden) description.
    ///
    /// # Errors
    /// As [`Scene::load`].
    pub fn load_description(desc: SceneDescription) -> SceneResult<Scene> {
        desc.build()
    }
}
