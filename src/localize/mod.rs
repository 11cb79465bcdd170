//! Localization (§6): the fine pattern's own deformation put back on the coarse cloth.
//!
//! The coarse [`World`] moves like the homogenized fabric (§5). Localization rebuilds, every
//! frame, a *fine* mesh whose vertices carry (u, v): the cells' own micro meshes tiled over the
//! cloth ([`tiled_mesh`]) or any render mesh. A fine vertex at material point `y` lands at
//!
//! ```text
//! x(y) = Σ_k b_k p_k  +  T(y) w(y),     w(y) = -(χ¹(y) Ê1 + χ²(y) Ê2 + χ³(y) Ê3)      (Eq. 20, 23)
//! ```
//!
//! * `b_k` are the barycentric coordinates of `y` in its coarse triangle's rest (u, v) shape and
//!   `p_k` that triangle's current corners: the affine embedding of Eq. 23 (`x0 + xi0 - x00`).
//! * `w` is the micro displacement of the cell problem (docs/CONVENTIONS.md: note the minus sign and
//!   `Ê3 = 2 E12`), with `χ` interpolated in the cell's micro mesh at `y mod cell` and the
//!   macro strain `Ê` of the coarse cloth at `y`.
//! * `T` carries the in-plane `w` into 3D: the first two columns of the paper's frame map
//!   `Q = V V0⁻¹` (Eq. 21–22), i.e. the triangle's deformation gradient `F = ∂x/∂(u,v)`
//!   (3×2), or its rotation part (below).
//!
//! **Strain and frame** ([`StrainMeasure`], per coarse triangle, in [`prepare`]):
//! * [`StrainMeasure::Green`] is the paper verbatim: the Green strain of Eq. 19,
//!   `E = (FᵀF − I)/2` (the covariant-basis formula is this, written with edge vectors), with
//!   `T = F`.
//! * [`StrainMeasure::Corotated`] (the default) uses the polar decomposition `F = R U`: the
//!   Biot strain `Ê = U − I` with `T = R`. This is the strain measure of the corotated linear
//!   FEM that steps the coarse cloth (§5.2), so the micro field is the linear cell solution
//!   seen in the triangle's rotated frame, `x = R (U y + w)`. For a laminate stretched across
//!   its layers the layer strains then match the closed form exactly, whereas Green + `F`
//!   over-shoots the fluctuation by a factor `λ(λ+1)/2` (3 % at 2 % stretch — 14 % of the hard
//!   layer's small strain); both agree to first order and for rigid motion.
//!
//! **No cracks.** `F` (or `R`), `Ê` and the normal are computed per coarse triangle and
//! area-averaged to the coarse vertices ([`VertexFrame`]); a fine vertex blends its corners'
//! frames with its barycentric weights, so the field is continuous across coarse edges (the
//! paper's "we blend the displacements across adjacent unit cells"). Where triangles of
//! *different* cells meet, `χ` itself would jump; binding blends it too: a coarse vertex holds
//! the area-weighted mixture of the `χ` of its incident triangles' cells, and a fine vertex the
//! barycentric blend of its corners' mixtures (a one-triangle-wide transition; where all
//! incident cells agree this is exactly the cell's `χ`). Binding is a pure function of (u, v):
//! a point on a coarse edge or vertex belongs to the lowest-index triangle containing it, so
//! duplicated render vertices along seams get bit-identical bindings and positions.
//!
//! **Costs.** Binding does the point location and the `χ` interpolation once ([`Binding`]
//! stores the triangle, two barycentrics and `χ` at the vertex: 36 bytes). Per frame,
//! [`prepare`] is O(coarse triangles) and [`localize`] per fine vertex gathers three
//! [`VertexFrame`]s and does a handful of `Vec3A` multiply-adds; it writes into a caller's
//! (interleaved) vertex buffer through [`StridedMut`] and can be split into ranges for jobs.
//! Normals are the barycentric blend of the coarse vertex normals, or recomputed from the fine
//! mesh ([`recompute_normals`]) where the extra cost is wanted.
//!
//! Everything here is no_std, allocation-free and panic-free (checked access throughout).
//!
//! Files: this one holds the per-frame half ([`StrainMeasure`], [`VertexFrame`], [`prepare`],
//! [`localize`], normals); `bind.rs` binding (point location, the `χ` blend, [`bind`](fn@bind));
//! `tiled.rs` the tiled micro meshes ([`tiled_mesh`]); `blocks.rs` the block formats.
//!
//! Per frame:
//!
//! ```ignore
//! prepare(&world, StrainMeasure::Corotated, &mut frames)?;
//! localize(&frames, world.triangles(), &bindings, 0, &mut positions, Some(NormalTarget::Interleaved { offset: 12 }))?;
//! ```

