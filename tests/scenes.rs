//! The bundled scenes load, map their MTL materials as documented, and render.

use crate::util::*;
use aleph::integrator::Strategy;
use aleph::material::{ColorSource, MaterialKind};
use aleph::scene::{Scene, SceneDescription};

fn load_small(rel: &str) -> Scene {
    let mut desc = SceneDescription::read(&repo(rel)).unwrap();
    desc.camera.resolution = [24, 16];
    Scene::load_description(desc).unwrap()
}

/// The material of `name` in `s`.
fn material<'a>(s: &'a Scene, name: &str) -> &'a aleph::material::Material {
    s.materials
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name}"))
}

#[test]
fn cornell_box_materials_and_light() {
    let s = load_small("scenes/cornell-box/scene.toml");
    assert_eq!(s.geometry.len(), 36);
    let light = material(&s, "light");
    assert!(
        matches!(light.emission, Some(ColorSource::Constant(c)) if c.to_array() == [17.0, 12.0, 4.0])
    );
    let red = material(&s, "leftWall");
    assert_eq!(red.kind, MaterialKind::Diffuse);
    // The light quad's two triangles are the only emitters, and they face down (−y).
    assert_eq!(s.lights.len(), 2);
    for t in s.lights.triangle_ids() {
        assert!(s.geometry.tris.get(t as usize).geometric_normal().y < -0.99);
    }
}

/// The Cornell box in millimetres (tinyobjloader's): its light's emission comes from the scene
/// file's override (the MTL writes it as `Ka`), its walls and blocks are white of reflectance 1,
/// and the back wall stands at z = 559.2 mm.
#[test]
fn cornell_box_in_original_units_emits_through_the_override() {
    let s = load_small("scenes/cornell-original/scene.toml");
    assert_eq!(s.geometry.len(), 36);
    let light = material(&s, "light");
    assert!(matches!(light.emission, Some(ColorSource::Constant(c)) if c.to_array() == [20.0; 3]));
    let white = material(&s, "white");
    assert_eq!(white.kind, MaterialKind::Diffuse);
    assert!(matches!(white.kd, ColorSource::Constant(c) if c.to_array() == [1.0; 3]));
    assert_eq!(s.lights.len(), 2);
    let mut z_max = f32::MIN;
    for i in 0..s.geometry.len() {
        let t = s.geometry.tris.get(i);
        for p in t.p {
            z_max = z_max.max(p.z);
        }
        if t.light != u32::MAX {
            assert!(t.geometric_normal().y < -0.99, "the light faces down");
        }
    }
    assert_eq!(z_max, 559.2);
}

#[test]
fn holodeck_textures_and_emissive_screens() {
    let s = load_small("scenes/holodeck/scene.toml");
    assert_eq!(s.geometry.len(), 4015 + 4); // the OBJ's triangles + two quad lights
    let wall = material(&s, "holodeckwirefrane");
    // Ks 0.2, Ns 20 with map_Kd and map_Ks: glossy, α = sqrt(2/22), both colours textured.
    match wall.kind {
        MaterialKind::Glossy { alpha } => assert!((alpha - (2.0f32 / 22.0).sqrt()).abs() < 1e-6),
        k => panic!("wall is {k:?}"),
    }
    assert!(matches!(wall.kd, ColorSource::Texture { .. }));
    assert!(matches!(wall.ks, ColorSource::Texture { .. }));
    // map_Ke -mm 0 0.4 screen.png with Ke 1: emission = 0.4 × texel.
    let screens = material(&s, "screens");
    match screens.emission {
        Some(ColorSource::Texture { base, gain, .. }) => assert_eq!((base, gain), (0.0, 0.4)),
        e => panic!("screens emission is {e:?}"),
    }
    assert_eq!(s.textures.len(), 3);
    let film = render(&s, Strategy::Mis, 4);
    let rgb = film.mean_rgb();
    assert!(rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
    assert!(rgb.iter().any(|&v| v > 0.0));
}

#[test]
fn cornell_variants_materials_and_lights() {
    // Glossy: Ks 0.9 / 0.8 at Ns 40 are GGX lobes of α = sqrt(2 / (Ns + 2)); the MTL lacks the
    // `light` its OBJ uses, and the scene file gives it the original box's emission.
    let g = load_small("scenes/cornell-variants/glossy.toml");
    for name in ["sphere", "shortBox"] {
        match material(&g, name).kind {
            MaterialKind::Glossy { alpha } => {
                assert!(
                    (alpha - (2.0f32 / 42.0).sqrt()).abs() < 1e-6,
                    "{name}: α {alpha}"
                )
            }
            k => panic!("{name} is {k:?}"),
        }
    }
    assert!(matches!(material(&g, "light").emission,
        Some(ColorSource::Constant(c)) if c.to_array() == [17.0, 12.0, 4.0]));
    assert_eq!(g.lights.len(), 2);
    // Mirror: illum 5 makes the tall box a mirror of Ks 0.95.
    let m = load_small("scenes/cornell-variants/mirror.toml");
    assert_eq!(material(&m, "tallBox").kind, MaterialKind::Mirror);
    assert_eq!(m.lights.len(), 2);
    // Sphere: a mirror sphere and a clear dielectric one of Ni 2.5 (the MTL's Tf 0.1 overridden).
    let s = load_small("scenes/cornell-variants/sphere.toml");
    assert_eq!(material(&s, "leftSphere").kind, MaterialKind::Mirror);
    assert!(
        matches!(material(&s, "rightSphere").kind, MaterialKind::Dielectric { ior } if ior == 2.5)
    );
    assert_eq!(material(&s, "rightSphere").transmittance, glam::Vec3::ONE);
    for scene in [&g, &m, &s] {
        let rgb = render(scene, Strategy::Mis, 4).mean_rgb();
        assert!(rgb.iter().all(|v| v.is_finite() && *v >= 0.0));
        assert!(rgb.iter().any(|&v| v > 0.0));
    }
}
