//! Binding a fine mesh to the coarse cloth, once: [`Binding`] (triangle, barycentrics, `χ` at
//! the vertex) and [`BindError`]; point location in the coarse rest (u, v) shape (a walk across
//! edges from the previous vertex's triangle, then a scan; ties to the lowest-index triangle);
//! the `χ` blend (a coarse vertex's area-weighted mixture of its incident cells' `χ`, a fine
//! vertex's barycentric blend of its corners'); [`bind`] and [`bind_to_triangle`].

use core::fmt;

use bytemuck::{Pod, Zeroable};
use glam::Vec3A;

use crate::blob::{Blob, Cell};
use crate::strided::{StrideError, Strided};
use crate::world::World;

/// Barycentric slack of point location: a point whose barycentric coordinates in a triangle
/// are all ≥ `-LOCATE_TOLERANCE` is in it. Points within this (relative) distance of the
/// cloth's boundary are accepted and extrapolated; points this close to an interior edge go to
/// the lowest-index triangle of the edge.
pub const LOCATE_TOLERANCE: f64 = 1e-5;

/// Where a fine vertex sits: its coarse triangle, its barycentric place there, and the
/// characteristic displacements at its place in the cell. Written by [`bind`]; plain data, so
/// an engine can store it with its mesh asset.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Binding {
    /// Index of the coarse triangle in `World::triangles()`.
    pub triangle: u32,
    /// Barycentric weights of the triangle's corners 1 and 2; corner 0 has `1 - b1 - b2`.
    pub bary: [f32; 2],
    /// `(χ¹u, χ¹v, χ²u, χ²v, χ³u, χ³v)` at the vertex, metres per unit strain.
    pub chi: [f32; 6],
}

const _: () = assert!(core::mem::size_of::<Binding>() == 36);

impl Binding {
    pub const ZERO: Binding = Binding {
        triangle: 0,
        bary: [0.0; 2],
        chi: [0.0; 6],
    };
}

/// Why [`bind`] (or the tiled-mesh builders) refused. Nothing is written on error.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BindError {
    /// Fine vertex `vertex` lies outside every coarse triangle's (u, v) (or is not finite).
    OutOfDomain {
        vertex: u32,
    },
    /// An output holds `len` elements where `needed` are required.
    BufferTooSmall {
        needed: usize,
        len: usize,
    },
    /// A strided input's stride cannot hold its element.
    BadStride,
    /// Coarse triangle `triangle`'s material is not a cell of the blob.
    CellMissing {
        triangle: u32,
    },
    /// [`bind_to_triangle`] or a tiled mesh named a triangle or cell that does not exist.
    NoSuchTriangle {
        triangle: u32,
    },
    NoSuchCell {
        cell: u32,
    },
    /// The world has no triangles.
    EmptyWorld,
    /// More fine vertices than a `u32` can index.
    TooLarge,
}

impl From<StrideError> for BindError {
    fn from(e: StrideError) -> Self {
        match e {
            StrideError::BadStride { .. } => BindError::BadStride,
            StrideError::BufferTooSmall { needed, len } => {
                BindError::BufferTooSmall { needed, len }
            }
        }
    }
}

