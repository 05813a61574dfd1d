//! Partial films: part of one frame rendered on its own (on another machine), written to a
//! file, and merged.
//!
//! Two ways to split a frame:
//! - **Sample ranges** ([`Split::Samples`], uniform sampler): every sample's random numbers depend
//!   only on (seed, pixel, sample index) ([`crate::rng`]), so the samples `first..end` of every
//!   pixel can be taken anywhere. The part's [`Film`] starts each pixel at index `first`
//!   ([`Film::starting_at`]); because the film's sums are exact ([`crate::film::ExactSum`]),
//!   [`merge_parts`] of parts that cover `0..N` gives a film whose image is bit-identical to a
//!   single render of N samples per pixel.
//! - **Row tiles** ([`Split::Rows`], adaptive samplers): tile I of K renders adaptively with
//!   samples confined to its rows plus a margin ([`crate::adaptive::AdaptiveSettings::rows`])
//!   and keeps only its own rows. The merged image is not the single machine's (each tile's
//!   threshold map sees first-pass noise beyond its margin); docs/farm.md gives the measured
//!   cost.
//!
//! # File layout (OpenEXR, one part, ZIP-compressed, version 2)
//! - `R`, `G`, `B` (f32): the part's own mean radiance, W·sr⁻¹·m⁻², so that any EXR viewer shows
//!   a preview of the part;
//! - `spp` (u32): samples per pixel in the part;
//! - the exact sums, each an f64 pair (hi, lo) in its canonical form
//!   ([`crate::film::ExactSum::normalized`]), stored as the IEEE-754 bit patterns split in
//!   32-bit words: channel `Film.S.hi0` holds the low word of `hi`, `Film.S.hi1` the high word,
//!   `Film.S.lo0` and `Film.S.lo1` those of `lo` (all u32), for S in `EvenR`, `EvenG`, `EvenB`
//!   (samples with even index), `OddR`, `OddG`, `OddB` (odd index) and `Y2` (Σ Y²);
//! - row tiles only: `Threshold.Y` and `Error.Y` (f32), the sampler's last threshold and error;
//! - header attributes: `alephPartialFilm` = `2` (the layout version; 2 since the recipe is a
//!   render job's record), `alephPart` = `I/K` (part
//!   I of K, from 1), `alephRecipe` (an opaque text that parts of one render share; the
//!   render-job layer stores the job's TOML record there, [`crate::job`]), `radianceUnits`, and either `alephSamples` =
//!   `FIRST..END` (the sample indices every pixel holds) or `alephRows` = `START..END/HEIGHT`
//!   (the image rows the tile holds, of the frame's HEIGHT; the file is END − START rows high);
//!   a row tile whose half-buffers are power-of-two blocks of one sequence
//!   ([`crate::film::HalfSplit::Blocks`], the perceptual sampler's) adds `alephHalves` =
//!   `blocks` (the `Even`/`Odd` sums then hold half-buffers A and B).

use crate::film::{ExactRgb, ExactSum, Film, HalfSplit, PixelStats};
use crate::integrator::{Integrator, Strategy};
use crate::output::{AtomicOutputs, ChannelData, OutputError, write_exr};
use crate::render::{RenderStats, render_counts};
use crate::sampler::SampleStreams;
use crate::scene::Scene;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Layout version written in `alephPartialFilm`.
pub const FORMAT_VERSION: &str = "2";

/// Names of the exact sums, in file order.
const SUMS: [&str; 7] = ["EvenR", "EvenG", "EvenB", "OddR", "OddG", "OddB", "Y2"];

/// How a part divides its frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Split {
    /// Samples `first..end` of every pixel.
    Samples {
        /// First sample index held.
        first: u32,
        /// One past the last sample index held.
        end: u32,
    },
    /// Rows `start..end` of a frame `height` rows high, all their samples.
    Rows {
        /// First row held (row 0 at the top).
        start: u32,
        /// One past the last row held.
        end: u32,
        /// The frame's height.
        height: u32,
    },
}

/// A partial film and what it is part of.
#[derive(Clone, Debug, PartialEq)]
pub struct PartialFilm {
    /// The part's pixels: the whole frame for [`Split::Samples`], its rows for [`Split::Rows`].
    pub film: Film,
    /// How the part divides the frame.
    pub split: Split,
    /// Part number, from 1.
    pub index: u32,
    /// Number of parts of the render.
    pub count: u32,
    /// What the parts of one render share (the CLI: its arguments).
    pub recipe: String,
    /// Row tiles: the sampler's last threshold and error per pixel (in the sampler's units).
    pub threshold_error: Option<(Vec<f32>, Vec<f32>)>,
}

