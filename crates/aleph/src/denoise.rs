//! Denoising a render with Intel Open Image Denoise (OIDN 2.5, its "RT" filter), given clean
//! auxiliary images from the renderer: the albedo and the normal of the first non-specular
//! surface each pixel sees, averaged over jittered samples (Cycles' "Denoising Albedo" and
//! "Denoising Normal" passes; OIDN's documentation, "RT filter", for their meaning).
//!
//! The library is optional: built with the `denoise` feature (scripts/oidn.sh installs it and
//! points the build at it), [`AVAILABLE`] is true; without it [`denoise`] returns
//! [`DenoiseError::NotBuilt`], whose message says how to build it, so callers can refuse
//! `--denoise` before rendering.

use crate::film::Film;
use crate::rng::{Rng, mix64};
use crate::sampler::sobol::shuffled_scrambled_sobol2d;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Whether this build can denoise (the `denoise` feature).
pub const AVAILABLE: bool = cfg!(feature = "denoise");

/// How to build a binary that denoises, for messages.
pub const HOW_TO_BUILD: &str = "this aleph was built without denoising; build it with \
     `eval \"$(bash scripts/oidn.sh)\" && cargo build --release --features denoise` \
     (docs/denoise.md)";

/// Samples per pixel of the auxiliary images (their edges are antialiased like the render's).
pub const AUX_SPP: u32 = 16;

/// Samples per pixel of the auxiliary images a preview's first images (its first pass, shown
/// at 1 spp and whole) are denoised with; the full ones ([`AUX_SPP`]) are made for the loop's
/// first judgement. On the holodeck at 512² (2 cores) 4-spp ones took 0.15 s of the 0.9–1.0 s
/// before the first image; with 2 spp it came at 0.78–0.87 s, its FLIP mean against a 512-spp
/// reference 0.138 (4 spp: 0.132, 16: 0.126, 1: 0.147).
pub const PREVIEW_FIRST_AUX_SPP: u32 = 2;

/// Seed offset of the auxiliary images, independent of the render's samples.
const AUX_SEED_XOR: u64 = 0xA0C5_11AE;

/// The final denoising a user asks for (`aleph render --denoise-quality`, a job's
/// `output.denoise_quality`), as Blender's denoiser "Quality" setting offers it: the model the
/// EXR's and the PNG's image is denoised by. A preview's refinements and the loop's
/// judgements use the fast model either way.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FinalQuality {
    /// OIDN's high-quality filter, its large model for clean auxiliary images where they have
    /// at least the image's samples ([`Quality::final_for`]).
    #[default]
    High,
    /// OIDN's fast filter ([`Quality::Fast`]): on the Cornell box at 256² and 2 cores 0.04 s
    /// against the large model's 0.15 s; a worse image per sample on all four bundled stills,
    /// a better one per second on the Cornell box, the Mori knob and Lost Empire at 2–8 spp,
    /// a worse one on the holodeck (docs/denoise.md, "Which model and how many auxiliary
    /// samples, per unit of time").
    Fast,
}

/// OIDN's filter quality ("quality" of the RT filter, OIDN 2 documentation) and whether it is
/// told the auxiliary images are clean (`cleanAux`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Quality {
    /// OIDN's high-quality model, the auxiliary images taken as possibly noisy: 0.33 s for
    /// 512² on 2 cores. For an image of more samples per pixel than its auxiliary images
    /// ([`Quality::final_for`]).
    #[default]
    High,
    /// OIDN's large model for clean auxiliary images (high quality with `cleanAux`), about
    /// 0.8 s for 512² on 2 cores: for an image of no more samples per pixel than its auxiliary
    /// images ([`Quality::final_for`]).
    HighCleanAux,
    /// The smaller, faster model OIDN offers for interactive previews (`cleanAux` off, where
    /// it denoised better): 512² on 2 cores in 0.18 s (OIDN 2.5.1's CPU device; its
    /// "balanced" mode runs the high model without `cleanAux` there).
    Fast,
}

impl Quality {
    /// How OIDN was asked to run, for files' metadata: its filter quality and whether the
    /// auxiliary images were declared clean.
    pub fn describe(self) -> &'static str {
        match self {
            Quality::High => "quality high, cleanAux false",
            Quality::HighCleanAux => "quality high, cleanAux true (the large model)",
            Quality::Fast => "quality fast, cleanAux false",
        }
    }

    /// The model for a final image a user asked `want` of: [`Quality::final_for`] for
    /// [`FinalQuality::High`], [`Quality::Fast`] for [`FinalQuality::Fast`].
    pub fn chosen(want: FinalQuality, spp: f64, aux_spp: u32) -> Quality {
        match want {
            FinalQuality::High => Quality::final_for(spp, aux_spp),
            FinalQuality::Fast => Quality::Fast,
        }
    }

    /// The model for a final image of `spp` samples per pixel (mean; fresh and reused) with
    /// auxiliary images of `aux_spp`: [`Quality::HighCleanAux`] where the auxiliaries have at
    /// least the image's samples, as OIDN's `cleanAux` asks (auxiliaries without noise
    /// relative to the colour), else [`Quality::High`]. Measured against 4096-spp references
    /// (uniform, 256², 16-spp auxiliaries, docs/denoise.md): with `cleanAux` ColorVideoVDP JOD
    /// rose on the Cornell box, Mori knob, Lost Empire and holodeck at 1–16 spp, and FLIP
    /// mean fell on all four at 1–8; from 16 spp the holodeck's FLIP mean rose (at 32: 0.0742
    /// against 0.0674; at its stop, 699 spp, 0.0439 against 0.0328), the large model keeping
    /// the 16-spp auxiliaries' sub-pixel detail as texture.
    pub fn final_for(spp: f64, aux_spp: u32) -> Quality {
        if spp <= aux_spp as f64 {
            Quality::HighCleanAux
        } else {
            Quality::High
        }
    }
}

