//! Every `[[light]]` entry of a scene file, checked in one place: quads (added to the geometry
//! as emissive triangles), the environment, suns, point and spot lights.

use super::obj::Builder;
use super::schema::{LightDesc, MAX_COORDINATE, MAX_LUMINANCE_CD_M2, SceneDescription};
use crate::error::SceneResult;
use crate::geometry::{STATIC_INSTANCE, TriangleAttributes};
use crate::light::{Environment, OtherLights, PointLight, SUN_ANGULAR_DIAMETER_DEG, Sun};
use crate::material::{ColorSource, Material, MaterialKind};
use glam::Vec2;
use glam::Vec3;
use std::path::Path;

/// Checks that every value is finite and, for colours, ≥ 0.
fn colour(v: [f32; 3], key: &str) -> Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite() && *x >= 0.0) {
        Ok(Vec3::from(v))
    } else {
        Err(format!("{key} must be finite and ≥ 0, got {v:?}"))
    }
}

fn position(v: [f32; 3], key: &str) -> Result<Vec3, String> {
    if v.iter().all(|x| x.is_finite() && x.abs() <= MAX_COORDINATE) {
        Ok(Vec3::from(v))
    } else {
        Err(format!(
            "{key} must be finite and within ±{MAX_COORDINATE:e}, got {v:?}"
        ))
    }
}

fn angle(v: Option<f32>, default: f32, key: &str, lo: f32, hi: f32) -> Result<f32, String> {
    let a = v.unwrap_or(default);
    if a.is_finite() && a > lo && a < hi {
        Ok(a)
    } else {
        Err(format!("{key} must be in ({lo}, {hi}) degrees, got {a}"))
    }
}

/// Loads an equirectangular environment image (EXR, Radiance HDR, or PNG/JPEG taken as sRGB).
fn environment_map(
    base: &Path,
    file: &Path,
    strength: f32,
    rotate: f32,
) -> Result<Environment, String> {
    let path = base.join(file);
    let img = crate::imageio::read_image(&path).map_err(|e| e.to_string())?;
    if img.width != 2 * img.height {
        eprintln!(
            "warning: {}: an equirectangular map is usually twice as wide as high; this one is \
             {}×{} (used as is)",
            path.display(),
            img.width,
            img.height
        );
    }
    if img.clamped_negative > 0 {
        eprintln!(
            "warning: {}: {} negative texel values clamped to 0 (radiance cannot be negative)",
            path.display(),
            img.clamped_negative
        );
    }
    let rgb: Vec<Vec3> = img
        .rgb
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    if let Some(i) = rgb.iter().position(|&c| !(c * strength).is_finite()) {
        return Err(format!(
            "{}: texel ({}, {}) = {:e} times strength {strength} overflows f32",
            path.display(),
            i % img.width,
            i / img.width,
            rgb[i].max_element()
        ));
    }
    Environment::from_map(img.width, img.height, &rgb, strength, rotate).ok_or_else(|| {
        format!(
            "{}: the environment map is black everywhere",
            path.display()
        )
    })
}

fn environment(
    base: &Path,
    file: &Option<std::path::PathBuf>,
    radiance: Option<[f32; 3]>,
    strength: Option<f32>,
    rotate_deg: Option<f32>,
) -> Result<Environment, String> {
    let strength = strength.unwrap_or(1.0);
    if !(strength.is_finite() && strength >= 0.0) {
        return Err(format!("strength must be finite and ≥ 0, got {strength}"));
    }
    let rotate = rotate_deg.unwrap_or(0.0);
    if !rotate.is_finite() {
        return Err(format!("rotate_deg must be finite, got {rotate}"));
    }
    match (file, radiance) {
        (Some(_), Some(_)) => Err("give either file or radiance, not both".into()),
        (None, None) => Err("give a file (an equirectangular .hdr or .exr) or a radiance".into()),
        (None, Some(r)) => Ok(Environment::constant(colour(r, "radiance")? * strength)),
        (Some(f), None) => environment_map(base, f, strength, rotate),
    }
}

fn sun(direction: [f32; 3], irradiance: [f32; 3], diameter: Option<f32>) -> Result<Sun, String> {
    let d = position(direction, "direction")?;
    let e = colour(irradiance, "irradiance")?;
    let a = angle(
        diameter,
        SUN_ANGULAR_DIAMETER_DEG,
        "angular_diameter_deg",
        0.0,
        180.0,
    )?;
    Sun::new(d, e, a).ok_or_else(|| "direction must not be zero".into())
}