/// What a partial film's header says: enough to check a set of parts before reading their
/// pixels.
#[derive(Clone, Debug, PartialEq)]
pub struct PartInfo {
    /// Width of the file in pixels.
    pub width: u32,
    /// Height of the file in pixels.
    pub height: u32,
    /// How the part divides the frame.
    pub split: Split,
    /// Part number, from 1.
    pub index: u32,
    /// Number of parts of the render.
    pub count: u32,
    /// What the parts of one render share.
    pub recipe: String,
}

impl PartialFilm {
    /// The header's view of this part.
    pub fn info(&self) -> PartInfo {
        PartInfo {
            width: self.film.width,
            height: self.film.height,
            split: self.split,
            index: self.index,
            count: self.count,
            recipe: self.recipe.clone(),
        }
    }
}

/// `STEM.part-I-of-K.exr` (sample ranges) or `STEM.tile-I-of-K.exr` (row tiles): where part
/// `index` of `count` of the render `STEM` goes.
pub fn part_path(stem: &Path, index: u32, count: u32, tiles: bool) -> PathBuf {
    let kind = if tiles { "tile" } else { "part" };
    crate::deliver::with_ext(stem, &format!("{kind}-{index}-of-{count}.exr"))
}

/// The sample range of part `index` (from 1) of `count` of an `spp`-sample render:
/// `(index − 1)·spp/count .. index·spp/count`, so that the parts tile `0..spp`. The same rule
/// gives tile `index`'s rows of an image `spp` rows high.
///
/// # Panics
/// If `index` is 0 or above `count`.
pub fn part_range(spp: u32, index: u32, count: u32) -> (u32, u32) {
    assert!(index >= 1 && index <= count, "part {index} of {count}");
    let at = |i: u32| (spp as u64 * i as u64 / count as u64) as u32;
    (at(index - 1), at(index))
}

/// Renders part `index` (from 1) of `count` of a uniform render of `spp` samples per pixel of
/// `scene`'s current frame: the samples [`part_range`] of every pixel, with the same integrator
/// and random streams as [`crate::adaptive::render_adaptive`]'s uniform sampler. `progress`
/// gets the samples of each finished row.
///
/// # Panics
/// If `index` is 0 or above `count`, or `count` exceeds `spp` (a part would be empty).
pub fn render_part(
    scene: &Scene,
    spp: u32,
    index: u32,
    count: u32,
    recipe: String,
    progress: &(dyn Fn(u64) + Sync),
) -> (PartialFilm, RenderStats) {
    assert!(count <= spp, "{count} parts of {spp} samples");
    let (first, end) = part_range(spp, index, count);
    let integrator = Integrator {
        max_depth: scene.settings.max_depth,
        strategy: Strategy::Mis,
    };
    let mut film = Film::starting_at(scene.camera.width, scene.camera.height, first);
    let counts = vec![end - first; film.len()];
    let stats = render_counts(
        scene,
        &integrator,
        &mut film,
        &counts,
        SampleStreams::Fixed(spp),
        progress,
    );
    let part = PartialFilm {
        film,
        split: Split::Samples { first, end },
        index,
        count,
        recipe,
        threshold_error: None,
    };
    (part, stats)
}

/// Rows `start..end` of a full-frame `film` (and of the per-pixel threshold and error) as the
/// row tile `index` of `count`.
///
/// # Panics
/// If the rows are not inside the film, or the threshold or error has another size.
pub fn tile_of(
    film: &Film,
    rows: (u32, u32),
    threshold_error: Option<(&[f32], &[f32])>,
    index: u32,
    count: u32,
    recipe: String,
) -> PartialFilm {
    let (start, end) = rows;
    assert!(start < end && end <= film.height);
    let w = film.width as usize;
    let span = start as usize * w..end as usize * w;
    PartialFilm {
        film: Film {
            width: film.width,
            height: end - start,
            pixels: film.pixels[span.clone()].to_vec(),
            history: None,
            split: film.split,
        },
        split: Split::Rows {
            start,
            end,
            height: film.height,
        },
        index,
        count,
        recipe,
        threshold_error: threshold_error.map(|(t, e)| (t[span.clone()].to_vec(), e[span].to_vec())),
    }
}

