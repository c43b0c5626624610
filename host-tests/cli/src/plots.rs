//! The SVG plots of the `ema` commands, drawn with plotters' SVG backend: a time-series plot
//! (`ema discover`'s `fit.svg` and `residual.svg`) and a grouped bar chart (`ema campaign`'s
//! `error.svg` and `time.svg`, like the paper's Figures 4–5, Dalla Vedova, Berri, Re, ICSRS
//! 2018).
//!
//! Both have round ticks (plotters places them at 1, 2 or 5 × 10ⁿ steps), axis titles with
//! their units, a zero line and a legend: every line and bar series is named there, and so are the
//! shaded time windows of a time-series plot. The files are byte-stable for a given input (no
//! timestamp, no random identifier).

use std::io;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// Colours of successive bar series (pairs of a dark and a light shade: low and high severity).
const BAR_COLOURS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(174, 199, 232),
    RGBColor(214, 39, 40),
    RGBColor(255, 152, 150),
    RGBColor(44, 160, 44),
    RGBColor(152, 223, 138),
];

/// Fill of the shaded time windows.
const SHADE: RGBColor = RGBColor(255, 200, 80);

/// Colour of the zero line.
const ZERO: RGBColor = RGBColor(90, 90, 90);

/// One line of a time-series plot.
#[derive(Clone, Copy, Debug)]
pub struct Line<'a> {
    /// Its name in the legend.
    pub name: &'a str,
    /// Its colour, `(r, g, b)`.
    pub colour: (u8, u8, u8),
    /// One value per time of the plot.
    pub values: &'a [f64],
}

/// What a legend entry shows beside its name.
#[derive(Clone, Copy, Debug)]
enum Swatch {
    /// A short line of this colour.
    Line(RGBColor),
    /// A filled square of this colour.
    Fill(RGBAColor),
}

/// A drawing result of the SVG backend.
type Drawn<T = ()> = Result<T, DrawingAreaErrorKind<io::Error>>;

/// Width of a legend entry's swatch and the gap after it, in pixels.
const SWATCH_W: i32 = 30;

/// Left edge of the legend and of the plotting area, in pixels (margin + label area).
const LEGEND_LEFT: i32 = 72;

/// Height of one legend row, in pixels.
const LEGEND_ROW: i32 = 20;

/// The legend's font.
fn legend_font() -> FontDesc<'static> {
    ("sans-serif", 13).into_font()
}

/// The rows of a legend of `names` laid out left to right within `width` pixels: for each name
/// its row and its x offset.
fn legend_layout(area: &DrawingArea<SVGBackend, Shift>, names: &[&str], width: i32) -> Drawn<Vec<(i32, i32)>> {
    let (mut row, mut x) = (0, LEGEND_LEFT);
    let mut places = Vec::with_capacity(names.len());
    for name in names {
        let (w, _) = area.estimate_text_size(name, &legend_font().into_text_style(area))?;
        let item = SWATCH_W + i32::try_from(w).unwrap_or(width) + 24;
        if x > LEGEND_LEFT && x + item > width {
            (row, x) = (row + 1, LEGEND_LEFT);
        }
        places.push((row, x));
        x += item;
    }
    Ok(places)
}

/// Draws a legend below a plot, in `area`: each entry a swatch and its name, at the places of
/// [`legend_layout`].
fn draw_legend(area: &DrawingArea<SVGBackend, Shift>, items: &[(&str, Swatch)], places: &[(i32, i32)]) -> Drawn {
    for ((name, swatch), &(row, x)) in items.iter().zip(places) {
        let y = 10 + row * LEGEND_ROW;
        match *swatch {
            Swatch::Line(c) => area.draw(&PathElement::new([(x, y), (x + 22, y)], c.stroke_width(2)))?,
            Swatch::Fill(c) => area.draw(&Rectangle::new([(x + 4, y - 6), (x + 18, y + 6)], c.filled()))?,
        }
        let style = legend_font().into_text_style(area).pos(Pos::new(HPos::Left, VPos::Center));
        area.draw(&Text::new(name.to_string(), (x + SWATCH_W, y), style))?;
    }
    Ok(())
}

/// Splits `root` (`width` × `height` pixels) into the plot above and the legend of `items` below,
/// the legend as many rows high as it needs, and draws the legend.
fn with_legend<'a>(
    root: &DrawingArea<SVGBackend<'a>, Shift>,
    width: i32,
    height: i32,
    items: &[(&str, Swatch)],
) -> Drawn<DrawingArea<SVGBackend<'a>, Shift>> {
    let names: Vec<&str> = items.iter().map(|(n, _)| *n).collect();
    let places = legend_layout(root, &names, width - 12)?;
    let rows = places.iter().map(|p| p.0 + 1).max().unwrap_or(0);
    let (plot, legend) = root.split_vertically(height - rows * LEGEND_ROW - 6);
    draw_legend(&legend, items, &places)?;
    Ok(plot)
}

