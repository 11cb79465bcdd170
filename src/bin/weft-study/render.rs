//! A small orthographic, flat-shaded, depth-buffered triangle rasterizer for pictures of
//! cloth (study and demo), drawing into the `weft-cell preview` image (`preview::Image`,
//! its 5×7 font and its PNG writer). Triangles are coloured by material.

use glam::Vec3A;

use crate::preview::{material_colour, Clip, Image, Rgb};

/// A rectangle of the image, in pixels.
#[derive(Clone, Copy, Debug)]
pub struct Panel {
    pub x: usize,
    pub y: usize,
    pub w: usize,
    pub h: usize,
}

impl Panel {
    fn clip(&self) -> Clip {
        Clip {
            x0: self.x,
            y0: self.y,
            x1: self.x + self.w,
            y1: self.y + self.h,
        }
    }
}

/// An orthographic camera: looking along `-toward`, `up` on screen, `scale` pixels per metre,
/// `center` (world) at the panel's centre.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    right: Vec3A,
    up: Vec3A,
    toward: Vec3A,
    center: Vec3A,
    scale: f32,
}

impl Camera {
    /// A camera looking from `toward` with `up` roughly up, framing every point of `meshes`
    /// into `panel` with a margin of `margin` pixels.
    pub fn fit(
        toward: Vec3A,
        up: Vec3A,
        meshes: &[&[Vec3A]],
        panel: &Panel,
        margin: f32,
    ) -> Camera {
        let toward = toward.normalize();
        let right = up.cross(toward).normalize();
        let up = toward.cross(right);
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for p in meshes.iter().flat_map(|m| m.iter()) {
            let s = [p.dot(right), p.dot(up)];
            for k in 0..2 {
                lo[k] = lo[k].min(s[k]);
                hi[k] = hi[k].max(s[k]);
            }
        }
        let span = [(hi[0] - lo[0]).max(1e-9), (hi[1] - lo[1]).max(1e-9)];
        let scale = ((panel.w as f32 - 2.0 * margin) / span[0])
            .min((panel.h as f32 - 2.0 * margin) / span[1])
            .max(1e-9);
        let c = [(lo[0] + hi[0]) * 0.5, (lo[1] + hi[1]) * 0.5];
        Camera {
            right,
            up,
            toward,
            center: right * c[0] + up * c[1],
            scale,
        }
    }

    /// The same view zoomed on `focus` with `scale` pixels per metre.
    pub fn zoomed(&self, focus: Vec3A, scale: f32) -> Camera {
        Camera {
            center: focus,
            scale,
            ..*self
        }
    }

    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// Screen position (pixels, y down) and depth (larger is nearer) of `p` in `panel`.
    fn project(&self, p: Vec3A, panel: &Panel) -> [f64; 3] {
        let d = p - self.center;
        [
            panel.x as f64 + panel.w as f64 * 0.5 + f64::from(d.dot(self.right) * self.scale),
            panel.y as f64 + panel.h as f64 * 0.5 - f64::from(d.dot(self.up) * self.scale),
            f64::from(d.dot(self.toward)),
        ]
    }
}

/// A depth buffer for one panel.
pub struct Depth {
    z: Vec<f64>,
    panel: Panel,
}

impl Depth {
    pub fn new(panel: Panel) -> Depth {
        Depth {
            z: vec![f64::NEG_INFINITY; panel.w * panel.h],
            panel,
        }
    }
}

/// Colour of a triangle lit from the viewer's upper left (two-sided, flat).
fn shade(c: Rgb, normal: Vec3A, cam: &Camera) -> Rgb {
    let light = (cam.toward + cam.up * 0.6 - cam.right * 0.4).normalize();
    let l = normal.normalize_or_zero().dot(light).abs();
    let f = 0.35 + 0.65 * l;
    c.map(|v| (f32::from(v) * f).round().clamp(0.0, 255.0) as u8)
}

/// Draws a triangle mesh, each triangle in its material's colour, flat shaded, depth tested;
/// `wire` also draws every triangle's edges in that colour.
pub fn draw_mesh(
    img: &mut Image,
    depth: &mut Depth,
    cam: &Camera,
    positions: &[Vec3A],
    triangles: &[[u32; 3]],
    materials: &[u32],
    wire: Option<Rgb>,
) {
    draw_mesh_with(
        img,
        depth,
        cam,
        positions,
        triangles,
        &|t| material_colour(materials[t]),
        wire,
    );
}

/// [`draw_mesh`] with each triangle's colour from `colour(triangle index)`.
pub fn draw_mesh_with(
    img: &mut Image,
    depth: &mut Depth,
    cam: &Camera,
    positions: &[Vec3A],
    triangles: &[[u32; 3]],
    colour: &dyn Fn(usize) -> Rgb,
    wire: Option<Rgb>,
) {
    let panel = depth.panel;
    for (t, tri) in triangles.iter().enumerate() {
        let [a, b, c] = tri.map(|i| positions[i as usize]);
        let colour = shade(colour(t), (b - a).cross(c - a), cam);
        let s = [a, b, c].map(|p| cam.project(p, &panel));
        fill(img, depth, s, colour);
    }
    if let Some(w) = wire {
        // depth tested, a little in front so the triangle's own edges show
        let bias = 1.5 / f64::from(cam.scale);
        for tri in triangles {
            let s = tri.map(|i| cam.project(positions[i as usize], &panel));
            for k in 0..3 {
                line_depth(img, depth, s[k], s[(k + 1) % 3], w, bias);
            }
        }
    }
}

