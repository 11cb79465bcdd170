//! `weft-cell preview LIB.weft -o cell.png`: one picture to check a cell blob at a glance.
//!
//! One row per cell, four panels per row:
//! (a) the pattern, triangles coloured by material, with a legend (material index, C11);
//! (b–d) the micro mesh deformed under the unit macro strains E¹, E², E³ (docs/CONVENTIONS.md): node
//! displacement `s·(E^k (y - y_c) - chi^k)` (affine part plus the periodic fluctuation
//! `w = -chi^k`; taking the affine part about the cell centre `y_c` is only a rigid translation
//! that keeps the picture centred), with the exaggeration `s` chosen so the largest displacement
//! is 15 % of the cell's larger side and printed in the label, over the dashed outline of the
//! undeformed cell.
//!
//! All panels of a row share one length scale so they compare directly. The rasterizer and the
//! 5×7 font are built in: the picture needs nothing but the `png` encoder.

use std::path::Path;

use weft::blob::{load_aligned, Blob, Cell};

// Layout in pixels. The image is `WIDTH` wide and `2·MARGIN + cells·ROW_HEIGHT` tall
// (tests/cli.rs checks this).
const MARGIN: usize = 16;
const PANEL: usize = 240;
const GAP: usize = 16;
const TITLE_H: usize = 24;
const LABEL_H: usize = 22;
const LEGEND_GAP: usize = 8;
const LINE_H: usize = 18;
const LEGEND_LINES: usize = 2;
const LEGEND_PER_LINE: usize = 4;
const ROW_HEIGHT: usize = TITLE_H + LABEL_H + PANEL + LEGEND_GAP + LEGEND_LINES * LINE_H + GAP;
const WIDTH: usize = 2 * MARGIN + 4 * PANEL + 3 * GAP;
/// Font magnification: 5×7 glyphs drawn as 10×14.
pub(crate) const FONT_SCALE: usize = 2;
/// Largest displacement as a fraction of the cell's larger side.
const EXAGGERATION: f64 = 0.15;

pub(crate) type Rgb = [u8; 3];
pub(crate) const WHITE: Rgb = [255, 255, 255];
const PANEL_BG: Rgb = [242, 242, 242];
pub(crate) const INK: Rgb = [20, 20, 20];
const OUTLINE: Rgb = [40, 40, 40];
/// Tableau-10: distinct at a glance, readable by most colour-blind viewers.
pub(crate) const PALETTE: [Rgb; 10] = [
    [78, 121, 167],
    [242, 142, 43],
    [225, 87, 89],
    [118, 183, 178],
    [89, 161, 79],
    [237, 201, 72],
    [176, 122, 161],
    [255, 157, 167],
    [156, 117, 95],
    [186, 176, 172],
];

pub(crate) fn material_colour(m: u32) -> Rgb {
    PALETTE[m as usize % PALETTE.len()]
}

fn darker(c: Rgb) -> Rgb {
    c.map(|v| (f32::from(v) * 0.6) as u8)
}

pub fn run(blob_path: &Path, out_png: &Path) -> Result<(), String> {
    let bytes = load_aligned(blob_path).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    let blob = Blob::parse(&bytes).map_err(|e| format!("{}: {e}", blob_path.display()))?;
    if blob.cell_count() == 0 {
        return Err(format!("{}: the blob holds no cells", blob_path.display()));
    }
    let image = render(&blob);
    image
        .save_png(out_png)
        .map_err(|e| format!("{}: {e}", out_png.display()))
}

fn render(blob: &Blob) -> Image {
    let mut img = Image::new(WIDTH, 2 * MARGIN + blob.cell_count() * ROW_HEIGHT);
    for (i, cell) in blob.cells().enumerate() {
        draw_cell_row(&mut img, i, &cell, MARGIN + i * ROW_HEIGHT);
    }
    img
}

/// Short number for labels: three significant digits, scientific outside [0.01, 1e4).
fn short(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if (0.01..1e4).contains(&a) {
        let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.2e}")
    }
}

/// Maps cell coordinates (metres, v up) into a panel (pixels, y down).
#[derive(Clone, Copy)]
struct View {
    x0: f64,
    y0: f64,
    scale: f64,
    /// World point shown at the panel's lower-left corner.
    origin: [f64; 2],
}