fn spot(
    position_: [f32; 3],
    look_at: [f32; 3],
    intensity: [f32; 3],
    cone: Option<f32>,
    delta: Option<f32>,
) -> Result<PointLight, String> {
    let p = position(position_, "position")?;
    let axis = (position(look_at, "look_at")? - p).normalize_or_zero();
    if axis == Vec3::ZERO {
        return Err("look_at must differ from position".into());
    }
    let total = angle(cone, 30.0, "cone_angle_deg", 0.0, 180.0)?;
    let width = delta.unwrap_or(5.0);
    if !(width.is_finite() && (0.0..=total).contains(&width)) {
        return Err(format!(
            "cone_delta_deg must be in [0, cone_angle_deg = {total}], got {width}"
        ));
    }
    Ok(PointLight {
        position: p,
        intensity: colour(intensity, "intensity")?,
        spot: Some((
            axis,
            total.to_radians().cos(),
            (total - width).to_radians().cos(),
        )),
    })
}

/// Builds the non-geometric lights of the scene's `[[light]]` list.
///
/// # Errors
/// [`crate::error::SceneError::Invalid`] naming the scene file and the light's number: a value
/// out of range, two environments, an unreadable or black environment map, or emission whose
/// luminance overflows f32 at the scene's luminance scale.
pub(super) fn other_lights(
    desc: &SceneDescription,
    luminance_scale: f32,
) -> SceneResult<OtherLights> {
    let base = desc.path.parent().unwrap_or(Path::new(""));
    let mut out = OtherLights::default();
    for (i, l) in desc.lights.iter().enumerate() {
        let at = |msg: String| desc.invalid(format!("[[light]] #{}: {msg}", i + 1));
        let peak = match l {
            LightDesc::Quad { .. } => continue,
            LightDesc::Environment {
                file,
                radiance,
                strength,
                rotate_deg,
            } => {
                if out.environment.is_some() {
                    return Err(at("a scene has at most one environment".into()));
                }
                let env = environment(base, file, *radiance, *strength, *rotate_deg).map_err(at)?;
                let peak = env.max_radiance().max_element();
                out.environment = Some(env);
                peak
            }
            LightDesc::Sun {
                direction,
                irradiance,
                angular_diameter_deg,
            } => {
                let s = sun(*direction, *irradiance, *angular_diameter_deg).map_err(at)?;
                let peak = s.radiance.max_element();
                out.suns.push(s);
                peak
            }
            LightDesc::Point {
                position: p,
                intensity,
            } => {
                let light = PointLight {
                    position: position(*p, "position").map_err(at)?,
                    intensity: colour(*intensity, "intensity").map_err(at)?,
                    spot: None,
                };
                let peak = light.intensity.max_element();
                out.points.push(light);
                peak
            }
            LightDesc::Spot {
                position: p,
                look_at,
                intensity,
                cone_angle_deg,
                cone_delta_deg,
            } => {
                let light =
                    spot(*p, *look_at, *intensity, *cone_angle_deg, *cone_delta_deg).map_err(at)?;
                let peak = light.intensity.max_element();
                out.points.push(light);
                peak
            }
        };
        let lum = peak as f64 * luminance_scale as f64;
        if !lum.is_finite() || lum > MAX_LUMINANCE_CD_M2 {
            return Err(at(format!(
                "peak emission {peak:e} × luminance_scale {luminance_scale} is beyond \
                 {MAX_LUMINANCE_CD_M2:e} cd/m², where f32 image arithmetic overflows"
            )));
        }
    }
    Ok(out)
}

/// Adds every `[[light]]` quad as two emissive triangles with a material of its own.
pub(super) fn add_light_quads(desc: &SceneDescription, b: &mut Builder) -> SceneResult<()> {
    for (i, l) in desc.lights.iter().enumerate() {
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
                        desc.invalid(format!("[[light]] #{}: values must be finite", i + 1))
                    );
                }
                if radiance.iter().any(|&v| v < 0.0) {
                    return Err(desc.invalid(format!("[[light]] #{}: radiance must be ≥ 0", i + 1)));
                }
                let (c, e1, e2) = (Vec3::from(*corner), Vec3::from(*edge1), Vec3::from(*edge2));
                let far = [c, c + e1, c + e2, c + e1 + e2]
                    .iter()
                    .any(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE);
                if far {
                    return Err(desc.invalid(format!(
                        "[[light]] #{}: corners beyond ±{MAX_COORDINATE:e}, where f32 \
                             arithmetic overflows",
                        i + 1
                    )));
                }
                if e1.cross(e2).length() <= 0.0 {
                    return Err(desc.invalid(format!(
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