use core::fmt;

use glam::Vec3A;

use crate::collide::ColliderSet;
use crate::strided::{self, StridedMut};
use crate::world::World;

mod bind;
pub mod blocks;
mod tiled;

pub use bind::{bind, bind_to_triangle, bindings_needed, BindError, Binding, LOCATE_TOLERANCE};
pub use tiled::{tiled_mesh, tiled_mesh_counts};

/// Why a per-frame call refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LocalizeError {
    /// `frames` is shorter than the coarse vertex count, or the positions of
    /// [`prepare_mesh`] disagree with the rest shape.
    FrameCount { needed: usize, len: usize },
    /// `bindings[first .. first + count]` is out of range.
    Range {
        first: usize,
        count: usize,
        len: usize,
    },
    /// Binding `index` names a coarse triangle (or the triangle a vertex) that does not exist.
    /// Nothing has been written.
    BadBinding { index: usize },
    /// A coarse or fine triangle names a vertex that does not exist.
    BadTriangle { triangle: usize },
    /// The normals buffer holds fewer elements than the positions.
    BufferTooSmall { needed: usize, len: usize },
    /// An interleaved normal overlaps the position or does not fit in the record.
    NormalLayout,
}

impl fmt::Display for LocalizeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            LocalizeError::FrameCount { needed, len } => {
                write!(f, "{len} vertex frames given, {needed} needed")
            }
            LocalizeError::Range { first, count, len } => write!(
                f,
                "bindings {first}..{first}+{count} out of range (there are {len})"
            ),
            LocalizeError::BadBinding { index } => write!(f, "binding {index} is invalid"),
            LocalizeError::BadTriangle { triangle } => {
                write!(f, "triangle {triangle} names a missing vertex")
            }
            LocalizeError::BufferTooSmall { needed, len } => {
                write!(f, "normals buffer holds {len} elements, {needed} needed")
            }
            LocalizeError::NormalLayout => {
                write!(
                    f,
                    "interleaved normal overlaps the position or leaves the record"
                )
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for LocalizeError {}

// ---------------------------------------------------------------------------------------------
// Per frame
// ---------------------------------------------------------------------------------------------

/// How [`prepare`] measures a coarse triangle's strain and which frame carries `w` into 3D
/// (module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum StrainMeasure {
    /// Polar decomposition `F = R U`: Biot strain `U − I`, frame `R`. Consistent with the
    /// corotated linear FEM of the coarse step.
    #[default]
    Corotated,
    /// The paper verbatim: Green strain `(FᵀF − I)/2` (Eq. 19), frame `F` (Eq. 21–22).
    Green,
}

/// A coarse vertex's share of the deformation: the area-weighted average of its incident
/// triangles', so that the barycentric blend in [`localize`] is continuous.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexFrame {
    /// Current position.
    pub p: Vec3A,
    /// The frame carrying `(u, v)` displacements into 3D: columns `∂x/∂u`, `∂x/∂v` of `F`
    /// ([`StrainMeasure::Green`]) or of its rotation `R` ([`StrainMeasure::Corotated`]).
    pub f1: Vec3A,
    pub f2: Vec3A,
    /// Macro strain `Ê = [E11, E22, 2 E12]`.
    pub strain: Vec3A,
    /// Unit normal (area-weighted, oriented as `∂x/∂u × ∂x/∂v`: +z for a cloth at rest).
    pub normal: Vec3A,
}

impl VertexFrame {
    /// The frame of a vertex at the origin of a cloth at rest.
    pub const REST: VertexFrame = VertexFrame {
        p: Vec3A::ZERO,
        f1: Vec3A::X,
        f2: Vec3A::Y,
        strain: Vec3A::ZERO,
        normal: Vec3A::Z,
    };
}

