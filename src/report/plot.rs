//! Log-log line plots as SVG (plotters), readable without any font files.

use std::path::Path;

use plotters::coord::combinators::BindKeyPoints;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

/// One named line of points. Its colour tells one thing apart (a
/// backend), its line and marker another (an estimator, a scene family),
/// so that a plot of many series never gives two the same look.
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    /// The colour's index: series of one backend share it.
    pub colour: usize,
    /// The line's and marker's index: series of one estimator share it.
    pub style: usize,
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// Size of the axes' area; the legend column is added to its right,
/// as wide as its longest name needs (the legend never covers data and
/// never runs off the canvas).
const PLOT_SIZE: (u32, u32) = (650, 560);

/// An upper bound on the width of one character of the legend's 14-pixel
/// sans-serif text (an average letter is 7-8 pixels wide).
pub const LEGEND_CHAR_WIDTH: u32 = 9;

/// Where a legend's text starts, from the column's left edge.
const LEGEND_TEXT_X: u32 = 48;

/// The legend column's width for `series`.
pub fn legend_width(series: &[Series]) -> u32 {
    let longest = series
        .iter()
        .map(|s| s.name.chars().count())
        .max()
        .unwrap_or(0);
    LEGEND_TEXT_X + LEGEND_CHAR_WIDTH * longest as u32 + 16
}

/// Line dash patterns (dash, gap in pixels; none for a solid line), one
/// per style.
const DASHES: [Option<(u32, u32)>; 4] = [None, Some((10, 5)), Some((3, 4)), Some((18, 6))];

/// Draws `style`'s marker at `at` in `colour`.
fn marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    at: (i32, i32),
    style: usize,
    colour: RGBColor,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    let (x, y) = at;
    match style % 4 {
        0 => area.draw(&Circle::new(at, 4, colour.filled()))?,
        1 => area.draw(&TriangleMarker::new(at, 5, colour.filled()))?,
        2 => area.draw(&Rectangle::new(
            [(x - 4, y - 4), (x + 4, y + 4)],
            colour.filled(),
        ))?,
        _ => area.draw(&Cross::new(at, 5, colour.stroke_width(2)))?,
    }
    Ok(())
}

/// Draws a line through `points` (pixel coordinates) in `style`'s dashes.
fn line<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    points: Vec<(i32, i32)>,
    style: usize,
    colour: RGBColor,
) -> Result<(), Box<dyn std::error::Error>>
where
    DB::ErrorType: 'static,
{
    match DASHES[style % DASHES.len()] {
        None => area.draw(&PathElement::new(points, colour.stroke_width(2)))?,
        Some((dash, gap)) => area.draw(&DashedPathElement::new(
            points,
            dash,
            gap,
            colour.stroke_width(2),
        ))?,
    }
    Ok(())
}

/// Draws `series` on log-log axes into an SVG file: grid lines only at the
/// labelled ticks (1, 2 and 5 per decade, or fewer on wide ranges), the
/// legend in a column to the right of the axes.
pub fn loglog(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), String> {
    let points = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| *x > 0.0 && *y > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in points {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if x0 > x1 {
        return Err(format!("{}: nothing to plot", path.display()));
    }
    let (x0, x1, y0, y1) = (x0 / 1.3, x1 * 1.3, y0 / 1.3, y1 * 1.3);
    let size = (PLOT_SIZE.0 + legend_width(series), PLOT_SIZE.1);
    let draw = || -> Result<(), Box<dyn std::error::Error>> {
        let root = SVGBackend::new(path, size).into_drawing_area();
        root.fill(&WHITE)?;
        let (plot_area, legend_area) = root.split_horizontally(PLOT_SIZE.0);
        let mut chart = ChartBuilder::on(&plot_area)
            .caption(title, ("sans-serif", 22))
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (x0..x1).log_scale().with_key_points(log_ticks(x0, x1)),
                (y0..y1).log_scale().with_key_points(log_ticks(y0, y1)),
            )?;
        chart
            .configure_mesh()
            .x_desc(x_label)
            .y_desc(y_label)
            .x_label_formatter(&|v| tick(*v))
            .y_label_formatter(&|v| tick(*v))
            .label_style(("sans-serif", 14))
            .bold_line_style(BLACK.mix(0.12))
            .light_line_style(TRANSPARENT)
            .draw()?;
        for (i, s) in series.iter().enumerate() {
            let colour = COLOURS[s.colour % COLOURS.len()];
            let pts: Vec<(f64, f64)> = s
                .points
                .iter()
                .copied()
                .filter(|(x, y)| *x > 0.0 && *y > 0.0)
                .collect();
            // In the canvas's pixels (the axes' area starts at its left
            // edge), so that lines and markers share one drawing routine
            // with the legend.
            let pixels: Vec<(i32, i32)> = pts.iter().map(|p| chart.backend_coord(p)).collect();
            line(&root, pixels.clone(), s.style, colour)?;
            for &p in &pixels {
                marker(&root, p, s.style, colour)?;
            }
            // The legend: one line per series, top down, beside the axes.
            let y = 70 + 24 * i as i32;
            line(&legend_area, vec![(8, y), (40, y)], s.style, colour)?;
            marker(&legend_area, (24, y), s.style, colour)?;
            legend_area.draw(&Text::new(
                s.name.clone(),
                (LEGEND_TEXT_X as i32, y - 7),
                ("sans-serif", 14).into_font(),
            ))?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| format!("{}: cannot draw the plot: {e}", path.display()))
}

/// Tick values for a log axis over `lo..hi`: 1, 2 and 5 times each power
/// of ten inside, or only 1 and 3 (or only the powers) when that would
/// give more than 12; at least the two ends' nearest values.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    let first = lo.log10().floor() as i32;
    let last = hi.log10().ceil() as i32;
    let within = |steps: &[f64]| -> Vec<f64> {
        (first..=last)
            .flat_map(|e| steps.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|v| (lo..=hi).contains(v))
            .collect()
    };
    for steps in [&[1.0, 2.0, 5.0][..], &[1.0, 3.0], &[1.0]] {
        let ticks = within(steps);
        // Enough to read the axis by, not so many they crowd; the powers
        // alone are taken if there are at least two.
        let enough = (3..=12).contains(&ticks.len()) || (steps.len() == 1 && ticks.len() >= 2);
        if enough {
            return ticks;
        }
    }
    // A range inside one decade: five evenly spaced in the log.
    (0..=4)
        .map(|k| lo * (hi / lo).powf(k as f64 / 4.0))
        .collect()
}

