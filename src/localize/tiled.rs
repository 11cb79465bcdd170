//! Tiled micro meshes: a cell's own micro mesh laid over the (u, v) bounding box of the coarse
//! cloth as a render mesh to [`bind`](fn@super::bind) ([`tiled_mesh`]), and its vertex and
//! triangle counts ([`tiled_mesh_counts`]).

use crate::blob::{Blob, Cell};
use crate::world::World;

use super::BindError;

/// One axis of a tiled mesh: lattice lines `lo..=hi` of spacing `h`, clamped to `[min, max]`.
#[derive(Clone, Copy)]
struct Axis {
    lo: i64,
    hi: i64,
    h: f64,
    min: f64,
    max: f64,
}

impl Axis {
    fn new(min: f64, max: f64, h: f64) -> Option<Axis> {
        // Snap to a lattice line within 1e-4 of a square, so an edge that is a multiple of
        // the spacing up to rounding does not leave a sliver column.
        let snap = |q: f64, up: bool| {
            let r = libm::round(q);
            if (q - r).abs() <= 1e-4 {
                r
            } else if up {
                libm::ceil(q)
            } else {
                libm::floor(q)
            }
        };
        let (lo, hi) = (snap(min / h, false), snap(max / h, true));
        let ok = lo.is_finite() && hi.is_finite() && hi > lo && (hi - lo) < 1e9;
        ok.then_some(Axis {
            lo: lo as i64,
            hi: hi as i64,
            h,
            min,
            max,
        })
    }
    fn nodes(&self) -> usize {
        (self.hi - self.lo + 1) as usize
    }
    fn at(&self, k: usize) -> f32 {
        ((self.lo + k as i64) as f64 * self.h).clamp(self.min, self.max) as f32
    }
    /// Index of the cell square that lattice square `k` is, modulo `n`.
    fn wrap(&self, k: usize, n: usize) -> usize {
        (self.lo + k as i64).rem_euclid(n.max(1) as i64) as usize
    }
}

fn tiling<'b>(
    world: &World<'_>,
    blob: &Blob<'b>,
    cell: u32,
) -> Result<(Cell<'b>, Axis, Axis), BindError> {
    let c = blob
        .cell(cell as usize)
        .ok_or(BindError::NoSuchCell { cell })?;
    if world.triangles().is_empty() {
        return Err(BindError::EmptyWorld);
    }
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for r in world.rest_positions() {
        for (k, x) in [f64::from(r.x), f64::from(r.y)].into_iter().enumerate() {
            if let (Some(l), Some(h)) = (lo.get_mut(k), hi.get_mut(k)) {
                *l = l.min(x);
                *h = h.max(x);
            }
        }
    }
    let h = c.width() / f64::from(c.nu().max(1));
    let u = Axis::new(lo[0], hi[0], h).ok_or(BindError::TooLarge)?;
    let v = Axis::new(lo[1], hi[1], h).ok_or(BindError::TooLarge)?;
    let nodes = u
        .nodes()
        .checked_mul(v.nodes())
        .ok_or(BindError::TooLarge)?;
    if u32::try_from(nodes).is_err() {
        return Err(BindError::TooLarge);
    }
    Ok((c, u, v))
}

/// Vertex and triangle counts of [`tiled_mesh`].
pub fn tiled_mesh_counts(
    world: &World<'_>,
    blob: &Blob<'_>,
    cell: u32,
) -> Result<(usize, usize), BindError> {
    let (_, u, v) = tiling(world, blob, cell)?;
    Ok((u.nodes() * v.nodes(), 2 * (u.nodes() - 1) * (v.nodes() - 1)))
}

/// Cell `cell`'s micro mesh tiled over the (u, v) bounding box of the coarse cloth, as a
/// render mesh to [`bind`](fn@super::bind): a non-periodic grid on the cell's lattice (node
/// spacing `h = width / nu`, lattice anchored at the origin as the cells are), the outer
/// columns and rows clamped to the box, node `(i, j)` at index `j·nx + i`, square `(i, j)`
/// split into `[ll, lr, ur]`, `[ll, ur, ul]` (counter-clockwise, docs/ARCHITECTURE.md).
/// `materials_out`, if given, receives each triangle's material (index into the cell's materials).
///
/// The box is the cloth only for a rectangular cloth; for other outlines the caller drops the
/// vertices outside (binding reports them as `OutOfDomain`). Returns the counts written.
pub fn tiled_mesh(
    world: &World<'_>,
    blob: &Blob<'_>,
    cell: u32,
    uv_out: &mut [[f32; 2]],
    triangles_out: &mut [[u32; 3]],
    materials_out: Option<&mut [u32]>,
) -> Result<(usize, usize), BindError> {
    let (c, u, v) = tiling(world, blob, cell)?;
    let (nx, ny) = (u.nodes(), v.nodes());
    let (nvert, ntri) = (nx * ny, 2 * (nx - 1) * (ny - 1));
    let small = |needed, len| BindError::BufferTooSmall { needed, len };
    if uv_out.len() < nvert {
        return Err(small(nvert, uv_out.len()));
    }
    if triangles_out.len() < ntri {
        return Err(small(ntri, triangles_out.len()));
    }
    if let Some(m) = &materials_out {
        if m.len() < ntri {
            return Err(small(ntri, m.len()));
        }
    }
    for (k, o) in uv_out.iter_mut().take(nvert).enumerate() {
        *o = [u.at(k % nx), v.at(k / nx)];
    }
    let id = |i: usize, j: usize| crate::lattice::node(i, j, nx) as u32;
    let mut tris = triangles_out.iter_mut();
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let (ll, lr, ur, ul) = (id(i, j), id(i + 1, j), id(i + 1, j + 1), id(i, j + 1));
            if let (Some(a), Some(b)) = (tris.next(), tris.next()) {
                [*a, *b] = crate::lattice::square_triangles(ll, lr, ur, ul);
            }
        }
    }
    if let Some(m) = materials_out {
        let nu = c.nu() as usize;
        let nv = c.nv() as usize;
        let mut out = m.iter_mut();
        for j in 0..ny - 1 {
            for i in 0..nx - 1 {
                let square = v.wrap(j, nv) * nu + u.wrap(i, nu);
                let mat = c.tri_material.get(2 * square).copied().unwrap_or(0);
                for o in out.by_ref().take(2) {
                    *o = mat;
                }
            }
        }
    }
    Ok((nvert, ntri))
}