/// Errors reading or merging partial films; each names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PartialError {
    /// The file could not be read or is not a partial film.
    #[error("{}: {message}", path.display())]
    Read {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// The parts do not make up one render.
    #[error("{}: {message}", path.display())]
    Mismatch {
        /// The file that does not fit.
        path: PathBuf,
        /// What does not fit.
        message: String,
    },
    /// No parts were given.
    #[error("no partial films to merge")]
    Empty,
    /// Writing failed.
    #[error(transparent)]
    Output(#[from] OutputError),
}

/// The f64 bit pattern as (low, high) 32-bit words.
fn words(v: f64) -> (u32, u32) {
    let b = v.to_bits();
    (b as u32, (b >> 32) as u32)
}

fn from_words(lo: u32, hi: u32) -> f64 {
    f64::from_bits((hi as u64) << 32 | lo as u64)
}

/// The sums of a pixel in file order.
fn sums(p: &PixelStats) -> [ExactSum; 7] {
    let (e, o) = (p.sum_even.0, p.sum_odd.0);
    [e[0], e[1], e[2], o[0], o[1], o[2], p.sum_lum2]
}

/// The u32 channels of the exact sums.
fn sum_channels(f: &Film) -> Vec<(String, ChannelData)> {
    let mut extra = Vec::new();
    for (k, name) in SUMS.iter().enumerate() {
        let pairs: Vec<(f64, f64)> = f
            .pixels
            .iter()
            .map(|p| sums(p)[k].normalized().parts())
            .collect();
        for (half, pick) in [("hi", 0usize), ("lo", 1)] {
            let value = |pr: &(f64, f64)| if pick == 0 { pr.0 } else { pr.1 };
            let w0 = pairs.iter().map(|pr| words(value(pr)).0).collect();
            let w1 = pairs.iter().map(|pr| words(value(pr)).1).collect();
            extra.push((format!("Film.{name}.{half}0"), ChannelData::U32(w0)));
            extra.push((format!("Film.{name}.{half}1"), ChannelData::U32(w1)));
        }
    }
    extra
}

/// Header attribute of a row tile whose half-buffers are power-of-two blocks
/// ([`HalfSplit::Blocks`]): `blocks`. Absent: even and odd samples.
const HALVES_ATTRIBUTE: &str = "alephHalves";

/// Writes `part` to `path` (staged and renamed into place).
///
/// # Errors
/// [`PartialError::Output`] naming the file; nothing is left at `path` then.
///
/// # Panics
/// If a sample part's pixels do not all hold its sample range.
pub fn write_partial(path: &Path, part: &PartialFilm) -> Result<(), PartialError> {
    let f = &part.film;
    let mut extra = vec![("spp".to_string(), ChannelData::U32(f.spp()))];
    extra.extend(sum_channels(f));
    let mut attributes = vec![
        ("alephPartialFilm".to_string(), FORMAT_VERSION.to_string()),
        (
            "alephPart".to_string(),
            format!("{}/{}", part.index, part.count),
        ),
        ("alephRecipe".to_string(), part.recipe.clone()),
        (
            "radianceUnits".to_string(),
            "W.sr^-1.m^-2 (linear Rec.709 RGB); mean of this part's samples".to_string(),
        ),
    ];
    match part.split {
        Split::Samples { first, end } => {
            assert!(f.pixels.iter().all(|p| p.first == first && p.n == end));
            attributes.push(("alephSamples".into(), format!("{first}..{end}")));
        }
        Split::Rows { start, end, height } => {
            attributes.push(("alephRows".into(), format!("{start}..{end}/{height}")));
        }
    }
    if f.split == HalfSplit::Blocks {
        attributes.push((HALVES_ATTRIBUTE.into(), "blocks".into()));
    }
    if let Some((t, e)) = &part.threshold_error {
        extra.push(("Threshold.Y".into(), ChannelData::F32(t.clone())));
        extra.push(("Error.Y".into(), ChannelData::F32(e.clone())));
    }
    let rgb = f.mean_rgb();
    let mut out = AtomicOutputs::new();
    out.stage(path, |w| {
        write_exr(w, path, f.width, f.height, &rgb, &extra, &attributes)
    })?;
    out.commit()?;
    Ok(())
}

/// Parses `A..B` / `I/K` attributes.
fn pair(text: &str, sep: &str) -> Option<(u32, u32)> {
    let (a, b) = text.split_once(sep)?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

/// Reads a partial film written by [`write_partial`].
///
/// # Errors
/// [`PartialError::Read`] naming the file: unreadable, not a partial film, another layout
/// version, or channels missing or of the wrong type.
pub fn read_partial(path: &Path) -> Result<PartialFilm, PartialError> {
    let err = |message: String| PartialError::Read {
        path: path.to_path_buf(),
        message,
    };
    let raw = crate::imageio::read_exr_raw(path).map_err(|e| match e {
        crate::imageio::ImageError::Read { message, .. } => err(format!("cannot read: {message}")),
        other => err(other.to_string()),
    })?;
    decode(&raw).map_err(|m| err(format!("not a partial film: {m}")))
}

/// Reads only the header of a partial film written by [`write_partial`].
///
/// # Errors
/// [`PartialError::Read`] naming the file: unreadable, or not a partial film of this layout.
pub fn read_part_info(path: &Path) -> Result<PartInfo, PartialError> {
    let err = |message: String| PartialError::Read {
        path: path.to_path_buf(),
        message,
    };
    let meta = exr::meta::MetaData::read_from_file(path, false)
        .map_err(|e| err(format!("cannot read: {e}")))?;
    let h = meta.headers.first().ok_or_else(|| err("no layer".into()))?;
    let attrs: HashMap<String, String> = h
        .own_attributes
        .other
        .iter()
        .filter_map(|(k, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) => Some((k.to_string(), t.to_string())),
            _ => None,
        })
        .collect();
    let (w, hh) = (h.layer_size.width() as u32, h.layer_size.height() as u32);
    part_info(w, hh, &attrs).map_err(|m| err(format!("not a partial film: {m}")))
}

/// The [`Split`] an attribute set names.
fn split_of(w: u32, h: u32, attrs: &HashMap<String, String>) -> Result<Split, String> {
    if let Some(s) = attrs.get("alephSamples") {
        let (first, end) = pair(s, "..")
            .filter(|(a, b)| a < b)
            .ok_or("alephSamples is not FIRST..END")?;
        return Ok(Split::Samples { first, end });
    }
    let rows = attrs
        .get("alephRows")
        .ok_or("no alephSamples or alephRows")?;
    let bad = || "alephRows is not START..END/HEIGHT for this file's rows".to_string();
    let (range, height) = rows.split_once('/').ok_or_else(bad)?;
    let (start, end) = pair(range, "..").ok_or_else(bad)?;
    let height: u32 = height.trim().parse().map_err(|_| bad())?;
    if start >= end || end > height || end - start != h || w == 0 {
        return Err(bad());
    }
    Ok(Split::Rows { start, end, height })
}

/// The [`PartInfo`] of an EXR's size and text attributes.
fn part_info(w: u32, h: u32, attrs: &HashMap<String, String>) -> Result<PartInfo, String> {
    let attr = |k: &str| attrs.get(k).ok_or_else(|| format!("no {k} attribute"));
    let version = attr("alephPartialFilm")?;
    if version != FORMAT_VERSION {
        return Err(format!(
            "layout version {version}, this aleph reads {FORMAT_VERSION}"
        ));
    }
    let (index, count) = pair(attr("alephPart")?, "/")
        .filter(|&(i, k)| i >= 1 && i <= k)
        .ok_or("alephPart is not I/K with 1 ≤ I ≤ K")?;
    Ok(PartInfo {
        width: w,
        height: h,
        split: split_of(w, h, attrs)?,
        index,
        count,
        recipe: attr("alephRecipe")?.clone(),
    })
}

/// Builds a [`PartialFilm`] from an EXR's channels and text attributes.
fn decode(raw: &crate::imageio::RawExr) -> Result<PartialFilm, String> {
    if raw.origin != [0, 0] {
        return Err(format!(
            "its data window starts at ({}, {}); a partial film's starts at (0, 0) (edited by \
             hand?)",
            raw.origin[0], raw.origin[1]
        ));
    }
    let info = part_info(raw.width, raw.height, &raw.text)?;
    let channel = |name: &str| {
        raw.u32s
            .get(name)
            .ok_or_else(|| format!("no u32 channel {name}"))
    };
    let spp = channel("spp")?;
    let first = match info.split {
        Split::Samples { first, end } => {
            if spp.iter().any(|&n| n != end - first) {
                return Err(format!(
                    "the spp channel disagrees with samples {first}..{end}"
                ));
            }
            first
        }
        Split::Rows { .. } => 0,
    };
    let mut film = Film::starting_at(raw.width, raw.height, first);
    film.split = match raw.text.get(HALVES_ATTRIBUTE).map(String::as_str) {
        None => HalfSplit::Interleaved,
        Some("blocks") if matches!(info.split, Split::Rows { .. }) => HalfSplit::Blocks,
        Some(other) => {
            return Err(format!(
                "{HALVES_ATTRIBUTE} is {other:?}, not \"blocks\" of a row tile"
            ));
        }
    };
    for (p, &n) in film.pixels.iter_mut().zip(spp) {
        p.n = first + n;
    }
    for (k, name) in SUMS.iter().enumerate() {
        let c = |half: &str, word: u32| channel(&format!("Film.{name}.{half}{word}"));
        let (h0, h1, l0, l1) = (c("hi", 0)?, c("hi", 1)?, c("lo", 0)?, c("lo", 1)?);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            let s = ExactSum::from_parts(from_words(h0[i], h1[i]), from_words(l0[i], l1[i]));
            match k {
                0..=2 => p.sum_even.0[k] = s,
                3..=5 => p.sum_odd.0[k - 3] = s,
                _ => p.sum_lum2 = s,
            }
        }
    }
    let finite = |s: &ExactRgb| {
        s.0.iter()
            .all(|v| v.value().is_finite() && v.value() >= 0.0)
    };
    if !film
        .pixels
        .iter()
        .all(|p| finite(&p.sum_even) && finite(&p.sum_odd))
    {
        return Err("a sum is negative, NaN or infinite".into());
    }
    let threshold_error = match (raw.f32s.get("Threshold.Y"), raw.f32s.get("Error.Y")) {
        (Some(t), Some(e)) => Some((t.clone(), e.clone())),
        _ => None,
    };
    Ok(PartialFilm {
        film,
        split: info.split,
        index: info.index,
        count: info.count,
        recipe: info.recipe,
        threshold_error,
    })
}