/// Per-vertex frames of the world's current shape: `frames[..world.vertex_count()]`, their
/// positions in the caller's coordinates (the world's strains and frames come from its local
/// positions, so they keep their precision however far the world is from zero).
pub fn prepare(
    world: &World<'_>,
    measure: StrainMeasure,
    frames: &mut [VertexFrame],
) -> Result<(), LocalizeError> {
    prepare_mesh(
        world.rest_positions(),
        world.positions(),
        world.triangles(),
        measure,
        frames,
    )?;
    if world.origin() != glam::DVec3::ZERO {
        for f in frames.iter_mut().take(world.vertex_count()) {
            f.p = Vec3A::from(world.to_world(f.p));
        }
    }
    Ok(())
}

/// [`prepare`] on plain slices: rest positions `(u, v, 0)`, current positions, triangles.
///
/// Per triangle (Eq. 19, 21–22), with rest edges `D = [uv1 − uv0, uv2 − uv0]` (2×2) and
/// current edges `X = [x1 − x0, x2 − x0]` (3×2): `F = X D⁻¹`, then the strain and frame of
/// `measure`, and `A (∂x/∂u × ∂x/∂v)` (`A` the rest area) for the normal, which is the
/// 3D-area-weighted normal oriented by the (u, v) winding. Each is averaged over a vertex's
/// triangles with weight `A`. A triangle whose `F` is not finite or, for the corotated
/// measure, is collapsed (no rotation defined) is skipped; a vertex without usable triangles
/// keeps the rest frame at its current position.
pub fn prepare_mesh(
    rest: &[Vec3A],
    positions: &[Vec3A],
    triangles: &[[u32; 3]],
    measure: StrainMeasure,
    frames: &mut [VertexFrame],
) -> Result<(), LocalizeError> {
    let n = positions.len();
    if rest.len() != n {
        return Err(LocalizeError::FrameCount {
            needed: n,
            len: rest.len(),
        });
    }
    let Some(frames) = frames.get_mut(..n) else {
        return Err(LocalizeError::FrameCount {
            needed: n,
            len: frames.len(),
        });
    };
    if let Some(t) = triangles
        .iter()
        .position(|t| t.iter().any(|&v| v as usize >= n))
    {
        return Err(LocalizeError::BadTriangle { triangle: t });
    }
    // Accumulate weighted sums; `p.x` holds the weight until the end.
    let zero = VertexFrame {
        p: Vec3A::ZERO,
        f1: Vec3A::ZERO,
        f2: Vec3A::ZERO,
        strain: Vec3A::ZERO,
        normal: Vec3A::ZERO,
    };
    frames.fill(zero);
    for tri in triangles {
        let [Some(&r0), Some(&r1), Some(&r2)] = tri.map(|v| rest.get(v as usize)) else {
            continue;
        };
        let [Some(&x0), Some(&x1), Some(&x2)] = tri.map(|v| positions.get(v as usize)) else {
            continue;
        };
        let Some(t) = triangle_frame([r0, r1, r2], [x0, x1, x2], measure) else {
            continue;
        };
        for &v in tri {
            if let Some(f) = frames.get_mut(v as usize) {
                f.p.x += t.area;
                f.f1 += t.f1 * t.area;
                f.f2 += t.f2 * t.area;
                f.strain += t.strain * t.area;
                f.normal += t.normal * t.area;
            }
        }
    }
    for (f, &x) in frames.iter_mut().zip(positions) {
        let w = f.p.x;
        if w > 0.0 && w.is_finite() {
            let inv = 1.0 / w;
            f.f1 *= inv;
            f.f2 *= inv;
            f.strain *= inv;
            f.normal = f
                .normal
                .normalize_or(f.f1.cross(f.f2).normalize_or(Vec3A::Z));
        } else {
            *f = VertexFrame::REST;
        }
        f.p = x;
    }
    Ok(())
}

/// One coarse triangle's deformation.
struct TriangleFrame {
    area: f32,
    f1: Vec3A,
    f2: Vec3A,
    strain: Vec3A,
    /// `∂x/∂u × ∂x/∂v` of `F` (its length is the area ratio).
    normal: Vec3A,
}

