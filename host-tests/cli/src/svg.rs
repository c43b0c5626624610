//! The hand-written SVG of the `ema` commands, in one place: a time-series plot (`ema discover`'s
//! `fit.svg` and `residual.svg`) and a grouped bar chart (`ema campaign`'s `error.svg` and
//! `time.svg`, like the paper's Figures 4–5). Plain strings, no plotting dependency: the plots
//! are small, and the files stay byte-stable for a given input.

use std::fmt::Write as _;

/// Colours of successive bar series (pairs of a dark and a light shade).
const BAR_COLOURS: [&str; 6] = ["#1f77b4", "#aec7e8", "#d62728", "#ff9896", "#2ca02c", "#98df8a"];

/// The opening of a `width` × `height` document: the `<svg>` element (sans-serif, 12 px) and a
/// white background.
fn document(width: f64, height: f64) -> String {
    format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{width}\" height=\"{height}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    )
}

/// Closes a document opened by [`document`].
fn finish(mut svg: String) -> String {
    svg.push_str("</svg>\n");
    svg
}

/// A time-series plot: one polyline per `(name, colour, values)` of `lines` against the times
/// `t` (s), a legend on the right, the zero line, and the time spans of `shaded` (start, end in
/// s) shaded in yellow. The value axis spans the lines' range.
pub fn line_plot(title: &str, unit: &str, t: &[f64], lines: &[(&str, &str, &[f64])], shaded: &[(f64, f64)]) -> String {
    let (w, h, left, right, top, bottom) = (960.0, 360.0, 60.0, 150.0, 30.0, 40.0);
    let t_max = t.last().copied().unwrap_or(1.0).max(1e-9);
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, _, y) in lines {
        for v in y.iter() {
            lo = lo.min(*v);
            hi = hi.max(*v);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        (lo, hi) = (-1.0, 1.0);
    }
    let x = |tt: f64| left + (w - left - right) * tt / t_max;
    let y = |v: f64| top + (h - top - bottom) * (hi - v) / (hi - lo);
    let mut s = document(w, h);
    let _ = writeln!(s, "<text x=\"{left}\" y=\"18\" font-size=\"14\">{title}</text>");
    for &(start, end) in shaded {
        let _ = writeln!(
            s,
            "<rect x=\"{:.1}\" y=\"{top}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"#ffdd88\" opacity=\"0.4\"/>",
            x(start),
            (x(end) - x(start)).max(1.0),
            h - top - bottom
        );
    }
    let _ = writeln!(
        s,
        "<line x1=\"{left}\" y1=\"{0:.1}\" x2=\"{1:.1}\" y2=\"{0:.1}\" stroke=\"#999\"/>",
        y(0.0f64.clamp(lo, hi)),
        w - right
    );
    for k in 0..=5 {
        let v = lo + (hi - lo) * k as f64 / 5.0;
        let _ = writeln!(s, "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{v:.2}</text>", left - 4.0, y(v) + 4.0);
        let tt = t_max * k as f64 / 5.0;
        let _ = writeln!(
            s,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{tt:.2}</text>",
            x(tt),
            h - bottom + 16.0
        );
    }
    let _ =
        writeln!(s, "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">time (s)</text>", x(t_max / 2.0), h - 6.0);
    let _ =
        writeln!(s, "<text x=\"12\" y=\"{:.1}\" transform=\"rotate(-90 12 {:.1})\">{unit}</text>", h / 2.0, h / 2.0);
    for (j, (name, colour, values)) in lines.iter().enumerate() {
        let mut pts = String::new();
        for (tt, v) in t.iter().zip(values.iter()) {
            let _ = write!(pts, "{:.1},{:.1} ", x(*tt), y(*v));
        }
        let _ = writeln!(s, "<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1\" points=\"{pts}\"/>");
        let ly = top + 16.0 * j as f64 + 8.0;
        let _ = writeln!(
            s,
            "<line x1=\"{0:.1}\" y1=\"{ly:.1}\" x2=\"{1:.1}\" y2=\"{ly:.1}\" stroke=\"{colour}\" stroke-width=\"2\"/><text x=\"{2:.1}\" y=\"{3:.1}\">{name}</text>",
            w - right + 10.0,
            w - right + 30.0,
            w - right + 34.0,
            ly + 4.0
        );
    }
    finish(s)
}

/// A grouped bar chart: one group of bars per name of `groups`, one bar per name of `series`
/// (`value(group, series)`, `None` for no bar, with the value in its tooltip), a legend below.
/// The value axis runs from 0 to `top`, with five labelled grid lines.
pub fn grouped_bars(
    title: &str,
    unit: &str,
    groups: &[&str],
    series: &[String],
    top: f64,
    value: impl Fn(usize, usize) -> Option<f64>,
) -> String {
    let (w, h, left, bottom, top_margin) = (760.0, 360.0, 60.0, 50.0, 40.0);
    let group_w = (w - left - 20.0) / groups.len() as f64;
    let bar_w = group_w * 0.8 / series.len().max(1) as f64;
    let mut svg = document(w, h);
    let _ = writeln!(svg, "<text x=\"{}\" y=\"22\" text-anchor=\"middle\" font-size=\"15\">{title}</text>", w / 2.0);
    let plot_h = h - top_margin - bottom;
    for t in 0..=4 {
        let v = top * f64::from(t) / 4.0;
        let y = top_margin + plot_h * (1.0 - f64::from(t) / 4.0);
        let _ = writeln!(
            svg,
            "<line x1=\"{left}\" y1=\"{y:.1}\" x2=\"{:.1}\" y2=\"{y:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{v:.2}</text>",
            w - 20.0,
            left - 6.0,
            y + 4.0
        );
    }
    let _ = writeln!(
        svg,
        "<text x=\"14\" y=\"{:.1}\" transform=\"rotate(-90 14 {:.1})\" text-anchor=\"middle\">{unit}</text>",
        top_margin + plot_h / 2.0,
        top_margin + plot_h / 2.0
    );
    for (g, group) in groups.iter().enumerate() {
        let x0 = left + group_w * g as f64 + group_w * 0.1;
        for (s, name) in series.iter().enumerate() {
            if let Some(v) = value(g, s) {
                let bh = plot_h * v / top;
                let _ = writeln!(
                    svg,
                    "<rect x=\"{:.1}\" y=\"{:.1}\" width=\"{:.1}\" height=\"{bh:.1}\" fill=\"{}\"><title>{name} {group}: {v:.3}</title></rect>",
                    x0 + bar_w * s as f64,
                    top_margin + plot_h - bh,
                    bar_w * 0.95,
                    BAR_COLOURS[s % BAR_COLOURS.len()],
                );
            }
        }
        let _ = writeln!(
            svg,
            "<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{group}</text>",
            x0 + group_w * 0.4,
            h - bottom + 18.0
        );
    }
    // Legend entries 130 px apart, closer when more series (six: three algorithms) would overflow
    // the width.
    let legend_step = ((w - left - 20.0) / series.len().max(1) as f64).min(130.0);
    for (s, name) in series.iter().enumerate() {
        let x = left + 10.0 + legend_step * s as f64;
        let _ = writeln!(
            svg,
            "<rect x=\"{x:.1}\" y=\"{:.1}\" width=\"12\" height=\"12\" fill=\"{}\"/><text x=\"{:.1}\" y=\"{:.1}\">{name}</text>",
            h - 18.0,
            BAR_COLOURS[s % BAR_COLOURS.len()],
            x + 16.0,
            h - 8.0
        );
    }
    finish(svg)
}