/// A merged render: the whole frame's film, the recipe its parts share, and for row tiles the
/// threshold and error assembled from the tiles.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The frame's film.
    pub film: Film,
    /// The parts' recipe.
    pub recipe: String,
    /// Row tiles: threshold and error per pixel.
    pub threshold_error: Option<(Vec<f32>, Vec<f32>)>,
    /// Whether the parts were row tiles.
    pub tiles: bool,
}

/// Merges the parts of one render, read from `paths` (headers first, then one part's pixels at
/// a time): they must share their recipe, width, kind and part count, and hold disjoint sample
/// ranges that cover `0..N` (bit-identical to a single render's image, see [`Film::merge`]) or
/// disjoint row ranges that cover the frame, with every part `1..=K` present once.
///
/// # Errors
/// [`PartialError`] naming the file that cannot be read or does not fit.
pub fn merge_parts(paths: &[PathBuf]) -> Result<Merged, PartialError> {
    merge_parts_with(paths, &|a, b| {
        if a == b {
            Ok(())
        } else {
            Err(format!("recipes differ:\n  {a}\n  {b}"))
        }
    })
}

/// [`merge_parts`] with the parts' recipes compared by `same_recipe` (first part's, other
/// part's), which says how they differ when they do (the render-job layer compares structured
/// records, [`crate::job::merge`]).
///
/// # Errors
/// As [`merge_parts`].
pub fn merge_parts_with(
    paths: &[PathBuf],
    same_recipe: &dyn Fn(&str, &str) -> Result<(), String>,
) -> Result<Merged, PartialError> {
    let mut infos = Vec::new();
    for p in paths {
        infos.push((p.clone(), read_part_info(p)?));
    }
    check_same_render(&infos, same_recipe)?;
    infos.sort_by_key(|(_, p)| match p.split {
        Split::Samples { first, .. } => first,
        Split::Rows { start, .. } => start,
    });
    check_coverage(&infos)?;
    let tiles = matches!(infos[0].1.split, Split::Rows { .. });
    let (w, h) = match infos[0].1.split {
        Split::Rows { height, .. } => (infos[0].1.width, height),
        Split::Samples { .. } => (infos[0].1.width, infos[0].1.height),
    };
    let mut film = Film::starting_at(w, h, 0);
    let n = film.len();
    let mut te = tiles.then(|| (vec![0f32; n], vec![0f32; n]));
    // One part in memory at a time.
    for (path, info) in &infos {
        let part = read_partial(path)?;
        if part.info() != *info {
            return Err(mismatch(path, "changed while merging".into()));
        }
        match part.split {
            Split::Samples { .. } => film.merge(&part.film).map_err(|m| mismatch(path, m))?,
            Split::Rows { start, .. } => {
                let at = start as usize * w as usize;
                let span = at..at + part.film.len();
                film.pixels[span.clone()].copy_from_slice(&part.film.pixels);
                film.split = part.film.split;
                match (&mut te, &part.threshold_error) {
                    (Some((t, e)), Some((pt, pe))) => {
                        t[span.clone()].copy_from_slice(pt);
                        e[span].copy_from_slice(pe);
                    }
                    _ => te = None,
                }
            }
        }
    }
    Ok(Merged {
        film,
        recipe: infos.swap_remove(0).1.recipe,
        threshold_error: te,
        tiles,
    })
}