fn triangle_frame(r: [Vec3A; 3], x: [Vec3A; 3], measure: StrainMeasure) -> Option<TriangleFrame> {
    let (d1, d2) = (r[1] - r[0], r[2] - r[0]);
    let det = d1.x * d2.y - d2.x * d1.y;
    let (e1, e2) = (x[1] - x[0], x[2] - x[0]);
    // F = X D⁻¹ with D⁻¹ = [[d2.y, -d2.x], [-d1.y, d1.x]] / det
    let g1 = (e1 * d2.y - e2 * d1.y) / det;
    let g2 = (e2 * d1.x - e1 * d2.x) / det;
    if !(det != 0.0 && g1.is_finite() && g2.is_finite()) {
        return None;
    }
    let (c11, c22, c12) = (g1.dot(g1), g2.dot(g2), g1.dot(g2));
    let normal = g1.cross(g2);
    let (f1, f2, strain) = match measure {
        // Eq. 19: E = (FᵀF − I)/2, engineering shear 2 E12 = c12.
        StrainMeasure::Green => (
            g1,
            g2,
            Vec3A::new(0.5 * (c11 - 1.0), 0.5 * (c22 - 1.0), c12),
        ),
        // U = sqrt(C) for a 2×2 SPD C: (C + s I) / t with s = sqrt(det C) = |g1 × g2|,
        // t = sqrt(tr C + 2 s); R = F U⁻¹ with U⁻¹ = adj(U) / s.
        StrainMeasure::Corotated => {
            let s = normal.length();
            let t = libm::sqrtf(c11 + c22 + 2.0 * s);
            if !(s > 1e-12 * (c11 + c22) && t > 0.0 && t.is_finite()) {
                return None;
            }
            let (u11, u22, u12) = ((c11 + s) / t, (c22 + s) / t, c12 / t);
            let r1 = (g1 * u22 - g2 * u12) / s;
            let r2 = (g2 * u11 - g1 * u12) / s;
            (r1, r2, Vec3A::new(u11 - 1.0, u22 - 1.0, 2.0 * u12))
        }
    };
    Some(TriangleFrame {
        area: 0.5 * det.abs(),
        f1,
        f2,
        strain,
        normal,
    })
}

/// Where [`localize`] and [`recompute_normals`] put normals.
#[derive(Debug)]
pub enum NormalTarget<'n, 'b> {
    /// In the positions' own records, at byte `offset` of each record (an interleaved vertex
    /// buffer; must not overlap the position and must fit in the stride).
    Interleaved { offset: usize },
    /// In a buffer of their own, element `i` with position `i`.
    Buffer(&'n mut StridedMut<'b, 3>),
}

/// The three corner frames of a binding's triangle.
#[inline(always)]
fn corners<'f>(
    frames: &'f [VertexFrame],
    triangles: &[[u32; 3]],
    b: &Binding,
) -> Option<[&'f VertexFrame; 3]> {
    let t = triangles.get(b.triangle as usize)?;
    Some([
        frames.get(t[0] as usize)?,
        frames.get(t[1] as usize)?,
        frames.get(t[2] as usize)?,
    ])
}

/// Eq. 20 and 23 with blended frames: `Σ b_k p_k + T w`, `w = -(χ¹Ê1 + χ²Ê2 + χ³Ê3)`.
#[inline(always)]
fn position(c: [&VertexFrame; 3], b: &Binding) -> Vec3A {
    let [b1, b2] = b.bary;
    let b0 = 1.0 - b1 - b2;
    let [c0, c1, c2] = c;
    // positions as corner 0 plus edge offsets: rounding relative to the triangle, not to |p|
    let p = c0.p + (c1.p - c0.p) * b1 + (c2.p - c0.p) * b2;
    let f1 = c0.f1 * b0 + c1.f1 * b1 + c2.f1 * b2;
    let f2 = c0.f2 * b0 + c1.f2 * b1 + c2.f2 * b2;
    let e = c0.strain * b0 + c1.strain * b1 + c2.strain * b2;
    let [x1u, x1v, x2u, x2v, x3u, x3v] = b.chi;
    let wu = -(x1u * e.x + x2u * e.y + x3u * e.z);
    let wv = -(x1v * e.x + x2v * e.y + x3v * e.z);
    p + f1 * wu + f2 * wv
}