/// Why an image could not be denoised.
#[derive(Debug, thiserror::Error)]
pub enum DenoiseError {
    /// The binary was built without the `denoise` feature.
    #[error("{HOW_TO_BUILD}")]
    NotBuilt,
    /// Open Image Denoise refused or failed (no CPU device, out of memory, …).
    #[error("Open Image Denoise: {0}")]
    Oidn(String),
    /// The buffers do not describe a `width × height` RGB image.
    #[error("denoise: {0}")]
    Size(String),
}

/// The auxiliary images of a render, interleaved RGB / XYZ, row-major, `3 · width · height`
/// values each.
#[derive(Clone, Debug, PartialEq)]
pub struct Aux {
    /// Albedo of the first non-specular surface, in [0, 1] per channel (an emitter or the sky
    /// seen directly reports its radiance capped at luminance 1).
    pub albedo: Vec<f32>,
    /// Its normal in world space, facing the camera, averaged over the pixel's samples (length
    /// up to 1; zero where every sample missed the scene).
    pub normal: Vec<f32>,
}

/// Samples every pixel's auxiliary images take first ([`render_aux`]): the first four points of
/// the pixel's Owen-scrambled Sobol' sequence, one in each quadrant of the pixel (and in each
/// quarter of its width and of its height).
pub const AUX_FIRST_SPP: u32 = 4;

/// Largest difference, per channel of the albedo and per component of the normal, between the
/// first [`AUX_FIRST_SPP`] samples of a pixel for it to count as one surface ([`render_aux`]):
/// one step of an 8-bit albedo. Where they agree so, their mean is within it of the mean of
/// any other samples that agree as well.
pub const AUX_AGREE: f32 = 1.0 / 256.0;

/// Largest difference per albedo channel between the first [`AUX_FIRST_SPP`] samples of a
/// pixel whose samples all saw one textured material with one normal, for them to stand for
/// the pixel ([`render_aux`]): sixteen 8-bit steps. Four stratified samples average a texture
/// that changes this little within the pixel nearly as well as sixteen do (against 1024-sample
/// references, the albedo's RMS error on the holodeck and Lost Empire 1.02× that of the rule
/// before, which took all sixteen wherever a channel changed by more than [`AUX_AGREE`];
/// docs/denoise.md); the grid lines and block edges that change more take all sixteen.
pub const AUX_TEXTURE_AGREE: f32 = 1.0 / 16.0;

/// Renders the auxiliary images of `scene` with up to `spp` samples per pixel under `seed`
/// (deterministic for any thread count). A pixel's positions are the points of a shuffled,
/// Owen-scrambled 2-D Sobol' sequence of its own
/// ([`crate::sampler::sobol::shuffled_scrambled_sobol2d`]), so every power-of-two prefix is a
/// net over the pixel. Every pixel takes the first [`AUX_FIRST_SPP`]; where those see one
/// surface (albedo and normal agree within [`AUX_AGREE`], or, on one textured material, the
/// albedo within [`AUX_TEXTURE_AGREE`]) and their mean agrees with the 4-neighbours' as well,
/// it is the pixel's value; the rest, the pixels on either side of an edge, a texture's sharp
/// detail, glass or motion, take all `spp` ([`edges`]).
pub fn render_aux(scene: &Scene, spp: u32, seed: u64) -> Aux {
    render_aux_counted(scene, spp, seed).0
}

/// [`render_aux`] and the number of first-surface samples it took (at most `spp` a pixel).
pub fn render_aux_counted(scene: &Scene, spp: u32, seed: u64) -> (Aux, u64) {
    let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
    let seed = seed ^ AUX_SEED_XOR;
    let first = spp.min(AUX_FIRST_SPP);
    let mut px = vec![AuxSum::EMPTY; w * h];
    px.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
        for (x, p) in row.iter_mut().enumerate() {
            *p = AuxSum::of(scene, seed, y * w + x, 0..first);
        }
    });
    if spp > first {
        let near_edge = edges(&px, w, h);
        px.par_chunks_mut(w)
            .zip(near_edge.par_chunks(w))
            .enumerate()
            .for_each(|(y, (row, near))| {
                for (x, p) in row.iter_mut().enumerate() {
                    if near[x] {
                        p.add(&AuxSum::of(scene, seed, y * w + x, first..spp));
                    }
                }
            });
    }
    let mut albedo = Vec::with_capacity(3 * w * h);
    let mut normal = Vec::with_capacity(3 * w * h);
    for p in &px {
        let (a, n) = p.mean();
        albedo.extend_from_slice(&a.to_array());
        normal.extend_from_slice(&n.to_array());
    }
    let taken = px.iter().map(|p| p.taken as u64).sum();
    (Aux { albedo, normal }, taken)
}