impl fmt::Display for BindError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BindError::OutOfDomain { vertex } => {
                write!(
                    f,
                    "fine vertex {vertex} lies outside the coarse cloth's (u, v)"
                )
            }
            BindError::BufferTooSmall { needed, len } => {
                write!(f, "output holds {len} elements, {needed} needed")
            }
            BindError::BadStride => write!(f, "stride cannot hold the element"),
            BindError::CellMissing { triangle } => {
                write!(f, "coarse triangle {triangle}'s cell is not in the blob")
            }
            BindError::NoSuchTriangle { triangle } => write!(f, "no coarse triangle {triangle}"),
            BindError::NoSuchCell { cell } => write!(f, "no cell {cell} in the blob"),
            BindError::EmptyWorld => write!(f, "the world has no triangles"),
            BindError::TooLarge => write!(f, "too many fine vertices for u32 indices"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for BindError {}

/// Number of [`Binding`]s [`bind`] needs for `fine_uv`: one per fine vertex.
pub fn bindings_needed(fine_uv: &Strided<'_, 2>) -> usize {
    fine_uv.count()
}

/// The coarse cloth's rest (u, v) shape, for point location.
struct Domain<'w, 'a> {
    world: &'w World<'a>,
    rest: &'w [Vec3A],
    triangles: &'w [[u32; 3]],
    materials: &'w [u32],
}

impl<'w, 'a> Domain<'w, 'a> {
    fn new(world: &'w World<'a>) -> Result<Self, BindError> {
        let d = Domain {
            world,
            rest: world.rest_positions(),
            triangles: world.triangles(),
            materials: world.triangle_materials(),
        };
        if d.triangles.is_empty() {
            return Err(BindError::EmptyWorld);
        }
        Ok(d)
    }

    fn uv(&self, v: u32) -> Option<[f64; 2]> {
        let r = self.rest.get(v as usize)?;
        Some([f64::from(r.x), f64::from(r.y)])
    }

    /// Barycentric coordinates of `p` in triangle `t`'s rest (u, v) (either orientation).
    fn bary(&self, t: usize, p: [f64; 2]) -> Option<[f64; 3]> {
        let tri = self.triangles.get(t)?;
        let (a, b, c) = (self.uv(tri[0])?, self.uv(tri[1])?, self.uv(tri[2])?);
        let (e1, e2, q) = (
            [b[0] - a[0], b[1] - a[1]],
            [c[0] - a[0], c[1] - a[1]],
            [p[0] - a[0], p[1] - a[1]],
        );
        let det = e1[0] * e2[1] - e2[0] * e1[1];
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let b1 = (q[0] * e2[1] - e2[0] * q[1]) / det;
        let b2 = (e1[0] * q[1] - q[0] * e1[1]) / det;
        Some([1.0 - b1 - b2, b1, b2])
    }

    fn contains(&self, t: usize, p: [f64; 2]) -> bool {
        self.bary(t, p)
            .is_some_and(|b| b.iter().all(|&x| x >= -LOCATE_TOLERANCE))
    }

    /// The triangle across the edge opposite corner `k` of `t`, if any.
    fn neighbour(&self, t: usize, k: usize) -> Option<usize> {
        let tri = self.triangles.get(t)?;
        let a = *tri.get((k + 1) % 3)?;
        let b = *tri.get((k + 2) % 3)?;
        self.world
            .incident_triangles(a as usize)
            .iter()
            .map(|&s| s as usize)
            .find(|&s| s != t && self.triangles.get(s).is_some_and(|ts| ts.contains(&b)))
    }

    /// The lowest-index triangle containing `p`, starting a walk at `*hint` (updated).
    fn locate(&self, p: [f64; 2], hint: &mut usize) -> Option<usize> {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        let nt = self.triangles.len();
        let mut t = if *hint < nt { *hint } else { 0 };
        let mut found = None;
        // Walk towards p across the edge of the most negative barycentric coordinate. A walk
        // can cycle on odd meshes or stop at the boundary (concave outline, separate pieces);
        // a scan settles those.
        for _ in 0..nt.min(4096) {
            let Some(b) = self.bary(t, p) else { break };
            let (mut k, mut worst) = (0, b[0]);
            for (i, &x) in b.iter().enumerate() {
                if x < worst {
                    (k, worst) = (i, x);
                }
            }
            if worst >= -LOCATE_TOLERANCE {
                found = Some(t);
                break;
            }
            match self.neighbour(t, k) {
                Some(s) => t = s,
                None => break,
            }
        }
        let found = match found {
            Some(t) => t,
            None => (0..nt).find(|&t| self.contains(t, p))?,
        };
        *hint = found;
        // Canonical owner: every triangle containing p within the tolerance touches a corner
        // of `found` (conforming mesh), so the minimum over their one-rings is the global one
        // and does not depend on where the walk started.
        let mut best = found;
        for &c in self.triangles.get(found)? {
            for &s in self.world.incident_triangles(c as usize) {
                let s = s as usize;
                if s < best && self.contains(s, p) {
                    best = s;
                }
            }
        }
        Some(best)
    }

    /// Checks every triangle's cell exists.
    fn check_cells(&self, blob: &Blob<'_>) -> Result<(), BindError> {
        let cells = blob.cell_count();
        for (t, &m) in self.materials.iter().enumerate() {
            if m as usize >= cells {
                return Err(BindError::CellMissing { triangle: t as u32 });
            }
        }
        Ok(())
    }

    /// `χ` at `p` in triangle `t` (barycentrics `b`): the cell's own where every triangle
    /// around `t`'s corners has `t`'s cell, else the blend of the corners' cell mixtures.
    fn chi<'b>(
        &self,
        blob: &Blob<'b>,
        cache: &mut CellCache<'b>,
        t: usize,
        p: [f64; 2],
        b: [f64; 3],
    ) -> Result<[f64; 6], BindError> {
        let tri = *self
            .triangles
            .get(t)
            .ok_or(BindError::NoSuchTriangle { triangle: t as u32 })?;
        let own = *self
            .materials
            .get(t)
            .ok_or(BindError::CellMissing { triangle: t as u32 })?;
        let uniform = tri.iter().all(|&c| {
            self.world
                .incident_triangles(c as usize)
                .iter()
                .all(|&s| self.materials.get(s as usize) == Some(&own))
        });
        let missing = |s: usize| BindError::CellMissing { triangle: s as u32 };
        if uniform {
            let cell = cache.get(blob, own).ok_or(missing(t))?;
            return Ok(chi_in_cell(&cell, p));
        }
        let mut out = [0.0f64; 6];
        for (&c, &bk) in tri.iter().zip(&b) {
            let (mut sum, mut weight) = ([0.0f64; 6], 0.0f64);
            for &s in self.world.incident_triangles(c as usize) {
                let s = s as usize;
                let m = *self.materials.get(s).ok_or(missing(s))?;
                let area = self.area(s);
                let cell = cache.get(blob, m).ok_or(missing(s))?;
                let x = chi_in_cell(&cell, p);
                for (o, v) in sum.iter_mut().zip(x) {
                    *o += area * v;
                }
                weight += area;
            }
            if weight > 0.0 {
                for (o, v) in out.iter_mut().zip(sum) {
                    *o += bk * v / weight;
                }
            }
        }
        Ok(out)
    }

    fn area(&self, t: usize) -> f64 {
        let Some(tri) = self.triangles.get(t) else {
            return 0.0;
        };
        match (self.uv(tri[0]), self.uv(tri[1]), self.uv(tri[2])) {
            (Some(a), Some(b), Some(c)) => {
                0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])).abs()
            }
            _ => 0.0,
        }
    }

    fn binding<'b>(
        &self,
        blob: &Blob<'b>,
        cache: &mut CellCache<'b>,
        t: usize,
        p: [f64; 2],
    ) -> Result<Binding, BindError> {
        let b = self
            .bary(t, p)
            .ok_or(BindError::NoSuchTriangle { triangle: t as u32 })?;
        let chi = self.chi(blob, cache, t, p, b)?;
        Ok(Binding {
            triangle: t as u32,
            bary: [b[1] as f32, b[2] as f32],
            chi: chi.map(|x| x as f32),
        })
    }
}