impl View {
    fn px(&self, p: [f64; 2]) -> [f64; 2] {
        [
            self.x0 + (p[0] - self.origin[0]) * self.scale,
            self.y0 + PANEL as f64 - (p[1] - self.origin[1]) * self.scale,
        ]
    }
}

/// The four corners' node indices and rest positions of square `(i, j)` of the periodic mesh.
/// Positions are unwrapped: a corner across the periodic seam is the stored node shifted by one
/// period, so the square is drawn where it lies rather than folded back.
fn square_corners(c: &Cell, i: usize, j: usize) -> [(usize, [f64; 2]); 4] {
    let (nu, nv) = (c.nu() as usize, c.nv() as usize);
    let (w, h) = (c.width(), c.height());
    let corner = |a: usize, b: usize| {
        let n = (b % nv) * nu + a % nu;
        let p = c.nodes[n];
        let shift = [(a / nu) as f64 * w, (b / nv) as f64 * h];
        (n, [f64::from(p[0]) + shift[0], f64::from(p[1]) + shift[1]])
    };
    [
        corner(i, j),
        corner(i + 1, j),
        corner(i + 1, j + 1),
        corner(i, j + 1),
    ]
}

/// Displacement per unit strain of load case `k` (0..3) at rest position `y` of node `n`:
/// affine part `F (y - y_c)` with `F` the symmetric gradient of `E^k` (engineering shear, so the
/// off-diagonal is half of E3) and `y_c` the cell centre, plus the fluctuation `w = -chi^k`.
fn displacement(c: &Cell, k: usize, n: usize, y: [f64; 2]) -> [f64; 2] {
    let e = [
        (k == 0) as u8 as f64,
        (k == 1) as u8 as f64,
        (k == 2) as u8 as f64,
    ];
    let y = [y[0] - 0.5 * c.width(), y[1] - 0.5 * c.height()];
    let affine = [
        e[0] * y[0] + 0.5 * e[2] * y[1],
        0.5 * e[2] * y[0] + e[1] * y[1],
    ];
    let chi = c.chi[n];
    [
        affine[0] - f64::from(chi[2 * k]),
        affine[1] - f64::from(chi[2 * k + 1]),
    ]
}

/// Exaggeration for load case `k`: largest displacement = EXAGGERATION × larger cell side.
fn exaggeration(c: &Cell, k: usize) -> f64 {
    let (nu, nv) = (c.nu() as usize, c.nv() as usize);
    let mut max: f64 = 0.0;
    for j in 0..=nv {
        for i in 0..=nu {
            // corner (i, j) is the lower-left corner of square (i, j) (unwrapped)
            let (n, y) = square_corners(c, i, j)[0];
            let d = displacement(c, k, n, y);
            max = max.max(d[0].hypot(d[1]));
        }
    }
    if max > 0.0 {
        EXAGGERATION * c.width().max(c.height()) / max
    } else {
        0.0
    }
}

