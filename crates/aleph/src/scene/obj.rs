//! OBJ/MTL meshes and their textures: `map_*` options, MTL reading and validation, material
//! conversion, and the builder that collects triangles, materials and textures.

use crate::error::{SceneError, SceneResult};
use crate::geometry::{AlphaMask, TriangleAttributes, Triangles};
use crate::material::{ColorSource, Material, MaterialKind};
use crate::texture::{BumpKind, BumpMap, Texture, looks_like_normal_map};
use glam::{Mat3, Mat4, Vec2, Vec3};
use std::cell::RefCell;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use super::schema::*;

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

/// The BSDF an MTL material asks for: dielectric for `illum` 4, 6, 7, 9 or any transparency
/// (`d` < 1, `Tr` > 0), mirror for `illum` 5, 8 or a specular exponent of 10,000 or more, glossy
/// (GGX α from `Ns`) with any specular colour or texture, else diffuse.
fn material_kind(m: &tobj::Material, ks_c: Vec3) -> MaterialKind {
    let illum = m.illumination_model.unwrap_or(2);
    let tr: f32 = m
        .unknown_param
        .get("Tr")
        .and_then(|s| s.trim().parse().ok())
        .unwrap_or(0.0);
    let dissolve = m.dissolve.unwrap_or(1.0);
    let ns = m.shininess.unwrap_or(0.0);
    let has_ks = ks_c.max_element() > 0.0 || m.specular_texture.is_some();
    if matches!(illum, 4 | 6 | 7 | 9) || dissolve < 1.0 || tr > 0.0 {
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
    }
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

/// Which objects of an OBJ file a `[[mesh]]` takes.
pub(super) struct ObjectFilter<'a> {
    pub(super) only: Option<&'a [String]>,
    pub(super) exclude: &'a [String],
    /// The scene file and the `[[mesh]]` number (from 1) the selection comes from, for errors.
    pub(super) scene: &'a Path,
    pub(super) mesh: usize,
}

impl ObjectFilter<'_> {
    fn keeps(&self, name: &str) -> bool {
        self.only.is_none_or(|o| o.iter().any(|n| n == name))
            && !self.exclude.iter().any(|n| n == name)
    }

    /// Every name given must exist in the file, no name may be both kept and left out, and
    /// the selection must keep at least one object (an empty mesh is never what was meant).
    fn check(&self, models: &[tobj::Model], obj: &Path) -> SceneResult<()> {
        let bad = |message: String| {
            Err(SceneError::Invalid {
                path: self.scene.to_path_buf(),
                message: format!("[[mesh]] #{} ({}): {message}", self.mesh, obj.display()),
            })
        };
        let names: Vec<&str> = models.iter().map(|m| m.name.as_str()).collect();
        if self.only.is_some_and(|o| o.is_empty()) {
            return bad(
                "objects = [] selects no object (leave it out to load every object)".into(),
            );
        }
        let given = self.only.unwrap_or(&[]).iter().chain(self.exclude);
        for n in given {
            if !names.contains(&n.as_str()) {
                return bad(format!(
                    "no object or group is named {n:?} (the file has {names:?})"
                ));
            }
        }
        if let Some(n) = self
            .only
            .unwrap_or(&[])
            .iter()
            .find(|n| self.exclude.contains(n))
        {
            return bad(format!("{n:?} is in both objects and exclude_objects"));
        }
        if !names.iter().any(|n| self.keeps(n)) {
            return bad(format!(
                "objects and exclude_objects leave none of the file's objects {names:?}"
            ));
        }
        Ok(())
    }
}

#[derive(Default)]
pub(super) struct Builder {
    pub(super) tris: Triangles,
    pub(super) materials: Vec<Material>,
    pub(super) material_index: HashMap<String, u32>,
    pub(super) textures: Vec<Texture>,
    pub(super) texture_index: HashMap<PathBuf, u32>,
    /// Non-colour textures (bump and normal maps), by file, into `textures`.
    pub(super) data_index: HashMap<PathBuf, u32>,
    pub(super) masks: Vec<AlphaMask>,
    pub(super) mask_index: HashMap<(PathBuf, Option<char>), u32>,
    pub(super) default_material: Option<u32>,
    /// Material names the scene file overrides (`[materials.NAME]`): a `usemtl` stub of one of
    /// these is what the user asked for, not worth a warning.
    pub(super) overridden: std::collections::HashSet<String>,
    /// MTL materials whose ambient colour `Ka` exceeds 1 in a channel, with it and their MTL
    /// file: no reflectance does, and some files (tinyobjloader's Cornell box, for one) write
    /// an emitter's radiance there. aleph reads emission from `Ke` only; a scene without a
    /// light names these in its error.
    pub(super) ambient_above_one: Vec<(String, [f32; 3], PathBuf)>,
}

