//! Building a [`Scene`] from its description: the camera and its keys, the animation's
//! frames and every mesh's transform track, the meshes (through [`super::obj`]), material
//! overrides, explicit lights, and the BVH.

use super::{RenderSettings, Scene, World};
use crate::animation::{
    AnimationSettings, CameraKey, CameraTrack, DEFAULT_SHUTTER, FrameTime, TransformKey,
    TransformTrack,
};
use crate::camera::Camera;
use crate::error::{SceneError, SceneResult};
use crate::geometry::{Cutouts, Geometry, STATIC_INSTANCE, Triangles};
use crate::light::Lights;
use crate::material::{ColorSource, Material, MaterialKind};
use glam::{Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::obj::{Builder, ObjectFilter};
use super::schema::*;

impl SceneDescription {
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
        super::lights::add_light_quads(&self, &mut b)?;
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
            hint: ambient_hint(&b.ambient_above_one),
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
                scene: &self.path,
                mesh: i + 1,
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
        check_resolution(w, h).map_err(|m| self.invalid(format!("camera.resolution {m}")))?;
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
        if to_target == Vec3::ZERO {
            // Before the focus check, which would otherwise blame a distance nobody set.
            return Err(self.invalid(format!(
                "camera.look_at {:?} equals camera.position: the camera has no view direction",
                c.look_at
            )));
        }
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

/// The hint a scene without a light gives about MTL materials whose ambient colour exceeds 1
/// ([`super::obj::Builder::ambient_above_one`]): empty without any.
fn ambient_hint(found: &[(String, [f32; 3], PathBuf)]) -> String {
    let Some((name, ka, mtl)) = found.first() else {
        return String::new();
    };
    let others = match found.len() {
        1 => String::new(),
        n => format!(" (and {} more)", n - 1),
    };
    let [r, g, b] = *ka;
    format!(
        ". Material \"{name}\" of {} gives Ka {r} {g} {b}{others}, above 1, which no reflectance \
         is: if it is meant to emit, write `Ke {r} {g} {b}` there, or add `[materials.{name}]` \
         with `emission = [{r}, {g}, {b}]` to the scene file (aleph reads emission from Ke only)",
        mtl.display()
    )
}
