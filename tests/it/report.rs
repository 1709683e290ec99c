//! Reports and figures: content checks (image size, non-blank pixels, one SVG element
//! group per series), a self-contained HTML with every section, and a headless-browser
//! check when Chromium is installed.

use crate::common;
use crate::common::{BIN, tmpdir};
use std::path::Path;
use std::process::Command;

fn quickstart(out: &Path) -> String {
    let o = Command::new(BIN)
        .args([
            "quickstart",
            "--out",
            out.to_str().unwrap(),
            "--bootstrap",
            "20",
            "--quiet",
        ])
        .output()
        .unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(o.status.success(), "{text}");
    text
}

/// Fraction of pixels that differ from the top-left (background) pixel.
fn ink_fraction(png: &Path) -> (u32, u32, f64) {
    let img = image::open(png)
        .unwrap_or_else(|e| panic!("{}: {e}", png.display()))
        .to_rgb8();
    let bg = *img.get_pixel(0, 0);
    let ink = img.pixels().filter(|p| **p != bg).count();
    (
        img.width(),
        img.height(),
        ink as f64 / (img.width() * img.height()) as f64,
    )
}

/// Distinct non-background colours in a PNG (a colour map uses many, a blank plot one).
fn colours(png: &Path) -> usize {
    let img = image::open(png).unwrap().to_rgb8();
    let mut set = std::collections::HashSet::new();
    for p in img.pixels() {
        set.insert(p.0);
    }
    set.len()
}

#[test]
fn quickstart_report_has_every_section_and_real_figures() {
    let out = tmpdir("qs");
    quickstart(&out);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for id in [
        "id=\"crossover\"",
        "id=\"maps\"",
        "id=\"stress\"",
        "id=\"provenance\"",
    ] {
        assert!(html.contains(id), "section {id} missing");
    }
    // Self-contained: figures are inline SVG, nothing is fetched.
    assert!(html.matches("<svg").count() >= 4, "inline figures");
    assert!(
        !html.contains("http://") || !html.contains("src=\"http"),
        "no remote resources"
    );
    assert!(!html.contains("<script src"), "no external scripts");
    assert!(html.contains("Θ") && html.contains("η_c"), "fit table");

    for stem in ["crossover", "map_speed", "map_j2", "map_d2min"] {
        let png = out.join("figures").join(format!("{stem}.png"));
        let svg = out.join("figures").join(format!("{stem}.svg"));
        let (w, h, ink) = ink_fraction(&png);
        assert!(w >= 600 && h >= 400, "{stem}: {w}x{h}");
        assert!(ink > 0.02, "{stem}: only {ink} of the pixels are drawn");
        let text = std::fs::read_to_string(&svg).unwrap();
        assert!(
            text.starts_with("<svg") || text.contains("<svg"),
            "{stem}.svg"
        );
        assert!(text.contains("<text"), "{stem}.svg has labels");
    }
    // The crossover plot: sample points (circles) and two polylines (binned curve and
    // Eq. 19) for the one data set.
    let svg = std::fs::read_to_string(out.join("figures/crossover.svg")).unwrap();
    assert!(svg.matches("<circle").count() > 500, "scatter points drawn");
    assert!(
        svg.matches("<polyline").count() >= 2,
        "binned curve and fitted law"
    );
    // Maps colour each grain: many colours, and one circle per grain per panel.
    assert!(colours(&out.join("figures/map_speed.png")) > 50);
    let map = std::fs::read_to_string(out.join("figures/map_d2min.svg")).unwrap();
    assert!(
        map.matches("<circle").count() > 2000,
        "grains drawn as disks"
    );
}

#[test]
fn report_opens_in_headless_chromium_when_available() {
    let browser = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        });
    let Some(browser) = browser else {
        common::cannot_check(
            "no chromium on this machine: the browser check is skipped (.ci/run installs it)",
        );
        return;
    };
    let out = tmpdir("chromium");
    quickstart(&out);
    let html = out.join("report.html");
    // The DOM after load: every inline SVG figure and every section must be in it.
    let o = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--disable-gpu", "--dump-dom"])
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let dom = String::from_utf8_lossy(&o.stdout);
    for id in ["crossover", "maps", "stress", "provenance"] {
        assert!(
            dom.contains(&format!("id=\"{id}\"")),
            "section {id} not in the rendered DOM"
        );
    }
    assert!(dom.matches("<svg").count() >= 4);
    let shot = out.join("report.png");
    let o = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--window-size=1280,2400",
        ])
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", html.display()))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, _, ink) = ink_fraction(&shot);
    assert!(ink > 0.05, "screenshot is nearly blank ({ink})");
    let keep = Path::new(env!("CARGO_TARGET_TMPDIR")).join("report-screenshot.png");
    std::fs::copy(&shot, &keep).unwrap();
    eprintln!("screenshot kept at {}", keep.display());
}