/// A drawing error of plotters, as an I/O error (the caller names the file).
/// An SVG of `size_px` (width, height) pixels that `draw` fills, as text.
fn render_svg<E: std::fmt::Display>(
    size_px: (u32, u32),
    draw: impl FnOnce(&DrawingArea<SVGBackend, Shift>) -> Result<(), E>,
) -> io::Result<String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size_px).into_drawing_area();
        draw(&root).map_err(plot_error)?;
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

fn plot_error(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(format!("cannot draw the plot: {e}"))
}

/// `[lo, hi]` widened by 5 % on each side and to include 0, so the zero line is always in view;
/// `[-1, 1]` when there are no finite values.
fn value_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    let mut any = false;
    for v in values.filter(|v| v.is_finite()) {
        (lo, hi, any) = (lo.min(v), hi.max(v), true);
    }
    if !any || hi <= lo {
        return (-1.0, 1.0);
    }
    let pad = 0.05 * (hi - lo);
    (lo - if lo < 0.0 { pad } else { 0.0 }, hi + if hi > 0.0 { pad } else { 0.0 })
}

/// A time-series plot: one line per [`Line`] against the times `t` (s), the zero line, the time
/// spans of `shaded` (start, end in s) shaded and named `shaded_name` in the legend. The value
/// axis spans the lines' range and 0; `y_title` names it with its unit.
pub fn line_plot(
    title: &str,
    y_title: &str,
    t: &[f64],
    lines: &[Line],
    shaded: &[(f64, f64)],
    shaded_name: &str,
) -> io::Result<String> {
    render_svg((960, 440), |root| draw_lines(root, title, y_title, t, lines, shaded, shaded_name))
}

fn draw_lines(
    root: &DrawingArea<SVGBackend, Shift>,
    title: &str,
    y_title: &str,
    t: &[f64],
    lines: &[Line],
    shaded: &[(f64, f64)],
    shaded_name: &str,
) -> Drawn {
    root.fill(&WHITE)?;
    let shade = SHADE.mix(0.35);
    let mut items: Vec<(&str, Swatch)> = Vec::new();
    if !shaded.is_empty() {
        items.push((shaded_name, Swatch::Fill(shade)));
    }
    items.extend(lines.iter().map(|l| (l.name, Swatch::Line(RGBColor(l.colour.0, l.colour.1, l.colour.2)))));
    items.push(("zero", Swatch::Line(ZERO)));
    let plot = with_legend(root, 960, 440, &items)?;
    let t_max = t.last().copied().filter(|v| v.is_finite() && *v > 0.0).unwrap_or(1.0);
    let (lo, hi) = value_range(lines.iter().flat_map(|l| l.values.iter().copied()));
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..t_max, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .y_desc(y_title)
        .x_labels(12)
        .y_labels(8)
        .light_line_style(RGBColor(240, 240, 240))
        .draw()?;
    chart.draw_series(shaded.iter().map(|&(a, b)| Rectangle::new([(a, lo), (b, hi)], shade.filled())))?;
    chart.draw_series(LineSeries::new([(0.0, 0.0), (t_max, 0.0)], ZERO.stroke_width(1)))?;
    for line in lines {
        let (r, g, b) = line.colour;
        chart.draw_series(LineSeries::new(
            t.iter().zip(line.values).filter(|(_, v)| v.is_finite()).map(|(&x, &y)| (x, y)),
            RGBColor(r, g, b).stroke_width(1),
        ))?;
    }
    Ok(())
}

/// A grouped bar chart: one group of bars per name of `groups`, one bar per name of `series`
/// (`value(group, series)`, `None` for no bar), a legend naming the series. The value axis runs
/// from 0 to `top` (its unit `unit`), with round ticks.
pub fn grouped_bars(
    title: &str,
    unit: &str,
    groups: &[&str],
    series: &[String],
    top: f64,
    value: impl Fn(usize, usize) -> Option<f64>,
) -> io::Result<String> {
    render_svg((820, 420), |root| draw_bars(root, title, unit, groups, series, top, value))
}