/// Which pixels of a `w × h` image of first samples `px` take the rest of their samples: those
/// whose samples disagree, and those whose mean differs from a 4-neighbour's (an edge that runs
/// along the border between two pixels, which each pixel's first samples saw on one side only).
fn edges(px: &[AuxSum], w: usize, h: usize) -> Vec<bool> {
    let means: Vec<[f32; 6]> = px
        .par_iter()
        .map(|p| {
            let (a, n) = p.mean();
            [a.x, a.y, a.z, n.x, n.y, n.z]
        })
        .collect();
    (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (x, y) = (i % w, i / w);
            // Neighbours on one textured material may differ in albedo by the texture's detail.
            let differs = |j: usize| {
                let one_texture = px[i]
                    .one_texture()
                    .is_some_and(|m| px[j].one_texture() == Some(m));
                !one_surface(
                    std::array::from_fn(|c| (means[i][c] - means[j][c]).abs()),
                    one_texture,
                )
            };
            !px[i].uniform()
                || (x > 0 && differs(i - 1))
                || (x + 1 < w && differs(i + 1))
                || (y > 0 && differs(i - w))
                || (y + 1 < h && differs(i + w))
        })
        .collect()
}

/// Whether differences `d` (per albedo channel, then per normal component) are those of one
/// surface: each within [`AUX_AGREE`], the albedo's within [`AUX_TEXTURE_AGREE`] on one textured
/// material (`textured`).
fn one_surface(d: [f32; 6], textured: bool) -> bool {
    (0..6).all(|c| {
        let tol = if textured && c < 3 {
            AUX_TEXTURE_AGREE
        } else {
            AUX_AGREE
        };
        d[c] <= tol
    })
}

/// One pixel's auxiliary samples: their sums, how many were taken, the range of each albedo
/// channel and normal component over them, and the textured material all of them saw.
#[derive(Clone, Copy, Debug)]
struct AuxSum {
    albedo: Vec3,
    normal: Vec3,
    taken: u32,
    lo: [f32; 6],
    hi: [f32; 6],
    /// The index of the textured material every sample saw; [`AuxSum::NONE_YET`] before the
    /// first sample, [`AuxSum::NOT_ONE`] where any saw another surface or no textured one.
    material: u32,
}

impl AuxSum {
    const NONE_YET: u32 = u32::MAX;
    const NOT_ONE: u32 = u32::MAX - 1;

    const EMPTY: AuxSum = AuxSum {
        albedo: Vec3::ZERO,
        normal: Vec3::ZERO,
        taken: 0,
        lo: [f32::INFINITY; 6],
        hi: [f32::NEG_INFINITY; 6],
        material: AuxSum::NONE_YET,
    };

    /// The textured material all the samples saw, if they saw one.
    fn one_texture(&self) -> Option<u32> {
        (self.material < AuxSum::NOT_ONE).then_some(self.material)
    }

    /// Records that a sample saw `textured` ([`crate::integrator::FirstSurface::textured`]).
    fn saw(&mut self, textured: Option<u32>) {
        self.material = match (self.material, textured) {
            (AuxSum::NONE_YET, Some(m)) => m,
            (m, Some(t)) if m == t => m,
            _ => AuxSum::NOT_ONE,
        };
    }

    /// Samples `ks` of pixel `index` (a finite sample adds to the sums; a non-finite one adds
    /// zero and makes the pixel non-uniform).
    fn of(scene: &Scene, seed: u64, index: usize, ks: std::ops::Range<u32>) -> AuxSum {
        let w = scene.camera.width as usize;
        let stream = mix64(seed ^ mix64((index as u64).wrapping_mul(0xD1B5_4A32_D192_ED03) ^ 3));
        let (x, y) = ((index % w) as u32, (index / w) as u32);
        let mut s = AuxSum::EMPTY;
        for k in ks {
            let (i, k) = (index as u64, k as u64);
            let time = scene.sample_time(seed, i, k);
            let u = shuffled_scrambled_sobol2d(k as u32, stream);
            let ray = scene.camera_ray(seed, (x, y), k, u, time);
            let mut rng = Rng::for_sample(seed, i, k);
            let first = crate::integrator::first_surface(scene, ray, &mut rng);
            let (albedo, normal) = (first.albedo, first.normal);
            s.saw(first.textured);
            // Albedo in [0, 1] as OIDN requires: an emitter's capped radiance scaled to
            // luminance 1.
            let l = crate::math::luminance(albedo);
            let albedo = if l > 1.0 { albedo / l } else { albedo };
            s.taken += 1;
            if !(albedo.is_finite() && normal.is_finite()) {
                s.lo = [f32::NEG_INFINITY; 6];
                s.hi = [f32::INFINITY; 6];
                continue;
            }
            let albedo = albedo.clamp(Vec3::ZERO, Vec3::ONE);
            s.albedo += albedo;
            s.normal += normal;
            let v = [albedo.x, albedo.y, albedo.z, normal.x, normal.y, normal.z];
            for ((lo, hi), v) in s.lo.iter_mut().zip(&mut s.hi).zip(v) {
                *lo = lo.min(v);
                *hi = hi.max(v);
            }
        }
        s
    }

    /// Whether every sample saw one surface: the same normal within [`AUX_AGREE`], and the
    /// same albedo within it, or within [`AUX_TEXTURE_AGREE`] on one textured material.
    fn uniform(&self) -> bool {
        let spread = std::array::from_fn(|c| self.hi[c] - self.lo[c]);
        one_surface(spread, self.one_texture().is_some())
    }