/// The last cell looked up (re-slicing a cell out of the blob is cheap but not free).
struct CellCache<'b> {
    last: Option<(u32, Cell<'b>)>,
}

impl<'b> CellCache<'b> {
    fn get(&mut self, blob: &Blob<'b>, i: u32) -> Option<Cell<'b>> {
        if let Some((j, c)) = self.last {
            if j == i {
                return Some(c);
            }
        }
        let c = blob.cell(i as usize)?;
        self.last = Some((i, c));
        Some(c)
    }
}

/// `χ` at material point `p` of the periodic cell tiling the (u, v) plane from the origin:
/// `y = p mod (width, height)`, located in the structured micro mesh (square `(i, j)`, lower
/// triangle `[ll, lr, ur]` below the diagonal, upper `[ll, ur, ul]` above, indices wrapped) and
/// interpolated linearly (P1, as the cell problem solved it).
fn chi_in_cell(cell: &Cell<'_>, p: [f64; 2]) -> [f64; 6] {
    let (nu, nv) = (cell.nu() as usize, cell.nv() as usize);
    let (w, h) = (cell.width(), cell.height());
    if nu == 0 || nv == 0 || !(w > 0.0 && h > 0.0) {
        return [0.0; 6];
    }
    // lattice coordinates in [0, n)
    let lattice = |x: f64, period: f64, n: usize| -> (usize, f64) {
        let y = x - period * libm::floor(x / period);
        let q = y / period * n as f64;
        let i = libm::floor(q);
        let (i, f) = if i.is_finite() && i >= 0.0 {
            (i as usize, q - i)
        } else {
            (0, 0.0)
        };
        if i >= n {
            (n - 1, 1.0) // y rounded up to the period
        } else {
            (i, f.clamp(0.0, 1.0))
        }
    };
    let (i, s) = lattice(p[0], w, nu);
    let (j, t) = lattice(p[1], h, nv);
    let (i1, j1) = ((i + 1) % nu, (j + 1) % nv);
    let node = |a: usize, b: usize| crate::lattice::node(a, b, nu);
    let (ll, lr, ur, ul) = (node(i, j), node(i1, j), node(i1, j1), node(i, j1));
    let corners = if s >= t {
        [(ll, 1.0 - s), (lr, s - t), (ur, t)]
    } else {
        [(ll, 1.0 - t), (ur, s), (ul, t - s)]
    };
    let mut out = [0.0f64; 6];
    for (n, wgt) in corners {
        if let Some(c) = cell.chi.get(n) {
            for (o, &v) in out.iter_mut().zip(c) {
                *o += wgt * f64::from(v);
            }
        }
    }
    out
}

/// Binds every fine vertex `fine_uv[i]` (material coordinates (u, v), metres) to the coarse
/// cloth: `out[i]` gets its coarse triangle, barycentric place and `χ`. `out` needs
/// [`bindings_needed`] entries (extra ones are left alone).
///
/// Point location walks from the previous vertex's triangle across edges (fast for coherent
/// vertex orders: a tiled or scanned mesh costs a few steps per vertex) and falls back to a
/// scan; a point on an edge or vertex (within [`LOCATE_TOLERANCE`]) belongs to the
/// lowest-index triangle containing it, so the result is a pure function of (u, v). The coarse
/// (u, v) layout is assumed not to overlap itself.
///
/// Errors (checked before anything is written, so `out` is untouched on error):
/// `BufferTooSmall`, `CellMissing` (lowest triangle whose material is not a blob cell),
/// `OutOfDomain` (lowest fine vertex outside the cloth), `EmptyWorld`, `TooLarge`.
pub fn bind(
    world: &World<'_>,
    blob: &Blob<'_>,
    fine_uv: &Strided<'_, 2>,
    out: &mut [Binding],
) -> Result<(), BindError> {
    let n = fine_uv.count();
    if out.len() < n {
        return Err(BindError::BufferTooSmall {
            needed: n,
            len: out.len(),
        });
    }
    if u32::try_from(n).is_err() {
        return Err(BindError::TooLarge);
    }
    let d = Domain::new(world)?;
    d.check_cells(blob)?;
    let uv = |i: usize| fine_uv.get(i).map(|p| [f64::from(p[0]), f64::from(p[1])]);
    // Pass 1: every vertex must be in the domain. Nothing is written yet.
    let mut hint = 0;
    for i in 0..n {
        let outside = BindError::OutOfDomain { vertex: i as u32 };
        let p = uv(i).ok_or(outside)?;
        d.locate(p, &mut hint).ok_or(outside)?;
    }
    // Pass 2: locate again (deterministic, so it succeeds) and write.
    let mut hint = 0;
    let mut cache = CellCache { last: None };
    for (i, o) in out.iter_mut().enumerate().take(n) {
        let outside = BindError::OutOfDomain { vertex: i as u32 };
        let p = uv(i).ok_or(outside)?;
        let t = d.locate(p, &mut hint).ok_or(outside)?;
        *o = d.binding(blob, &mut cache, t, p)?;
    }
    Ok(())
}

/// Binds one point to a given coarse triangle, without point location or domain check (the
/// barycentrics may lie outside [0, 1]). For render meshes built per coarse triangle, and for
/// checking continuity across coarse edges. A non-finite `uv` is `OutOfDomain { vertex: 0 }`.
pub fn bind_to_triangle(
    world: &World<'_>,
    blob: &Blob<'_>,
    triangle: u32,
    uv: [f32; 2],
) -> Result<Binding, BindError> {
    let d = Domain::new(world)?;
    let t = triangle as usize;
    if t >= d.triangles.len() {
        return Err(BindError::NoSuchTriangle { triangle });
    }
    d.check_cells(blob)?;
    let p = [f64::from(uv[0]), f64::from(uv[1])];
    if !(p[0].is_finite() && p[1].is_finite()) {
        return Err(BindError::OutOfDomain { vertex: 0 });
    }
    d.binding(blob, &mut CellCache { last: None }, t, p)
}
