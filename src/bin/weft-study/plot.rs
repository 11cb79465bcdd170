//! Hand-written SVG plots: scatter and line series on linear or logarithmic axes.

use std::fmt::Write as _;

pub struct Series {
    pub name: String,
    pub colour: &'static str,
    pub points: Vec<(f64, f64)>,
    /// Join the points (in the given order) with a line; `dashed` for a dashed one.
    pub line: bool,
    pub dashed: bool,
    /// Marker: 'o' circle, 's' square, '^' triangle, 'x' cross.
    pub marker: char,
}

pub struct Plot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_log: bool,
    pub y_log: bool,
    pub series: Vec<Series>,
}

/// Colour-blind-friendly (Okabe–Ito, then Tol's muted set), pairwise distinct: a plot with up to
/// this many series never repeats a colour ([`style`] changes the marker beyond that).
pub const COLOURS: [&str; 16] = [
    "#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442",
    "#882255", "#999999", "#332288", "#117733", "#AA4499", "#661100", "#44AA99", "#DDCC77",
];

/// Colour and marker of series `k` of a plot: distinct for every `k` below 4 × 16.
pub fn style(k: usize) -> (&'static str, char) {
    (
        COLOURS[k % COLOURS.len()],
        ['o', 's', '^', 'x'][(k / COLOURS.len()) % 4],
    )
}

const W: f64 = 560.0;
const H: f64 = 400.0;
const LEFT: f64 = 70.0;
const RIGHT: f64 = 16.0;
const TOP: f64 = 34.0;
const BOTTOM: f64 = 50.0;
const LEGEND_W: f64 = 230.0;

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

struct Axis {
    log: bool,
    lo: f64,
    hi: f64,
}

impl Axis {
    fn new(values: impl Iterator<Item = f64>, log: bool) -> Axis {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
            lo = lo.min(v);
            hi = hi.max(v);
        }
        if !lo.is_finite() {
            (lo, hi) = if log { (0.1, 10.0) } else { (0.0, 1.0) };
        }
        if log {
            lo = 10f64.powf(lo.log10().floor());
            hi = 10f64.powf(hi.log10().ceil());
            if hi <= lo {
                hi = lo * 10.0;
            }
        } else {
            let pad = ((hi - lo) * 0.05).max(1e-12);
            lo = if lo >= 0.0 && lo - pad < 0.0 {
                0.0
            } else {
                lo - pad
            };
            hi += pad;
        }
        Axis { log, lo, hi }
    }
    /// 0..1 along the axis.
    fn frac(&self, v: f64) -> f64 {
        if self.log {
            (v.log10() - self.lo.log10()) / (self.hi.log10() - self.lo.log10())
        } else {
            (v - self.lo) / (self.hi - self.lo)
        }
    }
    fn ticks(&self) -> Vec<(f64, String)> {
        if self.log {
            let (a, b) = (
                self.lo.log10().round() as i32,
                self.hi.log10().round() as i32,
            );
            (a..=b).map(|e| (10f64.powi(e), format!("1e{e}"))).collect()
        } else {
            let span = self.hi - self.lo;
            let raw = span / 5.0;
            let mag = 10f64.powf(raw.log10().floor());
            let step = [1.0, 2.0, 5.0, 10.0]
                .iter()
                .map(|m| m * mag)
                .find(|s| span / s <= 6.0)
                .unwrap_or(10.0 * mag);
            let mut t = (self.lo / step).ceil() * step;
            let mut out = Vec::new();
            while t <= self.hi + 1e-12 * span {
                out.push((t, format!("{}", (t / step).round() * step)));
                t += step;
            }
            out
        }
    }
}

fn marker(out: &mut String, m: char, x: f64, y: f64, c: &str) {
    let _ = match m {
        's' => writeln!(
            out,
            r#"<rect x="{:.1}" y="{:.1}" width="7" height="7" fill="{c}" fill-opacity="0.8"/>"#,
            x - 3.5,
            y - 3.5
        ),
        '^' => writeln!(
            out,
            r#"<polygon points="{:.1},{:.1} {:.1},{:.1} {:.1},{:.1}" fill="{c}" fill-opacity="0.8"/>"#,
            x,
            y - 4.5,
            x - 4.0,
            y + 3.5,
            x + 4.0,
            y + 3.5
        ),
        'x' => writeln!(
            out,
            r#"<path d="M{:.1},{:.1}L{:.1},{:.1}M{:.1},{:.1}L{:.1},{:.1}" stroke="{c}" stroke-width="2"/>"#,
            x - 4.0,
            y - 4.0,
            x + 4.0,
            y + 4.0,
            x - 4.0,
            y + 4.0,
            x + 4.0,
            y - 4.0
        ),
        _ => writeln!(
            out,
            r#"<circle cx="{x:.1}" cy="{y:.1}" r="3.8" fill="{c}" fill-opacity="0.8"/>"#
        ),
    };
}

