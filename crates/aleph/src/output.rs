//! Writing images: OpenEXR (linear radiance plus AOV channels) and PNG (display-encoded), each
//! written to a temporary file in the destination directory and renamed into place only when
//! every output of a command has been written, so a failure leaves no partial file behind.

use exr::prelude::*;
use std::collections::HashMap;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Errors writing output files. Each variant names the file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    /// The file could not be created, written or renamed into place (the cause is the error's
    /// source, printed by error chains).
    #[error("{}: cannot write", path.display())]
    Io {
        /// Destination.
        path: PathBuf,
        /// Cause.
        #[source]
        source: std::io::Error,
    },
    /// The image encoder failed.
    #[error("{}: cannot encode image: {message}", path.display())]
    Encode {
        /// Destination.
        path: PathBuf,
        /// Encoder message.
        message: String,
    },
}

/// Temporary files of every [`AtomicOutputs`] in this process that are not yet committed or
/// dropped, for [`remove_staged_temporaries`] to delete when the process is interrupted.
static STAGED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

fn unregister(path: &Path) {
    if let Ok(mut v) = STAGED.lock() {
        v.retain(|p| p != path);
    }
}

/// Deletes every staged temporary file of this process: call it from a SIGINT/SIGTERM handler
/// before exiting, so an interrupted write leaves nothing behind (a normal drop cleans up by
/// itself; a signal skips destructors).
pub fn remove_staged_temporaries() {
    remove_registered(|_| true);
}

fn remove_registered(which: impl Fn(&Path) -> bool) {
    if let Ok(v) = STAGED.lock() {
        for p in v.iter().filter(|p| which(p)) {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// Writes several files so that either all of them appear at their destinations or none does:
/// each is staged as a temporary file beside its destination, and [`AtomicOutputs::commit`]
/// renames them into place. Dropping without committing deletes the temporaries.
#[derive(Default)]
pub struct AtomicOutputs {
    staged: Vec<(tempfile::NamedTempFile, PathBuf)>,
}

impl AtomicOutputs {
    /// A new, empty set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Stages `dest` by calling `write` on a temporary file in the same directory.
    ///
    /// # Errors
    /// [`OutputError::Io`] if the directory does not exist or is not writable, or if `write`
    /// fails.
    pub fn stage(
        &mut self,
        dest: &Path,
        write: impl FnOnce(&mut BufWriter<&File>) -> std::result::Result<(), OutputError>,
    ) -> std::result::Result<(), OutputError> {
        check_output_location(dest)?;
        let io = |source: std::io::Error| OutputError::Io {
            path: dest.to_path_buf(),
            source,
        };
        let dir = match dest.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let prefix = format!(".{name}.");
        let mut builder = tempfile::Builder::new();
        builder.prefix(&prefix).suffix(".tmp");
        // Temporary files are private (0600) by default; outputs are ordinary files.
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            builder.permissions(std::fs::Permissions::from_mode(0o644));
        }
        let tmp = builder.tempfile_in(&dir).map_err(io)?;
        if let Ok(mut v) = STAGED.lock() {
            v.push(tmp.path().to_path_buf());
        }
        let written = (|| {
            let mut w = BufWriter::new(tmp.as_file());
            write(&mut w)?;
            w.flush().map_err(io)?;
            drop(w);
            tmp.as_file().sync_all().map_err(io)
        })();
        // Registered until committed or dropped (`Drop` below); a failed write drops it now.
        self.staged.push((tmp, dest.to_path_buf()));
        if written.is_err() {
            self.drop_last();
        }
        written
    }

    fn drop_last(&mut self) {
        if let Some((tmp, _)) = self.staged.pop() {
            unregister(tmp.path());
        }
    }

    /// Stages `dest` with the given contents (text reports, CSV, SVG).
    ///
    /// # Errors
    /// As [`AtomicOutputs::stage`].
    pub fn stage_bytes(
        &mut self,
        dest: &Path,
        bytes: &[u8],
    ) -> std::result::Result<(), OutputError> {
        self.stage(dest, |w| {
            w.write_all(bytes).map_err(|source| OutputError::Io {
                path: dest.to_path_buf(),
                source,
            })
        })
    }

    /// Renames every staged file into place, all or nothing: existing destinations are first
    /// moved aside, and if any rename fails, the files already placed are removed and the old
    /// ones put back, so a failed command replaces nothing.
    ///
    /// # Errors
    /// [`OutputError::Io`] naming the file whose rename failed (a destination that is a
    /// directory is refused before anything moves).
    pub fn commit(mut self) -> std::result::Result<(), OutputError> {
        let mut staged = std::mem::take(&mut self.staged);
        for (_, dest) in &staged {
            check_output_location(dest)?;
        }
        let mut backups: Vec<(PathBuf, PathBuf)> = Vec::new();
        let mut placed: Vec<PathBuf> = Vec::new();
        let result = (|| {
            for (_, dest) in &staged {
                if dest.exists() {
                    let aside = aside_name(dest);
                    std::fs::rename(dest, &aside).map_err(|source| OutputError::Io {
                        path: dest.clone(),
                        source,
                    })?;
                    backups.push((aside, dest.clone()));
                }
            }
            for (tmp, dest) in std::mem::take(&mut staged) {
                unregister(tmp.path());
                tmp.persist(&dest).map_err(|e| OutputError::Io {
                    path: dest.clone(),
                    source: e.error,
                })?;
                placed.push(dest);
            }
            Ok(())
        })();
        if result.is_err() {
            for p in &placed {
                let _ = std::fs::remove_file(p);
            }
            for (aside, dest) in &backups {
                let _ = std::fs::rename(aside, dest);
            }
        } else {
            for (aside, _) in &backups {
                let _ = std::fs::remove_file(aside);
            }
        }
        result
    }
}

impl Drop for AtomicOutputs {
    fn drop(&mut self) {
        for (tmp, _) in &self.staged {
            unregister(tmp.path());
        }
    }
}

/// A hidden name beside `dest` for its old version while a commit is under way.
fn aside_name(dest: &Path) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().to_string())
        .unwrap_or_default();
    dest.with_file_name(format!(".{name}.{}.old.tmp", std::process::id()))
}