    /// The mean albedo and normal over the samples taken (zero if none were).
    fn mean(&self) -> (Vec3, Vec3) {
        let k = self.taken.max(1) as f32;
        (self.albedo / k, self.normal / k)
    }

    /// Adds `o`'s sums and count (what the pixel's mean needs; the ranges and the material
    /// are read only by [`edges`], before any pixel takes more samples).
    fn add(&mut self, o: &AuxSum) {
        self.albedo += o.albedo;
        self.normal += o.normal;
        self.taken += o.taken;
    }
}

/// Denoises the linear RGB radiance `rgb` (interleaved, `3 · width · height`, any positive
/// scale: the filter is told it is HDR) with the auxiliary images, which it takes as clean
/// (`cleanAux`). Returns the denoised RGB, same layout and units.
///
/// Pixels where every auxiliary sample missed the scene (normal exactly zero) keep their input:
/// they see only the background, whose one source of variance is the pixel filter over the
/// environment's texels, and OIDN fills a black background with traces of light (up to 0.009
/// beside the Cornell box's 17.2 emitter) that move a log-average tone curve: Reinhard's L̄_w
/// of the box rose 25 % and its PNG came out 0.01 darker everywhere.
///
/// # Errors
/// [`DenoiseError::NotBuilt`] without the `denoise` feature; [`DenoiseError::Size`] if the
/// buffers' lengths do not match; [`DenoiseError::Oidn`] if the library fails.
pub fn denoise(
    rgb: &[f32],
    width: usize,
    height: usize,
    aux: &Aux,
) -> Result<Vec<f32>, DenoiseError> {
    denoise_with(rgb, width, height, aux, Quality::High)
}

/// [`denoise`] with OIDN's model of quality `quality`.
///
/// # Errors
/// As [`denoise`].
pub fn denoise_with(
    rgb: &[f32],
    width: usize,
    height: usize,
    aux: &Aux,
    quality: Quality,
) -> Result<Vec<f32>, DenoiseError> {
    let n = 3 * width * height;
    if rgb.len() != n || aux.albedo.len() != n || aux.normal.len() != n || n == 0 {
        return Err(DenoiseError::Size(format!(
            "{width}×{height} needs {n} values per image; got colour {}, albedo {}, normal {}",
            rgb.len(),
            aux.albedo.len(),
            aux.normal.len()
        )));
    }
    let mut out = run_oidn(rgb, (width, height), aux, quality)?;
    for ((o, i), n) in out
        .chunks_exact_mut(3)
        .zip(rgb.chunks_exact(3))
        .zip(aux.normal.chunks_exact(3))
    {
        if n.iter().all(|&v| v == 0.0) {
            o.copy_from_slice(i);
        }
    }
    Ok(out)
}

/// The process's OIDN CPU device, made at the first denoising and kept: making one for every
/// image cost 0.05 s of a 512² denoising (0.39 s against 0.33 s on 2 cores), and a perceptual
/// judgement denoises twice. Denoisings take turns on it (OIDN runs each on every core).
#[cfg(feature = "denoise")]
static DEVICE: std::sync::Mutex<Option<ffi::Device>> = std::sync::Mutex::new(None);

#[cfg(feature = "denoise")]
fn run_oidn(
    rgb: &[f32],
    size: (usize, usize),
    aux: &Aux,
    quality: Quality,
) -> Result<Vec<f32>, DenoiseError> {
    let mut device = DEVICE.lock().unwrap_or_else(|e| e.into_inner());
    if device.is_none() {
        *device = Some(ffi::Device::cpu().map_err(DenoiseError::Oidn)?);
    }
    let dev = device.as_ref().expect("made above");
    let mut out = vec![0f32; rgb.len()];
    if let Err(e) = dev.denoise(rgb, aux, &mut out, size, quality) {
        // A device that failed is not trusted with the next image.
        *device = None;
        return Err(DenoiseError::Oidn(e));
    }
    Ok(out)
}

/// OIDN's RT filter through the C API the `oidn` crate binds (`oidn::sys`). The crate's own
/// filter type (2.5.1) passes its clean-auxiliaries flag to OIDN as `clean_aux`, a name OIDN
/// does not know (it warns "unknown filter parameter" and keeps `cleanAux` false); the filter
/// here is set up as the OIDN 2 API documents it, with the images shared, not copied.
///
/// `cleanAux` is set for [`Quality::HighCleanAux`] only, where OIDN then runs its large model
/// for clean auxiliary images ([`Quality::final_for`] tells when).
#[cfg(feature = "denoise")]
mod ffi {
    use super::{Aux, Quality};
    use oidn::sys;
    use std::ffi::{CStr, c_char};

    /// An OIDN CPU device ([`Device::cpu`]).
    pub(super) struct Device(sys::OIDNDevice);

    // SAFETY: OIDN's API may be called from any thread; the caller keeps the device under a
    // mutex, so one filter runs on it at a time.
    unsafe impl Send for Device {}

    impl Drop for Device {
        fn drop(&mut self) {
            // SAFETY: the handle came from oidnNewDevice and is released once.
            unsafe { sys::oidnReleaseDevice(self.0) }
        }
    }

    /// A filter, released when dropped.
    struct Filter(sys::OIDNFilter);

