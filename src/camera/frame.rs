//! Grey-scale frames in memory and on disk: PNG and TIFF, 8 or 16 bit. A colour image
//! is refused (a camera that records colour is converted by the user, who knows which
//! channel carries the grains), so is a frame whose size differs from the movie's first.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};

/// One frame: intensities row by row (`pixels[row * width + col]`), as read (0–255 or
/// 0–65535), in `f32`, which holds every 16-bit value exactly.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub width: usize,
    pub height: usize,
    /// 8 or 16.
    pub bit_depth: u8,
    pub pixels: Vec<f32>,
}

impl Frame {
    pub fn new(width: usize, height: usize, bit_depth: u8) -> Self {
        Self {
            width,
            height,
            bit_depth,
            pixels: vec![0.0; width * height],
        }
    }
    /// The largest value a pixel can hold (255 or 65535).
    pub fn max_value(&self) -> f32 {
        if self.bit_depth == 16 { 65535.0 } else { 255.0 }
    }
    pub fn at(&self, row: usize, col: usize) -> f32 {
        self.pixels[row * self.width + col]
    }
}

fn input_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::Input {
        file: path.display().to_string(),
        msg: msg.into(),
    }
}

/// Reads one PNG or TIFF frame, 8 or 16 bit grey (grey with alpha: the alpha is
/// dropped). A truncated or corrupt file is an error naming it.
pub fn read_frame(path: &Path) -> Result<Frame> {
    Ok(read_frame_hashed(path)?.0)
}

/// `read_frame`, and the SHA-256 (hex) of the file's bytes, read once.
pub fn read_frame_hashed(path: &Path) -> Result<(Frame, String)> {
    use sha2::Digest;
    use std::io::Read;
    thread_local! {
        // The file's bytes and a PNG's decoded bytes, kept between frames (fresh
        // buffers per frame cost their page faults).
        static BYTES: std::cell::RefCell<(Vec<u8>, Vec<u8>)> = const {
            std::cell::RefCell::new((Vec::new(), Vec::new()))
        };
    }
    BYTES.with(|b| {
        let (bytes, decoded) = &mut *b.borrow_mut();
        bytes.clear();
        let io = |cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        };
        std::fs::File::open(path)
            .and_then(|mut f| f.read_to_end(bytes))
            .map_err(io)?;
        let hash = sha2::Sha256::digest(&bytes[..])
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect();
        let frame = if bytes.starts_with(b"\x89PNG\r\n\x1a\n") {
            decode_png(path, bytes, decoded)?
        } else {
            decode_frame(path, bytes)?
        };
        Ok((frame, hash))
    })
}

/// A PNG decoded with the `png` crate into `buf` (reused): grey or grey with alpha, 8
/// or 16 bit (lower depths expanded to 8); anything else is refused as colour.
fn decode_png(path: &Path, bytes: &[u8], buf: &mut Vec<u8>) -> Result<Frame> {
    let bad = |e: png::DecodingError| input_err(path, format!("cannot decode the image: {e}"));
    let mut dec = png::Decoder::new(bytes);
    dec.set_transformations(png::Transformations::EXPAND);
    let mut reader = dec.read_info().map_err(bad)?;
    let (color, depth) = reader.output_color_type();
    let channels = match color {
        png::ColorType::Grayscale => 1,
        png::ColorType::GrayscaleAlpha => 2,
        other => {
            return Err(input_err(
                path,
                format!(
                    "a {other:?} image; expected a grey-scale frame (8 or 16 bit): convert the channel that shows the grains"
                ),
            ));
        }
    };
    buf.clear();
    buf.resize(reader.output_buffer_size(), 0);
    let info = reader.next_frame(buf).map_err(bad)?;
    let (width, height) = (info.width as usize, info.height as usize);
    let data = &buf[..info.buffer_size()];
    let (bit_depth, pixels) = match depth {
        png::BitDepth::Sixteen => (
            16,
            pooled(
                data.chunks_exact(2 * channels)
                    .map(|c| f32::from(u16::from_be_bytes([c[0], c[1]]))),
            ),
        ),
        _ => (
            8,
            pooled(data.iter().step_by(channels).map(|&v| f32::from(v))),
        ),
    };
    if pixels.len() != width * height {
        return Err(input_err(
            path,
            format!("{} pixels decoded for {width}×{height}", pixels.len()),
        ));
    }
    Ok(Frame {
        width,
        height,
        bit_depth,
        pixels,
    })
}