/// Barycentric blend of the corner normals, normalized.
#[inline(always)]
fn normal(c: [&VertexFrame; 3], b: &Binding) -> Vec3A {
    let [b1, b2] = b.bary;
    let b0 = 1.0 - b1 - b2;
    let [c0, c1, c2] = c;
    (c0.normal * b0 + c1.normal * b1 + c2.normal * b2).normalize_or(c0.normal)
}

#[inline(always)]
fn put(rec: &mut [u8], at: usize, v: Vec3A) -> bool {
    strided::write::<3>(rec, at, v.to_array())
}

/// Localizes fine vertices `bindings[first .. first + positions.count()]`: element `i` of
/// `positions` (and of the normals, if asked) gets binding `first + i`. `frames` come from
/// [`prepare`] and `triangles` are the coarse ones (`World::triangles()`).
///
/// Position (Eq. 20–23): `x = Σ b_k p_k + T w`, with `T = Σ b_k T_k`, `Ê = Σ b_k Ê_k` the
/// blended frame and strain and `w = −(χ¹Ê1 + χ²Ê2 + χ³Ê3)`. Normal: `normalize(Σ b_k n_k)`.
///
/// Disjoint ranges can run as separate jobs ([`StridedMut::split_at`] splits a vertex buffer).
/// Everything is checked before anything is written, so on error no output changed: `Range`,
/// `BadBinding` (the lowest binding in the range not made for these triangles and frames),
/// `NormalLayout` / `BufferTooSmall`.
pub fn localize(
    frames: &[VertexFrame],
    triangles: &[[u32; 3]],
    bindings: &[Binding],
    first: usize,
    positions: &mut StridedMut<'_, 3>,
    normals: Option<NormalTarget<'_, '_>>,
) -> Result<(), LocalizeError> {
    let coarse = Coarse { frames, triangles };
    localize_colliding(
        coarse,
        bindings,
        first,
        positions,
        normals,
        ColliderSet::new(&[]),
    )
}

/// [`localize`], each fine vertex then pushed out of `colliders` along its blended coarse
/// normal to the collider's thickness ([`ColliderSet::push_out`]): the fine surface no longer
/// cuts into a pole or a leg that the coarse cloth, whose vertices alone touch the collider,
/// wraps. The push is a function of the vertex's position and blended normal only, which are
/// continuous across coarse edges, so the fine mesh stays crack-free. Empty `colliders` is
/// [`localize`] exactly, at its cost; otherwise each collider adds a proximity query per
/// vertex (README, "Measured").
pub fn localize_colliding(
    coarse: Coarse<'_>,
    bindings: &[Binding],
    first: usize,
    positions: &mut StridedMut<'_, 3>,
    normals: Option<NormalTarget<'_, '_>>,
    colliders: ColliderSet<'_>,
) -> Result<(), LocalizeError> {
    let range = checked_range(coarse, bindings, first, positions.count())?;
    if colliders.colliders.is_empty() {
        // the plain placement's loop, compiled apart: no per-vertex test
        write_placed(coarse, range, first, positions, normals, position)
    } else {
        // (the normal is blended only for the few vertices that need a push)
        let outside = |c: [&VertexFrame; 3], b: &Binding| {
            let x = position(c, b);
            if colliders.holds(x) {
                colliders.push_out(x, normal(c, b))
            } else {
                x
            }
        };
        write_placed(coarse, range, first, positions, normals, outside)
    }
}

/// [`localize`], then [`recompute_normals`] from the fine triangles `fine_triangles` (indices
/// relative to `first`, i.e. into `positions`), all checked before anything is written: the
/// errors of both, and no output changed on any of them.
pub fn localize_recomputed(
    frames: &[VertexFrame],
    triangles: &[[u32; 3]],
    bindings: &[Binding],
    first: usize,
    positions: &mut StridedMut<'_, 3>,
    fine_triangles: &[[u32; 3]],
    normals: NormalTarget<'_, '_>,
) -> Result<(), LocalizeError> {
    let coarse = Coarse { frames, triangles };
    let none = ColliderSet::new(&[]);
    localize_recomputed_colliding(
        coarse,
        bindings,
        first,
        positions,
        fine_triangles,
        normals,
        none,
    )
}