impl Plot {
    /// The plot as an SVG document, with the legend on the right.
    pub fn svg(&self) -> String {
        let pts = || self.series.iter().flat_map(|s| s.points.iter());
        let xa = Axis::new(pts().map(|p| p.0), self.x_log);
        let ya = Axis::new(pts().map(|p| p.1), self.y_log);
        let (pw, ph) = (W - LEFT - RIGHT, H - TOP - BOTTOM);
        let sx = |v: f64| LEFT + xa.frac(v) * pw;
        let sy = |v: f64| TOP + (1.0 - ya.frac(v)) * ph;
        let total_w = W + LEGEND_W;
        let visible = |p: &(f64, f64)| {
            p.0.is_finite()
                && p.1.is_finite()
                && (!self.x_log || p.0 > 0.0)
                && (!self.y_log || p.1 > 0.0)
        };
        // A series with nothing to draw (a timing-only case) gets no legend entry either.
        let drawn: Vec<&Series> = self
            .series
            .iter()
            .filter(|s| s.points.iter().any(visible))
            .collect();
        let legend_h = 20.0 + 18.0 * drawn.len() as f64;
        let total_h = H.max(legend_h + TOP);
        let mut o = String::new();
        let _ = writeln!(
            o,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{total_w}" height="{total_h}" viewBox="0 0 {total_w} {total_h}" font-family="sans-serif" font-size="12">"#
        );
        let _ = writeln!(o, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="20" text-anchor="middle" font-size="14" font-weight="bold">{}</text>"#,
            LEFT + pw / 2.0,
            esc(&self.title)
        );
        // grid and ticks
        for (v, label) in xa.ticks() {
            let x = sx(v);
            let _ = writeln!(
                o,
                r##"<line x1="{x:.1}" y1="{TOP}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" text-anchor="middle">{label}</text>"##,
                TOP + ph,
                TOP + ph + 16.0
            );
        }
        for (v, label) in ya.ticks() {
            let y = sy(v);
            let _ = writeln!(
                o,
                r##"<line x1="{LEFT}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" text-anchor="end">{label}</text>"##,
                LEFT + pw,
                LEFT - 5.0,
                y + 4.0
            );
        }
        let _ = writeln!(
            o,
            r##"<rect x="{LEFT}" y="{TOP}" width="{pw}" height="{ph}" fill="none" stroke="#333"/>"##
        );
        let _ = writeln!(
            o,
            r#"<text x="{:.1}" y="{:.1}" text-anchor="middle">{}</text>"#,
            LEFT + pw / 2.0,
            H - 10.0,
            esc(&self.x_label)
        );
        let _ = writeln!(
            o,
            r#"<text transform="translate(16,{:.1}) rotate(-90)" text-anchor="middle">{}</text>"#,
            TOP + ph / 2.0,
            esc(&self.y_label)
        );
        for s in &drawn {
            let shown: Vec<_> = s.points.iter().filter(|p| visible(p)).collect();
            if s.line && shown.len() > 1 {
                let d: Vec<String> = shown
                    .iter()
                    .map(|p| format!("{:.1},{:.1}", sx(p.0), sy(p.1)))
                    .collect();
                let dash = if s.dashed {
                    r#" stroke-dasharray="5,4""#
                } else {
                    ""
                };
                let _ = writeln!(
                    o,
                    r#"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"{dash}/>"#,
                    d.join(" "),
                    s.colour
                );
            }
            for p in shown {
                marker(&mut o, s.marker, sx(p.0), sy(p.1), s.colour);
            }
        }
        // legend
        for (k, s) in drawn.iter().enumerate() {
            let y = TOP + 10.0 + 18.0 * k as f64;
            let x = W + 6.0;
            if s.line {
                let dash = if s.dashed {
                    r#" stroke-dasharray="5,4""#
                } else {
                    ""
                };
                let _ = writeln!(
                    o,
                    r#"<line x1="{x:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}" stroke-width="1.5"{dash}/>"#,
                    x + 22.0,
                    s.colour
                );
            }
            marker(&mut o, s.marker, x + 11.0, y, s.colour);
            let _ = writeln!(
                o,
                r#"<text x="{:.1}" y="{:.1}">{}</text>"#,
                x + 28.0,
                y + 4.0,
                esc(&s.name)
            );
        }
        o.push_str("</svg>\n");
        o
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(name: &str, points: Vec<(f64, f64)>) -> Series {
        Series {
            name: name.into(),
            colour: COLOURS[0],
            points,
            line: true,
            dashed: false,
            marker: 'o',
        }
    }

    #[test]
    fn a_series_without_drawable_points_has_no_legend_entry() {
        let svg = Plot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            x_log: true,
            y_log: true,
            series: vec![
                series("drawn", vec![(1.0, 1.0), (2.0, 0.5)]),
                series("timing only", vec![]),
                series("not on a log axis", vec![(0.0, 1.0)]),
            ],
        }
        .svg();
        assert!(svg.contains(">drawn</text>"));
        assert!(!svg.contains("timing only"));
        assert!(!svg.contains("not on a log axis"));
    }

    #[test]
    fn styles_are_distinct() {
        let styles: Vec<_> = (0..4 * COLOURS.len()).map(style).collect();
        for (i, a) in styles.iter().enumerate() {
            assert!(!styles[..i].contains(a), "style {i} repeats");
        }
        let mut colours = COLOURS.to_vec();
        colours.sort_unstable();
        colours.dedup();
        assert_eq!(colours.len(), COLOURS.len());
    }
}