fn draw_bars(
    root: &DrawingArea<SVGBackend, Shift>,
    title: &str,
    unit: &str,
    groups: &[&str],
    series: &[String],
    top: f64,
    value: impl Fn(usize, usize) -> Option<f64>,
) -> Drawn {
    root.fill(&WHITE)?;
    let items: Vec<(&str, Swatch)> = series
        .iter()
        .enumerate()
        .map(|(s, name)| (name.as_str(), Swatch::Fill(BAR_COLOURS[s % BAR_COLOURS.len()].into())))
        .collect();
    let plot = with_legend(root, 820, 420, &items)?;
    let top = if top.is_finite() && top > 0.0 { top * 1.05 } else { 1.0 };
    let n_groups = groups.len().max(1);
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(28)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n_groups as f64, 0.0..top)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .y_desc(unit)
        .y_labels(8)
        .light_line_style(RGBColor(235, 235, 235))
        .draw()?;
    // the group names centred under their groups, in the x label area (the x axis has no
    // numeric ticks)
    for (g, name) in groups.iter().enumerate() {
        let (x, y) = chart.backend_coord(&(g as f64 + 0.5, 0.0));
        let style = legend_font().into_text_style(&plot).pos(Pos::new(HPos::Center, VPos::Top));
        plot.draw(&Text::new(name.to_string(), (x, y + 6), style))?;
    }
    chart.draw_series(LineSeries::new([(0.0, 0.0), (n_groups as f64, 0.0)], BLACK.stroke_width(1)))?;
    let bar_w = 0.8 / series.len().max(1) as f64;
    for s in 0..series.len() {
        let colour = BAR_COLOURS[s % BAR_COLOURS.len()];
        chart.draw_series((0..groups.len()).filter_map(|g| {
            let v = value(g, s)?;
            let x0 = g as f64 + 0.1 + bar_w * s as f64;
            Some(Rectangle::new([(x0, 0.0), (x0 + 0.95 * bar_w, v)], colour.filled()))
        }))?;
    }
    Ok(())
}

/// One fault mode of a severity plot ([`severity_plot`]).
#[derive(Clone, Debug)]
pub struct SeveritySeries<'a> {
    /// Its name in the legend.
    pub name: &'a str,
    /// Its colour, `(r, g, b)`.
    pub colour: (u8, u8, u8),
    /// `(flight, severity)` of each diagnosis.
    pub points: &'a [(f64, f64)],
    /// The points of `points` at which the mode was declared by pooled evidence (ringed).
    pub declared: &'a [(f64, f64)],
    /// The trend line, from `(flight, severity)` to `(flight, severity)`.
    pub trend: Option<((f64, f64), (f64, f64))>,
    /// The flights of the interval on the failing-threshold crossing (the RUL band), the upper
    /// end `None` when unbounded.
    pub band: Option<(f64, Option<f64>)>,
}

/// Severity against flight: per mode its diagnoses (points joined by a line), its trend and the
/// interval on the flight at which it reaches `threshold` (a shaded band), the threshold as a
/// horizontal line; the flight axis runs to `last_flight`.
pub fn severity_plot(title: &str, series: &[SeveritySeries], threshold: f64, last_flight: f64) -> io::Result<String> {
    render_svg((960, 460), |root| draw_severity(root, title, series, threshold, last_flight))
}

fn draw_severity(
    root: &DrawingArea<SVGBackend, Shift>,
    title: &str,
    series: &[SeveritySeries],
    threshold: f64,
    last_flight: f64,
) -> Drawn {
    root.fill(&WHITE)?;
    let colour = |s: &SeveritySeries| RGBColor(s.colour.0, s.colour.1, s.colour.2);
    let band_names: Vec<String> = series.iter().map(|s| format!("{} RUL band", s.name)).collect();
    let mut items: Vec<(&str, Swatch)> = Vec::new();
    for (s, band) in series.iter().zip(&band_names) {
        items.push((s.name, Swatch::Line(colour(s))));
        if s.band.is_some() {
            items.push((band.as_str(), Swatch::Fill(colour(s).mix(0.18))));
        }
    }
    items.push(("failing threshold", Swatch::Line(ZERO)));
    if series.iter().any(|s| !s.declared.is_empty()) {
        items.push(("ringed: declared by pooled evidence", Swatch::Line(ZERO)));
    }
    let plot = with_legend(root, 960, 460, &items)?;
    let x_max = if last_flight.is_finite() && last_flight > 1.0 { last_flight } else { 2.0 };
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..x_max, 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc("flight")
        .y_desc("severity")
        .x_labels(12)
        .y_labels(10)
        .light_line_style(RGBColor(240, 240, 240))
        .draw()?;
    for s in series {
        if let Some((lo, hi)) = s.band {
            let (lo, hi) = (lo.clamp(0.0, x_max), hi.unwrap_or(x_max).clamp(0.0, x_max));
            chart.draw_series([Rectangle::new([(lo, 0.0), (hi, 1.0)], colour(s).mix(0.18).filled())])?;
        }
    }
    chart.draw_series(LineSeries::new([(0.0, threshold), (x_max, threshold)], ZERO.stroke_width(1)))?;
    for s in series {
        let c = colour(s);
        chart.draw_series(LineSeries::new(s.points.iter().copied(), c.stroke_width(2)))?;
        chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, c.filled())))?;
        chart.draw_series(s.declared.iter().map(|&p| Circle::new(p, 7, c.stroke_width(2))))?;
        if let Some((a, b)) = s.trend {
            chart.draw_series(LineSeries::new([a, b], c.mix(0.6).stroke_width(1)))?;
        }
    }
    Ok(())
}