fn draw_cell_row(img: &mut Image, index: usize, c: &Cell, top: usize) {
    let title = format!(
        "{index}: {}   {}x{} px  refine {}  {} x {} mm   C11/C22 {}",
        c.name,
        c.cols,
        c.rows,
        c.refine,
        short(1e3 * c.width()),
        short(1e3 * c.height()),
        short(c.stiffness[0][0] / c.stiffness[1][1])
    );
    img.text(MARGIN, top + 4, &title, INK);

    // One view for all four panels: the cell plus the largest possible displacement on each side,
    // inside a 6 % margin so nothing touches the panel's edge.
    let (w, h) = (c.width(), c.height());
    let pad = EXAGGERATION * w.max(h);
    let fit = 0.88 * PANEL as f64;
    let scale = (fit / (w + 2.0 * pad)).min(fit / (h + 2.0 * pad));
    let used = [(w + 2.0 * pad) * scale, (h + 2.0 * pad) * scale];
    let panel_top = top + TITLE_H + LABEL_H;
    let (nu, nv) = (c.nu() as usize, c.nv() as usize);
    // Mesh lines only where they would not swamp the colours.
    let show_edges = (w / nu as f64) * scale >= 6.0;

    for panel in 0..4 {
        let x0 = MARGIN + panel * (PANEL + GAP);
        img.fill_rect(x0, panel_top, PANEL, PANEL, PANEL_BG);
        let view = View {
            x0: x0 as f64 + 0.5 * (PANEL as f64 - used[0]),
            y0: panel_top as f64 - 0.5 * (PANEL as f64 - used[1]),
            scale,
            origin: [-pad, -pad],
        };
        let clip = Clip {
            x0,
            y0: panel_top,
            x1: x0 + PANEL,
            y1: panel_top + PANEL,
        };
        let (label, s) = match panel {
            0 => ("(a) pattern".to_string(), 0.0),
            k => {
                let s = exaggeration(c, k - 1);
                let name = ["e11", "e22", "2e12"][k - 1];
                (
                    format!(
                        "({}) E{k}: {name} x{}",
                        ['a', 'b', 'c', 'd'][panel],
                        short(s)
                    ),
                    s,
                )
            }
        };
        img.text(x0, top + TITLE_H + 2, &label, INK);

        for j in 0..nv {
            for i in 0..nu {
                let corners = square_corners(c, i, j);
                let moved = corners.map(|(n, y)| {
                    if panel == 0 {
                        view.px(y)
                    } else {
                        let d = displacement(c, panel - 1, n, y);
                        view.px([y[0] + s * d[0], y[1] + s * d[1]])
                    }
                });
                let [ll, lr, ur, ul] = moved;
                let t = 2 * (j * nu + i);
                for (tri, m) in [
                    ([ll, lr, ur], c.tri_material[t]),
                    ([ll, ur, ul], c.tri_material[t + 1]),
                ] {
                    img.fill_triangle(tri, material_colour(m), &clip);
                    if show_edges {
                        let e = darker(material_colour(m));
                        img.line(tri[0], tri[1], e, &clip, false);
                        img.line(tri[1], tri[2], e, &clip, false);
                        img.line(tri[2], tri[0], e, &clip, false);
                    }
                }
            }
        }
        // Undeformed outline: dashed on the deformed panels, solid on the pattern.
        let box_ = [[0.0, 0.0], [w, 0.0], [w, h], [0.0, h]].map(|p| view.px(p));
        for e in 0..4 {
            img.line(box_[e], box_[(e + 1) % 4], OUTLINE, &clip, panel != 0);
        }
    }

    // Legend: material index, colour, C11.
    let legend_top = panel_top + PANEL + LEGEND_GAP;
    let slot = (WIDTH - 2 * MARGIN) / LEGEND_PER_LINE;
    let capacity = LEGEND_LINES * LEGEND_PER_LINE;
    for (m, rec) in c.materials.iter().enumerate().take(capacity) {
        let (line, col) = (m / LEGEND_PER_LINE, m % LEGEND_PER_LINE);
        let (x, y) = (MARGIN + col * slot, legend_top + line * LINE_H);
        if m == capacity - 1 && c.materials.len() > capacity {
            img.text(x, y, &format!("+{} more", c.materials.len() - m), INK);
            break;
        }
        img.fill_rect(x, y, 14, 14, material_colour(m as u32));
        img.text(
            x + 20,
            y,
            &format!("M{m} C11 {} N/m", short(rec.c[0][0])),
            INK,
        );
    }
}

// ---------------------------------------------------------------------------------------------
// A tiny RGB canvas
// ---------------------------------------------------------------------------------------------

pub(crate) struct Clip {
    pub(crate) x0: usize,
    pub(crate) y0: usize,
    pub(crate) x1: usize,
    pub(crate) y1: usize,
}

pub(crate) struct Image {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) px: Vec<Rgb>,
}

impl Image {
    pub(crate) fn new(width: usize, height: usize) -> Self {
        Image {
            width,
            height,
            px: vec![WHITE; width * height],
        }
    }

    pub(crate) fn set(&mut self, x: usize, y: usize, c: Rgb) {
        if x < self.width && y < self.height {
            self.px[y * self.width + x] = c;
        }
    }

    pub(crate) fn fill_rect(&mut self, x: usize, y: usize, w: usize, h: usize, c: Rgb) {
        for yy in y..y + h {
            for xx in x..x + w {
                self.set(xx, yy, c);
            }
        }
    }

