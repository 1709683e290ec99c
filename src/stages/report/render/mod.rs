//! Figures (plotters, headless: PNG and SVG from the bundled font, no system font or
//! display) and the self-contained HTML report. Knows nothing of files' formats: the
//! `report` stage hands it plain data.

pub mod curves;
pub mod figures;
pub mod html;
pub mod map;
pub mod scatter;

use crate::error::{Error, Result};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// The bundled font (DejaVu Sans; licence in assets/fonts/DejaVuSans.LICENSE).
static FONT: &[u8] = include_bytes!("../../../../assets/fonts/DejaVuSans.ttf");
pub const FONT_FAMILY: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        for style in [FontStyle::Normal, FontStyle::Bold] {
            // The bundled file is a valid font; a test renders text with it.
            let _ = plotters::style::register_font(FONT_FAMILY, style, FONT);
        }
    });
}

/// A figure's title and axis descriptions, as drawn.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Labels {
    pub title: String,
    pub x: String,
    pub y: String,
}

impl Labels {
    pub fn of(title: &str, x: &str, y: &str) -> Self {
        Labels {
            title: title.into(),
            x: x.into(),
            y: y.into(),
        }
    }
}

/// Something that draws itself on any plotters backend.
pub trait Figure {
    /// Width and height, pixels.
    fn size(&self) -> (u32, u32);
    /// Its title and axes (empty where a figure kind does not say), so that tests can
    /// hold a title that cites a paper's figure to that figure's axes.
    fn labels(&self) -> Labels {
        Labels::default()
    }
    fn draw<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
    ) -> std::result::Result<(), String>;
}

/// The files a figure was saved to, and its SVG markup for inlining.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SavedFigure {
    pub png: PathBuf,
    pub svg: PathBuf,
    #[serde(skip)]
    pub svg_text: String,
    #[serde(skip)]
    pub labels: Labels,
}

/// Render `fig` to `<stem>.png` and `<stem>.svg`, each written under a temporary name
/// and renamed into place.
pub fn save(fig: &impl Figure, stem: &Path) -> Result<SavedFigure> {
    register_font();
    let (w, h) = fig.size();
    let err = |what: &str, e: String| Error::Other(format!("{}: {what}: {e}", stem.display()));
    let mut svg_text = String::new();
    {
        let root = SVGBackend::with_string(&mut svg_text, (w, h)).into_drawing_area();
        fig.draw(&root).map_err(|e| err("drawing SVG", e))?;
        root.present().map_err(|e| err("SVG", e.to_string()))?;
    }
    let svg = stem.with_extension("svg");
    crate::io::atomic_write_str(&svg, &svg_text)?;
    let png = stem.with_extension("png");
    let dir = png.parent().unwrap_or(Path::new("."));
    let name = png
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    // The bitmap backend picks the encoder from the extension: keep `.png` last.
    let tmp = dir.join(format!(".{name}.partial-{}.png", std::process::id()));
    let drawn = (|| {
        let root = BitMapBackend::new(&tmp, (w, h)).into_drawing_area();
        fig.draw(&root).map_err(|e| err("drawing PNG", e))?;
        root.present().map_err(|e| err("PNG", e.to_string()))
    })();
    match drawn {
        Ok(()) => std::fs::rename(&tmp, &png).map_err(|e| Error::io(&png, e))?,
        Err(e) => {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
    }
    Ok(SavedFigure {
        png,
        svg,
        svg_text,
        labels: fig.labels(),
    })
}

/// Viridis, from its 9 anchor colours, t ∈ [0, 1].
pub fn viridis(t: f64) -> RGBColor {
    const A: [(u8, u8, u8); 9] = [
        (68, 1, 84),
        (71, 44, 122),
        (59, 81, 139),
        (44, 113, 142),
        (33, 144, 141),
        (39, 173, 129),
        (92, 200, 99),
        (170, 220, 50),
        (253, 231, 37),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * 8.0;
    let k = (x.floor() as usize).min(7);
    let f = x - k as f64;
    let mix = |a: u8, b: u8| (a as f64 + f * (b as f64 - a as f64)).round() as u8;
    RGBColor(
        mix(A[k].0, A[k + 1].0),
        mix(A[k].1, A[k + 1].1),
        mix(A[k].2, A[k + 1].2),
    )
}

/// Series colours: experiment, simulation, then others.
pub const PALETTE: [RGBColor; 4] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(148, 103, 189),
];