/// [`localize_recomputed`] with the fine vertices pushed out of `colliders` (as
/// [`localize_colliding`]) before their normals are recomputed.
pub fn localize_recomputed_colliding(
    coarse: Coarse<'_>,
    bindings: &[Binding],
    first: usize,
    positions: &mut StridedMut<'_, 3>,
    fine_triangles: &[[u32; 3]],
    normals: NormalTarget<'_, '_>,
    colliders: ColliderSet<'_>,
) -> Result<(), LocalizeError> {
    check_fine_triangles(fine_triangles, positions.count())?;
    let (bytes, stride, po, count) = positions.parts_mut();
    match &normals {
        NormalTarget::Interleaved { offset } => {
            check_interleaved(bytes.len(), stride, po, *offset, count)?
        }
        NormalTarget::Buffer(nb) if nb.count() < count => {
            return Err(LocalizeError::BufferTooSmall {
                needed: count,
                len: nb.count(),
            })
        }
        NormalTarget::Buffer(_) => {}
    }
    // (checks the range before it writes anything)
    localize_colliding(coarse, bindings, first, positions, None, colliders)?;
    recompute_normals(fine_triangles, positions, normals)
}

/// `bindings[first .. first + count]`, each of which names a coarse triangle whose corners
/// have frames.
fn checked_range<'b>(
    coarse: Coarse<'_>,
    bindings: &'b [Binding],
    first: usize,
    count: usize,
) -> Result<&'b [Binding], LocalizeError> {
    let range = LocalizeError::Range {
        first,
        count,
        len: bindings.len(),
    };
    let end = first.checked_add(count).ok_or(range)?;
    let bindings = bindings.get(first..end).ok_or(range)?;
    if let Some(i) = bindings
        .iter()
        .position(|b| corners(coarse.frames, coarse.triangles, b).is_none())
    {
        return Err(LocalizeError::BadBinding { index: first + i });
    }
    Ok(bindings)
}

/// Every fine triangle names vertices below `n`.
fn check_fine_triangles(fine_triangles: &[[u32; 3]], n: usize) -> Result<(), LocalizeError> {
    match fine_triangles
        .iter()
        .position(|t| t.iter().any(|&v| v as usize >= n))
    {
        Some(t) => Err(LocalizeError::BadTriangle { triangle: t }),
        None => Ok(()),
    }
}

/// The coarse cloth as localization reads it: the frames of [`prepare`] and the coarse
/// triangles (`World::triangles()`).
#[derive(Clone, Copy, Debug)]
pub struct Coarse<'a> {
    pub frames: &'a [VertexFrame],
    pub triangles: &'a [[u32; 3]],
}

/// Writes `place(corners, binding)` (and the blended normal, if asked) for every binding of a
/// range [`checked_range`] accepted.
fn write_placed(
    coarse: Coarse<'_>,
    bindings: &[Binding],
    first: usize,
    positions: &mut StridedMut<'_, 3>,
    normals: Option<NormalTarget<'_, '_>>,
    place: impl Fn([&VertexFrame; 3], &Binding) -> Vec3A,
) -> Result<(), LocalizeError> {
    let Coarse { frames, triangles } = coarse;
    let count = positions.count();
    let (bytes, stride, po, _) = positions.parts_mut();
    let bad = |i: usize| LocalizeError::BadBinding { index: first + i };
    match normals {
        // Record offsets cannot overflow: the constructor checked (count-1)·stride + po + 12
        // against the buffer (and check_interleaved the same for the normal).
        None => {
            for (i, b) in bindings.iter().enumerate() {
                let c = corners(frames, triangles, b).ok_or(bad(i))?;
                put(bytes, po + i * stride, place(c, b));
            }
        }
        Some(NormalTarget::Interleaved { offset: no }) => {
            check_interleaved(bytes.len(), stride, po, no, count)?;
            for (i, b) in bindings.iter().enumerate() {
                let c = corners(frames, triangles, b).ok_or(bad(i))?;
                put(bytes, po + i * stride, place(c, b));
                put(bytes, no + i * stride, normal(c, b));
            }
        }
        Some(NormalTarget::Buffer(nb)) => {
            if nb.count() < count {
                return Err(LocalizeError::BufferTooSmall {
                    needed: count,
                    len: nb.count(),
                });
            }
            let (nbytes, nstride, no, _) = nb.parts_mut();
            let records = bytes.chunks_mut(stride).zip(nbytes.chunks_mut(nstride));
            for (i, ((rec, nrec), b)) in records.zip(bindings).enumerate() {
                let c = corners(frames, triangles, b).ok_or(bad(i))?;
                put(rec, po, place(c, b));
                put(nrec, no, normal(c, b));
            }
        }
    }
    Ok(())
}