fn decode_frame(path: &Path, bytes: &[u8]) -> Result<Frame> {
    let reader = image::io::Reader::new(std::io::Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|cause| Error::Io {
            path: path.to_path_buf(),
            cause,
        })?;
    match reader.format() {
        Some(image::ImageFormat::Png) | Some(image::ImageFormat::Tiff) => {}
        Some(f) => {
            return Err(input_err(
                path,
                format!("{f:?} frames are not read; expected PNG or TIFF"),
            ));
        }
        None => {
            return Err(input_err(
                path,
                "not a PNG or TIFF image (unrecognised header)",
            ));
        }
    }
    let img = reader
        .decode()
        .map_err(|e| input_err(path, format!("cannot decode the image: {e}")))?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    use image::DynamicImage as D;
    let (bit_depth, pixels): (u8, Vec<f32>) = match img {
        // Into this thread's pooled buffer: a fresh one per frame cost its page faults.
        D::ImageLuma8(b) => (8, pooled(b.as_raw().iter().map(|&v| f32::from(v)))),
        D::ImageLumaA8(b) => (8, pooled(b.pixels().map(|p| f32::from(p.0[0])))),
        D::ImageLuma16(b) => (16, pooled(b.as_raw().iter().map(|&v| f32::from(v)))),
        D::ImageLumaA16(b) => (16, pooled(b.pixels().map(|p| f32::from(p.0[0])))),
        other => {
            return Err(input_err(
                path,
                format!(
                    "a {:?} image; expected a grey-scale frame (8 or 16 bit): convert the channel that shows the grains",
                    other.color()
                ),
            ));
        }
    };
    Ok(Frame {
        width,
        height,
        bit_depth,
        pixels,
    })
}

fn pooled(values: impl Iterator<Item = f32>) -> Vec<f32> {
    let mut v = super::filters::take(0);
    v.extend(values);
    v
}

/// Writes a frame as PNG or TIFF (by the extension), at its bit depth, values rounded
/// and clamped to the range; through a temporary name, renamed when complete.
pub fn write_frame(frame: &Frame, path: &Path) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let format = match ext.as_deref() {
        Some("png") => image::ImageFormat::Png,
        Some("tif") | Some("tiff") => image::ImageFormat::Tiff,
        _ => {
            return Err(Error::Param {
                name: "frame file".into(),
                msg: format!("{}: expected a .png, .tif or .tiff name", path.display()),
            });
        }
    };
    let (w, h) = (frame.width as u32, frame.height as u32);
    let max = frame.max_value();
    let q = |v: f32| v.round().clamp(0.0, max);
    let img = if frame.bit_depth == 16 {
        let raw: Vec<u16> = frame.pixels.iter().map(|&v| q(v) as u16).collect();
        image::DynamicImage::ImageLuma16(
            image::ImageBuffer::from_raw(w, h, raw).expect("buffer of width × height"),
        )
    } else {
        let raw: Vec<u8> = frame.pixels.iter().map(|&v| q(v) as u8).collect();
        image::DynamicImage::ImageLuma8(
            image::ImageBuffer::from_raw(w, h, raw).expect("buffer of width × height"),
        )
    };
    let tmp = tmp_name(path);
    img.save_with_format(&tmp, format)
        .map_err(|e| input_err(&tmp, format!("cannot write the frame: {e}")))?;
    std::fs::rename(&tmp, path).map_err(|cause| Error::Io {
        path: path.to_path_buf(),
        cause,
    })
}

fn tmp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The extension stays last so the encoder's format check sees it.
    path.with_file_name(format!(".tmp-{}-{name}", std::process::id()))
}

/// The frames of a movie in order, with their numbers (0, 1, …).
#[derive(Debug, Clone)]
pub struct FrameSet {
    pub paths: Vec<PathBuf>,
}

fn is_frame_name(p: &Path) -> bool {
    matches!(
        p.extension()
            .and_then(|e| e.to_str())
            .map(|e| e.to_ascii_lowercase())
            .as_deref(),
        Some("png") | Some("tif") | Some("tiff")
    )
}

/// Splits a name into text and number runs, so `frame_10` sorts after `frame_9`.
fn natural_key(s: &str) -> Vec<(String, u64)> {
    let mut out = Vec::new();
    let mut text = String::new();
    let mut chars = s.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_ascii_digit() {
            let mut digits = c.to_string();
            while let Some(&d) = chars.peek() {
                if d.is_ascii_digit() {
                    digits.push(d);
                    chars.next();
                } else {
                    break;
                }
            }
            let n = digits.parse::<u64>().unwrap_or(u64::MAX);
            out.push((std::mem::take(&mut text), n));
        } else {
            text.push(c);
        }
    }
    out.push((text, 0));
    out
}