    /// Fills pixels whose centres lie inside the triangle (either orientation), within `clip`.
    pub(crate) fn fill_triangle(&mut self, t: [[f64; 2]; 3], c: Rgb, clip: &Clip) {
        let edge = |a: [f64; 2], b: [f64; 2], p: [f64; 2]| {
            (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
        };
        let area = edge(t[0], t[1], t[2]);
        if area == 0.0 || !area.is_finite() {
            return;
        }
        let lo = |k: usize, min: usize| {
            (t.iter()
                .map(|p| p[k])
                .fold(f64::INFINITY, f64::min)
                .floor()
                .max(min as f64)) as usize
        };
        let hi = |k: usize, max: usize| {
            (t.iter()
                .map(|p| p[k])
                .fold(f64::NEG_INFINITY, f64::max)
                .ceil()
                .min(max as f64)) as usize
        };
        let (xa, xb) = (lo(0, clip.x0), hi(0, clip.x1));
        let (ya, yb) = (lo(1, clip.y0), hi(1, clip.y1));
        // Pixel centres exactly on a shared edge go to both triangles: no cracks between them.
        for y in ya..yb {
            for x in xa..xb {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let w0 = edge(t[1], t[2], p) * area.signum();
                let w1 = edge(t[2], t[0], p) * area.signum();
                let w2 = edge(t[0], t[1], p) * area.signum();
                if w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0 {
                    self.set(x, y, c);
                }
            }
        }
    }

    /// One-pixel line from `a` to `b` (DDA), optionally dashed (4 on, 3 off), within `clip`.
    pub(crate) fn line(&mut self, a: [f64; 2], b: [f64; 2], c: Rgb, clip: &Clip, dashed: bool) {
        let steps = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil().max(1.0);
        if !steps.is_finite() {
            return;
        }
        let steps = steps as usize;
        for s in 0..=steps {
            if dashed && s % 7 >= 4 {
                continue;
            }
            let f = s as f64 / steps as f64;
            let (x, y) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
            if x >= clip.x0 as f64
                && y >= clip.y0 as f64
                && x < clip.x1 as f64
                && y < clip.y1 as f64
            {
                self.set(x as usize, y as usize, c);
            }
        }
    }

    /// Draws `s` with the built-in font, top-left at `(x, y)`; characters it lacks show as '?'.
    pub(crate) fn text(&mut self, x: usize, y: usize, s: &str, c: Rgb) {
        let advance = 6 * FONT_SCALE;
        for (n, ch) in s.chars().enumerate() {
            let glyph = glyph(ch).unwrap_or_else(|| glyph('?').unwrap_or([0; 7]));
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..5 {
                    if bits & (0b10000 >> col) != 0 {
                        let px = x + n * advance + col * FONT_SCALE;
                        self.fill_rect(px, y + row * FONT_SCALE, FONT_SCALE, FONT_SCALE, c);
                    }
                }
            }
        }
    }

    pub(crate) fn save_png(&self, path: &Path) -> Result<(), String> {
        let file = std::fs::File::create(path).map_err(|e| e.to_string())?;
        let mut encoder = png::Encoder::new(
            std::io::BufWriter::new(file),
            self.width as u32,
            self.height as u32,
        );
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(|e| e.to_string())?;
        let data: Vec<u8> = self.px.iter().flatten().copied().collect();
        writer.write_image_data(&data).map_err(|e| e.to_string())?;
        writer.finish().map_err(|e| e.to_string())
    }
}