fn mismatch(path: &Path, message: String) -> PartialError {
    PartialError::Mismatch {
        path: path.to_path_buf(),
        message,
    }
}

/// What must agree between parts: the kind of split and the frame's size.
fn shape(p: &PartInfo) -> (bool, u32, u32, u32) {
    match p.split {
        Split::Samples { .. } => (false, p.width, p.height, p.count),
        Split::Rows { height, .. } => (true, p.width, height, p.count),
    }
}

/// All parts share the first one's recipe, kind, frame size and part count.
fn check_same_render(
    infos: &[(PathBuf, PartInfo)],
    same_recipe: &dyn Fn(&str, &str) -> Result<(), String>,
) -> Result<(), PartialError> {
    let (path0, first) = infos.first().ok_or(PartialError::Empty)?;
    let describe = |p: &PartInfo| {
        let (tiles, w, h, k) = shape(p);
        let kind = if tiles { "row tile" } else { "sample part" };
        format!("a {kind} of {k} of a {w}×{h} frame")
    };
    for (path, p) in &infos[1..] {
        if let Err(why) = same_recipe(&first.recipe, &p.recipe) {
            return Err(mismatch(
                path,
                format!("a part of another render than {} ({why})", path0.display()),
            ));
        }
        if shape(p) != shape(first) {
            return Err(mismatch(
                path,
                format!(
                    "{}, but {} is {}",
                    describe(p),
                    path0.display(),
                    describe(first)
                ),
            ));
        }
    }
    Ok(())
}