    impl Drop for Filter {
        fn drop(&mut self) {
            // SAFETY: the handle came from oidnNewFilter and is released once.
            unsafe { sys::oidnReleaseFilter(self.0) }
        }
    }

    impl Device {
        /// A committed CPU device.
        pub(super) fn cpu() -> Result<Device, String> {
            // SAFETY: a plain call of the C API; a null device is refused before any use.
            let d = unsafe { sys::oidnNewDevice(sys::OIDNDeviceType_OIDN_DEVICE_TYPE_CPU) };
            if d.is_null() {
                return Err("Open Image Denoise has no CPU device here".into());
            }
            let dev = Device(d);
            // SAFETY: `d` is a live device handle.
            unsafe { sys::oidnCommitDevice(d) };
            dev.error()?;
            Ok(dev)
        }

        /// The device's pending error, if any (clearing it).
        fn error(&self) -> Result<(), String> {
            let mut msg: *const c_char = std::ptr::null();
            // SAFETY: OIDN writes `msg` with a string it owns until its next call on the device.
            let code = unsafe { sys::oidnGetDeviceError(self.0, &mut msg) };
            if code == sys::OIDNError_OIDN_ERROR_NONE {
                return Ok(());
            }
            let text = if msg.is_null() {
                String::new()
            } else {
                // SAFETY: a NUL-terminated string from OIDN, copied at once.
                unsafe { CStr::from_ptr(msg) }
                    .to_string_lossy()
                    .into_owned()
            };
            Err(format!("Open Image Denoise error {code}: {text}"))
        }

        /// Runs the RT filter on `rgb` (HDR) with `aux` into `out`, all interleaved RGB of
        /// `w × h` pixels; `cleanAux` set for [`Quality::HighCleanAux`].
        ///
        /// # Panics
        /// If an image or `out` does not hold 3 · w · h values.
        pub(super) fn denoise(
            &self,
            rgb: &[f32],
            aux: &Aux,
            out: &mut [f32],
            (w, h): (usize, usize),
            quality: Quality,
        ) -> Result<(), String> {
            let n = 3 * w * h;
            assert!(rgb.len() == n && aux.albedo.len() == n && aux.normal.len() == n);
            assert_eq!(out.len(), n, "output size");
            let clean_aux = quality == Quality::HighCleanAux;
            let quality = match quality {
                Quality::High | Quality::HighCleanAux => sys::OIDNQuality_OIDN_QUALITY_HIGH,
                Quality::Fast => sys::OIDNQuality_OIDN_QUALITY_FAST,
            };
            // SAFETY: every image holds w × h packed FLOAT3 pixels (asserted) and is borrowed
            // for this call; OIDN reads the inputs and writes `out` only inside
            // oidnExecuteFilter, and the filter is released (dropped) before the call returns.
            unsafe {
                let f = sys::oidnNewFilter(self.0, c"RT".as_ptr());
                if f.is_null() {
                    self.error()?;
                    return Err("Open Image Denoise made no RT filter".into());
                }
                let f = Filter(f);
                let image = |name: &CStr, data: *const f32| {
                    let format = sys::OIDNFormat_OIDN_FORMAT_FLOAT3;
                    let p = data as *mut std::ffi::c_void;
                    sys::oidnSetSharedFilterImage(f.0, name.as_ptr(), p, format, w, h, 0, 0, 0)
                };
                image(c"color", rgb.as_ptr());
                image(c"albedo", aux.albedo.as_ptr());
                image(c"normal", aux.normal.as_ptr());
                image(c"output", out.as_mut_ptr());
                sys::oidnSetFilterBool(f.0, c"hdr".as_ptr(), true);
                sys::oidnSetFilterBool(f.0, c"cleanAux".as_ptr(), clean_aux);
                sys::oidnSetFilterInt(f.0, c"quality".as_ptr(), quality);
                sys::oidnCommitFilter(f.0);
                self.error()?;
                sys::oidnExecuteFilter(f.0);
            }
            self.error()
        }
    }
}

#[cfg(not(feature = "denoise"))]
fn run_oidn(_: &[f32], _: (usize, usize), _: &Aux, _: Quality) -> Result<Vec<f32>, DenoiseError> {
    Err(DenoiseError::NotBuilt)
}

/// A denoised render: the denoised and the raw radiance (interleaved RGB, W·sr⁻¹·m⁻²) and the
/// auxiliary images the denoiser was given.
#[derive(Clone, Debug)]
pub struct Denoised {
    /// The denoised radiance (interleaved RGB), blended with `noisy` by their estimated
    /// errors above [`BLEND_ABOVE_SPP`] ([`Denoised::blend_with_noisy`]).
    pub rgb: Vec<f32>,
    /// The render before denoising.
    pub noisy: Vec<f32>,
    /// Albedo and normal ([`render_aux`] at [`AUX_SPP`]).
    pub aux: Aux,
    /// The model that denoised it ([`Quality::chosen`]).
    pub quality: Quality,
    /// The noisy image's mean weight in `rgb` over the pixels, in [0, 1]: 0 where `rgb` is the
    /// denoiser's output alone, as it is until [`Denoised::blend_with_noisy`].
    pub noisy_weight: f64,
}