/// Checks, before any work, that `dest` can be written: its directory exists and is a
/// directory, and `dest` itself is not a directory.
///
/// # Errors
/// [`OutputError::Io`] naming `dest` and what is wrong.
pub fn check_output_location(dest: &Path) -> std::result::Result<(), OutputError> {
    let err = |kind: std::io::ErrorKind, what: String| OutputError::Io {
        path: dest.to_path_buf(),
        source: std::io::Error::new(kind, what),
    };
    let dir = match dest.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(err(
            std::io::ErrorKind::NotFound,
            format!("the directory {} does not exist", dir.display()),
        ));
    }
    if dest.is_dir() {
        return Err(err(
            std::io::ErrorKind::IsADirectory,
            "a directory is in the way".to_string(),
        ));
    }
    Ok(())
}

/// OpenEXR's standard attribute for the luminance, cd/m², of RGB (1, 1, 1): aleph writes its
/// `luminance_scale` there.
pub const WHITE_LUMINANCE: &str = "whiteLuminance";

/// Samples of one extra EXR channel.
#[derive(Clone, Debug)]
pub enum ChannelData {
    /// 32-bit float samples.
    F32(Vec<f32>),
    /// 32-bit unsigned integer samples.
    U32(Vec<u32>),
}

/// Encodes a single-part OpenEXR image with channels R, G, B (32-bit float, linear, row-major
/// interleaved input `rgb` of 3 × width × height values), the `extra` channels (names such as
/// `spp` or `Threshold.Y`), and string attributes (e.g. units) in the header. ZIP compression
/// (lossless). An attribute named [`WHITE_LUMINANCE`] whose value parses as a number is written
/// as OpenEXR's standard `whiteLuminance` (a float: cd/m² of RGB (1, 1, 1)), which other tools
/// and `aleph tonemap` read as the image's luminance scale.
///
/// # Panics
/// If a buffer's length does not match the image size.
pub fn write_exr(
    w: &mut BufWriter<&File>,
    dest: &Path,
    width: u32,
    height: u32,
    rgb: &[f32],
    extra: &[(String, ChannelData)],
    attributes: &[(String, String)],
) -> std::result::Result<(), OutputError> {
    let n = width as usize * height as usize;
    assert_eq!(rgb.len(), 3 * n);
    let plane = |c: usize| -> Vec<f32> { rgb.iter().skip(c).step_by(3).copied().collect() };
    let mut channels: Vec<AnyChannel<FlatSamples>> = vec![
        AnyChannel::new("R", FlatSamples::F32(plane(0))),
        AnyChannel::new("G", FlatSamples::F32(plane(1))),
        AnyChannel::new("B", FlatSamples::F32(plane(2))),
    ];
    for (name, data) in extra {
        let samples = match data {
            ChannelData::F32(v) => {
                assert_eq!(v.len(), n);
                FlatSamples::F32(v.clone())
            }
            ChannelData::U32(v) => {
                assert_eq!(v.len(), n);
                FlatSamples::U32(v.clone())
            }
        };
        channels.push(AnyChannel::new(name.as_str(), samples));
    }
    let mut attrs = LayerAttributes::default();
    let mut other = HashMap::new();
    for (k, v) in attributes {
        if k == WHITE_LUMINANCE
            && let Ok(white) = v.parse::<f32>()
        {
            attrs.white_luminance = Some(white);
            continue;
        }
        other.insert(
            Text::from(k.as_str()),
            AttributeValue::Text(Text::from(v.as_str())),
        );
    }
    attrs.other = other;
    attrs.software_name = Some(Text::from(concat!("aleph ", env!("CARGO_PKG_VERSION"))));
    let layer = Layer::new(
        (width as usize, height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    // Single-threaded so that block order, and hence the file's bytes, never depend on scheduling.
    let mut bytes = std::io::Cursor::new(Vec::new());
    Image::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut bytes)
        .map_err(|e| OutputError::Encode {
            path: dest.to_path_buf(),
            message: e.to_string(),
        })?;
    let mut bytes = bytes.into_inner();
    sort_exr_header_attributes(&mut bytes);
    w.write_all(&bytes).map_err(|source| OutputError::Io {
        path: dest.to_path_buf(),
        source,
    })
}

/// Sorts the attributes of a single-part EXR header by name, in place, so that the same image
/// always gives the same bytes (the exr crate keeps custom attributes in a `HashMap` and writes
/// them in its random iteration order). The header's length is unchanged, so the chunk offset
/// table that follows stays valid. A buffer that does not parse as a single-part header
/// (magic, version, then `name\0type\0size value` records up to a null byte) is left alone.
fn sort_exr_header_attributes(bytes: &mut [u8]) {
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    if bytes.len() < 9 || bytes[..4] != MAGIC || bytes[5] & 0x10 != 0 {
        return; // not EXR, or multi-part
    }
    let cstr_end = |from: usize| bytes[from..].iter().position(|&b| b == 0).map(|k| from + k);
    let mut records: Vec<(usize, usize)> = Vec::new();
    let mut pos = 8;
    loop {
        if pos >= bytes.len() {
            return;
        }
        if bytes[pos] == 0 {
            break;
        }
        let Some(name_end) = cstr_end(pos) else {
            return;
        };
        let Some(type_end) = cstr_end(name_end + 1) else {
            return;
        };
        let size_at = type_end + 1;
        let Some(size) = bytes.get(size_at..size_at + 4) else {
            return;
        };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let end = size_at + 4 + size.max(0) as usize;
        if size < 0 || end > bytes.len() {
            return;
        }
        records.push((pos, end));
        pos = end;
    }
    let start = 8;
    let mut sorted: Vec<&[u8]> = records.iter().map(|&(a, b)| &bytes[a..b]).collect();
    sorted.sort_by_key(|r| r.split(|&b| b == 0).next().unwrap_or(&[]).to_vec());
    let header: Vec<u8> = sorted.concat();
    bytes[start..pos].copy_from_slice(&header);
}

/// Encodes an animated PNG (APNG; plays in web browsers and most image viewers) of 8-bit RGB
/// frames (row-major, 3 per pixel, all `width × height`), each shown for 1/`fps` s, looping.
///
/// # Errors
/// [`OutputError::Encode`] if the encoder fails (no frames, a frame of the wrong size).
pub fn write_apng(
    w: &mut BufWriter<&File>,
    dest: &Path,
    width: u32,
    height: u32,
    frames: &[Vec<u8>],
    fps: f64,
) -> std::result::Result<(), OutputError> {
    let enc = |e: png::EncodingError| OutputError::Encode {
        path: dest.to_path_buf(),
        message: e.to_string(),
    };
    let mut e = png::Encoder::new(w, width, height);
    e.set_color(png::ColorType::Rgb);
    e.set_depth(png::BitDepth::Eight);
    e.set_animated(frames.len() as u32, 0).map_err(enc)?;
    // Delay as a fraction: 1000 / (1000 fps) s, numerator and denominator within u16.
    let den = (fps * 100.0).round().clamp(1.0, 65535.0) as u16;
    e.set_frame_delay(100, den).map_err(enc)?;
    let mut writer = e.write_header().map_err(enc)?;
    for f in frames {
        writer.write_image_data(f).map_err(enc)?;
    }
    writer.finish().map_err(enc)
}

/// Encodes 8-bit RGB display values (row-major, 3 per pixel) as PNG.
///
/// # Panics
/// If `rgb8.len() != 3 × width × height`.
pub fn write_png(
    w: &mut BufWriter<&File>,
    dest: &Path,
    width: u32,
    height: u32,
    rgb8: &[u8],
) -> std::result::Result<(), OutputError> {
    assert_eq!(rgb8.len(), 3 * width as usize * height as usize);
    let enc = image::codecs::png::PngEncoder::new(w);
    image::ImageEncoder::write_image(enc, rgb8, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| OutputError::Encode {
            path: dest.to_path_buf(),
            message: e.to_string(),
        })
}

/// sRGB OETF (IEC 61966-2-1): linear display value in [0, 1] to encoded [0, 1].
#[inline]
pub fn linear_to_srgb(c: f32) -> f32 {
    let c = c.clamp(0.0, 1.0);
    if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

/// Display-linear RGB in [0, 1] (interleaved) → 8-bit sRGB, rounding to nearest.
pub fn encode_srgb8(display_rgb: &[f32]) -> Vec<u8> {
    display_rgb
        .iter()
        .map(|&c| (linear_to_srgb(if c.is_finite() { c } else { 0.0 }) * 255.0 + 0.5) as u8)
        .collect()
}

/// The simplest tone mapping: multiply linear radiance by 2^`exposure_ev` and clip to [0, 1]
/// (the seed paper's "constant scaling", Figure 4).
pub fn expose(rgb: &[f32], exposure_ev: f32) -> Vec<f32> {
    let k = exposure_ev.exp2();
    rgb.iter().map(|&c| (c * k).clamp(0.0, 1.0)).collect()
}

/// Exposure in stops that maps the log-average luminance of linear `rgb` to middle grey 0.18
/// (the "key" of Reinhard et al. 2002, eq. 1–2, used here as a constant scale factor):
/// EV = log2(0.18 / exp(mean(ln(1e-4 + Y)))). Returns 0 for an empty or all-black image.
pub fn auto_exposure_ev(rgb: &[f32]) -> f32 {
    let mut sum = 0.0f64;
    let mut n = 0usize;
    for p in rgb.chunks_exact(3) {
        let y = perception::photometry::luminance(p[0], p[1], p[2]);
        if y.is_finite() && y > 0.0 {
            sum += (1e-4 + y as f64).ln();
            n += 1;
        }
    }
    if n == 0 {
        return 0.0;
    }
    let log_avg = (sum / n as f64).exp();
    (0.18 / log_avg).log2() as f32
}

#[cfg(test)]
mod exr_bytes_tests {
    use super::*;

    fn encode(attrs: &[(String, String)]) -> Vec<u8> {
        let tmp = tempfile::tempfile().unwrap();
        {
            let mut w = BufWriter::new(&tmp);
            let rgb = vec![0.5f32; 3 * 4 * 2];
            write_exr(&mut w, Path::new("x.exr"), 4, 2, &rgb, &[], attrs).unwrap();
            w.flush().unwrap();
        }
        let mut f = tmp;
        use std::io::{Read, Seek};
        f.rewind().unwrap();
        let mut v = Vec::new();
        f.read_to_end(&mut v).unwrap();
        v
    }

    #[test]
    fn exr_bytes_do_not_depend_on_hash_map_order() {
        let attrs: Vec<(String, String)> = (0..12)
            .map(|i| (format!("attr{i}"), format!("value {i}")))
            .collect();
        let first = encode(&attrs);
        // Fresh hash maps get fresh random keys: any order dependence would show within a few.
        for _ in 0..8 {
            assert_eq!(encode(&attrs), first);
        }
        // And the sorted header still reads back, with every attribute.
        let image = exr::image::read::read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .all_layers()
            .all_attributes()
            .from_buffered(std::io::Cursor::new(&first))
            .unwrap();
        assert_eq!(image.layer_data[0].attributes.other.len(), 12);
    }
}

#[cfg(test)]
mod commit_tests {
    use super::*;

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().to_string())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_failed_commit_replaces_nothing_and_leaves_no_temporary() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a.exr"), d.path().join("b.png"));
        std::fs::write(&a, b"old").unwrap();
        let mut out = AtomicOutputs::new();
        out.stage_bytes(&a, b"new").unwrap();
        out.stage_bytes(&b, b"new").unwrap();
        // A directory appears where b.png goes after staging (staging itself refuses one).
        std::fs::create_dir(&b).unwrap();
        let e = out.commit().unwrap_err().to_string();
        assert!(e.contains("b.png"), "{e}");
        assert_eq!(std::fs::read(&a).unwrap(), b"old");
        assert_eq!(names(d.path()), vec!["a.exr", "b.png"]);
    }

    #[test]
    fn a_commit_replaces_every_file_and_removes_the_old_ones() {
        let d = tempfile::tempdir().unwrap();
        let (a, b) = (d.path().join("a.exr"), d.path().join("b.png"));
        std::fs::write(&a, b"old").unwrap();
        let mut out = AtomicOutputs::new();
        out.stage_bytes(&a, b"new a").unwrap();
        out.stage_bytes(&b, b"new b").unwrap();
        out.commit().unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), b"new a");
        assert_eq!(std::fs::read(&b).unwrap(), b"new b");
        assert_eq!(names(d.path()), vec!["a.exr", "b.png"]);
    }
}

#[cfg(test)]
mod signal_tests {
    use super::*;

    #[test]
    fn staged_temporaries_are_removed_on_interruption() {
        let d = tempfile::tempdir().unwrap();
        let mut out = AtomicOutputs::new();
        out.stage_bytes(&d.path().join("a.exr"), b"x").unwrap();
        let tmp = out.staged[0].0.path().to_path_buf();
        assert!(tmp.exists());
        // What the SIGINT/SIGTERM handler of the binary does before exiting
        // (`remove_staged_temporaries`), limited to this test's directory so that tests running
        // beside it keep their files.
        remove_registered(|p| p.starts_with(d.path()));
        assert!(!tmp.exists());
        assert!(std::fs::read_dir(d.path()).unwrap().next().is_none());
        std::mem::forget(out); // as a signal would: no destructor runs
    }
}