/// Parts sorted by their first sample (row) must run from 0 to the end without gap or overlap,
/// one of each index.
fn check_coverage(parts: &[(PathBuf, PartInfo)]) -> Result<(), PartialError> {
    let mut next = 0;
    let mut seen = vec![None::<&Path>; parts[0].1.count as usize];
    let mut last_end = 0;
    for (path, p) in parts {
        let slot = &mut seen[p.index as usize - 1];
        if let Some(other) = slot {
            return Err(mismatch(
                path,
                format!(
                    "part {}/{} again (also {})",
                    p.index,
                    p.count,
                    other.display()
                ),
            ));
        }
        *slot = Some(path);
        let (what, a, b) = match p.split {
            Split::Samples { first, end } => ("samples", first, end),
            Split::Rows { start, end, .. } => ("rows", start, end),
        };
        if a != next {
            return Err(mismatch(
                path,
                format!("holds {what} {a}..{b}, but the parts before it end at {next}"),
            ));
        }
        next = b;
        last_end = b;
    }
    if let Some(i) = seen.iter().position(Option::is_none) {
        return Err(mismatch(
            &parts[0].0,
            format!("part {}/{} is missing", i + 1, parts[0].1.count),
        ));
    }
    if let Split::Rows { height, .. } = parts[0].1.split
        && last_end != height
    {
        return Err(mismatch(
            &parts[0].0,
            format!("the tiles end at row {last_end} of {height}"),
        ));
    }
    Ok(())
}
