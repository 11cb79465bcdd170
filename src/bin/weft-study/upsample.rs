//! Fine positions from a coarse cloth.
//!
//! * localization off: each fine vertex keeps its barycentric place in its coarse triangle
//!   (the affine embedding, Eq. 23 without `w`), normals are the barycentric blend of the
//!   coarse vertex normals;
//! * localization on: `weft::localize` (§6).

use glam::Vec3A;
use weft::blob::Blob;
use weft::world::World;

/// How fine positions (and normals) are made from the coarse cloth.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Barycentric embedding, blended normals.
    Off,
    /// Localization; normals blended from the coarse cloth or recomputed on the fine mesh.
    On { recompute_normals: bool },
}

impl Mode {
    pub fn localization(self) -> &'static str {
        match self {
            Mode::Off => "off",
            Mode::On { .. } => "on",
        }
    }
    pub fn normals(self) -> &'static str {
        match self {
            Mode::On {
                recompute_normals: true,
            } => "recomputed",
            _ => "blended",
        }
    }
}

/// Where each fine vertex sits in the coarse cloth.
pub struct Upsampler {
    triangle: Vec<u32>,
    bary: Vec<[f32; 3]>,
    coarse_normals: Vec<Vec3A>,
}

impl Upsampler {
    /// Binds every fine vertex `(u, v)` to the coarse triangle of `world` that contains it.
    pub fn new(
        world: &World<'_>,
        _blob: &Blob<'_>,
        fine_uv: &[[f32; 2]],
        _fine_triangles: &[[u32; 3]],
    ) -> Result<Upsampler, String> {
        let rest = world.rest_positions();
        let tris = world.triangles();
        let mut triangle = Vec::with_capacity(fine_uv.len());
        let mut bary = Vec::with_capacity(fine_uv.len());
        // A uniform grid of buckets over the coarse triangles' bounding boxes.
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for r in rest {
            lo = [lo[0].min(r.x), lo[1].min(r.y)];
            hi = [hi[0].max(r.x), hi[1].max(r.y)];
        }
        let nb = ((tris.len() as f64).sqrt().ceil() as usize).max(1);
        let cell = |p: f32, k: usize| -> usize {
            let f = (p - lo[k]) / (hi[k] - lo[k]).max(f32::MIN_POSITIVE);
            ((f * nb as f32).floor().max(0.0) as usize).min(nb - 1)
        };
        let mut buckets = vec![Vec::new(); nb * nb];
        for (t, tri) in tris.iter().enumerate() {
            let c = tri.map(|i| rest[i as usize]);
            let (x0, x1) = (
                cell(c.iter().map(|p| p.x).fold(f32::INFINITY, f32::min), 0),
                cell(c.iter().map(|p| p.x).fold(f32::NEG_INFINITY, f32::max), 0),
            );
            let (y0, y1) = (
                cell(c.iter().map(|p| p.y).fold(f32::INFINITY, f32::min), 1),
                cell(c.iter().map(|p| p.y).fold(f32::NEG_INFINITY, f32::max), 1),
            );
            for by in y0..=y1 {
                for bx in x0..=x1 {
                    buckets[by * nb + bx].push(t as u32);
                }
            }
        }
        for (i, uv) in fine_uv.iter().enumerate() {
            let p = [f64::from(uv[0]), f64::from(uv[1])];
            let bucket = &buckets[cell(uv[1], 1) * nb + cell(uv[0], 0)];
            let mut best: Option<(f64, u32, [f64; 3])> = None;
            for &t in bucket {
                let c = tris[t as usize].map(|k| {
                    let r = rest[k as usize];
                    [f64::from(r.x), f64::from(r.y)]
                });
                let b = barycentric(c, p);
                let worst = b.iter().copied().fold(f64::INFINITY, f64::min);
                if best.is_none_or(|(w, _, _)| worst > w) {
                    best = Some((worst, t, b));
                }
            }
            match best {
                Some((w, t, b)) if w > -1e-4 => {
                    triangle.push(t);
                    bary.push(b.map(|x| x as f32));
                }
                _ => return Err(format!("fine vertex {i} lies outside the coarse cloth")),
            }
        }
        Ok(Upsampler {
            triangle,
            bary,
            coarse_normals: vec![Vec3A::Z; world.vertex_count()],
        })
    }

    /// Writes the fine positions and normals of `world`'s current state.
    pub fn run(
        &mut self,
        world: &World<'_>,
        mode: Mode,
        positions: &mut [Vec3A],
        normals: &mut [Vec3A],
    ) -> Result<(), String> {
        match mode {
            Mode::Off => {
                let x = world.positions();
                area_normals(world.triangles(), x, &mut self.coarse_normals);
                let tris = world.triangles();
                for (((p, nrm), &t), b) in positions
                    .iter_mut()
                    .zip(normals.iter_mut())
                    .zip(&self.triangle)
                    .zip(&self.bary)
                {
                    let c = tris[t as usize];
                    *p =
                        x[c[0] as usize] * b[0] + x[c[1] as usize] * b[1] + x[c[2] as usize] * b[2];
                    let n = self.coarse_normals[c[0] as usize] * b[0]
                        + self.coarse_normals[c[1] as usize] * b[1]
                        + self.coarse_normals[c[2] as usize] * b[2];
                    *nrm = n.normalize_or_zero();
                }
                Ok(())
            }
            Mode::On { .. } => Err("localization is not available yet".into()),
        }
    }
}

/// Barycentric coordinates of `p` in the triangle `c`.
fn barycentric(c: [[f64; 2]; 3], p: [f64; 2]) -> [f64; 3] {
    let (e1, e2) = (
        [c[1][0] - c[0][0], c[1][1] - c[0][1]],
        [c[2][0] - c[0][0], c[2][1] - c[0][1]],
    );
    let d = [p[0] - c[0][0], p[1] - c[0][1]];
    let det = e1[0] * e2[1] - e1[1] * e2[0];
    if det == 0.0 {
        return [f64::NEG_INFINITY; 3];
    }
    let b1 = (d[0] * e2[1] - d[1] * e2[0]) / det;
    let b2 = (e1[0] * d[1] - e1[1] * d[0]) / det;
    [1.0 - b1 - b2, b1, b2]
}

/// Area-weighted vertex normals of a triangle mesh (unit length; zero where undefined).
pub fn area_normals(triangles: &[[u32; 3]], x: &[Vec3A], out: &mut [Vec3A]) {
    out.iter_mut().for_each(|n| *n = Vec3A::ZERO);
    for t in triangles {
        let [a, b, c] = t.map(|i| x[i as usize]);
        let n = (b - a).cross(c - a);
        for &i in t {
            out[i as usize] += n;
        }
    }
    for n in out.iter_mut() {
        *n = n.normalize_or_zero();
    }
}