/// An interleaved normal at byte `no` of records that hold the position at `po`: inside the
/// record, not overlapping the position, inside the buffer for the last record.
fn check_interleaved(
    len: usize,
    stride: usize,
    po: usize,
    no: usize,
    count: usize,
) -> Result<(), LocalizeError> {
    let disjoint = no.checked_add(12).is_some_and(|e| e <= po) || po + 12 <= no;
    let needed =
        strided::bytes_needed(stride, no, 12, count).map_err(|_| LocalizeError::NormalLayout)?;
    if !disjoint || len < needed {
        return Err(LocalizeError::NormalLayout);
    }
    Ok(())
}

/// Recomputes normals from the fine mesh itself ("exact" normals): per fine vertex the
/// normalized sum of its fine triangles' `(b − a) × (c − a)` (area-weighted, oriented by the
/// triangles' winding; counter-clockwise in (u, v), as [`tiled_mesh`] makes them, gives the
/// same side as the blended normals). A vertex whose triangles are all collapsed keeps the
/// normal it had (or +z). `positions` is `&mut` only so that an interleaved normal can be
/// written next to it; positions are not changed.
pub fn recompute_normals(
    fine_triangles: &[[u32; 3]],
    positions: &mut StridedMut<'_, 3>,
    normals: NormalTarget<'_, '_>,
) -> Result<(), LocalizeError> {
    let n = positions.count();
    check_fine_triangles(fine_triangles, n)?;
    let mut io = match normals {
        NormalTarget::Interleaved { offset } => {
            let (bytes, stride, po, _) = positions.parts_mut();
            check_interleaved(bytes.len(), stride, po, offset, n)?;
            NormalIo::Interleaved {
                pos: positions,
                offset,
            }
        }
        NormalTarget::Buffer(nb) => {
            if nb.count() < n {
                return Err(LocalizeError::BufferTooSmall {
                    needed: n,
                    len: nb.count(),
                });
            }
            NormalIo::Separate {
                pos: positions,
                nrm: nb,
            }
        }
    };
    let face = |io: &NormalIo<'_, '_, '_, '_>, t: &[u32; 3]| -> Option<Vec3A> {
        let [a, b, c] = [
            io.position(t[0] as usize)?,
            io.position(t[1] as usize)?,
            io.position(t[2] as usize)?,
        ];
        let f = (b - a).cross(c - a);
        f.is_finite().then_some(f)
    };
    // Scale for the seed that keeps a collapsed vertex's previous normal (as
    // normals::vertex_normals does for the coarse mesh).
    let largest = fine_triangles
        .iter()
        .filter_map(|t| face(&io, t))
        .fold(0.0f32, |m, f| m.max(f.length()));
    let tau = (1e-6 * largest).max(1e-18);
    for i in 0..n {
        let prev = io.normal(i).unwrap_or(Vec3A::ZERO);
        let l2 = prev.length_squared();
        let seed = if prev.is_finite() && (0.25..4.0).contains(&l2) {
            prev / libm::sqrtf(l2)
        } else {
            Vec3A::Z
        };
        io.set_normal(i, seed * tau);
    }
    for t in fine_triangles {
        let Some(f) = face(&io, t) else { continue };
        for &v in t {
            if let Some(m) = io.normal(v as usize) {
                io.set_normal(v as usize, m + f);
            }
        }
    }
    for i in 0..n {
        let m = io.normal(i).unwrap_or(Vec3A::Z);
        io.set_normal(i, m.normalize_or(Vec3A::Z));
    }
    Ok(())
}