/// The text of every `<text>` element of an SVG.
fn svg_texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim().to_string())
        })
        .collect()
}

/// A 60-grain fast simulation to ε = 0.02 (8 frames, forces at frames 0 and 5), its
/// kinematics, and a report of it through the library.
#[test]
fn simulation_report_has_force_maps_kappa_and_numeric_colour_bars() {
    use pillar_pipe::kinematics::Convention;
    use pillar_pipe::stages::kinematics::{KinematicsOptions, LagSpec};
    use pillar_pipe::stages::report::{DatasetInputs, ReportOptions};

    let out = tmpdir("sim");
    let sim = out.join("sim");
    let o = Command::new(BIN)
        .args(["simulate", "pillar", "--n", "60", "--preset", "fast"])
        .args(["--strain", "0.02", "--quiet", "-o"])
        .arg(&sim)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let tracks = sim.join("tracks.parquet");
    let kin = out.join("kinematics.parquet");
    pillar_pipe::stages::kinematics::run(
        &tracks,
        &kin,
        &KinematicsOptions {
            lag: LagSpec::Frames(vec![1]),
            rc: None,
            start: None,
            every: None,
            convention: Convention::Paper,
            columns: Default::default(),
            quiet: true,
        },
    )
    .unwrap();
    let stages = 2;
    let rep = out.join("report");
    pillar_pipe::stages::report::run(
        &rep,
        &ReportOptions {
            title: "tiny simulation".into(),
            datasets: vec![DatasetInputs {
                label: "simulation".into(),
                tracks: Some(tracks),
                kinematics: Some(kin),
                fit: None,
                stress: Some(sim.join("stress_strain.parquet")),
                forces: Some(sim.join("forces.parquet")),
                ..Default::default()
            }],
            map_stages: stages,
            provenance: serde_json::json!({}),
            sizes: None,
        },
    )
    .unwrap();
    let html = std::fs::read_to_string(rep.join("report.html")).unwrap();
    for id in [
        "id=\"forces\"",
        "id=\"fig-forces_fn\"",
        "id=\"fig-forces_ft\"",
        "id=\"fig-forces_sub\"",
        "id=\"fig-kappa\"",
        "m g μ / D",
    ] {
        assert!(html.contains(id), "{id} missing from the report");
    }
    let fig = |stem: &str, ext: &str| rep.join("figures").join(format!("{stem}.{ext}"));
    for stem in ["forces_fn", "forces_ft", "forces_sub"] {
        let (w, h, ink) = ink_fraction(&fig(stem, "png"));
        assert!(w >= 600 && h >= 400, "{stem}: {w}x{h}");
        assert!(ink > 0.05, "{stem}: only {ink} of the pixels are drawn");
        assert!(colours(&fig(stem, "png")) > 20, "{stem}: grains coloured");
        // Every grain is in every snapshot of a simulation: one disk per grain per panel.
        let svg = std::fs::read_to_string(fig(stem, "svg")).unwrap();
        assert_eq!(svg.matches("<circle").count(), 60 * stages, "{stem}");
        let texts = svg_texts(&svg);
        assert!(
            texts.iter().filter(|t| t.contains("ε = ")).count() == stages,
            "{stem}: panels labelled with their strain: {texts:?}"
        );
    }
    let (_, _, ink) = ink_fraction(&fig("kappa", "png"));
    assert!(ink > 0.02, "kappa figure blank");
    let kappa = std::fs::read_to_string(fig("kappa", "svg")).unwrap();
    assert!(kappa.contains("<polyline"), "κ curve drawn");
    // Colour bars: five ticks that read as increasing numbers (no "1e-2.7"), on linear
    // and log scales alike.
    for stem in [
        "map_speed",
        "map_j2",
        "map_d2min",
        "forces_fn",
        "forces_sub",
    ] {
        let svg = std::fs::read_to_string(fig(stem, "svg")).unwrap();
        let ticks: Vec<f64> = svg_texts(&svg)
            .iter()
            .filter(|t| !t.contains(':') && !t.contains('('))
            .map(|t| {
                t.parse::<f64>()
                    .unwrap_or_else(|_| panic!("{stem}: tick {t:?} is not a number"))
            })
            .collect();
        assert_eq!(ticks.len(), 5, "{stem}: {ticks:?}");
        assert!(ticks.windows(2).all(|w| w[0] < w[1]), "{stem}: {ticks:?}");
    }
}