/// A short tick label: plain for 0.01..10000, scientific otherwise.
fn tick(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    let a = v.abs();
    if (0.01..10_000.0).contains(&a) {
        let s = format!("{v:.3}");
        let s = if a < 0.1 { format!("{v:.4}") } else { s };
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Least-squares slope of log y against log x.
/// The least-squares line `y = a + b x` through `points`: `(b, a, R²)`.
pub fn line_fit(points: &[(f64, f64)]) -> (f64, f64, f64) {
    let n = points.len() as f64;
    if n < 2.0 {
        return (f64::NAN, f64::NAN, f64::NAN);
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    let syy: f64 = points.iter().map(|p| (p.1 - my) * (p.1 - my)).sum();
    let b = sxy / sxx;
    let r2 = if syy > 0.0 {
        sxy * sxy / (sxx * syy)
    } else {
        1.0
    };
    (b, my - b * mx, r2)
}

pub fn loglog_slope(points: &[(f64, f64)]) -> f64 {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    let n = pts.len() as f64;
    if n < 2.0 {
        return f64::NAN;
    }
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Twelve series, three backends by four estimators, with the longest
    /// names the report gives: every legend line lies inside the canvas,
    /// and no two series look the same (colour, dashes and marker).
    #[test]
    fn legends_fit_the_canvas_and_every_series_looks_its_own() {
        let estimators = ["hemisphere", "light sampling", "MIS", "adaptive (MIS)"];
        let series: Vec<Series> = (0..3)
            .flat_map(|b| {
                estimators.iter().enumerate().map(move |(e, name)| Series {
                    name: format!("embree{b}, cloud of bunnies, {name} (slope 0.55)"),
                    points: vec![
                        (1.0 + b as f64, 2.0 + e as f64),
                        (10.0, 5.0 * (1 + e) as f64),
                    ],
                    colour: b,
                    style: e,
                })
            })
            .collect();
        let path = std::env::temp_dir().join(format!("hybrid-plot-{}.svg", std::process::id()));
        loglog(&path, "title", "x", "y", &series).expect("the plot draws");
        let svg = std::fs::read_to_string(&path).expect("the plot is written");
        let _ = std::fs::remove_file(&path);
        let width: u32 = svg
            .split("width=\"")
            .nth(1)
            .and_then(|w| w.split('"').next())
            .and_then(|w| w.parse().ok())
            .expect("the SVG names its width");
        for s in &series {
            let at = svg
                .find(&s.name)
                .unwrap_or_else(|| panic!("{} is in the legend", s.name));
            let x: u32 = svg[..at]
                .rsplit("x=\"")
                .next()
                .and_then(|x| x.split('"').next())
                .and_then(|x| x.parse().ok())
                .expect("the legend's text has an x");
            let end = x + LEGEND_CHAR_WIDTH * s.name.chars().count() as u32;
            assert!(
                end <= width,
                "{} ends at {end}, past the canvas's {width}",
                s.name
            );
        }
        let looks: std::collections::HashSet<_> = series
            .iter()
            .map(|s| (s.colour % COLOURS.len(), s.style % DASHES.len()))
            .collect();
        assert_eq!(looks.len(), series.len(), "two series look the same");
        // Three colours and four dash patterns are drawn.
        for c in &COLOURS[..3] {
            let hex = format!("#{:02X}{:02X}{:02X}", c.0, c.1, c.2);
            assert!(svg.to_uppercase().contains(&hex), "colour {hex} is drawn");
        }
        assert!(svg.matches("<path").count() + svg.matches("<polyline").count() >= 12);
    }

    #[test]
    fn log_axes_get_labelled_ticks_inside_their_range() {
        // Under two decades: 1, 2 and 5 per decade.
        assert_eq!(
            log_ticks(0.0007, 0.06),
            vec![0.001, 0.002, 0.005, 0.01, 0.02, 0.05]
        );
        // Four decades would give 13: 1 and 3 instead.
        let wide = log_ticks(50.0, 2e6);
        assert!(wide.len() <= 12 && wide.len() >= 5, "{wide:?}");
        assert!(wide.iter().all(|v| (50.0..=2e6).contains(v)));
        // Inside one decade: still several ticks, spread in the log.
        let narrow = log_ticks(0.11, 0.15);
        assert!(narrow.len() >= 3, "{narrow:?}");
        assert!(narrow.windows(2).all(|w| w[0] < w[1]));
    }
}