/// Denoises `noisy`, the radiance of a render of `scene` (its current frame) of `spp` samples
/// per pixel (mean, fresh and reused), with auxiliary images rendered at [`AUX_SPP`] samples
/// per pixel from the scene's seed, by the model [`Quality::chosen`] picks for `want`.
///
/// # Errors
/// As [`denoise`].
pub fn denoise_render(
    scene: &Scene,
    noisy: Vec<f32>,
    spp: f64,
    want: FinalQuality,
) -> Result<Denoised, DenoiseError> {
    if !AVAILABLE {
        return Err(DenoiseError::NotBuilt);
    }
    let aux = render_aux(scene, AUX_SPP, scene.settings.seed);
    Denoised::of(scene, noisy, aux, spp, want)
}

impl Denoised {
    /// `noisy`, the radiance of a render of `scene` of `spp` samples per pixel (mean, fresh and
    /// reused), denoised with its auxiliary images `aux` (made at [`AUX_SPP`]) by the model
    /// [`Quality::chosen`] picks for `want`.
    ///
    /// # Errors
    /// As [`denoise`].
    pub fn of(
        scene: &Scene,
        noisy: Vec<f32>,
        aux: Aux,
        spp: f64,
        want: FinalQuality,
    ) -> Result<Denoised, DenoiseError> {
        let (w, h) = (scene.camera.width as usize, scene.camera.height as usize);
        let quality = Quality::chosen(want, spp, AUX_SPP);
        let rgb = denoise_with(&noisy, w, h, &aux, quality)?;
        Ok(Denoised {
            rgb,
            noisy,
            aux,
            quality,
            noisy_weight: 0.0,
        })
    }

    /// Blends the noisy render back into the denoised one, pixel by pixel, by the inverse of
    /// each one's estimated squared error, where the render has more than
    /// [`BLEND_ABOVE_SPP`] samples per pixel (mean; `spp`); below, nothing changes. `film` is
    /// the render the noisy image is the mean of (its half-buffers give the noisy image's
    /// error; a frame's own samples, not a reusing frame's).
    ///
    /// The two errors, in luminance and each averaged over 3 × 3 pixels: the noisy image's,
    /// the half-buffers' difference (e_n² = (k (Y(A) − Y(B)))², its variance); the denoised
    /// image's, its residual against the noisy one averaged over
    /// (2 · [`BIAS_RADIUS`] + 1)² pixels (e_d² = box(Y(F) − Y(D(F)))²), where the noise
    /// cancels and what the filter took away or added systematically remains: the detail the
    /// auxiliary images do not show (sub-pixel texture, soft shadows) and the filter's own
    /// grain on a nearly clean input. The noisy image's share is e_d² / (e_d² + e_n²) (1
    /// where both are 0), the minimum-variance combination of two estimates with independent
    /// errors; the denoiser's own variance is left out (it would take two more filter runs,
    /// [`DenoisedError`]). Measured (docs/denoise.md, 256², 2048-spp references, as
    /// displayed): the holodeck's FLIP mean at 32 / 64 spp 0.0630 / 0.0518 → 0.0609 / 0.0503,
    /// at its stop with the denoiser (697.6 spp) 0.0307 → 0.0284 and ColorVideoVDP JOD 9.961
    /// → 9.991; the Cornell box, the Mori knob and Lost Empire within 0.0002 of FLIP mean
    /// and 0.003 JOD. Below 16 spp the same blend lost (the Cornell box at 4 spp: JOD 9.798 →
    /// 9.726; the holodeck 9.721 → 9.594): the residual still carries the noise there.
    ///
    /// # Panics
    /// If the film's size differs from the image's.
    pub fn blend_with_noisy(&mut self, film: &Film, spp: f64) {
        if spp > BLEND_ABOVE_SPP as f64 {
            let share = noisy_shares(film, &self.noisy, &self.rgb);
            self.blend(&share);
        }
    }

    /// Each pixel becomes noisy + (1 − s) · (denoised − noisy) for its noisy share s in
    /// `share` (row-major, in [0, 1]); [`Denoised::noisy_weight`] is their mean.
    ///
    /// # Panics
    /// If `share` does not hold one value per pixel.
    pub fn blend(&mut self, share: &[f32]) {
        assert_eq!(3 * share.len(), self.rgb.len(), "one share per pixel");
        self.rgb
            .par_chunks_exact_mut(3)
            .zip(self.noisy.par_chunks_exact(3))
            .zip(share.par_iter())
            .for_each(|((d, n), &k)| {
                if k >= 1.0 {
                    d.copy_from_slice(n);
                } else if k > 0.0 {
                    for (d, &n) in d.iter_mut().zip(n) {
                        *d = n + (1.0 - k) * (*d - n);
                    }
                }
            });
        self.noisy_weight =
            share.iter().map(|&k| k as f64).sum::<f64>() / share.len().max(1) as f64;
    }
}

/// Mean samples per pixel above which [`Denoised::blend_with_noisy`] blends: the auxiliary
/// images' [`AUX_SPP`], from where the result is denoised without `cleanAux`
/// ([`Quality::final_for`]).
pub const BLEND_ABOVE_SPP: u32 = AUX_SPP;

