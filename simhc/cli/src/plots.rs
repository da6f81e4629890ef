//! Figures of the benchmarks, written as PNG and SVG with plotters (pure-Rust backends; the
//! labels use an embedded subset of DejaVu Sans through ab_glyph, so no system font or
//! fontconfig is needed).

use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../assets/DejaVuSans-subset.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The embedded font is valid (it is parsed here on every run of the figures).
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Distinct colors for up to 10 series.
const COLORS: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// One curve: a name and its points.
pub type Series = (String, Vec<(f64, f64)>);

/// One panel of a figure.
pub struct Panel {
    /// Panel title.
    pub title: String,
    /// X axis label.
    pub x_label: String,
    /// Y axis label.
    pub y_label: String,
    /// Curves.
    pub series: Vec<Series>,
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

fn draw_panel<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, panel: &Panel, step: bool) -> DrawResult
where
    DB::ErrorType: 'static,
{
    let points = panel.series.iter().flat_map(|s| s.1.iter());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in points {
        if x.is_finite() && y.is_finite() {
            (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
        }
    }
    if !x0.is_finite() {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = 0.05 * (y1 - y0).abs().max(1e-9);
    let (y0, y1) = (if y0 >= 0.0 { 0.0 } else { y0 - pad }, y1 + pad);
    let mut chart = ChartBuilder::on(area)
        .caption(&panel.title, ("sans-serif", 20))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(55)
        .build_cartesian_2d(x0..x1, y0..y1)?;
    chart.configure_mesh().x_desc(panel.x_label.as_str()).y_desc(panel.y_label.as_str()).label_style(("sans-serif", 13)).draw()?;
    for (k, (name, pts)) in panel.series.iter().enumerate() {
        let color = COLORS[k % COLORS.len()];
        let pts: Vec<(f64, f64)> = pts.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()).collect();
        let line: Vec<(f64, f64)> = if step {
            // histogram outline: horizontal segments of width `w` centred on the bin centres
            let w = if pts.len() > 1 { pts[1].0 - pts[0].0 } else { 1.0 };
            pts.iter().flat_map(|&(x, y)| [(x - w / 2.0, y), (x + w / 2.0, y)]).collect()
        } else {
            pts.clone()
        };
        chart
            .draw_series(LineSeries::new(line, color.stroke_width(2)))?
            .label(name.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
        if !step {
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 3, color.filled())))?;
        }
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 12))
        .position(if step { SeriesLabelPosition::UpperMiddle } else { SeriesLabelPosition::UpperRight })
        .draw()?;
    Ok(())
}

fn draw_all<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, title: &str, panels: &[Panel], step: bool) -> DrawResult
where
    DB::ErrorType: 'static,
{
    root.fill(&WHITE)?;
    let root = root.titled(title, ("sans-serif", 22))?;
    let areas = root.split_evenly((1, panels.len().max(1)));
    for (area, panel) in areas.iter().zip(panels) {
        draw_panel(area, panel, step)?;
    }
    root.present()?;
    Ok(())
}

/// Writes `base.png` and `base.svg` with the panels side by side (`step`: histogram outlines
/// instead of lines with markers). Returns the two paths.
pub fn write_figure(base: &Path, title: &str, panels: &[Panel], step: bool) -> Result<Vec<PathBuf>, String> {
    register_font();
    if let Some(dir) = base.parent() {
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    }
    let size = (520 * panels.len().max(1) as u32, 440);
    let png = base.with_extension("png");
    let svg = base.with_extension("svg");
    draw_all(BitMapBackend::new(&png, size).into_drawing_area(), title, panels, step).map_err(|e| format!("{}: {e}", png.display()))?;
    draw_all(SVGBackend::new(&svg, size).into_drawing_area(), title, panels, step).map_err(|e| format!("{}: {e}", svg.display()))?;
    Ok(vec![png, svg])
}

/// Histogram of `log10(values)` (values clamped below at `1e-15`) over `[lo, hi)` in `bins`
/// bins, as (bin centre, fraction of `values` in percent); values outside the range go to the
/// first / last bin. Non-finite values are left out (they still count in the denominator).
pub fn log10_histogram(values: &[f64], lo: f64, hi: f64, bins: usize) -> Vec<(f64, f64)> {
    let w = (hi - lo) / bins as f64;
    let mut counts = vec![0usize; bins];
    for &v in values {
        if !v.is_finite() {
            continue;
        }
        let l = v.max(1e-15).log10();
        let k = (((l - lo) / w).floor().max(0.0) as usize).min(bins - 1);
        counts[k] += 1;
    }
    let n = values.len().max(1) as f64;
    counts.iter().enumerate().map(|(k, &c)| (lo + (k as f64 + 0.5) * w, 100.0 * c as f64 / n)).collect()
}