/// 5×7 bitmap glyphs (rows top to bottom, bit 4 = leftmost column), after the HD44780 ROM font.
fn glyph(ch: char) -> Option<[u8; 7]> {
    Some(match ch {
        ' ' => [0, 0, 0, 0, 0, 0, 0],
        '0' => [
            0b01110, 0b10001, 0b10011, 0b10101, 0b11001, 0b10001, 0b01110,
        ],
        '1' => [
            0b00100, 0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        '2' => [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
        '3' => [
            0b11111, 0b00010, 0b00100, 0b00010, 0b00001, 0b10001, 0b01110,
        ],
        '4' => [
            0b00010, 0b00110, 0b01010, 0b10010, 0b11111, 0b00010, 0b00010,
        ],
        '5' => [
            0b11111, 0b10000, 0b11110, 0b00001, 0b00001, 0b10001, 0b01110,
        ],
        '6' => [
            0b00110, 0b01000, 0b10000, 0b11110, 0b10001, 0b10001, 0b01110,
        ],
        '7' => [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b01000, 0b01000,
        ],
        '8' => [
            0b01110, 0b10001, 0b10001, 0b01110, 0b10001, 0b10001, 0b01110,
        ],
        '9' => [
            0b01110, 0b10001, 0b10001, 0b01111, 0b00001, 0b00010, 0b01100,
        ],
        'A' => [
            0b01110, 0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001,
        ],
        'B' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10001, 0b10001, 0b11110,
        ],
        'C' => [
            0b01110, 0b10001, 0b10000, 0b10000, 0b10000, 0b10001, 0b01110,
        ],
        'D' => [
            0b11100, 0b10010, 0b10001, 0b10001, 0b10001, 0b10010, 0b11100,
        ],
        'E' => [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b11111,
        ],
        'F' => [
            0b11111, 0b10000, 0b10000, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
        'G' => [
            0b01110, 0b10001, 0b10000, 0b10111, 0b10001, 0b10001, 0b01111,
        ],
        'H' => [
            0b10001, 0b10001, 0b10001, 0b11111, 0b10001, 0b10001, 0b10001,
        ],
        'I' => [
            0b01110, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        'J' => [
            0b00111, 0b00010, 0b00010, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
        'K' => [
            0b10001, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010, 0b10001,
        ],
        'L' => [
            0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b10000, 0b11111,
        ],
        'M' => [
            0b10001, 0b11011, 0b10101, 0b10101, 0b10001, 0b10001, 0b10001,
        ],
        'N' => [
            0b10001, 0b10001, 0b11001, 0b10101, 0b10011, 0b10001, 0b10001,
        ],
        'O' => [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
        'P' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10000, 0b10000, 0b10000,
        ],
        'Q' => [
            0b01110, 0b10001, 0b10001, 0b10001, 0b10101, 0b10010, 0b01101,
        ],
        'R' => [
            0b11110, 0b10001, 0b10001, 0b11110, 0b10100, 0b10010, 0b10001,
        ],
        'S' => [
            0b01111, 0b10000, 0b10000, 0b01110, 0b00001, 0b00001, 0b11110,
        ],
        'T' => [
            0b11111, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100,
        ],
        'U' => [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
        'V' => [
            0b10001, 0b10001, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ],
        'W' => [
            0b10001, 0b10001, 0b10001, 0b10101, 0b10101, 0b10101, 0b01010,
        ],
        'X' => [
            0b10001, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001, 0b10001,
        ],
        'Y' => [
            0b10001, 0b10001, 0b10001, 0b01010, 0b00100, 0b00100, 0b00100,
        ],
        'Z' => [
            0b11111, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b11111,
        ],
        'a' => [
            0b00000, 0b00000, 0b01110, 0b00001, 0b01111, 0b10001, 0b01111,
        ],
        'b' => [
            0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b11110,
        ],
        'c' => [
            0b00000, 0b00000, 0b01110, 0b10000, 0b10000, 0b10001, 0b01110,
        ],
        'd' => [
            0b00001, 0b00001, 0b01101, 0b10011, 0b10001, 0b10001, 0b01111,
        ],
        'e' => [
            0b00000, 0b00000, 0b01110, 0b10001, 0b11111, 0b10000, 0b01110,
        ],
        'f' => [
            0b00110, 0b01001, 0b01000, 0b11100, 0b01000, 0b01000, 0b01000,
        ],
        'g' => [
            0b00000, 0b01111, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
        ],
        'h' => [
            0b10000, 0b10000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001,
        ],
        'i' => [
            0b00100, 0b00000, 0b01100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        'j' => [
            0b00010, 0b00000, 0b00110, 0b00010, 0b00010, 0b10010, 0b01100,
        ],
        'k' => [
            0b10000, 0b10000, 0b10010, 0b10100, 0b11000, 0b10100, 0b10010,
        ],
        'l' => [
            0b01100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b01110,
        ],
        'm' => [
            0b00000, 0b00000, 0b11010, 0b10101, 0b10101, 0b10001, 0b10001,
        ],
        'n' => [
            0b00000, 0b00000, 0b10110, 0b11001, 0b10001, 0b10001, 0b10001,
        ],
        'o' => [
            0b00000, 0b00000, 0b01110, 0b10001, 0b10001, 0b10001, 0b01110,
        ],
        'p' => [
            0b00000, 0b00000, 0b11110, 0b10001, 0b11110, 0b10000, 0b10000,
        ],
        'q' => [
            0b00000, 0b00000, 0b01101, 0b10011, 0b01111, 0b00001, 0b00001,
        ],
        'r' => [
            0b00000, 0b00000, 0b10110, 0b11001, 0b10000, 0b10000, 0b10000,
        ],
        's' => [
            0b00000, 0b00000, 0b01110, 0b10000, 0b01110, 0b00001, 0b11110,
        ],
        't' => [
            0b01000, 0b01000, 0b11100, 0b01000, 0b01000, 0b01001, 0b00110,
        ],
        'u' => [
            0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b10011, 0b01101,
        ],
        'v' => [
            0b00000, 0b00000, 0b10001, 0b10001, 0b10001, 0b01010, 0b00100,
        ],
        'w' => [
            0b00000, 0b00000, 0b10001, 0b10001, 0b10101, 0b10101, 0b01010,
        ],
        'x' => [
            0b00000, 0b00000, 0b10001, 0b01010, 0b00100, 0b01010, 0b10001,
        ],
        'y' => [
            0b00000, 0b00000, 0b10001, 0b10001, 0b01111, 0b00001, 0b01110,
        ],
        'z' => [
            0b00000, 0b00000, 0b11111, 0b00010, 0b00100, 0b01000, 0b11111,
        ],
        '.' => [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b01100,
        ],
        ',' => [
            0b00000, 0b00000, 0b00000, 0b00000, 0b01100, 0b00100, 0b01000,
        ],
        '-' => [
            0b00000, 0b00000, 0b00000, 0b11111, 0b00000, 0b00000, 0b00000,
        ],
        '+' => [
            0b00000, 0b00100, 0b00100, 0b11111, 0b00100, 0b00100, 0b00000,
        ],
        '=' => [
            0b00000, 0b00000, 0b11111, 0b00000, 0b11111, 0b00000, 0b00000,
        ],
        ':' => [
            0b00000, 0b01100, 0b01100, 0b00000, 0b01100, 0b01100, 0b00000,
        ],
        '/' => [
            0b00000, 0b00001, 0b00010, 0b00100, 0b01000, 0b10000, 0b00000,
        ],
        '(' => [
            0b00010, 0b00100, 0b01000, 0b01000, 0b01000, 0b00100, 0b00010,
        ],
        ')' => [
            0b01000, 0b00100, 0b00010, 0b00010, 0b00010, 0b00100, 0b01000,
        ],
        '[' => [
            0b01110, 0b01000, 0b01000, 0b01000, 0b01000, 0b01000, 0b01110,
        ],
        ']' => [
            0b01110, 0b00010, 0b00010, 0b00010, 0b00010, 0b00010, 0b01110,
        ],
        '_' => [
            0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b00000, 0b11111,
        ],
        '%' => [
            0b11000, 0b11001, 0b00010, 0b00100, 0b01000, 0b10011, 0b00011,
        ],
        '*' => [
            0b00000, 0b00100, 0b10101, 0b01110, 0b10101, 0b00100, 0b00000,
        ],
        '^' => [
            0b00100, 0b01010, 0b10001, 0b00000, 0b00000, 0b00000, 0b00000,
        ],
        '?' => [
            0b01110, 0b10001, 0b00001, 0b00010, 0b00100, 0b00000, 0b00100,
        ],
        '!' => [
            0b00100, 0b00100, 0b00100, 0b00100, 0b00100, 0b00000, 0b00100,
        ],
        '\'' => [
            0b01100, 0b00100, 0b01000, 0b00000, 0b00000, 0b00000, 0b00000,
        ],
        '"' => [
            0b01010, 0b01010, 0b01010, 0b00000, 0b00000, 0b00000, 0b00000,
        ],
        '#' => [
            0b01010, 0b01010, 0b11111, 0b01010, 0b11111, 0b01010, 0b01010,
        ],
        '<' => [
            0b00010, 0b00100, 0b01000, 0b10000, 0b01000, 0b00100, 0b00010,
        ],
        '>' => [
            0b01000, 0b00100, 0b00010, 0b00001, 0b00010, 0b00100, 0b01000,
        ],
        _ => return None,
    })
}