/// The noisy image's share of each pixel in [`Denoised::blend_with_noisy`] (row-major), from
/// `film`, its mean `noisy` and the denoised image `denoised` (interleaved RGB).
fn noisy_shares(film: &Film, noisy: &[f32], denoised: &[f32]) -> Vec<f32> {
    let (w, h) = (film.width as usize, film.height as usize);
    assert_eq!(3 * w * h, noisy.len(), "the film is the noisy image's");
    assert_eq!(noisy.len(), denoised.len());
    let residual: Vec<f32> = noisy
        .par_chunks_exact(3)
        .zip(denoised.par_chunks_exact(3))
        .map(|(f, d)| y(f) - y(d))
        .collect();
    let bias = crate::imaging::box_mean(&residual, w, h, BIAS_RADIUS);
    let e_d: Vec<f32> = bias.par_iter().map(|b| b * b).collect();
    // Each pixel's half-buffer means read once, in parallel (not as two whole images).
    let e_n: Vec<f32> = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let (a, b, _) = film.means(i);
            let (a, b) = (a.as_vec3().to_array(), b.as_vec3().to_array());
            let d = film.difference_scale(i) as f32 * (y(&a) - y(&b));
            d * d
        })
        .collect();
    let (e_d, e_n) = (
        crate::imaging::box_mean(&e_d, w, h, 1),
        crate::imaging::box_mean(&e_n, w, h, 1),
    );
    e_d.par_iter()
        .zip(e_n.par_iter())
        .map(|(&d, &n)| if d + n > 0.0 { d / (d + n) } else { 1.0 })
        .collect()
}

/// Radius of the box over which the denoiser's residual is averaged into its bias estimate
/// ([`DenoisedError::bias`]): 7 × 7 pixels average the residual's noise down by 7.
pub const BIAS_RADIUS: usize = 3;

/// The estimated error of the denoised image of a film, per pixel (row-major), in luminance Y
/// (`perception::photometry::luminance` of the radiance, W·sr⁻¹·m⁻²).
#[derive(Clone, Debug)]
pub struct DenoisedError {
    /// The half-buffers (even and odd samples) denoised apart with the same auxiliary images,
    /// d = (Y(D(A)) − Y(D(B))) / 2, signed. Were the denoiser linear in its input, D(A) − D(B)
    /// would have twice the variance of D(A), whose variance is twice that of the full
    /// buffer's D(F), so |d| estimates the standard deviation of D(F) as |A − B| / 2 does that
    /// of F; and d's spectrum is that error's: low-frequency blotches where the denoiser
    /// averaged noise over a wide kernel, which the eye sees at a lower contrast than pixel
    /// noise (the perceptual sampler gives its threshold that spectrum:
    /// `perception::threshold::ThresholdMapper::band_power_shares`).
    pub difference: Vec<f32>,
    /// What d cannot see, the denoiser's bias (detail blurred away alike in both halves):
    /// |box(Y(F) − Y(D̄))| over (2 · [`BIAS_RADIUS`] + 1)² pixels, the residual between the
    /// unbiased input F = (A + B)/2 and the denoised mean D̄ = (D(A) + D(B))/2 (which stands in
    /// for D(F): no third filter), averaged so that its noise cancels and what the filter
    /// took away systematically remains.
    pub bias: Vec<f32>,
}

impl DenoisedError {
    /// The error estimate per pixel, √(d² + bias²). On the 64² Cornell box at 8 spp it ranks
    /// 4 × 4-pixel blocks like the true error of the denoised image (Spearman 0.62, against
    /// 0.60 for the raw half-buffer difference and 0.56 for |d| alone) and is 0.76× its size
    /// (|d| alone: 0.5×) (`tests/denoise.rs`).
    pub fn magnitude(&self) -> Vec<f32> {
        self.difference
            .par_iter()
            .zip(self.bias.par_iter())
            .map(|(d, b)| (d * d + b * b).sqrt())
            .collect()
    }
}

/// The luminance of an interleaved RGB pixel.
fn y(p: &[f32]) -> f32 {
    perception::photometry::luminance(p[0], p[1], p[2])
}

/// The half-buffers of `film` (even and odd samples) denoised apart by OIDN's model of
/// quality `q`, D(A) and D(B).
fn denoise_halves(
    film: &Film,
    aux: &Aux,
    q: Quality,
) -> Result<(Vec<f32>, Vec<f32>), DenoiseError> {
    let (w, h) = (film.width as usize, film.height as usize);
    let a = denoise_with(&film.mean_rgb_even(), w, h, aux, q)?;
    let b = denoise_with(&film.mean_rgb_odd(), w, h, aux, q)?;
    Ok((a, b))
}

/// d = (Y(D(A)) − Y(D(B))) / 2 per pixel ([`DenoisedError::difference`]).
fn half_difference(a: &[f32], b: &[f32]) -> Vec<f32> {
    a.par_chunks_exact(3)
        .zip(b.par_chunks_exact(3))
        .map(|(a, b)| 0.5 * (y(a) - y(b)))
        .collect()
}

/// The half-buffer part of [`denoised_error`] alone, [`DenoisedError::difference`], without
/// the bias term: what the perceptual sampler steers by. The halves are denoised by OIDN's
/// fast model ([`Quality::Fast`]), a stand-in for the high one the image is denoised by, at
/// about half the time: on the Cornell box at 256² the perceptual loop with the denoiser ran
/// 0.47–0.75× as long at 4–64 spp with the same scores (FLIP mean, p99 and ColorVideoVDP JOD
/// within their run-to-run scatter; docs/denoise.md), and on the 64² box at 8 spp its
/// difference ranks 4 × 4-pixel blocks against the true error with Spearman 0.55, the high
/// model's 0.49, at 1.20× the true error's size against 0.93× (`tests/denoise.rs`).
///
/// # Errors
/// As [`denoise`].
pub fn denoised_difference(film: &Film, aux: &Aux) -> Result<Vec<f32>, DenoiseError> {
    let (a, b) = denoise_halves(film, aux, Quality::Fast)?;
    Ok(half_difference(&a, &b))
}