/// A one-pixel line with depth test (DDA, depth interpolated linearly).
fn line_depth(img: &mut Image, depth: &Depth, a: [f64; 3], b: [f64; 3], c: Rgb, bias: f64) {
    let p = depth.panel;
    let (x0, y0, x1, y1) = (
        p.x as f64,
        p.y as f64,
        (p.x + p.w) as f64,
        (p.y + p.h) as f64,
    );
    // both ends beyond the same side: nothing to draw
    if (a[0] < x0 && b[0] < x0)
        || (a[0] >= x1 && b[0] >= x1)
        || (a[1] < y0 && b[1] < y0)
        || (a[1] >= y1 && b[1] >= y1)
    {
        return;
    }
    let steps = (b[0] - a[0]).abs().max((b[1] - a[1]).abs()).ceil().max(1.0);
    if !steps.is_finite() || steps > 1e5 {
        return;
    }
    let n = steps as usize;
    for s in 0..=n {
        let f = s as f64 / steps;
        let (x, y) = (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1]));
        if x < x0 || y < y0 || x >= x1 || y >= y1 {
            continue;
        }
        let z = a[2] + f * (b[2] - a[2]);
        let k = (y as usize - p.y) * p.w + (x as usize - p.x);
        if z + bias >= depth.z[k] {
            img.set(x as usize, y as usize, c);
        }
    }
}

/// A polyline through `points`, on top of everything.
pub fn draw_polyline(img: &mut Image, cam: &Camera, panel: &Panel, points: &[Vec3A], c: Rgb) {
    let clip = panel.clip();
    for w in points.windows(2) {
        let (p, q) = (cam.project(w[0], panel), cam.project(w[1], panel));
        img.line([p[0], p[1]], [q[0], q[1]], c, &clip, false);
    }
}

/// A filled triangle with depth test (pixel centres inside, either orientation).
fn fill(img: &mut Image, depth: &mut Depth, t: [[f64; 3]; 3], c: Rgb) {
    let p = depth.panel;
    let edge = |a: [f64; 3], b: [f64; 3], x: f64, y: f64| {
        (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0])
    };
    let area = edge(t[0], t[1], t[2][0], t[2][1]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let min = |k: usize| t.iter().map(|v| v[k]).fold(f64::INFINITY, f64::min);
    let max = |k: usize| t.iter().map(|v| v[k]).fold(f64::NEG_INFINITY, f64::max);
    let x0 = min(0).floor().max(p.x as f64) as usize;
    let x1 = max(0).ceil().min((p.x + p.w) as f64).max(0.0) as usize;
    let y0 = min(1).floor().max(p.y as f64) as usize;
    let y1 = max(1).ceil().min((p.y + p.h) as f64).max(0.0) as usize;
    for y in y0..y1 {
        for x in x0..x1 {
            let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
            let w0 = edge(t[1], t[2], px, py) / area;
            let w1 = edge(t[2], t[0], px, py) / area;
            let w2 = 1.0 - w0 - w1;
            if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                continue;
            }
            let z = w0 * t[0][2] + w1 * t[1][2] + w2 * t[2][2];
            let k = (y - p.y) * p.w + (x - p.x);
            if z >= depth.z[k] {
                depth.z[k] = z;
                img.set(x, y, c);
            }
        }
    }
}

/// The boundary of a structured `nx × ny` grid mesh (node `(i, j)` = `j·nx + i`), closed.
pub fn grid_boundary(positions: &[Vec3A], nx: usize, ny: usize) -> Vec<Vec3A> {
    let mut out = Vec::with_capacity(2 * (nx + ny));
    out.extend((0..nx).map(|i| positions[i]));
    out.extend((1..ny).map(|j| positions[j * nx + nx - 1]));
    out.extend((0..nx - 1).rev().map(|i| positions[(ny - 1) * nx + i]));
    out.extend((0..ny - 1).rev().map(|j| positions[j * nx]));
    out
}

/// A UV sphere of `radius` at `center` (positions, triangles), for drawing colliders.
pub fn sphere_mesh(center: Vec3A, radius: f32, rings: usize) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
    let segs = 2 * rings;
    let mut x = Vec::new();
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..segs {
            let ph = 2.0 * std::f32::consts::PI * j as f32 / segs as f32;
            x.push(
                center + radius * Vec3A::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos()),
            );
        }
    }
    let mut t = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            let a = (i * segs + j) as u32;
            let b = (i * segs + (j + 1) % segs) as u32;
            let c = a + segs as u32;
            let d = b + segs as u32;
            t.push([a, c, b]);
            t.push([b, c, d]);
        }
    }
    (x, t)
}