impl Builder {
    pub(super) fn texture(&mut self, dir: &Path, spec: &TextureSpec) -> SceneResult<ColorSource> {
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
        Ok(ColorSource::Texture {
            id,
            base: spec.base,
            gain: spec.gain,
        })
    }

    /// The cut-out mask of an MTL `map_d` argument: the `-imfchan` channel if given, else the
    /// image's alpha channel if it has one that is not opaque everywhere, else its luminance
    /// (values as stored, no sRGB decoding).
    pub(super) fn mask(&mut self, dir: &Path, spec: &TextureSpec) -> SceneResult<u32> {
        let path = dir.join(spec.file.replace('\\', "/"));
        let key = (path.clone(), spec.imfchan);
        if let Some(&id) = self.mask_index.get(&key) {
            return Ok(id);
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
        let rgba = img.into_rgba32f();
        // An alpha channel that is opaque everywhere masks nothing: the mask is then in the
        // colour channels (the MTL default for scalar maps, `-imfchan l`).
        let has_alpha = rgba.pixels().any(|p| p.0[3] < 1.0);
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
        Ok(id)
    }

    /// A bump (`normal = false`: height map unless the image is a normal map) or normal map.
    pub(super) fn bump(
        &mut self,
        dir: &Path,
        spec: &TextureSpec,
        normal: bool,
    ) -> SceneResult<BumpMap> {
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
        Ok(BumpMap { texture: id, kind })
    }

    pub(super) fn convert_material(
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
        // Every map_* statement's errors name the MTL file, the material and the statement.
        let at = |statement: &'static str| {
            move |e: SceneError| SceneError::MaterialTexture {
                mtl: mtl.to_path_buf(),
                material: m.name.clone(),
                statement,
                message: e.to_string(),
            }
        };
        let spec = |statement: &'static str, arg: &str| {
            parse_texture_spec(arg).ok_or_else(|| SceneError::MaterialTexture {
                mtl: mtl.to_path_buf(),
                material: m.name.clone(),
                statement,
                message: format!("names no image file (\"{statement} {}\")", arg.trim()),
            })
        };
        let kd = match &m.diffuse_texture {
            Some(t) => self
                .texture(dir, &spec("map_Kd", t)?)
                .map_err(at("map_Kd"))?,
            None => ColorSource::Constant(kd_c),
        };
        let ks = match &m.specular_texture {
            Some(t) => self
                .texture(dir, &spec("map_Ks", t)?)
                .map_err(at("map_Ks"))?,
            None => ColorSource::Constant(ks_c),
        };
        // tobj has no field for map_Ke; it lands in unknown_param.
        let emission = match m.unknown_param.get("map_Ke") {
            Some(t) => match self
                .texture(dir, &spec("map_Ke", t)?)
                .map_err(at("map_Ke"))?
            {
                ColorSource::Texture { id, base, gain } => {
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
        let kind = material_kind(m, ks_c);
        let ks = if kind == MaterialKind::Mirror && ks.is_black() {
            ColorSource::Constant(Vec3::ONE)
        } else {
            ks
        };
        let cutout = match &m.dissolve_texture {
            Some(t) => Some(self.mask(dir, &spec("map_d", t)?).map_err(at("map_d"))?),
            None => None,
        };
        let bump = match (m.unknown_param.get("norm"), &m.normal_texture) {
            (Some(t), _) => Some(
                self.bump(dir, &spec("norm", t)?, true)
                    .map_err(at("norm"))?,
            ),
            (None, Some(t)) => Some(
                self.bump(dir, &spec("bump", t)?, false)
                    .map_err(at("bump"))?,
            ),
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

    pub(super) fn load_obj(
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
        for m in &materials {
            if let Some(ka) = m.ambient.filter(|ka| ka.iter().any(|&c| c > 1.0)) {
                self.ambient_above_one
                    .push((m.name.clone(), ka, mtl_path.clone()));
            }
        }
        let mut local_to_global = Vec::with_capacity(materials.len());
        for m in &materials {
            let mat = self.convert_material(m, &mtl_dir, &mtl_path)?;
            let idx = self.materials.len() as u32;
            self.material_index.insert(m.name.clone(), idx);
            self.materials.push(mat);
            local_to_global.push(idx);
        }
        let normal_xf = Mat3::from_mat4(xf).inverse().transpose();
        select.check(&models, path)?;
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
    pub(super) fn add_model(
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

    pub(super) fn default_material(&mut self) -> u32 {
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
}