/// Estimates the error of the denoised image of `film` from its half-buffers
/// ([`DenoisedError`]), each denoised by the high-quality model the image is.
///
/// # Errors
/// As [`denoise`].
pub fn denoised_error(film: &Film, aux: &Aux) -> Result<DenoisedError, DenoiseError> {
    let (w, h) = (film.width as usize, film.height as usize);
    let (a, b) = denoise_halves(film, aux, Quality::High)?;
    let difference = half_difference(&a, &b);
    let input = film.mean_rgb();
    let residual: Vec<f32> = input
        .par_chunks_exact(3)
        .zip(a.par_chunks_exact(3).zip(b.par_chunks_exact(3)))
        .map(|(f, (a, b))| y(f) - 0.5 * (y(a) + y(b)))
        .collect();
    let bias = crate::imaging::box_mean(&residual, w, h, BIAS_RADIUS)
        .into_iter()
        .map(f32::abs)
        .collect();
    Ok(DenoisedError { difference, bias })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blend_takes_each_pixel_s_noisy_share_and_keeps_the_noisy_bits_at_one() {
        let share = [1.0, 0.5, 0.25, 0.0];
        let noisy: Vec<f32> = (0..12).map(|i| 0.1 * i as f32).collect();
        let denoised: Vec<f32> = noisy.iter().map(|v| v + 1.0).collect();
        let mut d = Denoised {
            rgb: denoised.clone(),
            noisy: noisy.clone(),
            aux: Aux {
                albedo: vec![0.5; 12],
                normal: vec![0.0; 12],
            },
            quality: Quality::High,
            noisy_weight: 0.0,
        };
        d.blend(&share);
        for (i, &k) in share.iter().enumerate() {
            for c in 3 * i..3 * i + 3 {
                let want = noisy[c] + (1.0 - k) * (denoised[c] - noisy[c]);
                assert!(
                    (d.rgb[c] - want).abs() < 1e-6,
                    "pixel {i}: {} against {want}",
                    d.rgb[c]
                );
            }
        }
        assert!((0..3).all(|c| d.rgb[c].to_bits() == noisy[c].to_bits()));
        assert!((d.noisy_weight - 0.4375).abs() < 1e-9, "{}", d.noisy_weight);
        assert_eq!(d.noisy, noisy);
    }

    #[test]
    fn the_noisy_share_weighs_the_two_images_by_their_estimated_squared_errors() {
        use glam::Vec3;
        // Grey pixels (Y = the grey level), 9 × 9, every pixel alike so every box mean is
        // exact. Halves of 0.5 and 1.5 (the noisy image 1): e_n = (½ (0.5 − 1.5))² = ¼.
        let film_of = |a: f32, b: f32| {
            let mut film = Film::new(9, 9);
            for p in film.pixels.iter_mut() {
                for _ in 0..8 {
                    p.add(Vec3::splat(a));
                    p.add(Vec3::splat(b));
                }
            }
            film
        };
        let noisy = vec![1.0f32; 3 * 81];
        let shifted = |by: f32| -> Vec<f32> { noisy.iter().map(|v| v - by).collect() };
        let noisy_film = film_of(0.5, 1.5);
        // The denoiser changed nothing: its error estimate is 0, the noisy image's share 0.
        let s = noisy_shares(&noisy_film, &noisy, &noisy);
        assert!(s.iter().all(|&k| k == 0.0), "{:?}", &s[..3]);
        // It moved every pixel by ½: e_d = ¼ = e_n, half each.
        let s = noisy_shares(&noisy_film, &noisy, &shifted(0.5));
        assert!(s.iter().all(|&k| (k - 0.5).abs() < 1e-6), "{:?}", &s[..3]);
        // By 1.5: e_d = 9/4, the noisy image's share 0.9.
        let s = noisy_shares(&noisy_film, &noisy, &shifted(1.5));
        assert!(s.iter().all(|&k| (k - 0.9).abs() < 1e-6), "{:?}", &s[..3]);
        // Halves that agree (no noise): the noisy image whatever the denoiser did.
        let clean = film_of(1.0, 1.0);
        let s = noisy_shares(&clean, &noisy, &shifted(0.01));
        assert!(s.iter().all(|&k| k == 1.0), "{:?}", &s[..3]);
        let s = noisy_shares(&clean, &noisy, &noisy);
        assert!(s.iter().all(|&k| k == 1.0), "{:?}", &s[..3]);
        // Nothing changes at or below 16 spp (the film's mean, as the caller gives it).
        let mut d = Denoised {
            rgb: shifted(0.5),
            noisy: noisy.clone(),
            aux: Aux {
                albedo: vec![0.5; 3 * 81],
                normal: vec![0.0; 3 * 81],
            },
            quality: Quality::High,
            noisy_weight: 0.0,
        };
        d.blend_with_noisy(&noisy_film, 16.0);
        assert_eq!(d.rgb, shifted(0.5));
        d.blend_with_noisy(&noisy_film, 16.5);
        assert!(d.rgb.iter().all(|&v| (v - 0.75).abs() < 1e-6));
    }
}