/// A shell-style pattern with `*` and `?` in the file name only (`frames/img_*.png`).
fn glob_match(pattern: &str, name: &str) -> bool {
    let (p, n): (Vec<char>, Vec<char>) = (pattern.chars().collect(), name.chars().collect());
    let (mut pi, mut ni, mut star, mut mark) = (0, 0, None, 0);
    while ni < n.len() {
        if pi < p.len() && (p[pi] == '?' || p[pi] == n[ni]) {
            pi += 1;
            ni += 1;
        } else if pi < p.len() && p[pi] == '*' {
            star = Some(pi);
            mark = ni;
            pi += 1;
        } else if let Some(s) = star {
            pi = s + 1;
            mark += 1;
            ni = mark;
        } else {
            return false;
        }
    }
    while pi < p.len() && p[pi] == '*' {
        pi += 1;
    }
    pi == p.len()
}

/// The frames named by `inputs`: folders (their PNG and TIFF files), patterns with `*`
/// or `?` in the file name, or files; each folder's or pattern's files in natural order
/// (`img2` before `img10`), the inputs in the order given. Nothing found is an error.
pub fn list_frames(inputs: &[PathBuf]) -> Result<FrameSet> {
    let mut paths = Vec::new();
    for input in inputs {
        let name = input
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let mut found: Vec<PathBuf> = if input.is_dir() {
            read_dir_files(input)?
                .into_iter()
                .filter(|p| is_frame_name(p))
                .collect()
        } else if name.contains('*') || name.contains('?') {
            let dir = match input.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            read_dir_files(&dir)?
                .into_iter()
                .filter(|p| {
                    p.file_name()
                        .is_some_and(|n| glob_match(&name, &n.to_string_lossy()))
                })
                .collect()
        } else if input.is_file() {
            vec![input.clone()]
        } else {
            return Err(Error::Io {
                path: input.clone(),
                cause: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file or folder"),
            });
        };
        if found.is_empty() {
            return Err(input_err(
                input,
                "no frames here: expected PNG or TIFF files (.png, .tif, .tiff)",
            ));
        }
        found.sort_by_cached_key(|p| {
            natural_key(&p.file_name().unwrap_or_default().to_string_lossy())
        });
        paths.extend(found);
    }
    if paths.is_empty() {
        return Err(Error::Param {
            name: "FRAMES".into(),
            msg: "no frames given".into(),
        });
    }
    Ok(FrameSet { paths })
}

fn read_dir_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let rd = std::fs::read_dir(dir).map_err(|cause| Error::Io {
        path: dir.to_path_buf(),
        cause,
    })?;
    let mut out = Vec::new();
    for e in rd {
        let e = e.map_err(|cause| Error::Io {
            path: dir.to_path_buf(),
            cause,
        })?;
        let p = e.path();
        if p.is_file() {
            out.push(p);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn natural_order_and_patterns() {
        let mut names = vec!["img10.png", "img2.png", "img1.png"];
        names.sort_by_cached_key(|n| natural_key(n));
        assert_eq!(names, ["img1.png", "img2.png", "img10.png"]);
        assert!(glob_match("img_*.png", "img_003.png"));
        assert!(!glob_match("img_*.png", "img_003.tif"));
        assert!(glob_match("f?.tif", "f1.tif"));
    }

    #[test]
    fn round_trip_8_and_16_bit_png_and_tiff() {
        let dir = std::env::temp_dir().join(format!("pp-frame-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for (depth, ext) in [(8u8, "png"), (16, "png"), (8, "tif"), (16, "tiff")] {
            let mut f = Frame::new(7, 5, depth);
            let max = f.max_value();
            for (i, v) in f.pixels.iter_mut().enumerate() {
                *v = (i as f32 * 37.0) % max;
            }
            let p = dir.join(format!("f{depth}.{ext}"));
            write_frame(&f, &p).unwrap();
            assert_eq!(read_frame(&p).unwrap(), f, "{}", p.display());
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn truncated_and_colour_files_are_errors_naming_the_file() {
        let dir = std::env::temp_dir().join(format!("pp-frame-bad-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut f = Frame::new(40, 30, 8);
        f.pixels.iter_mut().for_each(|v| *v = 100.0);
        let good = dir.join("good.png");
        write_frame(&f, &good).unwrap();
        let bytes = std::fs::read(&good).unwrap();
        let cut = dir.join("cut.png");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        let e = read_frame(&cut).unwrap_err().to_string();
        assert!(e.contains("cut.png"), "{e}");
        let junk = dir.join("junk.png");
        std::fs::write(&junk, b"not an image").unwrap();
        let e = read_frame(&junk).unwrap_err().to_string();
        assert!(e.contains("junk.png") && e.contains("PNG or TIFF"), "{e}");
        let rgb = dir.join("rgb.png");
        image::RgbImage::new(4, 4).save(&rgb).unwrap();
        let e = read_frame(&rgb).unwrap_err().to_string();
        assert!(e.contains("rgb.png") && e.contains("grey"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