/// One fault mode's detection curve: the fitted probability of detection and its lower 95 %
/// bound against severity, and the fraction of recordings detected at each severity tested.
#[derive(Clone, Debug)]
pub struct PodCurve<'a> {
    /// Its name in the legend.
    pub name: &'a str,
    /// Its colour, `(r, g, b)`.
    pub colour: (u8, u8, u8),
    /// `(severity, POD)` of the fitted curve (empty when none).
    pub fitted: &'a [(f64, f64)],
    /// `(severity, lower 95 % bound)` of the fitted curve.
    pub lower: &'a [(f64, f64)],
    /// `(severity, hits / recordings)` observed.
    pub observed: &'a [(f64, f64)],
}

/// Probability of detection against severity on a logarithmic axis from `lo` to `hi`: per mode
/// its fitted curve (solid), the curve's lower 95 % bound (thin) and the observed hit fractions
/// (points); 0.9 as a horizontal line.
pub fn pod_plot(title: &str, curves: &[PodCurve], lo: f64, hi: f64) -> io::Result<String> {
    render_svg((960, 480), |root| draw_pod(root, title, curves, lo, hi))
}

fn draw_pod(root: &DrawingArea<SVGBackend, Shift>, title: &str, curves: &[PodCurve], lo: f64, hi: f64) -> Drawn {
    root.fill(&WHITE)?;
    let colour = |c: &PodCurve| RGBColor(c.colour.0, c.colour.1, c.colour.2);
    let mut items: Vec<(&str, Swatch)> = curves.iter().map(|c| (c.name, Swatch::Line(colour(c)))).collect();
    items.push(("thin: lower 95 % bound; points: hits / recordings", Swatch::Line(ZERO)));
    items.push(("POD 0.9", Swatch::Line(ZERO)));
    let plot = with_legend(root, 960, 480, &items)?;
    let (lo, hi) = if lo > 0.0 && hi > lo { (lo, hi) } else { (1e-3, 1.0) };
    let mut chart = ChartBuilder::on(&plot)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d((lo..hi).log_scale(), 0.0..1.0)?;
    chart
        .configure_mesh()
        .x_desc("severity")
        .y_desc("probability of detection")
        .y_labels(10)
        .light_line_style(RGBColor(240, 240, 240))
        .draw()?;
    chart.draw_series(LineSeries::new([(lo, 0.9), (hi, 0.9)], ZERO.stroke_width(1)))?;
    for c in curves {
        let col = colour(c);
        chart.draw_series(LineSeries::new(c.fitted.iter().copied(), col.stroke_width(2)))?;
        chart.draw_series(LineSeries::new(c.lower.iter().copied(), col.mix(0.7).stroke_width(1)))?;
        chart.draw_series(c.observed.iter().map(|&p| Circle::new(p, 3, col.filled())))?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_plot_names_its_lines_and_its_shaded_windows() {
        let t: Vec<f64> = (0..100).map(|i| f64::from(i) * 0.01).collect();
        let y: Vec<f64> = t.iter().map(|x| (6.0 * x).sin()).collect();
        let svg = line_plot(
            "title",
            "I (A)",
            &t,
            &[Line { name: "model after (+ viscous 0.60)", colour: (1, 2, 3), values: &y }],
            &[(0.2, 0.3)],
            "windows holding half the residual energy",
        )
        .expect("draws");
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"), "{svg}");
        for needle in ["model after (+ viscous 0.60)", "windows holding half the residual energy", "time (s)", "I (A)"]
        {
            assert!(svg.contains(needle), "{needle} missing");
        }
        // round ticks on the time axis
        assert!(svg.contains("\n0.5\n") && svg.contains("\n0.9\n"), "{svg}");
        assert_eq!(
            svg,
            line_plot(
                "title",
                "I (A)",
                &t,
                &[Line { name: "model after (+ viscous 0.60)", colour: (1, 2, 3), values: &y }],
                &[(0.2, 0.3)],
                "windows holding half the residual energy"
            )
            .expect("draws")
        );
    }

    #[test]
    fn value_ranges_include_zero() {
        assert_eq!(value_range([2.0, 4.0].into_iter()), (0.0, 4.2));
        let (lo, hi) = value_range([-2.0, -1.0].into_iter());
        assert!(lo < -2.0 && hi == 0.0);
        assert_eq!(value_range(std::iter::empty()), (-1.0, 1.0));
    }
}