/// Positions and normals for [`recompute_normals`], interleaved or separate.
enum NormalIo<'s, 'a, 'n, 'b> {
    Interleaved {
        pos: &'s mut StridedMut<'a, 3>,
        offset: usize,
    },
    Separate {
        pos: &'s mut StridedMut<'a, 3>,
        nrm: &'n mut StridedMut<'b, 3>,
    },
}

impl NormalIo<'_, '_, '_, '_> {
    fn position(&self, i: usize) -> Option<Vec3A> {
        match self {
            NormalIo::Interleaved { pos, .. } | NormalIo::Separate { pos, .. } => {
                pos.get(i).map(Vec3A::from)
            }
        }
    }
    fn normal(&self, i: usize) -> Option<Vec3A> {
        match self {
            NormalIo::Interleaved { pos, offset } => pos.read_at::<3>(i, *offset),
            NormalIo::Separate { nrm, .. } => nrm.get(i),
        }
        .map(Vec3A::from)
    }
    fn set_normal(&mut self, i: usize, v: Vec3A) {
        match self {
            NormalIo::Interleaved { pos, offset } => pos.write_at::<3>(i, *offset, v.to_array()),
            NormalIo::Separate { nrm, .. } => nrm.set(i, v.to_array()),
        };
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn polar_strain_of_a_stretch_and_rotation() {
        let r = [Vec3A::ZERO, Vec3A::X, Vec3A::Y];
        let rot = glam::Mat3A::from_rotation_z(0.7) * glam::Mat3A::from_rotation_x(1.1);
        let x = r.map(|p| rot * Vec3A::new(p.x * 1.1, p.y * 0.95, 0.0) + Vec3A::ONE);
        let t = triangle_frame(r, x, StrainMeasure::Corotated).unwrap();
        assert!((t.strain - Vec3A::new(0.1, -0.05, 0.0)).length() < 1e-6);
        assert!((t.f1 - rot * Vec3A::X).length() < 1e-6);
        assert!((t.f2 - rot * Vec3A::Y).length() < 1e-6);
        let g = triangle_frame(r, x, StrainMeasure::Green).unwrap();
        let green = Vec3A::new(0.5 * (1.21 - 1.0), 0.5 * (0.9025 - 1.0), 0.0);
        assert!((g.strain - green).length() < 1e-6);
        assert!((g.f1 - rot * Vec3A::X * 1.1).length() < 1e-6);
        // shear: U symmetric, R = F U⁻¹ orthonormal
        let x = r.map(|p| rot * Vec3A::new(p.x + 0.3 * p.y, p.y, 0.0));
        let t = triangle_frame(r, x, StrainMeasure::Corotated).unwrap();
        assert!((t.f1.length() - 1.0).abs() < 1e-6 && (t.f2.length() - 1.0).abs() < 1e-6);
        assert!(t.f1.dot(t.f2).abs() < 1e-6);
        // clockwise (u, v) winding gives the same frame
        let rc = [r[0], r[2], r[1]];
        let xc = [x[0], x[2], x[1]];
        let c = triangle_frame(rc, xc, StrainMeasure::Corotated).unwrap();
        assert!((c.f1 - t.f1).length() < 1e-6 && (c.strain - t.strain).length() < 1e-6);
        assert!((c.normal - t.normal).length() < 1e-6);
        // collapsed
        let flat = [Vec3A::ZERO, Vec3A::X, Vec3A::X * 2.0];
        assert!(triangle_frame(r, flat, StrainMeasure::Corotated).is_none());
    }

    #[test]
    fn interleaved_normal_layout() {
        assert!(check_interleaved(64, 32, 0, 12, 2).is_ok());
        assert!(check_interleaved(64, 32, 12, 0, 2).is_ok());
        assert!(check_interleaved(64, 32, 0, 8, 2).is_err()); // overlaps
        assert!(check_interleaved(64, 32, 0, 24, 2).is_err()); // leaves the record
        assert!(check_interleaved(55, 32, 0, 12, 2).is_err()); // last normal past the end
        assert!(check_interleaved(56, 32, 0, 12, 2).is_ok());
    }
}
