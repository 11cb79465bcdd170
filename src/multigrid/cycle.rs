//! Every solve: the Galerkin operators of the levels with the filter folded in, and the
//! cycle that preconditions CG (see the module docs of [`super`]).

use super::*;
use crate::sparse::Scalars;
use glam::{Vec3Swizzles, Vec4Swizzles};

// ----- small block helpers -----

/// Symmetric 3×3 block as its upper triangle row by row, `[xx, xy, xz, yy, yz, zz]`: each
/// column is three of four consecutive floats ([`sym_mul`]).
type Sym = [f32; 6];

/// Four consecutive floats of `d` from `at`, in one unaligned load.
#[inline(always)]
fn quad(d: &[f32], at: usize) -> Option<glam::Vec4> {
    let q = d.get(at..at.checked_add(4)?)?;
    <[f32; 4]>::try_from(q).ok().map(glam::Vec4::from)
}

#[inline(always)]
pub(super) fn sym_mul(d: &[f32], v: Vec3A) -> Vec3A {
    // `[xx, xy, xz, yy, yz, zz]`: the columns `(xx, xy, xz)`, `(xy, yy, yz)`, `(xz, yz, zz)` are
    // lanes 0 1 2 of the loads from 0, 1 (lanes 0 2 3) and 2 (lanes 0 2 3): three loads and
    // two shuffles instead of six scalar loads and their inserts.
    let (Some(a), Some(b), Some(c), 6) = (quad(d, 0), quad(d, 1), quad(d, 2), d.len()) else {
        return Vec3A::NAN;
    };
    let (c0, c1, c2) = (
        Vec3A::from_vec4(a),
        Vec3A::from_vec4(b.xzww()),
        Vec3A::from_vec4(c.xzww()),
    );
    // Column by column, in SIMD lanes: lane k sums `d_k0 v.x + d_k1 v.y + d_k2 v.z` in the
    // same order as three scalar rows would, so the result is the same bits.
    c0 * v.xxx() + c1 * v.yyy() + c2 * v.zzz()
}

/// `d += s · sym(m)` (`sym(m) = (m + mᵀ)/2`).
#[inline(always)]
fn sym_add(d: &mut [f32], m: &Mat3A, s: f32) {
    let h = 0.5 * s;
    let add = [
        s * m.x_axis.x,
        h * (m.y_axis.x + m.x_axis.y),
        h * (m.z_axis.x + m.x_axis.z),
        s * m.y_axis.y,
        h * (m.z_axis.y + m.y_axis.z),
        s * m.z_axis.z,
    ];
    for (a, b) in d.iter_mut().zip(add) {
        *a += b;
    }
}

#[inline(always)]
pub(super) fn sym_to_mat(d: &[f32]) -> Mat3A {
    let &[xx, xy, xz, yy, yz, zz] = d else {
        return Mat3A::NAN;
    };
    Mat3A::from_cols(
        Vec3A::new(xx, xy, xz),
        Vec3A::new(xy, yy, yz),
        Vec3A::new(xz, yz, zz),
    )
}

/// The couplings of one row of a compact level, from its window `[start, end]` of the row
/// starts: `(j, A_ij)` for each stored upper block.
fn compact_row<'b>(
    w: &[u32],
    cols: &'b [u32],
    off: &'b [Mat3A],
) -> Result<impl Iterator<Item = (usize, Mat3A)> + 'b, MgError> {
    let (rc, ro) = crate::sparse::row_of(w, cols, off).map_err(|_| MgError::Internal)?;
    Ok(rc.iter().zip(ro).map(|(&j, &o)| (j as usize, o)))
}

/// A level's coupling blocks, which start on a `Mat3A` boundary of the aligned pool
/// ([`aligned`], [`Level::floats`]).
fn couplings(off: &[f32]) -> Result<&[Mat3A], MgError> {
    bytemuck::try_cast_slice(off).map_err(|_| MgError::Internal)
}

/// [`couplings`], to write.
fn couplings_mut(off: &mut [f32]) -> Result<&mut [Mat3A], MgError> {
    bytemuck::try_cast_slice_mut(off).map_err(|_| MgError::Internal)
}

/// The finest level's free-vertex flags in `blocks` (after its `n` inverses and lumped
/// weights, [`FINE_FLOATS`]): `1` where the filter block is the identity (every vertex after a
/// setup without a filter).
fn free_flags(blocks: &[f32], n: usize) -> Result<&[u32], MgError> {
    Ok(bytemuck::cast_slice(part(blocks, 7 * n, n)?))
}

/// A vertex's free-vertex flag from its filter block `s`: `1` where `s` is the identity.
fn free_flag(s: &Mat3A) -> u32 {
    u32::from(*s == Mat3A::IDENTITY)
}

/// [`free_flags`], to write.
fn free_flags_mut(blocks: &mut [f32], n: usize) -> Result<&mut [u32], MgError> {
    Ok(bytemuck::cast_slice_mut(part_mut(blocks, 7 * n, n)?))
}

/// The filter with its free vertices flagged: `S_i v` is `v` itself where `S_i = I` (most
/// vertices), without the 3×3 product, which costs every pass of the cycle's finest level.
/// The product `I v` is `v` too (but for the sign of a zero component), so the cycle is the
/// same.
struct Flagged<'f> {
    blocks: &'f [Mat3A],
    free: &'f [u32],
}

impl Filter for Flagged<'_> {
    #[inline(always)]
    fn at(&self, i: usize, v: Vec3A) -> Vec3A {
        if self.free.get(i).is_some_and(|&f| f != 0) {
            return v;
        }
        self.blocks.get(i).map_or(v, |s| *s * v)
    }
}

/// `blocks` from its first `Mat3A` boundary on (the caller's pool need only be `f32`-aligned;
/// [`blocks_len`] counts the floats this may skip).
fn aligned(blocks: &mut [f32]) -> &mut [f32] {
    let skip = blocks.as_ptr().align_offset(core::mem::align_of::<Mat3A>());
    let len = blocks.len();
    blocks.get_mut(skip.min(len)..).unwrap_or_default()
}

/// The upper cofactors `[c00, c01, c02, c11, c12, c22]` and the determinant of the symmetric
/// block with diagonal `[xx, yy, zz]` and off-diagonal `[xy, xz, yz]`: of one block in `f64`
/// ([`inverse_sym`]) or of four in lanes ([`inverse_sym4`]), the same operations in the same
/// order either way.
#[inline(always)]
fn cofactors<T>([xx, yy, zz]: [T; 3], [xy, xz, yz]: [T; 3]) -> ([T; 6], T)
where
    T: Copy + core::ops::Add<Output = T> + core::ops::Sub<Output = T> + core::ops::Mul<Output = T>,
{
    let c00 = yy * zz - yz * yz;
    let c01 = xz * yz - xy * zz;
    let c02 = xy * yz - xz * yy;
    let c11 = xx * zz - xz * xz;
    let c12 = xy * xz - xx * yz;
    let c22 = xx * yy - xy * xy;
    let det = xx * c00 + xy * c01 + xz * c02;
    ([c00, c01, c02, c11, c12, c22], det)
}

/// Inverse of a symmetric positive semidefinite block (from its symmetric part), in `f64`,
/// with a relative ridge ([`RIDGE`]): exactly symmetric, SPD, finite. A zero or non-finite
/// block (a fully constrained or broken direction) gives the zero block (decoupled); one that
/// is not positive even with the ridge falls back to the inverse of its positive diagonal.
pub(super) fn inverse_sym(m: &Mat3A) -> Sym {
    let [m00, m10, m20, m01, m11, m21, m02, m12, m22] = m.to_cols_array().map(f64::from);
    let (xy, xz, yz) = (0.5 * (m01 + m10), 0.5 * (m02 + m20), 0.5 * (m12 + m21));
    let scale = m00.max(m11).max(m22);
    if !(m.is_finite() && scale > 0.0 && scale.is_finite()) {
        return [0.0; 6];
    }
    let r = RIDGE * scale;
    let (xx, yy, zz) = (m00 + r, m11 + r, m22 + r);
    let ([c00, c01, c02, c11, c12, c22], det) = cofactors([xx, yy, zz], [xy, xz, yz]);
    if det > 0.0 && c22 > 0.0 && xx > 0.0 && det.is_finite() {
        let k = 1.0 / det;
        let e = [c00, c01, c02, c11, c12, c22].map(|v| (v * k) as f32);
        if e.iter().all(|v| v.is_finite()) {
            return e;
        }
    }
    let inv = |d: f64| if d > 0.0 { (1.0 / d) as f32 } else { 0.0 };
    [inv(xx), 0.0, 0.0, inv(yy), 0.0, inv(zz)]
}

/// [`inverse_sym`] of four blocks at once, in `f64` lanes, with the same operations in the
/// same order (so the same bits); a block that takes one of its fallbacks (not finite, not
/// positive) is made by it alone. The setup inverts every vertex's block at every solve, and
/// one at a time the `f64` division and the tests between them left the processor idle.
#[inline(always)]
fn inverse_sym4(m: &[Mat3A; 4]) -> [Sym; 4] {
    use glam::DVec4;
    let [b0, b1, b2, b3] = m;
    let lanes =
        |e: fn(&Mat3A) -> f32| DVec4::new(e(b0).into(), e(b1).into(), e(b2).into(), e(b3).into());
    let (m00, m11, m22) = (
        lanes(|b| b.x_axis.x),
        lanes(|b| b.y_axis.y),
        lanes(|b| b.z_axis.z),
    );
    let xy = (lanes(|b| b.y_axis.x) + lanes(|b| b.x_axis.y)) * 0.5;
    let xz = (lanes(|b| b.z_axis.x) + lanes(|b| b.x_axis.z)) * 0.5;
    let yz = (lanes(|b| b.z_axis.y) + lanes(|b| b.y_axis.z)) * 0.5;
    let scale = m00.max(m11).max(m22);
    let r = scale * RIDGE;
    let (xx, yy, zz) = (m00 + r, m11 + r, m22 + r);
    let ([c00, c01, c02, c11, c12, c22], det) = cofactors([xx, yy, zz], [xy, xz, yz]);
    let k = DVec4::ONE / det;
    let f32s = |c: DVec4| (c * k).as_vec4().to_array();
    let e = [
        f32s(c00),
        f32s(c01),
        f32s(c02),
        f32s(c11),
        f32s(c12),
        f32s(c22),
    ];
    let good = (scale.cmpgt(DVec4::ZERO) & det.cmpgt(DVec4::ZERO))
        & (c22.cmpgt(DVec4::ZERO) & xx.cmpgt(DVec4::ZERO))
        & (scale.is_finite_mask() & det.is_finite_mask());
    let mut out = [[0.0; 6]; 4];
    for (lane, (o, b)) in out.iter_mut().zip(m).enumerate() {
        let mut inv = [0.0f32; 6];
        for (v, c) in inv.iter_mut().zip(&e) {
            *v = c.get(lane).copied().unwrap_or(f32::NAN);
        }
        let fine = good.test(lane) && b.is_finite() && inv.iter().all(|v| v.is_finite());
        *o = if fine { inv } else { inverse_sym(b) };
    }
    out
}

crate::cpu::multiversion! {
    /// The finest level's smoother blocks `D̂_i⁻¹` ([`fine_block`], [`inverse_sym`]) of every
    /// vertex into the first `6 n` floats of `blocks`, four at a time ([`inverse_sym4`]), in
    /// the AVX2 build where the processor has it ([`crate::cpu`]; bit-identical).
    fn invert_fine, invert_fine_avx2 => invert_fine_body(
        blocks: &mut [f32],
        diag: &[Mat3A],
        filter: Option<&[Mat3A]>,
        lumped: bool,
    ) -> Result<(), MgError>
}

#[inline(always)]
fn invert_fine_body(
    blocks: &mut [f32],
    diag: &[Mat3A],
    filter: Option<&[Mat3A]>,
    lumped: bool,
) -> Result<(), MgError> {
    let n = diag.len();
    let block = |blocks: &[f32], i: usize| {
        let d = diag.get(i).ok_or(MgError::LengthMismatch)?;
        fine_block(blocks, n, filter, lumped, i, d)
    };
    let quads = n / 4;
    for q in 0..quads {
        let i = 4 * q;
        let m = [
            block(blocks, i)?,
            block(blocks, i + 1)?,
            block(blocks, i + 2)?,
            block(blocks, i + 3)?,
        ];
        let out = part_mut(blocks, 6 * i, 24)?;
        for (o, s) in out.chunks_exact_mut(6).zip(inverse_sym4(&m)) {
            o.copy_from_slice(&s);
        }
    }
    for i in 4 * quads..n {
        let inv = inverse_sym(&block(blocks, i)?);
        part_mut(blocks, 6 * i, 6)?.copy_from_slice(&inv);
    }
    Ok(())
}

crate::cpu::multiversion! {
    /// A compact level's block inverses ([`inverse_sym`]) of its diagonal blocks `diag` (6
    /// floats each) into `inv`, four at a time ([`inverse_sym4`]), in the AVX2 build where the
    /// processor has it ([`crate::cpu`]; bit-identical).
    fn invert_coarse, invert_coarse_avx2 => invert_coarse_body(diag: &[f32], inv: &mut [f32]) -> ()
}

#[inline(always)]
fn invert_coarse_body(diag: &[f32], inv: &mut [f32]) {
    let mut quads_in = diag.chunks_exact(24);
    let mut quads_out = inv.chunks_exact_mut(24);
    for (d, v) in (&mut quads_in).zip(&mut quads_out) {
        let mut m = [Mat3A::ZERO; 4];
        for (mk, dk) in m.iter_mut().zip(d.chunks_exact(6)) {
            *mk = sym_to_mat(dk);
        }
        for (o, s) in v.chunks_exact_mut(6).zip(inverse_sym4(&m)) {
            o.copy_from_slice(&s);
        }
    }
    let rest = quads_in.remainder().chunks_exact(6);
    for (d, v) in rest.zip(quads_out.into_remainder().chunks_exact_mut(6)) {
        v.copy_from_slice(&inverse_sym(&sym_to_mat(d)));
    }
}

crate::cpu::multiversion! {
    /// `y = A x` on a compact level: `diag` (6 per vertex), pattern `rs`/`cols`, `off` (a
    /// block per coupling). The AVX2 build where the processor has it ([`crate::cpu`];
    /// bit-identical).
    fn coarse_mul, coarse_mul_avx2 => coarse_mul_body(
        diag: &[f32],
        rs: &[u32],
        cols: &[u32],
        off: &[Mat3A],
        x: &[Vec3A],
        y: &mut [Vec3A],
    ) -> Result<(), MgError>
}

#[inline(always)]
fn coarse_mul_body(
    diag: &[f32],
    rs: &[u32],
    cols: &[u32],
    off: &[Mat3A],
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), MgError> {
    for ((yi, d), &xi) in y.iter_mut().zip(diag.chunks_exact(6)).zip(x) {
        *yi = sym_mul(d, xi);
    }
    // Rows from first to last, each split off the front of the rows after it (one row end
    // and one comparison per row), each row the fine product's (`sparse::block_row`).
    let (mut cols, mut off) = (cols, off);
    let mut start = 0usize;
    for (i, (&end, xi)) in rs.get(1..).unwrap_or(&[]).iter().zip(x).enumerate() {
        let len = (end as usize).checked_sub(start).ok_or(MgError::Internal)?;
        start = end as usize;
        let ((rc, c), (ro, o)) = cols
            .split_at_checked(len)
            .zip(off.split_at_checked(len))
            .ok_or(MgError::Internal)?;
        (cols, off) = (c, o);
        let acc = crate::sparse::block_row(Vec3A::ZERO, rc, ro, xi, x, y)
            .map_err(|_| MgError::Internal)?;
        if let Some(yi) = y.get_mut(i) {
            *yi += acc;
        }
    }
    Ok(())
}

/// Packed lower-triangular index of `(r, c)`, `r >= c`.
#[inline(always)]
pub(crate) fn tri(r: usize, c: usize) -> usize {
    r * (r + 1) / 2 + c
}

/// Cholesky `A = L Lᵀ` in `f64`, in place, of the symmetric `m × m` matrix held as its packed
/// lower triangle (entry `(r, c)`, `c ≤ r`, at [`tri`]`(r, c)`): the coarsest level's, and
/// the six rigid modes' of `step::system`. A pivot not above [`PIVOT`] times the largest
/// diagonal entry (or not finite) marks a direction `A` does not see: its column of `L` is
/// zero, and [`solve_packed`] gives it zero output. `None` if `dense` is too short.
pub(crate) fn factor_packed(dense: &mut [f64], m: usize) -> Option<()> {
    let mut scale = 0.0f64;
    for k in 0..m {
        scale = scale.max(dense.get(tri(k, k)).copied().unwrap_or(0.0));
    }
    for j in 0..m {
        let row_j = tri(j, 0);
        let mut d = dense.get(row_j + j).copied()?;
        for k in 0..j {
            let l = dense.get(row_j + k).copied()?;
            d -= l * l;
        }
        let ok = d > PIVOT * scale && d.is_finite();
        let ljj = if ok { libm::sqrt(d) } else { 0.0 };
        *dense.get_mut(row_j + j)? = ljj;
        for i in j + 1..m {
            let row_i = tri(i, 0);
            let v = if ok {
                let mut s = dense.get(row_i + j).copied()?;
                for k in 0..j {
                    let (a, b) = (
                        dense.get(row_i + k).copied()?,
                        dense.get(row_j + k).copied()?,
                    );
                    s -= a * b;
                }
                s / ljj
            } else {
                0.0 // decoupled direction: zero column
            };
            *dense.get_mut(row_i + j)? = v;
        }
    }
    Some(())
}

/// `y = A⁻¹ y` from the factor of [`factor_packed`] (`m = y.len()`); a decoupled direction
/// gets zero. `None` if `dense` is too short.
pub(crate) fn solve_packed(dense: &[f64], y: &mut [f64]) -> Option<()> {
    let m = y.len();
    // L y' = y
    for i in 0..m {
        let row = tri(i, 0);
        let lii = dense.get(row + i).copied()?;
        let mut s = y.get(i).copied()?;
        for k in 0..i {
            s -= dense.get(row + k).copied()? * y.get(k).copied()?;
        }
        *y.get_mut(i)? = if lii > 0.0 { s / lii } else { 0.0 };
    }
    // Lᵀ x = y'
    for i in (0..m).rev() {
        let lii = dense.get(tri(i, i)).copied()?;
        let mut s = y.get(i).copied()?;
        for k in i + 1..m {
            s -= dense.get(tri(k, i)).copied()? * y.get(k).copied()?;
        }
        *y.get_mut(i)? = if lii > 0.0 { s / lii } else { 0.0 };
    }
    Some(())
}

/// The multilevel preconditioner for one solve: the hierarchy of [`build`] with the coarse
/// operators of the current matrix and filter. Implements [`Preconditioner`] for
/// [`crate::pcg::solve_with`].
pub struct Multigrid<'a> {
    agg0: &'a [u32],
    /// Where each finest-level coupling lands in level 1's operator (see [`index_len`]).
    map0: &'a [u32],
    index: &'a [u32],
    blocks: &'a mut [f32],
    dense: &'a mut [f64],
    vectors: &'a mut [Vec3A],
    a: BlockMatrix<'a>,
    filter: Option<&'a [Mat3A]>,
    levels: [Level; MAX_LEVELS],
    count: usize,
    is_dense: bool,
    options: Options,
    /// The finest level smooths with its scalar couplings lumped (set up by every setup).
    is_lumped: bool,
    /// The finest level's lines ([`Smoother::Lines`]; set up by every setup).
    lines: usize,
}

impl<'a> Multigrid<'a> {
    /// Recomputes the hierarchy's operators for the matrix `a` (the same pattern as at
    /// [`build`]) and the PCG's constraint filter (`None`: unconstrained): the finest level's
    /// block inverses into `fine_inverse` (`n` blocks, overwritten; e.g. the caller's
    /// block-Jacobi array), the Galerkin coarse operators, their block inverses and the
    /// coarsest Cholesky factor into `mem`. Costs about two passes over `a`'s blocks.
    pub fn new(
        mem: Memory<'a>,
        a: BlockMatrix<'a>,
        filter: Option<&'a [Mat3A]>,
        options: Options,
    ) -> Result<Multigrid<'a>, MgError> {
        Self::new_probed(mem, a, filter, options, None)
    }

    /// [`Multigrid::new`] whose line smoother ([`Smoother::Lines`]) is checked for
    /// positivity with `probe` ([`Probe`]): one power step of the smoother per setup, whose
    /// growth estimates `λ_max(N Ã)`; where it reaches 1.9 (`LINE_LIMIT`) the level is
    /// smoothed by block Jacobi instead, this setup and the re-setups of [`Multigrid::renew`]
    /// after it.
    pub fn new_probed(
        mem: Memory<'a>,
        a: BlockMatrix<'a>,
        filter: Option<&'a [Mat3A]>,
        options: Options,
        probe: Option<Probe<'_>>,
    ) -> Result<Multigrid<'a>, MgError> {
        let mut mg = Self::prepare(mem, a, filter, options)?;
        mg.setup_fine(probe)?;
        mg.setup_levels()?;
        Ok(mg)
    }

    /// [`Multigrid::new`] for a filter that differs from the previous solve's only at the
    /// vertices `changed` (e.g. contacts let go): `mem` must hold the operators that
    /// [`Multigrid::new`] (or this) made for the same matrix `a` and that previous filter.
    /// Only what the changed vertices touch is recomputed on the finest level (their block
    /// inverses and the level-1 Galerkin blocks of their aggregates, summed in the same order
    /// as `new` sums them); the coarse levels are set up as by `new`. The operators are
    /// bit-identical to `new`'s. A `changed` vertex out of range is [`MgError::LengthMismatch`].
    pub fn renew(
        mem: Memory<'a>,
        a: BlockMatrix<'a>,
        filter: Option<&'a [Mat3A]>,
        changed: &[u32],
        options: Options,
    ) -> Result<Multigrid<'a>, MgError> {
        let mut mg = Self::prepare(mem, a, filter, options)?;
        mg.setup(Some(changed))?;
        Ok(mg)
    }

    /// The checks of [`Multigrid::new`], without the setup.
    fn prepare(
        mem: Memory<'a>,
        a: BlockMatrix<'a>,
        filter: Option<&'a [Mat3A]>,
        options: Options,
    ) -> Result<Multigrid<'a>, MgError> {
        let Memory {
            agg,
            index,
            blocks,
            dense,
            vectors,
        } = mem;
        let h = read_header(index).ok_or(MgError::NotBuilt)?;
        let blocks = aligned(blocks);
        let l0 = h.levels.first().ok_or(MgError::Internal)?;
        let n = a.diag.len();
        if l0.n != n || a.pattern.n() != n || a.pattern.nnz() != l0.nnz {
            return Err(MgError::NotBuilt);
        }
        // The scalar couplings must be those the hierarchy was built with (their coarse
        // couplings are in its patterns); their values are checked as they are read.
        if !a.scalars.is_empty() && a.scalars.pattern.n() != n {
            return Err(MgError::NotBuilt);
        }
        if a.off.len() < l0.nnz
            || a.pattern.cols.len() < l0.nnz
            || blocks.len() < fine_floats(n)
            || dense.len() < if h.dense { DENSE_LEN } else { 0 }
            || filter.is_some_and(|f| f.len() != n)
        {
            return Err(MgError::LengthMismatch);
        }
        // Every offset must lie inside the pools (they are the caller's: check once here).
        for lv in h.levels.iter().take(h.count).skip(1) {
            part(index, lv.rs, lv.n + 1)?;
            part(index, lv.cols, lv.nnz)?;
            part(blocks, lv.blk, lv.floats())?;
            part(vectors, lv.vec, VECTORS_PER_LEVEL * lv.n)?;
        }
        for lv in h.levels.iter().take(h.count.saturating_sub(1)).skip(1) {
            part(index, lv.agg, lv.n)?;
        }
        if !a.scalars.is_empty() && a.scalars.pattern.nnz() != h.scalars {
            return Err(MgError::NotBuilt);
        }
        let map0 = if h.count > 1 {
            part(index, HEADER, l0.nnz + h.scalars)?
        } else {
            &[]
        };
        let agg0 = agg.get(..n).ok_or(MgError::LengthMismatch)?;
        let mut mg = Multigrid {
            agg0,
            map0,
            index,
            blocks: &mut *blocks,
            dense: &mut *dense,
            vectors: &mut *vectors,
            a,
            filter,
            levels: h.levels,
            count: h.count,
            is_dense: h.dense,
            options,
            is_lumped: false,
            lines: 0,
        };
        mg.options.sweeps = mg.options.sweeps.max(1);
        mg.options.coarse_sweeps = mg.options.coarse_sweeps.max(1);
        mg.options.cycle = mg.options.cycle.clamp(1, 4);
        Ok(mg)
    }

    /// The shape of the hierarchy.
    pub fn info(&self) -> Info {
        info_of(&self.levels, self.count, self.is_dense)
    }

    fn level(&self, l: usize) -> Result<Level, MgError> {
        self.levels.get(l).copied().ok_or(MgError::Internal)
    }

    /// Every level's operators; with `changed`, the finest level's only where those vertices'
    /// filters changed since the last setup ([`Multigrid::renew`]).
    fn setup(&mut self, changed: Option<&[u32]>) -> Result<(), MgError> {
        match changed {
            None => self.setup_fine(None)?,
            Some(changed) => self.setup_changed(changed)?,
        }
        self.setup_levels()
    }

    /// The coarse levels' operators and the coarsest factor (after the finest level's).
    fn setup_levels(&mut self) -> Result<(), MgError> {
        for l in 1..self.count {
            self.setup_coarse(l)?;
        }
        if self.is_dense {
            self.factor_coarsest()?;
        }
        Ok(())
    }

    /// Whether the options ask for the finest level's scalar couplings lumped, and there are
    /// some ([`Options::lumped`]; whether they are weak enough is [`Self::lumped`]).
    fn lumping(&self) -> bool {
        self.options.lumped
            && self.options.smoother != Smoother::GaussSeidel
            && !self.a.scalars.is_empty()
    }

    /// Whether the finest level needs its scalar couplings' weights `w_i = Σ_j |s_ij|` (in
    /// `blocks`): to lump them ([`Self::lumping`]), or for the lines, whose `T` always holds
    /// them on its diagonal ([`Smoother::Lines`]).
    fn weighing(&self) -> bool {
        self.lumping() || (self.options.smoother == Smoother::Lines && !self.a.scalars.is_empty())
    }

    /// Whether the finest level smooths with its scalar couplings lumped: asked for
    /// ([`Self::lumping`]) and every vertex's weight `w_i` (in `blocks`) at most
    /// [`LUMP_LIMIT`] of its diagonal block's mean entry.
    fn lumped(&self) -> bool {
        let n = self.a.diag.len();
        self.lumping()
            && part(self.blocks, 6 * n, n).is_ok_and(|w| {
                w.iter().zip(self.a.diag).all(|(&w, d)| {
                    let scale = (d.x_axis.x + d.y_axis.y + d.z_axis.z) / 3.0;
                    w <= LUMP_LIMIT * scale
                })
            })
    }

    /// The finest level's smoother block of vertex `i` (diagonal block `d`): the inverse of
    /// `A_ii`, plus its lumped scalar couplings when [`Self::lumped`] (their weights already in
    /// `blocks`), filtered.
    fn fine_inverse(&self, i: usize, d: &Mat3A) -> Result<Sym, MgError> {
        let n = self.a.diag.len();
        Ok(inverse_sym(&fine_block(
            self.blocks,
            n,
            self.filter,
            self.is_lumped,
            i,
            d,
        )?))
    }

    /// The finest level's lines ([`Smoother::Lines`]): made from the matrix (`lines::build`),
    /// or, with `changed`, those of the changed vertices factored again (the lines of the last
    /// full setup); `Sₖ⁻¹` in the inverses' place. Returns whether there are lines: where no
    /// vertex is linked the level is smoothed by block Jacobi (`self.lines` is 0), and its
    /// inverses are for the caller to make.
    fn setup_lines(&mut self, changed: Option<&[u32]>) -> Result<bool, MgError> {
        let a = self.a;
        let n = a.diag.len();
        let layout = lines::Layout::new(n);
        let count = match changed {
            None => lines::build(&a, self.blocks, &layout)?,
            Some(changed) => {
                let count = lines::count(self.blocks, &layout)?;
                if count < n {
                    lines::mark(self.blocks, &layout, changed)?;
                }
                count
            }
        };
        self.lines = if count < n { count } else { 0 };
        if self.lines == 0 {
            return Ok(false);
        }
        let filter = self.filter;
        let weighed = !a.scalars.is_empty();
        let diagonal = |blocks: &[f32], i: usize| {
            let d = a.diag.get(i).ok_or(MgError::LengthMismatch)?;
            fine_block(blocks, n, filter, weighed, i, d)
        };
        let single = self.options.omega / LINE_OMEGA;
        let only = changed.is_some();
        lines::factor(
            a.off,
            filter,
            diagonal,
            self.blocks,
            &layout,
            self.lines,
            single,
            only,
        )?;
        Ok(true)
    }

    /// One power step of the line smoother `N Ã` (`N`: the line solve and its damping, block
    /// Jacobi's at lone vertices; `Ã` the smoothing operator, filtered) on the probe's `x`,
    /// and whether the growth it measured stays below [`LINE_LIMIT`]. The cycle is positive
    /// while `λ_max(N Ã) < 2` (the smoother then converges in `Ã`'s norm); the line part `T`
    /// need not dominate what it leaves out, and where it does not the CG breaks down (on six
    /// sets of adversarial scenes 178 of 360 did, ~95,000 times, each solve then retried with
    /// block-Jacobi smoothing; in scene 12001 `λ_max` was 35, on weft-bench's scene 1.7). `x`
    /// is kept `N Ã x_prev / ‖x_prev‖_Ã`, so `√(xᵀ Ã x)` estimates `λ_max` as the power method
    /// does, one step per setup: a lower bound that rises towards it over a few setups while
    /// the matrix changes slowly. A probe with nothing to go on (the first setup, a zero or
    /// non-finite iterate) starts from a fixed pattern and decides nothing.
    fn lines_positive(&mut self, probe: Probe<'_>) -> Result<bool, MgError> {
        let a = self.a;
        let n = a.diag.len();
        let (Some(x), Some(t)) = (probe.x.get_mut(..n), probe.t.get_mut(..n)) else {
            return Err(MgError::LengthMismatch);
        };
        let filter = self.filter;
        let (op, w) = smoothing_operator(a, self.blocks, self.is_lumped)?;
        let s = |i: usize, v: Vec3A| held(filter, i).map_or(v, |si| si * v);
        let growth = |x: &[Vec3A], t: &mut [Vec3A]| -> Result<f64, MgError> {
            op.mul(x, t).map_err(|_| MgError::LengthMismatch)?;
            for (i, (ti, &xi)) in t.iter_mut().zip(x).enumerate() {
                *ti = s(i, weighted(*ti, w, i, xi));
            }
            Ok(dot(x, t))
        };
        let mut norm = growth(x, t)?;
        let decided = norm > 0.0 && norm.is_finite();
        if !decided {
            for (i, xi) in x.iter_mut().enumerate() {
                // a fixed pattern of every frequency (Knuth's multiplicative hash)
                let h = (i as u32).wrapping_mul(2_654_435_761);
                let g = |k: u32| (h.rotate_left(k) & 1023) as f32 / 512.0 - 1.0;
                *xi = s(i, Vec3A::new(g(0), g(10), g(20)));
            }
            norm = growth(x, t)?;
            if !(norm > 0.0 && norm.is_finite()) {
                return Ok(true);
            }
        }
        let scale = (1.0 / libm::sqrt(norm)) as f32;
        let layout = lines::Layout::new(n);
        lines::solve(
            self.blocks,
            &layout,
            self.lines,
            t,
            x,
            LINE_OMEGA * scale,
            false,
        )?;
        for (i, xi) in x.iter_mut().enumerate() {
            *xi = s(i, *xi);
        }
        Ok(!decided || libm::sqrt(norm) < f64::from(LINE_LIMIT))
    }

    /// Finest level: `D̂_i⁻¹` for the smoother (after the lumped weights, if any), which
    /// vertices are free, and the Galerkin operator of level 1.
    fn setup_fine(&mut self, probe: Option<Probe<'_>>) -> Result<(), MgError> {
        let a = self.a;
        let n = a.diag.len();
        if self.weighing() {
            lump(&a.scalars, part_mut(self.blocks, 6 * n, n)?)?;
        }
        self.is_lumped = self.lumped();
        let mut lined = self.options.smoother == Smoother::Lines && self.setup_lines(None)?;
        if lined && probe.is_some_and(|p| !self.lines_positive(p).unwrap_or(true)) {
            lines::forget(self.blocks, &lines::Layout::new(n))?;
            self.lines = 0;
            lined = false;
        }
        if !lined {
            invert_fine(self.blocks, a.diag, self.filter, self.is_lumped)?;
        }
        // (all free without a filter: a later `renew` with one changes only its vertices)
        let free = free_flags_mut(self.blocks, n)?;
        match self.filter {
            Some(filter) => {
                for (flag, s) in free.iter_mut().zip(filter) {
                    *flag = free_flag(s);
                }
            }
            None => free.fill(1),
        }
        if self.count < 2 {
            return Ok(());
        }
        let l1 = self.level(1)?;
        let ops = part_mut(self.blocks, l1.blk, l1.floats())?;
        let cp = coarse_pattern(self.index, &l1)?;
        galerkin_fine(a, self.filter, self.agg0, self.map0, &cp, ops, None)
    }

    /// [`Self::setup_fine`] after a change of the filter at the vertices `changed` only (see
    /// [`Multigrid::renew`]).
    fn setup_changed(&mut self, changed: &[u32]) -> Result<(), MgError> {
        let a = self.a;
        // the weights are the earlier setup's, of the same matrix
        self.is_lumped = self.lumped();
        let lined = self.options.smoother == Smoother::Lines && self.setup_lines(Some(changed))?;
        if !lined {
            for &v in changed {
                let i = v as usize;
                let inv = self.fine_inverse(i, a.diag.get(i).ok_or(MgError::LengthMismatch)?)?;
                part_mut(self.blocks, 6 * i, 6)?.copy_from_slice(&inv);
            }
        }
        if let Some(filter) = self.filter {
            let n = a.diag.len();
            let free = free_flags_mut(self.blocks, n)?;
            for &v in changed {
                let i = v as usize;
                let s = filter.get(i).ok_or(MgError::LengthMismatch)?;
                *free.get_mut(i).ok_or(MgError::LengthMismatch)? = free_flag(s);
            }
        }
        if self.count < 2 {
            return Ok(());
        }
        let l1 = self.level(1)?;
        // The aggregates the change touches, flagged in level 1's vectors (free until a
        // cycle runs).
        let flags: &mut [u32] =
            bytemuck::cast_slice_mut(part_mut(self.vectors, l1.vec, l1.n.div_ceil(4))?);
        let flags = flags.get_mut(..l1.n).ok_or(MgError::Internal)?;
        flags.fill(0);
        for &v in changed {
            let big = *self.agg0.get(v as usize).ok_or(MgError::LengthMismatch)?;
            *flags.get_mut(big as usize).ok_or(MgError::Internal)? = 1;
        }
        let ops = part_mut(self.blocks, l1.blk, l1.floats())?;
        let cp = coarse_pattern(self.index, &l1)?;
        galerkin_fine(a, self.filter, self.agg0, self.map0, &cp, ops, Some(flags))
    }

    /// Level `l ≥ 1`: its block inverses and the Galerkin operator of level `l + 1`.
    fn setup_coarse(&mut self, l: usize) -> Result<(), MgError> {
        let lv = self.level(l)?;
        let next = if l + 1 < self.count {
            Some(self.level(l + 1)?)
        } else {
            None
        };
        let end = lv.blk + lv.floats();
        let (head, tail) = self.blocks.split_at_mut(end.min(self.blocks.len()));
        let ops = head.get_mut(lv.blk..).ok_or(MgError::Internal)?;
        let (diag, rest) = ops.split_at_mut(6 * lv.n);
        let (inv, off) = rest.split_at_mut(6 * lv.n);
        let off = couplings(off)?;
        invert_coarse(diag, inv);
        let Some(next) = next else {
            return Ok(());
        };
        let agg = part(self.index, lv.agg, lv.n)?;
        let rs = part(self.index, lv.rs, lv.n + 1)?;
        let cols = part(self.index, lv.cols, lv.nnz)?;
        let cp = coarse_pattern(self.index, &next)?;
        let nops = next
            .blk
            .checked_sub(end)
            .and_then(|at| tail.get_mut(at..))
            .and_then(|t| t.get_mut(..next.floats()))
            .ok_or(MgError::Internal)?;
        nops.fill(0.0);
        let (cdiag, rest) = nops.split_at_mut(6 * next.n);
        let coff = couplings_mut(rest.get_mut(6 * next.n..).ok_or(MgError::Internal)?)?;
        for (d, &big_i) in diag.chunks_exact(6).zip(agg) {
            for (c, &v) in part_mut(cdiag, 6 * big_i as usize, 6)?.iter_mut().zip(d) {
                *c += v;
            }
        }
        for (w, &big_i) in rs.windows(2).zip(agg) {
            for (j, blk) in compact_row(w, cols, off)? {
                let big_j = *agg.get(j).ok_or(MgError::Internal)?;
                accumulate(cdiag, coff, &cp, big_i as usize, big_j as usize, &blk)?;
            }
        }
        Ok(())
    }

    /// Dense `f64` Cholesky of the coarsest level, packed lower triangle, in place.
    fn factor_coarsest(&mut self) -> Result<(), MgError> {
        let lv = self.level(self.count - 1)?;
        let m = 3 * lv.n;
        if lv.n > MAX_DENSE {
            return Err(MgError::Internal);
        }
        let dense = self.dense.get_mut(..tri(m, 0)).ok_or(MgError::Internal)?;
        dense.fill(0.0);
        let ops = part(self.blocks, lv.blk, lv.floats())?;
        let (diag, rest) = ops.split_at(6 * lv.n);
        let off = couplings(rest.get(6 * lv.n..).ok_or(MgError::Internal)?)?;
        let rs = part(self.index, lv.rs, lv.n + 1)?;
        let cols = part(self.index, lv.cols, lv.nnz)?;
        for (i, d) in diag.chunks_exact(6).enumerate() {
            let b = sym_to_mat(d);
            for r in 0..3 {
                for c in 0..=r {
                    *dense
                        .get_mut(tri(3 * i + r, 3 * i + c))
                        .ok_or(MgError::Internal)? = f64::from(b.col(c)[r]);
                }
            }
        }
        for (i, w) in rs.windows(2).enumerate() {
            for (j, blk) in compact_row(w, cols, off)? {
                // Block (i, j), i < j, is stored; the lower triangle holds (j, i) = (i, j)ᵀ.
                for r in 0..3 {
                    for c in 0..3 {
                        *dense
                            .get_mut(tri(3 * j + r, 3 * i + c))
                            .ok_or(MgError::Internal)? = f64::from(blk.col(r)[c]);
                    }
                }
            }
        }
        factor_packed(dense, m).ok_or(MgError::Internal)
    }

    /// The cycle: `z = B r` for the finest level's `r`, `z`, and `t` (scratch).
    /// One cycle; its finest level (the vector passes around the products) in the AVX2 build
    /// where the processor has it ([`crate::cpu`]; bit-identical).
    fn cycle(&mut self, r0: &[Vec3A], z0: &mut [Vec3A], t0: &mut [Vec3A]) -> Result<(), MgError> {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            // SAFETY: the processor supports AVX2 (detected by `cpu::avx2`).
            return unsafe { self.cycle_avx2(r0, z0, t0) };
        }
        self.cycle_dispatch(r0, z0, t0)
    }

    /// [`Self::cycle`] compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn cycle_avx2(
        &mut self,
        r0: &[Vec3A],
        z0: &mut [Vec3A],
        t0: &mut [Vec3A],
    ) -> Result<(), MgError> {
        self.cycle_dispatch(r0, z0, t0)
    }

    #[inline(always)]
    fn cycle_dispatch(
        &mut self,
        r0: &[Vec3A],
        z0: &mut [Vec3A],
        t0: &mut [Vec3A],
    ) -> Result<(), MgError> {
        // The operators are read-only in a cycle: lent out of `self` for it, so that the
        // filter can borrow the free-vertex flags among them.
        let ops = core::mem::take(&mut self.blocks);
        let n = self.a.diag.len();
        let result = match (self.filter, free_flags(ops, n)) {
            (None, _) => self.cycle_with(ops, &Free, r0, z0, t0),
            (Some(blocks), Ok(free)) => self.cycle_with(ops, &Flagged { blocks, free }, r0, z0, t0),
            (Some(_), Err(e)) => Err(e),
        };
        self.blocks = ops;
        result
    }

    #[inline(always)]
    fn cycle_with<F: Filter>(
        &mut self,
        blocks: &[f32],
        f: &F,
        r0: &[Vec3A],
        z0: &mut [Vec3A],
        t0: &mut [Vec3A],
    ) -> Result<(), MgError> {
        let n = self.a.diag.len();
        let lumped = self.is_lumped;
        let (Some(z0), Some(t0)) = (z0.get_mut(..n), t0.get_mut(..n)) else {
            return Err(MgError::LengthMismatch);
        };
        if r0.len() != n {
            return Err(MgError::LengthMismatch);
        }
        let Multigrid {
            agg0,
            index,
            dense,
            vectors,
            a,
            levels,
            count,
            is_dense,
            options,
            lines: line_count,
            ..
        } = self;
        let ops = Ops {
            blocks,
            index,
            dense,
            levels,
            count: *count,
            is_dense: *is_dense,
            options: *options,
        };
        let (omega, nu) = (ops.options.omega, ops.options.sweeps);
        let inv = part(ops.blocks, 0, 6 * n)?;
        let (a, w) = smoothing_operator(*a, ops.blocks, lumped)?;
        let a = &a;
        // Pre-smoothing from z = 0, on the filtered input. The line smoother where the setup
        // made lines, else block Jacobi (for `Smoother::Lines` too: no vertex was linked).
        let layout = lines::Layout::new(n);
        let line_count = *line_count;
        let smoother = match ops.options.smoother {
            Smoother::Lines if line_count == 0 => Smoother::Jacobi,
            s => s,
        };
        match smoother {
            Smoother::Lines => {
                for (i, (ti, &ri)) in t0.iter_mut().zip(r0).enumerate() {
                    *ti = f.at(i, ri);
                }
                lines::solve(ops.blocks, &layout, line_count, t0, z0, LINE_OMEGA, false)?;
                for _ in 1..nu {
                    fine_residual(a, w, f, r0, z0, t0)?;
                    lines::solve(ops.blocks, &layout, line_count, t0, z0, LINE_OMEGA, true)?;
                }
            }
            Smoother::Jacobi => {
                for (i, ((zi, &ri), p)) in
                    z0.iter_mut().zip(r0).zip(inv.chunks_exact(6)).enumerate()
                {
                    *zi = omega * sym_mul(p, f.at(i, ri));
                }
                for _ in 1..nu {
                    fine_residual(a, w, f, r0, z0, t0)?;
                    smooth_coarse(inv, omega, t0, z0);
                }
            }
            Smoother::GaussSeidel => {
                z0.fill(Vec3A::ZERO);
                t0.copy_from_slice(r0);
                fine_forward(a, inv, f, t0, z0)?;
                for _ in 1..nu {
                    fine_residual(a, w, f, r0, z0, t0)?;
                    fine_forward(a, inv, f, t0, z0)?;
                }
            }
        }
        if ops.count > 1 {
            let l1 = ops.level(1)?;
            let agg: &[u32] = agg0;
            let v1 = vectors.get_mut(l1.vec..).ok_or(MgError::Internal)?;
            {
                // The residual `S (r − A z)`, restricted in the same pass (it is not kept).
                a.mul(z0, t0).map_err(|_| MgError::LengthMismatch)?;
                let r1 = v1.get_mut(..l1.n).ok_or(MgError::Internal)?;
                r1.fill(Vec3A::ZERO);
                let rows = t0.iter().zip(z0.iter()).zip(r0).zip(agg);
                for (i, (((&ti, &zi), &ri), &a)) in rows.enumerate() {
                    let ti = weighted(ti, w, i, zi);
                    *r1.get_mut(a as usize).ok_or(MgError::Internal)? += f.at(i, ri - ti);
                }
            }
            // The fine residual is restricted: `t0` is free to save the W-cycle's iterate.
            ops.correct(1, v1, t0)?;
            let z1 = part(v1, l1.n, l1.n)?;
            let beta = ops.options.correction;
            for (i, (zi, &a)) in z0.iter_mut().zip(agg).enumerate() {
                let c = *z1.get(a as usize).ok_or(MgError::Internal)?;
                *zi += f.at(i, beta * c);
            }
        }
        for _ in 0..nu {
            match smoother {
                Smoother::Lines => {
                    fine_residual(a, w, f, r0, z0, t0)?;
                    lines::solve(ops.blocks, &layout, line_count, t0, z0, LINE_OMEGA, true)?;
                }
                Smoother::Jacobi => {
                    // The residual `S (r − A z)` and the sweep in one pass (it is not kept).
                    a.mul(z0, t0).map_err(|_| MgError::LengthMismatch)?;
                    let rows = z0
                        .iter_mut()
                        .zip(t0.iter().zip(r0))
                        .zip(inv.chunks_exact(6));
                    for (i, ((zi, (&ti, &ri)), d)) in rows.enumerate() {
                        let ti = weighted(ti, w, i, *zi);
                        *zi += omega * sym_mul(d, f.at(i, ri - ti));
                    }
                }
                Smoother::GaussSeidel => {
                    fine_residual(a, w, f, r0, z0, t0)?;
                    fine_backward(a, inv, f, t0, z0)?;
                }
            }
        }
        Ok(())
    }
}

/// The read-only side of a cycle: the operators of every level and the cycle parameters.
struct Ops<'b> {
    blocks: &'b [f32],
    index: &'b [u32],
    dense: &'b [f64],
    levels: &'b [Level; MAX_LEVELS],
    count: usize,
    is_dense: bool,
    options: Options,
}

/// A level's `(r, z, t)` (`n` each) at the start of `vecs`, and the rest after them.
#[allow(clippy::type_complexity)]
fn split3(
    vecs: &mut [Vec3A],
    n: usize,
) -> Result<(&mut [Vec3A], &mut [Vec3A], &mut [Vec3A], &mut [Vec3A]), MgError> {
    if vecs.len() < 3 * n {
        return Err(MgError::Internal);
    }
    let (r, tail) = vecs.split_at_mut(n);
    let (z, tail) = tail.split_at_mut(n);
    let (t, rest) = tail.split_at_mut(n);
    Ok((r, z, t, rest))
}

impl Ops<'_> {
    fn level(&self, l: usize) -> Result<Level, MgError> {
        self.levels.get(l).copied().ok_or(MgError::Internal)
    }

    /// The coarse correction of level `c ≥ 1`: `z_c ≈ A_c⁻¹ r_c` by `γ` =
    /// [`Options::cycle`] stationary iterations of the level's cycle (`γ = 1`: a V-cycle,
    /// `2`: a W-cycle). `vecs` starts at level `c`'s vectors; `save` (at least `n_c`) is
    /// the parent's scratch, free during the correction. A fixed number of stationary steps
    /// of a symmetric convergent iteration is a fixed symmetric positive definite operator.
    fn correct(&self, c: usize, vecs: &mut [Vec3A], save: &mut [Vec3A]) -> Result<(), MgError> {
        if c + 1 == self.count && self.is_dense {
            return self.visit(c, vecs); // exact: a second visit would add nothing
        }
        if self.options.krylov {
            return self.krylov(c, vecs);
        }
        self.visit(c, vecs)?;
        let lv = self.level(c)?;
        let save = save.get_mut(..lv.n).ok_or(MgError::Internal)?;
        for _ in 1..self.options.cycle {
            let (diag, _, off, rs, cols) = level_ops(self.blocks, self.index, &lv)?;
            let (r, z, t, _) = split3(vecs, lv.n)?;
            save.copy_from_slice(z);
            coarse_residual(diag, rs, cols, off, r, z, t)?;
            r.copy_from_slice(t);
            self.visit(c, vecs)?;
            let (_, z, _, _) = split3(vecs, lv.n)?;
            for (zi, &s) in z.iter_mut().zip(save.iter()) {
                *zi += s;
            }
        }
        Ok(())
    }

    /// The K-cycle's correction on level `c` (Notay & Vassilevski 2008, Algorithm 2): `z` =
    /// up to two steps of CG on `A_c z = r` from zero, preconditioned by the level's own
    /// cycle `B_c`. With `c₁ = B_c r`, `w = A_c c₁`, `ρ₁ = c₁ᵀw`, `α₁ = c₁ᵀr` and
    /// `r̃ = r − (α₁/ρ₁) w`: if `‖r̃‖ ≤ t ‖r‖` ([`KRYLOV_SKIP`]) the first step is enough,
    /// `z = (α₁/ρ₁) c₁`; otherwise, with `c₂ = B_c r̃`, `v = A_c c₂`, `γ = c₁ᵀv`,
    /// `ρ₂ = c₂ᵀv − γ²/ρ₁` and `α₂ = c₂ᵀr̃`,
    /// `z = (α₁/ρ₁ − γ α₂/(ρ₁ ρ₂)) c₁ + (α₂/ρ₂) c₂`, the `A_c`-norm best correction in the
    /// span of `c₁` and `c₂`. A non-positive curvature (a level whose cycle or operator lost
    /// positivity in `f32`) falls back to the first step, or to no correction.
    fn krylov(&self, c: usize, vecs: &mut [Vec3A]) -> Result<(), MgError> {
        let lv = self.level(c)?;
        let n = lv.n;
        let (diag, _, off, rs, cols) = level_ops(self.blocks, self.index, &lv)?;
        self.visit(c, vecs)?;
        let (r, z, t, rest) = split3(vecs, n)?;
        let first = rest.get_mut(..n).ok_or(MgError::Internal)?;
        first.copy_from_slice(z);
        coarse_mul(diag, rs, cols, off, first, t)?;
        let (rho1, alpha1) = (dot(first, t), dot(first, r));
        if !(rho1 > 0.0 && rho1.is_finite() && alpha1.is_finite()) {
            z.fill(Vec3A::ZERO);
            return Ok(());
        }
        let step1 = (alpha1 / rho1) as f32;
        let before = dot(r, r);
        for (ri, &wi) in r.iter_mut().zip(t.iter()) {
            *ri -= step1 * wi;
        }
        if dot(r, r) <= KRYLOV_SKIP * KRYLOV_SKIP * before {
            for (zi, &fi) in z.iter_mut().zip(first.iter()) {
                *zi = step1 * fi;
            }
            return Ok(());
        }
        self.visit(c, vecs)?;
        let (r, z, t, rest) = split3(vecs, n)?;
        let first = rest.get(..n).ok_or(MgError::Internal)?;
        coarse_mul(diag, rs, cols, off, z, t)?;
        let (gamma, curv2, alpha2) = (dot(first, t), dot(z, t), dot(z, r));
        let rho2 = curv2 - gamma * gamma / rho1;
        let (k1, k2) = if rho2 > 0.0 && rho2.is_finite() && alpha2.is_finite() {
            (
                (alpha1 / rho1 - gamma * alpha2 / (rho1 * rho2)) as f32,
                (alpha2 / rho2) as f32,
            )
        } else {
            (step1, 0.0)
        };
        for (zi, &fi) in z.iter_mut().zip(first) {
            *zi = k1 * fi + k2 * *zi;
        }
        Ok(())
    }

    /// One cycle on coarse level `l` (`z = B_l r`; `vecs` starts at its vectors).
    fn visit(&self, l: usize, vecs: &mut [Vec3A]) -> Result<(), MgError> {
        let lv = self.level(l)?;
        if l + 1 >= self.count {
            return self.coarsest(&lv, vecs);
        }
        let next = self.level(l + 1)?;
        let (diag, inv, off, rs, cols) = level_ops(self.blocks, self.index, &lv)?;
        let agg = part(self.index, lv.agg, lv.n)?;
        let (r, z, t, rest) = split3(vecs, lv.n)?;
        let (omega, nu) = (self.options.omega, self.options.sweeps);
        match self.options.smoother {
            Smoother::Jacobi | Smoother::Lines => {
                for ((zi, &ri), d) in z.iter_mut().zip(r.iter()).zip(inv.chunks_exact(6)) {
                    *zi = omega * sym_mul(d, ri);
                }
                for _ in 1..nu {
                    coarse_residual(diag, rs, cols, off, r, z, t)?;
                    smooth_coarse(inv, omega, t, z);
                }
            }
            Smoother::GaussSeidel => {
                z.fill(Vec3A::ZERO);
                t.copy_from_slice(r);
                forward(inv, rs, cols, off, t, z)?;
                for _ in 1..nu {
                    coarse_residual(diag, rs, cols, off, r, z, t)?;
                    forward(inv, rs, cols, off, t, z)?;
                }
            }
        }
        coarse_residual(diag, rs, cols, off, r, z, t)?;
        // `rest` starts after this level's r, z, t; the child's vectors start after its fourth
        // (the K-cycle's saved direction), which `rest` also holds.
        let gap = next
            .vec
            .checked_sub(lv.vec + 3 * lv.n)
            .filter(|&g| g >= lv.n)
            .ok_or(MgError::Internal)?;
        let child = rest.get_mut(gap..).ok_or(MgError::Internal)?;
        {
            let rc = child.get_mut(..next.n).ok_or(MgError::Internal)?;
            rc.fill(Vec3A::ZERO);
            for (&ti, &a) in t.iter().zip(agg) {
                *rc.get_mut(a as usize).ok_or(MgError::Internal)? += ti;
            }
        }
        self.correct(l + 1, child, t)?;
        let zc = part(child, next.n, next.n)?;
        let beta = self.options.correction;
        for (zi, &a) in z.iter_mut().zip(agg) {
            *zi += beta * *zc.get(a as usize).ok_or(MgError::Internal)?;
        }
        for _ in 0..nu {
            coarse_residual(diag, rs, cols, off, r, z, t)?;
            match self.options.smoother {
                Smoother::Jacobi | Smoother::Lines => smooth_coarse(inv, omega, t, z),
                Smoother::GaussSeidel => backward(inv, rs, cols, off, t, z)?,
            }
        }
        Ok(())
    }

    /// The coarsest level: `z = A⁻¹ r` (dense) or smoothing sweeps (symmetric).
    fn coarsest(&self, lv: &Level, vecs: &mut [Vec3A]) -> Result<(), MgError> {
        let (diag, inv, off, rs, cols) = level_ops(self.blocks, self.index, lv)?;
        let (r, z, t, _) = split3(vecs, lv.n)?;
        if self.is_dense {
            let m = 3 * lv.n;
            let mut y = [0.0f64; DENSE_DOF];
            let y = y.get_mut(..m).ok_or(MgError::Internal)?;
            for (k, yk) in y.iter_mut().enumerate() {
                *yk = f64::from(r.get(k / 3).ok_or(MgError::Internal)?[k % 3]);
            }
            solve_packed(self.dense, y).ok_or(MgError::Internal)?;
            for (i, zi) in z.iter_mut().enumerate() {
                let g = |c: usize| y.get(3 * i + c).copied().unwrap_or(0.0) as f32;
                *zi = Vec3A::new(g(0), g(1), g(2));
            }
            return Ok(());
        }
        let omega = self.options.omega;
        match self.options.smoother {
            Smoother::Jacobi | Smoother::Lines => {
                for ((zi, &ri), d) in z.iter_mut().zip(r.iter()).zip(inv.chunks_exact(6)) {
                    *zi = omega * sym_mul(d, ri);
                }
                for _ in 1..self.options.coarse_sweeps {
                    coarse_residual(diag, rs, cols, off, r, z, t)?;
                    smooth_coarse(inv, omega, t, z);
                }
            }
            Smoother::GaussSeidel => {
                // Symmetric Gauss–Seidel: forward then backward, `coarse_sweeps` times.
                z.fill(Vec3A::ZERO);
                t.copy_from_slice(r);
                forward(inv, rs, cols, off, t, z)?;
                coarse_residual(diag, rs, cols, off, r, z, t)?;
                backward(inv, rs, cols, off, t, z)?;
                for _ in 1..self.options.coarse_sweeps {
                    coarse_residual(diag, rs, cols, off, r, z, t)?;
                    forward(inv, rs, cols, off, t, z)?;
                    coarse_residual(diag, rs, cols, off, r, z, t)?;
                    backward(inv, rs, cols, off, t, z)?;
                }
            }
        }
        Ok(())
    }
}

/// The K-cycle's threshold `t`: the second inner step is skipped once the first has reduced
/// the level's residual norm to `t` of its start (Notay & Vassilevski's value).
const KRYLOV_SKIP: f64 = 0.25;

/// `aᵀ b` with `f64` sums (serial: bit-reproducible).
fn dot(a: &[Vec3A], b: &[Vec3A]) -> f64 {
    a.iter()
        .zip(b)
        .fold(0.0, |s, (&x, &y)| s + crate::pcg::dot64(x, y))
}

/// `t = S (r − A z)` on the finest level, with `A`'s lumped scalar couplings `w` (empty:
/// none) on its diagonal.
fn fine_residual<F: Filter>(
    a: &BlockMatrix<'_>,
    w: &[f32],
    f: &F,
    r: &[Vec3A],
    z: &[Vec3A],
    t: &mut [Vec3A],
) -> Result<(), MgError> {
    a.mul(z, t).map_err(|_| MgError::LengthMismatch)?;
    for (i, ((ti, &ri), &zi)) in t.iter_mut().zip(r).zip(z).enumerate() {
        *ti = f.at(i, ri - weighted(*ti, w, i, zi));
    }
    Ok(())
}

/// The finest level's smoothing operator: `a` itself, or, `lumped`, `Ã` with its scalar
/// couplings lumped ([`Options::lumped`]): their product left out (the matrix returned), their
/// weights `w` (in `blocks`, returned) on the diagonal ([`weighted`]).
fn smoothing_operator<'m, 'b>(
    a: BlockMatrix<'m>,
    blocks: &'b [f32],
    lumped: bool,
) -> Result<(BlockMatrix<'m>, &'b [f32]), MgError> {
    if !lumped {
        return Ok((a, &[]));
    }
    let n = a.diag.len();
    let stripped = BlockMatrix {
        scalars: Scalars::NONE,
        ..a
    };
    Ok((stripped, part(blocks, 6 * n, n)?))
}

/// `(A z)_i` with the lumped weight `w_i` of vertex `i`'s scalar couplings added: `t + w_i z`,
/// or `t` itself when there are no weights (`w` empty: nothing lumped).
#[inline(always)]
fn weighted(t: Vec3A, w: &[f32], i: usize, z: Vec3A) -> Vec3A {
    match w.get(i) {
        Some(&wi) => t + wi * z,
        None => t,
    }
}

/// The lumped weights of the scalar couplings `s`: `w_i = Σ_j |scale · s_ij|` over vertex `i`'s
/// couplings in either orientation ([`Options::lumped`]).
fn lump(s: &Scalars, w: &mut [f32]) -> Result<(), MgError> {
    w.fill(0.0);
    for i in 0..w.len() {
        for (k, j) in s.pattern.upper(i) {
            let v = (s.scale * *s.off.get(k).ok_or(MgError::LengthMismatch)?).abs();
            *w.get_mut(i).ok_or(MgError::Internal)? += v;
            *w.get_mut(j).ok_or(MgError::LengthMismatch)? += v;
        }
    }
    Ok(())
}

/// `Aᵀ v` for a stored block `A` (`v · column`).
#[inline(always)]
fn mul_t(m: &Mat3A, v: Vec3A) -> Vec3A {
    Vec3A::new(m.x_axis.dot(v), m.y_axis.dot(v), m.z_axis.dot(v))
}

/// A forward block Gauss–Seidel sweep on the finest level: `t` holds the residual of `z` on
/// entry (its constrained components are ignored); `z += (D̂ + L̂)⁻¹ t` with `L̂` the strictly
/// lower part of `S A S`, visiting the vertices in ascending order. The lower blocks are the
/// transposed upper ones, so the sweep scatters: `t_j −= A_ijᵀ δ_i` for the `j > i` of row
/// `i`. `t` is consumed.
fn fine_forward<F: Filter>(
    a: &BlockMatrix<'_>,
    inv: &[f32],
    f: &F,
    t: &mut [Vec3A],
    z: &mut [Vec3A],
) -> Result<(), MgError> {
    for (i, (zi, d)) in z.iter_mut().zip(inv.chunks_exact(6)).enumerate() {
        let ti = *t.get(i).ok_or(MgError::Internal)?;
        let delta = f.at(i, sym_mul(d, f.at(i, ti)));
        *zi += delta;
        for (k, j) in a.pattern.upper(i) {
            let m = a.off.get(k).ok_or(MgError::Internal)?;
            *t.get_mut(j).ok_or(MgError::Internal)? -= mul_t(m, delta);
        }
        let sc = &a.scalars;
        if !sc.is_empty() {
            for (k, j) in sc.pattern.upper(i) {
                let v = sc.scale * *sc.off.get(k).ok_or(MgError::Internal)?;
                *t.get_mut(j).ok_or(MgError::Internal)? -= v * delta;
            }
        }
    }
    Ok(())
}

/// The backward sweep, the adjoint of [`fine_forward`]: `z += (D̂ + Û)⁻¹ t`, descending; the
/// upper blocks gather the updates `δ_j` (`j > i`), which are kept in `t`.
fn fine_backward<F: Filter>(
    a: &BlockMatrix<'_>,
    inv: &[f32],
    f: &F,
    t: &mut [Vec3A],
    z: &mut [Vec3A],
) -> Result<(), MgError> {
    for (i, (zi, d)) in z.iter_mut().zip(inv.chunks_exact(6)).enumerate().rev() {
        let mut s = *t.get(i).ok_or(MgError::Internal)?;
        for (k, j) in a.pattern.upper(i) {
            let m = a.off.get(k).ok_or(MgError::Internal)?;
            s -= *m * *t.get(j).ok_or(MgError::Internal)?;
        }
        let sc = &a.scalars;
        if !sc.is_empty() {
            for (k, j) in sc.pattern.upper(i) {
                let v = sc.scale * *sc.off.get(k).ok_or(MgError::Internal)?;
                s -= v * *t.get(j).ok_or(MgError::Internal)?;
            }
        }
        let delta = f.at(i, sym_mul(d, f.at(i, s)));
        *zi += delta;
        *t.get_mut(i).ok_or(MgError::Internal)? = delta;
    }
    Ok(())
}

/// [`fine_forward`] on a compact level (no filter).
fn forward(
    inv: &[f32],
    rs: &[u32],
    cols: &[u32],
    off: &[Mat3A],
    t: &mut [Vec3A],
    z: &mut [Vec3A],
) -> Result<(), MgError> {
    for (i, ((zi, d), w)) in z
        .iter_mut()
        .zip(inv.chunks_exact(6))
        .zip(rs.windows(2))
        .enumerate()
    {
        let delta = sym_mul(d, *t.get(i).ok_or(MgError::Internal)?);
        *zi += delta;
        for (j, blk) in compact_row(w, cols, off)? {
            *t.get_mut(j).ok_or(MgError::Internal)? -= mul_t(&blk, delta);
        }
    }
    Ok(())
}

/// [`fine_backward`] on a compact level (no filter).
fn backward(
    inv: &[f32],
    rs: &[u32],
    cols: &[u32],
    off: &[Mat3A],
    t: &mut [Vec3A],
    z: &mut [Vec3A],
) -> Result<(), MgError> {
    for (i, ((zi, d), w)) in z
        .iter_mut()
        .zip(inv.chunks_exact(6))
        .zip(rs.windows(2))
        .enumerate()
        .rev()
    {
        let mut s = *t.get(i).ok_or(MgError::Internal)?;
        for (j, blk) in compact_row(w, cols, off)? {
            s -= blk * *t.get(j).ok_or(MgError::Internal)?;
        }
        let delta = sym_mul(d, s);
        *zi += delta;
        *t.get_mut(i).ok_or(MgError::Internal)? = delta;
    }
    Ok(())
}

/// Level `lv`'s `(diag, inv, off, rs, cols)`.
#[allow(clippy::type_complexity)]
fn level_ops<'b>(
    blocks: &'b [f32],
    index: &'b [u32],
    lv: &Level,
) -> Result<(&'b [f32], &'b [f32], &'b [Mat3A], &'b [u32], &'b [u32]), MgError> {
    let ops = part(blocks, lv.blk, lv.floats())?;
    let (diag, rest) = ops.split_at(6 * lv.n);
    let (inv, off) = rest.split_at(6 * lv.n);
    Ok((
        diag,
        inv,
        couplings(off)?,
        part(index, lv.rs, lv.n + 1)?,
        part(index, lv.cols, lv.nnz)?,
    ))
}

/// Vertex `i`'s filter block where it holds a direction, `None` where it is the identity (a
/// free vertex), so that its couplings are taken as they are instead of through two 3×3
/// products each (`I A I` is `A`).
pub(super) fn held(filter: Option<&[Mat3A]>, i: usize) -> Option<Mat3A> {
    filter
        .and_then(|f| f.get(i))
        .copied()
        .filter(|si| *si != Mat3A::IDENTITY)
}

/// The filtered coupling `S_i A_ij S_j` of the block `m` between vertices whose filters are
/// `si` and `sj` ([`held`]).
pub(super) fn filtered_coupling(si: Option<Mat3A>, m: &Mat3A, sj: Option<Mat3A>) -> Mat3A {
    match (si, sj) {
        (None, None) => *m,
        (a, b) => a.unwrap_or(Mat3A::IDENTITY) * *m * b.unwrap_or(Mat3A::IDENTITY),
    }
}

/// The finest level's smoothing block of vertex `i` (diagonal block `d`, `n` vertices):
/// `A_ii`, plus its lumped scalar couplings when `lumped` (their weights in `blocks`),
/// filtered.
fn fine_block(
    blocks: &[f32],
    n: usize,
    filter: Option<&[Mat3A]>,
    lumped: bool,
    i: usize,
    d: &Mat3A,
) -> Result<Mat3A, MgError> {
    let d = if lumped {
        let w = *part(blocks, 6 * n, n)?
            .get(i)
            .ok_or(MgError::LengthMismatch)?;
        *d + Mat3A::from_diagonal(glam::Vec3::splat(w))
    } else {
        *d
    };
    Ok(filtered(filter, i, &d))
}

/// Vertex `i`'s filtered diagonal block `S A_ii S + τ (I − S)`: the constrained directions
/// get the block's own scale so the inverse is well conditioned; they are decoupled anyway.
fn filtered(filter: Option<&[Mat3A]>, i: usize, d: &Mat3A) -> Mat3A {
    match filter.and_then(|f| f.get(i)) {
        Some(s) if *s != Mat3A::IDENTITY => {
            let tau = (d.x_axis.x + d.y_axis.y + d.z_axis.z) / 3.0;
            let tau = if tau.is_finite() && tau > 0.0 {
                tau
            } else {
                1.0
            };
            *s * *d * *s + (Mat3A::IDENTITY - *s) * tau
        }
        _ => *d,
    }
}

/// The Galerkin operator of level 1, `Pᵀ (S A S) P`, into `ops` (level 1's diagonal and
/// coupling blocks; its inverses are left to `setup_coarse`): the blocks start from zero and
/// one pass over the fine blocks and scalar couplings, in vertex order, sums into them where
/// the build's coupling map `map` says. With `only`, just the blocks of which either aggregate
/// is flagged: they then start from zero and receive exactly the sums, in exactly the order,
/// of a full pass; the others are kept.
fn galerkin_fine(
    a: BlockMatrix<'_>,
    filter: Option<&[Mat3A]>,
    agg: &[u32],
    map: &[u32],
    cp: &Pattern<'_>,
    ops: &mut [f32],
    only: Option<&[u32]>,
) -> Result<(), MgError> {
    let n1 = cp.n();
    let (cdiag, rest) = ops.split_at_mut((6 * n1).min(ops.len()));
    let coff = couplings_mut(rest.get_mut(6 * n1..).ok_or(MgError::Internal)?)?;
    let (map_blocks, map_scalars) = map.split_at(a.pattern.nnz().min(map.len()));
    let wanted = |big_i: u32, big_j: u32| {
        only.is_none_or(|f| {
            f.get(big_i as usize).is_some_and(|&x| x != 0)
                || f.get(big_j as usize).is_some_and(|&x| x != 0)
        })
    };
    for (big_i, d) in cdiag.chunks_exact_mut(6).enumerate() {
        if wanted(big_i as u32, big_i as u32) {
            d.fill(0.0);
        }
        for (k, big_j) in cp.upper(big_i) {
            if wanted(big_i as u32, big_j as u32) {
                *coff.get_mut(k).ok_or(MgError::Internal)? = Mat3A::ZERO;
            }
        }
    }
    let s = |i: usize| held(filter, i);
    for (i, (d, &big_i)) in a.diag.iter().zip(agg).enumerate() {
        if !wanted(big_i, big_i) {
            continue;
        }
        let f = match s(i) {
            Some(si) => si * *d * si,
            None => *d,
        };
        sym_add(part_mut(cdiag, 6 * big_i as usize, 6)?, &f, 1.0);
    }
    for (i, &big_i) in agg.iter().enumerate() {
        let si = s(i);
        for (k, j) in a.pattern.upper(i) {
            let big_j = *agg.get(j).ok_or(MgError::Internal)?;
            if !wanted(big_i, big_j) {
                continue;
            }
            let m = a.off.get(k).ok_or(MgError::Internal)?;
            let f = filtered_coupling(si, m, s(j));
            let code = *map_blocks.get(k).ok_or(MgError::Internal)?;
            place(cdiag, coff, code, big_i as usize, &f)?;
        }
    }
    // The scalar couplings `c s_ij I3` (`S_i S_j` between filters).
    let scalars = a.scalars;
    if !scalars.is_empty() {
        for (i, &big_i) in agg.iter().enumerate() {
            let si = s(i);
            for (k, j) in scalars.pattern.upper(i) {
                let big_j = *agg.get(j).ok_or(MgError::Internal)?;
                if !wanted(big_i, big_j) {
                    continue;
                }
                let v = scalars.scale * *scalars.off.get(k).ok_or(MgError::Internal)?;
                let f = match (si, s(j)) {
                    (None, None) => Mat3A::from_diagonal(glam::Vec3::splat(v)),
                    (a, b) => a.unwrap_or(Mat3A::IDENTITY) * b.unwrap_or(Mat3A::IDENTITY) * v,
                };
                let code = *map_scalars.get(k).ok_or(MgError::Internal)?;
                place(cdiag, coff, code, big_i as usize, &f)?;
            }
        }
    }
    Ok(())
}

/// Adds the fine coupling block `f` of a vertex of aggregate `i` to the coarse operator,
/// where its `code` in the coupling map says: both (i, i) and its transpose into `i`'s
/// diagonal block ([`SAME`]: `2 sym(f)`), or `f` (`fᵀ`, [`TRANSPOSED`]) into a coupling block.
#[inline(always)]
fn place(
    cdiag: &mut [f32],
    coff: &mut [Mat3A],
    code: u32,
    i: usize,
    f: &Mat3A,
) -> Result<(), MgError> {
    if code == SAME {
        sym_add(part_mut(cdiag, 6 * i, 6)?, f, 2.0);
    } else if code & TRANSPOSED == 0 {
        *coff.get_mut(code as usize).ok_or(MgError::Internal)? += *f;
    } else {
        *coff
            .get_mut((code & !TRANSPOSED) as usize)
            .ok_or(MgError::Internal)? += f.transpose();
    }
    Ok(())
}

/// Adds the fine block `f` between vertices of aggregates `i` and `j` (stored as the fine
/// `(row, col)` upper block) to the coarse operator of pattern `cp`.
fn accumulate(
    cdiag: &mut [f32],
    coff: &mut [Mat3A],
    cp: &Pattern<'_>,
    i: usize,
    j: usize,
    f: &Mat3A,
) -> Result<(), MgError> {
    place(cdiag, coff, coupling_code(cp, i, j)?, i, f)
}

fn smooth_coarse(inv: &[f32], omega: f32, t: &[Vec3A], z: &mut [Vec3A]) {
    for ((zi, &ti), d) in z.iter_mut().zip(t).zip(inv.chunks_exact(6)) {
        *zi += omega * sym_mul(d, ti);
    }
}

/// `t = r − A z` on a compact level.
fn coarse_residual(
    diag: &[f32],
    rs: &[u32],
    cols: &[u32],
    off: &[Mat3A],
    r: &[Vec3A],
    z: &[Vec3A],
    t: &mut [Vec3A],
) -> Result<(), MgError> {
    coarse_mul(diag, rs, cols, off, z, t)?;
    for (ti, &ri) in t.iter_mut().zip(r) {
        *ti = ri - *ti;
    }
    Ok(())
}

impl Preconditioner for Multigrid<'_> {
    /// One V-cycle (see the module docs); on an internal error `z` is NaN, which the PCG
    /// reports as a breakdown.
    fn apply(&mut self, r: &[Vec3A], z: &mut [Vec3A], scratch: &mut [Vec3A]) {
        if self.cycle(r, z, scratch).is_err() {
            z.fill(Vec3A::NAN);
        }
    }
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::pcg::tests::Scratch;
    use crate::pcg::{self, solve_with, Blocks, Settings};
    use crate::sparse::tests::{dense, random_pairs, spring_system, Lcg, OwnedPattern};
    use crate::sparse::{add_block, Scalars};

    /// `sym_mul` in SIMD lanes is the three scalar rows, bit for bit (values over 40 binades,
    /// both signs), so the cycle's results did not change with it.
    #[test]
    fn sym_mul_is_the_scalar_rows_bit_for_bit() {
        let mut rng = Lcg(7);
        let mut wide = || {
            let e = rng.below(40) as i32 - 20;
            (2.0 * rng.uniform() - 1.0) * 2f32.powi(e)
        };
        for _ in 0..10_000 {
            let d: [f32; 6] = core::array::from_fn(|_| wide());
            let v = Vec3A::new(wide(), wide(), wide());
            let [xx, xy, xz, yy, yz, zz] = d;
            let rows = [
                xx * v.x + xy * v.y + xz * v.z,
                xy * v.x + yy * v.y + yz * v.z,
                xz * v.x + yz * v.y + zz * v.z,
            ];
            let got = sym_mul(&d, v).to_array();
            assert_eq!(got.map(f32::to_bits), rows.map(f32::to_bits), "{d:?} {v:?}");
        }
        assert!(sym_mul(&[1.0; 5], Vec3A::ONE).is_nan());
    }

    /// The four-lane inverse is [`inverse_sym`] lane by lane, bit for bit, and so are the
    /// passes that use it: SPD blocks over 40 binades (with nonsymmetric parts), and every
    /// fallback (zero, not finite, indefinite, overflowing, tiny) in any lane beside good ones.
    #[test]
    fn four_inverses_at_once_are_the_single_ones_bit_for_bit() {
        let mut rng = Lcg(11);
        let spd = |rng: &mut Lcg| {
            let s = 2f32.powi(rng.below(40) as i32 - 20);
            let m = rng.mat();
            (m * m.transpose() + Mat3A::from_diagonal(glam::Vec3::splat(0.01)) + rng.mat() * 1e-3)
                * s
        };
        let odd = [
            Mat3A::ZERO,
            Mat3A::NAN,
            Mat3A::from_diagonal(glam::Vec3::new(1.0, -1.0, 1.0)),
            Mat3A::from_diagonal(glam::Vec3::splat(f32::MAX)),
            Mat3A::from_diagonal(glam::Vec3::new(f32::MIN_POSITIVE, 1e-45, 1.0)),
            Mat3A::from_cols_array(&[1.0, 2.0, 0.0, 2.0, 1.0, 0.0, 0.0, 0.0, 1.0]),
        ];
        let bits = |s: &[f32]| s.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for round in 0..4000 {
            let m: [Mat3A; 4] = core::array::from_fn(|k| {
                if round % 3 == 0 && rng.below(4) as usize == k {
                    odd[rng.below(odd.len() as u32) as usize]
                } else {
                    spd(&mut rng)
                }
            });
            let single: Vec<f32> = m.iter().flat_map(inverse_sym).collect();
            assert_eq!(
                bits(inverse_sym4(&m).as_flattened()),
                bits(&single),
                "{m:?}"
            );
            // the coarse levels' pass, on the symmetric parts (five blocks: a remainder too)
            let diag: Vec<f32> = m
                .iter()
                .chain(&m[..1])
                .flat_map(|b| {
                    let [xx, _, _, xy, yy, _, xz, yz, zz] = b.to_cols_array();
                    [xx, xy, xz, yy, yz, zz]
                })
                .collect();
            let mut inv = vec![0.0; diag.len()];
            invert_coarse(&diag, &mut inv);
            let want: Vec<f32> = diag
                .chunks_exact(6)
                .flat_map(|d| inverse_sym(&sym_to_mat(d)))
                .collect();
            assert_eq!(bits(&inv), bits(&want));
        }
    }

    /// Owned hierarchy memory for `n` vertices and `nnz` couplings.
    struct Mem {
        agg: Vec<u32>,
        index: Vec<u32>,
        blocks: Vec<f32>,
        dense: Vec<f64>,
        vectors: Vec<Vec3A>,
    }

    impl Mem {
        fn new(n: usize, nnz: usize) -> Self {
            Self {
                agg: vec![0; n],
                index: vec![0; index_len(n, nnz)],
                blocks: vec![0.0; blocks_len(n, nnz)],
                dense: vec![0.0; dense_len(n, nnz)],
                vectors: vec![Vec3A::ZERO; vectors_len(n, nnz)],
            }
        }
        fn mem(&mut self) -> Memory<'_> {
            Memory {
                agg: &self.agg,
                index: &self.index,
                blocks: &mut self.blocks,
                dense: &mut self.dense,
                vectors: &mut self.vectors,
            }
        }
    }

    /// A symmetric block system `A = M + Σ_e` of element terms on `pairs` (SPD).
    struct System {
        op: OwnedPattern,
        diag: Vec<Mat3A>,
        off: Vec<Mat3A>,
        /// Scalar couplings (`Scalars`, scale 1) on their own pattern; empty for none.
        sop: OwnedPattern,
        soff: Vec<f32>,
    }

    impl System {
        /// Random couplings with random SPD edge terms.
        fn random(rng: &mut Lcg, n: usize, stiffness: f32) -> Self {
            let pairs = random_pairs(rng, n, 2 * n);
            let (op, diag, off) = spring_system(rng, n, &pairs, stiffness, 1.0, None);
            Self::blocks(op, diag, off)
        }

        fn blocks(op: OwnedPattern, diag: Vec<Mat3A>, off: Vec<Mat3A>) -> Self {
            let sop = OwnedPattern {
                row_start: vec![],
                cols: vec![],
            };
            Self {
                op,
                diag,
                off,
                sop,
                soff: vec![],
            }
        }

        fn matrix(&self) -> BlockMatrix<'_> {
            BlockMatrix {
                diag: &self.diag,
                pattern: self.op.pattern(),
                off: &self.off,
                scalars: Scalars {
                    pattern: self.sop.pattern(),
                    off: &self.soff,
                    scale: 1.0,
                },
            }
        }
    }

    /// A wavy `k × k` grid cloth, each square split along a random diagonal when `flips`;
    /// couplings = edges plus the hinge pairs (vertices opposite an interior edge).
    fn grid_cloth(rng: &mut Lcg, k: usize, flips: bool) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
        let h = 1.0 / (k - 1) as f32;
        let pos: Vec<Vec3A> = (0..k * k)
            .map(|v| {
                let (u, w) = ((v % k) as f32 * h, (v / k) as f32 * h);
                Vec3A::new(u, 0.2 * (3.0 * w).sin() * u, w)
            })
            .collect();
        let mut tris = Vec::new();
        for j in 0..k - 1 {
            for i in 0..k - 1 {
                let a = (j * k + i) as u32;
                let (b, c, d) = (a + 1, a + k as u32, a + k as u32 + 1);
                if flips && rng.uniform() > 0.0 {
                    tris.push([a, b, c]);
                    tris.push([b, d, c]);
                } else {
                    tris.push([a, b, d]);
                    tris.push([a, d, c]);
                }
            }
        }
        (pos, tris)
    }

    /// A disk: `rings` rings around a centre, ring `r` with `6 r` vertices (irregular valences).
    fn disk_cloth(rings: usize) -> (Vec<Vec3A>, Vec<[u32; 3]>) {
        let mut pos = vec![Vec3A::ZERO];
        let mut start = vec![0usize];
        for r in 1..=rings {
            start.push(pos.len());
            for s in 0..6 * r {
                let t = s as f32 / (6 * r) as f32 * core::f32::consts::TAU;
                let rad = r as f32 / rings as f32;
                pos.push(Vec3A::new(rad * t.cos(), 0.1 * rad * rad, rad * t.sin()));
            }
        }
        let mut tris = Vec::new();
        for r in 1..=rings {
            let (inner_n, outer_n) = (if r == 1 { 1 } else { 6 * (r - 1) }, 6 * r);
            let (ib, ob) = (start[r - 1], start[r]);
            // Walk both rings by angle, emitting triangles (a standard ring stitch).
            let (mut i, mut o) = (0usize, 0usize);
            while i < inner_n || o < outer_n {
                let ti = if inner_n == 1 {
                    f32::INFINITY
                } else {
                    (i as f32 + 0.5) / inner_n as f32
                };
                let to = (o as f32 + 0.5) / outer_n as f32;
                let a = (ib + i % inner_n) as u32;
                let b = (ob + o % outer_n) as u32;
                if o < outer_n && (to <= ti || i >= inner_n) {
                    tris.push([a, b, (ob + (o + 1) % outer_n) as u32]);
                    o += 1;
                } else {
                    tris.push([a, b, (ib + (i + 1) % inner_n) as u32]);
                    i += 1;
                }
            }
        }
        (pos, tris)
    }

    /// Edges and hinge pairs of a triangle list.
    fn couplings_of(tris: &[[u32; 3]]) -> (Vec<[u32; 2]>, Vec<[u32; 2]>) {
        use std::collections::BTreeMap;
        let mut opp: BTreeMap<(u32, u32), Vec<u32>> = BTreeMap::new();
        for t in tris {
            for e in 0..3 {
                let (a, b, c) = (t[e], t[(e + 1) % 3], t[(e + 2) % 3]);
                opp.entry((a.min(b), a.max(b))).or_default().push(c);
            }
        }
        let edges: Vec<[u32; 2]> = opp.keys().map(|&(a, b)| [a, b]).collect();
        let hinges: Vec<[u32; 2]> = opp
            .values()
            .filter(|o| o.len() == 2)
            .map(|o| [o[0], o[1]])
            .collect();
        (edges, hinges)
    }

    /// Symmetric edge adjacency (CSR) of `edges`.
    fn ring(n: usize, edges: &[[u32; 2]]) -> (Vec<u32>, Vec<u32>) {
        let mut adj = vec![Vec::new(); n];
        for &[a, b] in edges {
            adj[a as usize].push(b);
            adj[b as usize].push(a);
        }
        let mut start = vec![0u32];
        let mut list = Vec::new();
        for a in &mut adj {
            a.sort_unstable();
            list.extend_from_slice(a);
            start.push(list.len() as u32);
        }
        (start, list)
    }

    /// A cloth system on a triangle mesh: stiff springs on edges, weak ones on hinge pairs,
    /// `h²k/m = ratio`.
    struct Cloth {
        sys: System,
        ring: (Vec<u32>, Vec<u32>),
    }

    fn cloth(rng: &mut Lcg, pos: &[Vec3A], tris: &[[u32; 3]], ratio: f32) -> Cloth {
        let n = pos.len();
        let (edges, hinges) = couplings_of(tris);
        let mut pairs = edges.clone();
        pairs.extend_from_slice(&hinges);
        let (edge_op, edge_diag, edge_off) = spring_system(rng, n, &edges, ratio, 1.0, Some(pos));
        // Re-pattern with the hinge pairs too (weak bending-like terms).
        let op = OwnedPattern::build(n, &pairs);
        let p = op.pattern();
        let mut off = vec![Mat3A::ZERO; op.cols.len()];
        for i in 0..n {
            for (k, j) in edge_op.pattern().upper(i) {
                off[p.find(i, j).unwrap()] = edge_off[k];
            }
        }
        let mut diag = edge_diag;
        for &[a, b] in &hinges {
            let k = 1e-3 * ratio * Mat3A::IDENTITY;
            add_block(&p, &mut diag, &mut off, a as usize, a as usize, k).unwrap();
            add_block(&p, &mut diag, &mut off, b as usize, b as usize, k).unwrap();
            add_block(&p, &mut diag, &mut off, a as usize, b as usize, -k).unwrap();
        }
        let sys = System::blocks(op, diag, off);
        Cloth {
            sys,
            ring: ring(n, &edges),
        }
    }

    /// The cloth's hinge couplings (those that are no edge) moved from blocks `s I3` to
    /// scalar couplings, as the world stores them.
    fn split(c: &Cloth, tris: &[[u32; 3]]) -> System {
        let n = c.sys.diag.len();
        let (edges, _) = couplings_of(tris);
        let eop = OwnedPattern::build(n, &edges);
        let ep = eop.pattern();
        let (mut off, mut spairs, mut svals) = (vec![Mat3A::ZERO; eop.cols.len()], vec![], vec![]);
        for i in 0..n {
            for (k, j) in c.sys.op.pattern().upper(i) {
                let m = c.sys.off[k];
                match ep.find(i, j) {
                    Some(e) => off[e] = m,
                    None => {
                        assert_eq!(m, Mat3A::from_diagonal(glam::Vec3::splat(m.x_axis.x)));
                        spairs.push([i as u32, j as u32]);
                        svals.push(m.x_axis.x);
                    }
                }
            }
        }
        let sop = OwnedPattern::build(n, &spairs);
        let mut soff = vec![0.0; sop.cols.len()];
        for (&[i, j], &v) in spairs.iter().zip(&svals) {
            soff[sop.pattern().find(i as usize, j as usize).unwrap()] = v;
        }
        System {
            op: eop,
            diag: c.sys.diag.clone(),
            off,
            sop,
            soff,
        }
    }

    fn built(sys: &System, graph: Option<Graph<'_>>) -> (Mem, Info) {
        let (n, nnz) = (sys.diag.len(), sys.op.cols.len() + sys.soff.len());
        let mut mem = Mem::new(n, nnz);
        let mut scratch = vec![0u32; scratch_len(n, nnz)];
        let info = build(
            &sys.op.pattern(),
            &sys.sop.pattern(),
            graph,
            &mut mem.agg,
            &mut mem.index,
            &mut scratch,
            mem.vectors.len(),
        )
        .unwrap();
        (mem, info)
    }

    fn nn(n: Vec3A) -> Mat3A {
        let n = n.normalize();
        Mat3A::from_cols(n * n.x, n * n.y, n * n.z)
    }

    fn settings(tolerance: f32, max_iterations: u32) -> Settings {
        Settings {
            tolerance,
            max_iterations,
            ..Settings::default()
        }
    }

    /// Solves with block Jacobi and with the multigrid preconditioner; returns both solutions
    /// and stats.
    fn both(
        sys: &System,
        graph: Option<Graph<'_>>,
        filter: Option<&[Mat3A]>,
        b: &[Vec3A],
        z: &[Vec3A],
        tol: f32,
    ) -> ((Vec<Vec3A>, pcg::Stats), (Vec<Vec3A>, pcg::Stats)) {
        let n = b.len();
        let a = sys.matrix();
        let mut w = Scratch::new(n);
        let pj: Vec<Mat3A> = sys.diag.iter().map(|&d| pcg::invert_block(d)).collect();
        let mut xj = z.to_vec();
        let sj = pcg::solve(&a, &pj, filter, b, &mut xj, &settings(tol, 5000), w.work()).unwrap();
        let (mut mem, _) = built(sys, graph);
        let mut mg = Multigrid::new(mem.mem(), a, filter, Options::default()).unwrap();
        let mut xm = z.to_vec();
        let sm = solve_with(
            &a,
            &mut mg,
            filter,
            b,
            &mut xm,
            &settings(tol, 500),
            w.work(),
        )
        .unwrap();
        ((xj, sj), (xm, sm))
    }

    fn rel_diff(x: &[Vec3A], y: &[Vec3A]) -> f64 {
        let num: f64 = x
            .iter()
            .zip(y)
            .map(|(a, b)| f64::from((*a - *b).length_squared()))
            .sum();
        let den: f64 = y.iter().map(|b| f64::from(b.length_squared())).sum();
        (num / den.max(1e-300)).sqrt()
    }

    #[test]
    fn galerkin_coarse_operator_is_pt_a_p() {
        let mut rng = Lcg(1);
        let n = 60;
        let sys = System::random(&mut rng, n, 3.0);
        let mut filter = vec![Mat3A::IDENTITY; n];
        filter[3] = Mat3A::ZERO;
        filter[10] = Mat3A::IDENTITY - nn(Vec3A::new(1.0, 2.0, -0.5));
        let (mut mem, info) = built(&sys, None);
        assert!(info.levels >= 2, "{info:?}");
        let mg =
            Multigrid::new(mem.mem(), sys.matrix(), Some(&filter), Options::default()).unwrap();
        let (l0, l1) = (mg.levels[0], mg.levels[1]);
        let _ = l0;
        let agg = mg.agg0;
        // Dense P̂ᵀ A P̂ with P̂ = S P.
        let a = dense(&sys.diag, &sys.op.pattern(), &sys.off);
        let (m, mc) = (3 * n, 3 * l1.n);
        let mut ph = vec![0.0f64; m * mc];
        for i in 0..n {
            for r in 0..3 {
                for c in 0..3 {
                    ph[(3 * i + r) * mc + 3 * agg[i] as usize + c] = f64::from(filter[i].col(c)[r]);
                }
            }
        }
        let mut ap = vec![0.0; m * mc];
        for r in 0..m {
            for k in 0..m {
                if a[r * m + k] != 0.0 {
                    for c in 0..mc {
                        ap[r * mc + c] += a[r * m + k] * ph[k * mc + c];
                    }
                }
            }
        }
        let mut want = vec![0.0; mc * mc];
        for r in 0..mc {
            for k in 0..m {
                if ph[k * mc + r] != 0.0 {
                    for c in 0..mc {
                        want[r * mc + c] += ph[k * mc + r] * ap[k * mc + c];
                    }
                }
            }
        }
        let ops = &mg.blocks[l1.blk..l1.blk + l1.floats()];
        let cdiag: Vec<Mat3A> = ops[..6 * l1.n].chunks(6).map(sym_to_mat).collect();
        let coff = couplings(&ops[12 * l1.n..]).unwrap().to_vec();
        let cp = coarse_pattern(mg.index, &l1).unwrap();
        let got = dense(&cdiag, &cp, &coff);
        let scale = want.iter().fold(0.0f64, |s, v| s.max(v.abs()));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() <= 1e-5 * scale, "{g} vs {w}");
        }
    }

    #[test]
    fn random_spd_systems_match_block_jacobi() {
        let mut rng = Lcg(2);
        for (n, k) in [
            (1usize, 1.0f32),
            (2, 1.0),
            (9, 1.0),
            (40, 5.0),
            (150, 50.0),
            (300, 500.0),
        ] {
            let sys = System::random(&mut rng, n, k);
            let b: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let z = vec![Vec3A::ZERO; n];
            // (1e-5: at 1e-6 the stiffest system's true residuals stay at 5–6e-6 in f32;
            // the solves used to claim 1e-6 on their drifted recursive residuals)
            let ((xj, sj), (xm, sm)) = both(&sys, None, None, &b, &z, 1e-5);
            assert!(sj.converged && sm.converged, "n={n}: {sj:?} {sm:?}");
            let e = rel_diff(&xm, &xj);
            assert!(e <= 1e-4, "n={n}: {e:e}");
        }
    }

    fn graph(c: &Cloth) -> Graph<'_> {
        Graph {
            start: &c.ring.0,
            adjacency: &c.ring.1,
        }
    }

    /// Pins on a few vertices and oblique contacts (`I − n nᵀ`) on a band.
    fn constraints(rng: &mut Lcg, n: usize) -> Vec<Mat3A> {
        let mut f = vec![Mat3A::IDENTITY; n];
        for i in [0, n / 3, n - 1] {
            f[i] = Mat3A::ZERO;
        }
        for i in (n / 2..n / 2 + n / 10).step_by(2) {
            f[i] = Mat3A::IDENTITY - nn(Vec3A::new(0.3, 1.0, 0.2) + 0.3 * rng.vec());
        }
        f
    }

    /// A 17×17-vertex cloth (random diagonals, stiffness ratio 500) with [`constraints`] as
    /// its filter, and the random stream after them.
    fn constrained_cloth(seed: u64) -> (Lcg, Cloth, Vec<Mat3A>) {
        let mut rng = Lcg(seed);
        let (pos, tris) = grid_cloth(&mut rng, 17, true);
        let c = cloth(&mut rng, &pos, &tris, 500.0);
        let filter = constraints(&mut rng, pos.len());
        (rng, c, filter)
    }

    /// The world stores bending between vertices that share no edge as scalar couplings
    /// (`Scalars`), not blocks: the hierarchy, the Galerkin operators and every smoother must
    /// give the same preconditioner either way (to f32 round-off), filtered or not, when the
    /// scalar couplings are not lumped ([`Options::lumped`], tested below).
    #[test]
    fn scalar_couplings_precondition_as_the_same_blocks_do() {
        let mut rng = Lcg(11);
        let (pos, tris) = grid_cloth(&mut rng, 17, true);
        let c = cloth(&mut rng, &pos, &tris, 500.0);
        let split = split(&c, &tris);
        assert!(!split.soff.is_empty() && split.off.len() < c.sys.off.len());
        let n = pos.len();
        let filter = constraints(&mut rng, n);
        let gauss_seidel = Options {
            smoother: Smoother::GaussSeidel,
            ..Options::V_CYCLE
        };
        let exact = |o: Options| Options { lumped: false, ..o };
        for (f, options) in [None, Some(&filter[..])].into_iter().flat_map(|f| {
            [Options::V_CYCLE, gauss_seidel, Options::default()]
                .into_iter()
                .map(move |o| (f, exact(o)))
        }) {
            let (mut mem_b, info_b) = built(&c.sys, Some(graph(&c)));
            let (mut mem_s, info_s) = built(&split, Some(graph(&c)));
            assert_eq!(info_b.vertices, info_s.vertices);
            assert_eq!(info_b.couplings[1..], info_s.couplings[1..]);
            assert!(info_b.levels >= 2 && info_b.levels == info_s.levels);
            let mut mg_b = Multigrid::new(mem_b.mem(), c.sys.matrix(), f, options).unwrap();
            let mut mg_s = Multigrid::new(mem_s.mem(), split.matrix(), f, options).unwrap();
            let mut t = vec![Vec3A::ZERO; n];
            for _ in 0..3 {
                let r: Vec<Vec3A> = (0..n)
                    .map(|i| f.map_or(rng.vec(), |f| f[i] * rng.vec()))
                    .collect();
                let (mut zb, mut zs) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
                mg_b.apply(&r, &mut zb, &mut t);
                mg_s.apply(&r, &mut zs, &mut t);
                assert!(
                    rel_diff(&zb, &zs) < 1e-4,
                    "{options:?}: {}",
                    rel_diff(&zb, &zs)
                );
            }
            // And the products agree.
            let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let (mut yb, mut ys) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
            c.sys.matrix().mul(&x, &mut yb).unwrap();
            split.matrix().mul(&x, &mut ys).unwrap();
            assert!(rel_diff(&yb, &ys) < 1e-5);
        }
    }

    /// The scalar couplings lumped on the Jacobi smoother's diagonal ([`Options::lumped`]): the
    /// cycle stays symmetric and positive, and preconditions CG about as well as the exact one,
    /// on the world's bending couplings and on stronger ones of either sign (`Ã − A` is positive
    /// semidefinite whatever their sign; leaving them out without the weights would not be);
    /// couplings beyond `LUMP_LIMIT` are smoothed exactly.
    #[test]
    fn lumped_scalar_couplings_keep_the_cycle_symmetric_and_positive() {
        let mut rng = Lcg(12);
        let (pos, tris) = grid_cloth(&mut rng, 17, true);
        let c = cloth(&mut rng, &pos, &tris, 500.0);
        let n = pos.len();
        // Stronger couplings: every scalar coupling made `±s`, `s` a multiple of the mean
        // diagonal entry (with a Laplacian term `s (e_i ∓ e_j)(e_i ∓ e_j)ᵀ`, so the matrix
        // stays SPD): lumped weights of at most 0.3 % (the cloth's own), 4.8 % and 4000 % of
        // the diagonal. The last is beyond `LUMP_LIMIT`: smoothed exactly.
        let with = |factor: f32| {
            let mut sys = split(&c, &tris);
            let mean = sys.diag.iter().map(|d| d.x_axis.x).sum::<f32>() / n as f32;
            for i in 0..n {
                for (k, j) in sys.sop.pattern().upper(i) {
                    let s = factor * mean * if k % 2 == 0 { 1.0 } else { -1.0 };
                    sys.soff[k] += s;
                    for v in [i, j] {
                        sys.diag[v] += Mat3A::from_diagonal(glam::Vec3::splat(s.abs()));
                    }
                }
            }
            sys
        };
        let filter = constraints(&mut rng, n);
        let b: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
        let z = vec![Vec3A::ZERO; n];
        let cases = [
            ("weak", 0.0, true),
            ("moderate", 0.006, true),
            ("strong", 50.0, false),
        ];
        for (name, factor, lumped) in cases {
            let sys = &with(factor);
            for f in [None, Some(&filter[..])] {
                let (mut mem, _) = built(sys, Some(graph(&c)));
                let options = Options::default();
                assert!(options.lumped);
                let mut mg = Multigrid::new(mem.mem(), sys.matrix(), f, options).unwrap();
                assert_eq!(mg.is_lumped, lumped, "{name}");
                // The K-cycle's inner CG makes the default a nonlinear map: positive is what it
                // keeps. The V-cycle is linear: symmetric and positive.
                assert_symmetric_positive(&mut mg, f, &mut rng, false, name);
                let (mut vmem, _) = built(sys, Some(graph(&c)));
                let v_cycle = Options::V_CYCLE;
                let mut mv = Multigrid::new(vmem.mem(), sys.matrix(), f, v_cycle).unwrap();
                assert_eq!(mv.is_lumped, lumped, "{name}");
                assert_symmetric_positive(&mut mv, f, &mut rng, true, name);
                // CG with the lumped cycle against the exact one.
                let a = sys.matrix();
                let mut iterations = [0u32; 2];
                for (k, lumped) in [true, false].into_iter().enumerate() {
                    let (mut mem, _) = built(sys, Some(graph(&c)));
                    let options = Options {
                        lumped,
                        ..Options::default()
                    };
                    let mut mg = Multigrid::new(mem.mem(), a, f, options).unwrap();
                    let mut w = Scratch::new(n);
                    let mut x = z.clone();
                    let s = solve_with(&a, &mut mg, f, &b, &mut x, &settings(1e-5, 500), w.work())
                        .unwrap();
                    assert!(s.converged, "{name}, lumped {lumped}: {s:?}");
                    iterations[k] = s.iterations;
                }
                // measured (unfiltered, filtered): weak [25, 28], [21, 21]; moderate [14, 14]
                // both; strong, exact either way, [12, 12], [12, 12]
                assert!(
                    iterations[0] <= iterations[1] + iterations[1] / 4 + 1,
                    "{name}: {iterations:?}"
                );
            }
        }
    }

    #[test]
    fn cycle_is_symmetric_and_positive() {
        let mut rng = Lcg(3);
        let (pos, tris) = grid_cloth(&mut rng, 17, true);
        let c = cloth(&mut rng, &pos, &tris, 500.0);
        let n = pos.len();
        let filter = constraints(&mut rng, n);
        // The linear cycles (the K-cycle's inner CG makes it a nonlinear map, tested below).
        let variants = [
            Options::V_CYCLE,
            Options {
                smoother: Smoother::Jacobi,
                omega: 0.6,
                cycle: 2,
                ..Options::V_CYCLE
            },
            Options {
                smoother: Smoother::GaussSeidel,
                sweeps: 2,
                cycle: 2,
                coarse_sweeps: 2,
                ..Options::V_CYCLE
            },
            Options {
                smoother: Smoother::Lines,
                ..Options::V_CYCLE
            },
            Options {
                smoother: Smoother::Lines,
                sweeps: 2,
                cycle: 2,
                ..Options::V_CYCLE
            },
        ];
        for (f, options) in [None, Some(&filter[..])]
            .into_iter()
            .flat_map(|f| variants.iter().map(move |o| (f, *o)))
        {
            let (mut mem, info) = built(&c.sys, Some(graph(&c)));
            assert!(info.levels >= 3, "{info:?}");
            let mut mg = Multigrid::new(mem.mem(), c.sys.matrix(), f, options).unwrap();
            assert_symmetric_positive(&mut mg, f, &mut rng, true, &format!("{options:?}"));
        }
    }

    /// The cycle skips the filter's product on the vertices flagged free (`Flagged`): it is the
    /// cycle of the filter's blocks applied everywhere, bit for bit, and a flag that lies (a
    /// held vertex marked free) changes it.
    #[test]
    fn the_free_vertex_flags_are_the_filter() {
        let (mut rng, c, filter) = constrained_cloth(5);
        let n = filter.len();
        let held = filter.iter().filter(|s| **s != Mat3A::IDENTITY).count();
        assert!(held > 10 && held < n / 2, "{held} of {n}");
        let (mut mem, _) = built(&c.sys, Some(graph(&c)));
        let mut mg =
            Multigrid::new(mem.mem(), c.sys.matrix(), Some(&filter), Options::default()).unwrap();
        // a residual with a component the filter takes out, and one that it keeps
        let r: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
        let (mut flagged, mut t) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
        mg.apply(&r, &mut flagged, &mut t);
        let ops = core::mem::take(&mut mg.blocks);
        let mut every = vec![Vec3A::ZERO; n];
        mg.cycle_with(ops, &Blocks(&filter), &r, &mut every, &mut t)
            .unwrap();
        let bits = |z: &[Vec3A]| {
            z.iter()
                .map(|v| v.to_array().map(f32::to_bits))
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&flagged), bits(&every));
        // flag a held vertex free: the cycle no longer filters it
        let i = filter.iter().position(|s| *s != Mat3A::IDENTITY).unwrap();
        free_flags_mut(ops, n).unwrap()[i] = 1;
        let free = free_flags(ops, n).unwrap();
        let mut lying = vec![Vec3A::ZERO; n];
        mg.cycle_with(
            ops,
            &Flagged {
                blocks: &filter,
                free,
            },
            &r,
            &mut lying,
            &mut t,
        )
        .unwrap();
        assert_ne!(bits(&lying), bits(&every));
    }

    /// The coupling blocks are read as `Mat3A` from the pool's first 16-byte boundary on: a
    /// pool lent one, two or three floats off that boundary holds the same operators and
    /// gives the same cycle, bit for bit.
    #[test]
    fn a_pool_off_a_block_boundary_gives_the_same_cycle() {
        let (mut rng, c, filter) = constrained_cloth(11);
        let n = c.sys.diag.len();
        let r: Vec<Vec3A> = (0..n).map(|i| filter[i] * rng.vec()).collect();
        let (mut mem, info) = built(&c.sys, Some(graph(&c)));
        assert!(info.levels >= 2 && info.couplings[1] > 0, "{info:?}");
        let len = mem.blocks.len();
        let mut pool = vec![0.0f32; len + 3];
        let mut cycles = Vec::new();
        for skip in 0..4 {
            let mut memory = mem.mem();
            // `skip` = 0 is the test allocator's own (aligned) pool
            if skip > 0 {
                memory.blocks = &mut pool[skip..skip + len];
            }
            let pointer = memory.blocks.as_ptr() as usize;
            let mut mg =
                Multigrid::new(memory, c.sys.matrix(), Some(&filter), Options::default()).unwrap();
            let (mut z, mut t) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
            mg.apply(&r, &mut z, &mut t);
            assert!(z.iter().all(|v| v.is_finite()));
            cycles.push((pointer % 16, z));
        }
        let offsets: std::collections::BTreeSet<usize> = cycles.iter().map(|c| c.0).collect();
        assert_eq!(
            offsets.len(),
            4,
            "every offset from a boundary: {offsets:?}"
        );
        for (_, z) in &cycles[1..] {
            for (a, b) in z.iter().zip(&cycles[0].1) {
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
        }
    }

    /// Applies the cycle `mg` to random vectors in `range(S)` (`f`: the filter) and asserts
    /// `xᵀ B x > 0` and, when `symmetric` (a linear cycle), `xᵀ B y = yᵀ B x` to 1e-5 of
    /// their scale.
    fn assert_symmetric_positive(
        mg: &mut Multigrid,
        f: Option<&[Mat3A]>,
        rng: &mut Lcg,
        symmetric: bool,
        what: &str,
    ) {
        let n = mg.a.diag.len();
        let mut filtered_vec = || -> Vec<Vec3A> {
            (0..n)
                .map(|i| f.map_or(rng.vec(), |f| f[i] * rng.vec()))
                .collect()
        };
        let dot = |a: &[Vec3A], b: &[Vec3A]| -> f64 {
            a.iter().zip(b).map(|(a, b)| f64::from(a.dot(*b))).sum()
        };
        let mut t = vec![Vec3A::ZERO; n];
        for _ in 0..5 {
            let (x, y) = (filtered_vec(), filtered_vec());
            let (mut bx, mut by) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
            mg.apply(&x, &mut bx, &mut t);
            mg.apply(&y, &mut by, &mut t);
            assert!(dot(&x, &bx) > 0.0 && dot(&y, &by) > 0.0, "{what}");
            if symmetric {
                let (xby, ybx) = (dot(&x, &by), dot(&y, &bx));
                let scale = (dot(&x, &bx).abs() * dot(&y, &by).abs()).sqrt();
                assert!((xby - ybx).abs() <= 1e-5 * scale, "{what}: {xby} vs {ybx}");
            }
        }
    }

    #[test]
    fn cloth_systems_with_pins_and_contacts_match_block_jacobi() {
        let mut rng = Lcg(4);
        let meshes = [
            grid_cloth(&mut rng, 21, false),
            grid_cloth(&mut rng, 23, true),
            disk_cloth(12),
        ];
        for (m, (pos, tris)) in meshes.iter().enumerate() {
            let c = cloth(&mut rng, pos, tris, 100.0);
            let n = pos.len();
            let filter = constraints(&mut rng, n);
            let b: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let z: Vec<Vec3A> = (0..n).map(|_| 0.5 * rng.vec()).collect();
            for f in [None, Some(&filter[..])] {
                let ((xj, sj), (xm, sm)) = both(&c.sys, Some(graph(&c)), f, &b, &z, 1e-5);
                assert!(sj.converged && sm.converged, "mesh {m}: {sj:?} {sm:?}");
                let e = rel_diff(&xm, &xj);
                assert!(e <= 1e-3, "mesh {m}: {e:e}");
                assert!(
                    sm.iterations * 3 < sj.iterations,
                    "mesh {m}: {sm:?} vs {sj:?}"
                );
                if let Some(f) = f {
                    for (i, s) in f.iter().enumerate() {
                        // Constrained components are the prescribed ones.
                        let held = (Mat3A::IDENTITY - *s) * (xm[i] - z[i]);
                        assert!(held.length() <= 1e-6 * (1.0 + z[i].length()), "{i}: {held}");
                    }
                }
            }
        }
    }

    /// An anisotropic cloth (the springs along `u` 100× as stiff as the others): the line
    /// smoother ([`Smoother::Lines`]) solves it in a fraction of block Jacobi's cycles, to the
    /// same solution, with pins and contacts too. Its lines are the grid's rows (along
    /// the strong springs), found from the matrix alone.
    #[test]
    fn lines_smooth_an_anisotropic_cloth_in_few_iterations() {
        let mut rng = Lcg(8);
        let k = 41;
        let (c, n) = ribbed_grid(&mut rng, k);
        let filter = constraints(&mut rng, n);
        let b: Vec<Vec3A> = (0..n)
            .map(|_| Vec3A::new(0.0, 0.0, -1.0) + 0.1 * rng.vec())
            .collect();
        let z = vec![Vec3A::ZERO; n];
        let a = c.sys.matrix();
        for f in [None, Some(&filter[..])] {
            let mut counts = Vec::new();
            let mut solutions = Vec::new();
            for smoother in [Smoother::Jacobi, Smoother::Lines] {
                let options = Options {
                    smoother,
                    ..Options::default()
                };
                let (mut mem, _) = built(&c.sys, Some(graph(&c)));
                let mut mg = Multigrid::new(mem.mem(), a, f, options).unwrap();
                let mut x = z.clone();
                let mut w = Scratch::new(n);
                let st =
                    solve_with(&a, &mut mg, f, &b, &mut x, &settings(1e-5, 500), w.work()).unwrap();
                assert!(st.converged, "{smoother:?}: {st:?}");
                counts.push(st.iterations);
                solutions.push(x);
            }
            // measured 22 against 64, and 25 against 124 with pins and contacts
            assert!(
                5 * counts[1] <= 2 * counts[0],
                "lines {} against block Jacobi {} iterations",
                counts[1],
                counts[0]
            );
            let e = rel_diff(&solutions[1], &solutions[0]);
            assert!(e <= 1e-3, "{e:e}");
        }
    }

    /// CG iterations at tolerance 1e-3 on a pinned and contact-filtered cloth at 21/41/81/161
    /// per side whose system stiffens as it is refined. The linear cycles' counts grow with
    /// the mesh (measured [15, 18, 25, 26] for block Gauss–Seidel with a W-cycle, [23, 33, 53,
    /// 63] for the Jacobi V-cycle: unsmoothed aggregation's piecewise-constant corrections
    /// are scaled wrong, more so the more levels there are); the K-cycle's do not.
    pub(super) fn growth_counts(options: Options) -> Vec<u32> {
        let mut rng = Lcg(5);
        let mut counts = Vec::new();
        for k in [21usize, 41, 81, 161] {
            let (pos, tris) = grid_cloth(&mut rng, k, false);
            // h²k/m grows like k² for a fixed sheet: the system gets stiffer when refined.
            let ratio = 2.0 * (k * k) as f32;
            let c = cloth(&mut rng, &pos, &tris, ratio);
            let n = pos.len();
            let filter = constraints(&mut rng, n);
            // A smooth load (gravity-like) plus a little noise.
            let b: Vec<Vec3A> = (0..n)
                .map(|_| Vec3A::new(0.0, 0.0, -1.0) + 0.1 * rng.vec())
                .collect();
            let z = vec![Vec3A::ZERO; n];
            let (mut mem, _) = built(&c.sys, Some(graph(&c)));
            let a = c.sys.matrix();
            let mut mg = Multigrid::new(mem.mem(), a, Some(&filter), options).unwrap();
            let mut x = z.clone();
            let mut w = Scratch::new(n);
            let st = solve_with(
                &a,
                &mut mg,
                Some(&filter),
                &b,
                &mut x,
                &settings(1e-3, 200),
                w.work(),
            )
            .unwrap();
            assert!(st.converged, "{k}: {st:?}");
            counts.push(st.iterations);
        }
        counts
    }

    #[test]
    fn iterations_grow_slowly_as_the_cloth_is_refined() {
        let counts = growth_counts(Options::FEWEST_ITERATIONS);
        assert!(counts.iter().all(|&c| c <= 30), "{counts:?}");
        assert!(
            counts.windows(2).all(|w| w[1] * 10 <= w[0] * 14),
            "{counts:?}"
        );
        // The plain V-cycle with damped Jacobi (measured [23, 33, 53, 63]).
        let counts = growth_counts(Options::V_CYCLE);
        assert!(counts.iter().all(|&c| c <= 70), "{counts:?}");
        assert!(
            counts.windows(2).all(|w| w[1] * 10 <= w[0] * 17),
            "{counts:?}"
        );
    }

    /// The default K-cycle's count does not grow with the mesh: measured [17, 17, 20, 17] at
    /// 21/41/81/161 per side, where the same V-cycle without the inner CG needs
    /// [23, 33, 53, 63]. Pinned: at most 22 everywhere, and the finest mesh within 1.25× of
    /// the coarsest.
    #[test]
    fn the_k_cycle_needs_as_many_iterations_at_every_size() {
        let counts = growth_counts(Options::default());
        assert!(counts.iter().all(|&c| c <= 22), "{counts:?}");
        let (first, last) = (counts[0], counts[counts.len() - 1]);
        assert!(last * 4 <= first * 5, "{counts:?}");
    }

    /// The K-cycle is not a fixed linear map, but each application is a positive correction:
    /// `rᵀ B(r) > 0` (two CG steps from zero on SPD levels), and it leaves constrained
    /// directions alone; it is deterministic (the same input gives the same bits), also across
    /// the baseline and AVX2 builds of the cycle and of the coarse product (`crate::cpu`).
    #[test]
    fn the_k_cycle_is_positive_filtered_and_deterministic() {
        let (mut rng, c, filter) = constrained_cloth(7);
        let n = filter.len();
        let (mut mem, info) = built(&c.sys, Some(graph(&c)));
        // Level 1 is not an exact dense solve, so it takes the K-cycle's inner CG.
        assert!(
            info.levels >= 3 || (info.levels == 2 && !info.dense),
            "{info:?}"
        );
        let options = Options::default();
        assert!(options.krylov);
        let mut mg = Multigrid::new(mem.mem(), c.sys.matrix(), Some(&filter), options).unwrap();
        let mut t = vec![Vec3A::ZERO; n];
        for _ in 0..5 {
            let r: Vec<Vec3A> = (0..n).map(|i| filter[i] * rng.vec()).collect();
            let (mut z, mut again) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
            mg.apply(&r, &mut z, &mut t);
            mg.apply(&r, &mut again, &mut t);
            assert_eq!(z, again);
            let rz: f64 = r.iter().zip(&z).map(|(a, b)| f64::from(a.dot(*b))).sum();
            assert!(rz > 0.0, "{rz}");
            for (i, (s, zi)) in filter.iter().zip(&z).enumerate() {
                let held = (Mat3A::IDENTITY - *s) * *zi;
                assert!(held.length() <= 1e-6 * (1.0 + zi.length()), "{i}: {held}");
            }
            #[cfg(target_arch = "x86_64")]
            if crate::cpu::avx2() {
                let (mut base, mut wide) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
                mg.cycle_dispatch(&r, &mut base, &mut t).unwrap();
                // SAFETY: the processor supports AVX2 (checked above).
                unsafe { mg.cycle_avx2(&r, &mut wide, &mut t) }.unwrap();
                assert!(base
                    .iter()
                    .zip(&wide)
                    .all(|(a, b)| a.to_array() == b.to_array()));
                assert_eq!(z, wide);
            }
        }
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            let lv = mg.levels[1];
            let (diag, _, off, rs, cols) = level_ops(mg.blocks, mg.index, &lv).unwrap();
            let x: Vec<Vec3A> = (0..lv.n).map(|_| rng.vec()).collect();
            let (mut y, mut wide) = (vec![Vec3A::ZERO; lv.n], vec![Vec3A::ZERO; lv.n]);
            coarse_mul_body(diag, rs, cols, off, &x, &mut y).unwrap();
            // SAFETY: as above.
            unsafe { coarse_mul_avx2(diag, rs, cols, off, &x, &mut wide) }.unwrap();
            assert!(y
                .iter()
                .zip(&wide)
                .all(|(a, b)| a.to_array() == b.to_array()));
        }
    }

    /// `renew` after some vertices' filters changed (contacts let go, others caught) gives the
    /// operators `new` gives for the new filter, bit for bit: the finest level's inverses,
    /// every coarse level and the coarsest factor; a changed vertex out of range is an error.
    #[test]
    fn renew_after_a_local_filter_change_is_new_bit_for_bit() {
        let (mut rng, c, before) = constrained_cloth(29);
        let n = before.len();
        let options = Options::default();
        // let go of every other held vertex, and catch a few free ones
        let mut after = before.clone();
        let mut changed = Vec::new();
        for i in 0..n {
            let held = before[i] != Mat3A::IDENTITY;
            if (held && i % 2 == 0) || (!held && i % 37 == 5) {
                after[i] = if held {
                    Mat3A::IDENTITY
                } else {
                    Mat3A::IDENTITY - nn(rng.vec() + Vec3A::Y)
                };
                changed.push(i as u32);
            }
        }
        assert!(changed.len() > 5);
        let (mut renewed, mut fresh, info) =
            assert_renew_is_new(&c, Some(&before), &after, &changed);
        assert!(info.levels >= 3, "{info:?}");
        assert_eq!(
            renewed
                .dense
                .iter()
                .map(|x| x.to_bits())
                .collect::<Vec<_>>(),
            fresh.dense.iter().map(|x| x.to_bits()).collect::<Vec<_>>()
        );
        // and the cycles agree
        let r: Vec<Vec3A> = (0..n).map(|i| after[i] * rng.vec()).collect();
        let mut t = vec![Vec3A::ZERO; n];
        let (mut z1, mut z2) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
        let mut a =
            Multigrid::renew(renewed.mem(), c.sys.matrix(), Some(&after), &[], options).unwrap();
        a.apply(&r, &mut z1, &mut t);
        let mut b = Multigrid::new(fresh.mem(), c.sys.matrix(), Some(&after), options).unwrap();
        b.apply(&r, &mut z2, &mut t);
        assert_eq!(z1, z2);
        let bad = [n as u32];
        assert_eq!(
            Multigrid::renew(renewed.mem(), c.sys.matrix(), Some(&after), &bad, options).err(),
            Some(MgError::LengthMismatch)
        );
    }

    /// The World renews an unconstrained solve's operators for one that catches a few
    /// vertices (`contacts::engage`): from a setup without a filter, `renew` with one is `new`
    /// with it, bit for bit (its free-vertex flags included).
    #[test]
    fn renew_after_an_unconstrained_setup_is_new_bit_for_bit() {
        let (mut rng, c, _) = constrained_cloth(31);
        let n = c.sys.diag.len();
        let mut after = vec![Mat3A::IDENTITY; n];
        let changed: Vec<u32> = (0..n as u32).filter(|i| i % 23 == 4).collect();
        for &i in &changed {
            after[i as usize] = Mat3A::IDENTITY - nn(rng.vec() + Vec3A::Z);
        }
        assert_renew_is_new(&c, None, &after, &changed);
    }

    /// With the line smoother, `renew` factors again only the lines of the vertices whose
    /// filter changed, and that is `new` bit for bit, the cycle's output too.
    #[test]
    fn renew_of_lines_is_new_bit_for_bit() {
        let mut rng = Lcg(33);
        let (c, n) = ribbed_grid(&mut rng, 17);
        let before = constraints(&mut rng, n);
        let mut after = before.clone();
        let changed: Vec<u32> = (0..n as u32).filter(|i| i % 19 == 3).collect();
        for &i in &changed {
            let i = i as usize;
            after[i] = if before[i] == Mat3A::IDENTITY {
                Mat3A::IDENTITY - nn(rng.vec() + Vec3A::Z)
            } else {
                Mat3A::IDENTITY
            };
        }
        let options = Options {
            smoother: Smoother::Lines,
            ..Options::default()
        };
        let (mut renewed, mut fresh, _) =
            assert_renew_is_new_with(&c, Some(&before), &after, &changed, options);
        let r: Vec<Vec3A> = (0..n).map(|i| after[i] * rng.vec()).collect();
        let mut t = vec![Vec3A::ZERO; n];
        let (mut z1, mut z2) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
        let mut a =
            Multigrid::renew(renewed.mem(), c.sys.matrix(), Some(&after), &[], options).unwrap();
        assert!(a.lines > 0 && a.lines < n, "{} lines", a.lines);
        a.apply(&r, &mut z1, &mut t);
        let mut b = Multigrid::new(fresh.mem(), c.sys.matrix(), Some(&after), options).unwrap();
        b.apply(&r, &mut z2, &mut t);
        assert_eq!(z1, z2);
    }

    /// The line smoother's probe (`Multigrid::new_probed`): from nothing it decides nothing and
    /// keeps the lines (the cycle the unprobed one, bit for bit); over setups of a cloth whose
    /// lines are sound its power iterate stays below the limit and the lines stay; an iterate
    /// whose growth reaches the limit drops them for block Jacobi, the same cycle as
    /// [`Smoother::Jacobi`]'s bit for bit, and so do the re-setups after it.
    #[test]
    fn a_probe_that_measures_growth_drops_the_lines() {
        let mut rng = Lcg(34);
        let (c, n) = ribbed_grid(&mut rng, 17);
        let filter = constraints(&mut rng, n);
        let f = Some(&filter[..]);
        let a = c.sys.matrix();
        let lines = Options {
            smoother: Smoother::Lines,
            ..Options::default()
        };
        let r: Vec<Vec3A> = (0..n).map(|i| filter[i] * rng.vec()).collect();
        let mut t = vec![Vec3A::ZERO; n];
        let cycle = |mg: &mut Multigrid<'_>, t: &mut [Vec3A]| {
            let mut z = vec![Vec3A::ZERO; n];
            mg.apply(&r, &mut z, t);
            z
        };
        let (mut x, mut scratch) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
        let (mut mem, _) = built(&c.sys, Some(graph(&c)));
        let (mut plain, _) = built(&c.sys, Some(graph(&c)));
        let unprobed = cycle(
            &mut Multigrid::new(plain.mem(), a, f, lines).unwrap(),
            &mut t,
        );
        for setup in 0..12 {
            let probe = Probe {
                x: &mut x,
                t: &mut scratch,
            };
            let mut mg = Multigrid::new_probed(mem.mem(), a, f, lines, Some(probe)).unwrap();
            assert!(
                mg.lines > 0 && mg.lines < n,
                "setup {setup}: {} lines",
                mg.lines
            );
            if setup == 0 {
                assert_eq!(cycle(&mut mg, &mut t), unprobed);
            }
        }
        // its growth is what the iterate's norm says: ten times it is past any limit
        for xi in x.iter_mut() {
            *xi *= 10.0;
        }
        let probe = Probe {
            x: &mut x,
            t: &mut scratch,
        };
        let mut mg = Multigrid::new_probed(mem.mem(), a, f, lines, Some(probe)).unwrap();
        assert_eq!(mg.lines, 0);
        let dropped = cycle(&mut mg, &mut t);
        let jacobi = Options {
            smoother: Smoother::Jacobi,
            ..lines
        };
        let (mut other, _) = built(&c.sys, Some(graph(&c)));
        assert_eq!(
            dropped,
            cycle(
                &mut Multigrid::new(other.mem(), a, f, jacobi).unwrap(),
                &mut t
            )
        );
        let mut again = Multigrid::renew(mem.mem(), a, f, &[], lines).unwrap();
        assert_eq!(again.lines, 0);
        assert_eq!(cycle(&mut again, &mut t), dropped);
    }

    /// A `k × k` grid cloth (unrotated, springs of 400) made [`ribbed`], and its vertex count.
    fn ribbed_grid(rng: &mut Lcg, k: usize) -> (Cloth, usize) {
        let (pos, tris) = grid_cloth(rng, k, false);
        (ribbed(cloth(rng, &pos, &tris, 400.0), &pos), pos.len())
    }

    /// `c` with its springs along `u` (between vertices of one row of `pos`) 100× as stiff:
    /// each such coupling block, and its share of the two diagonal blocks, times 100.
    fn ribbed(mut c: Cloth, pos: &[Vec3A]) -> Cloth {
        let p = c.sys.op.pattern();
        for i in 0..pos.len() {
            for (k, j) in p.upper(i) {
                let d = pos[j] - pos[i];
                if d.x.abs() > 0.9 * d.length() {
                    let b = 99.0 * c.sys.off[k];
                    c.sys.off[k] += b;
                    c.sys.diag[i] -= b;
                    c.sys.diag[j] -= b;
                }
            }
        }
        c
    }

    /// Sets up `c`'s operators for the filter `before`, renews them for `after` (which differs
    /// at `changed`) and asserts the pool is what a fresh setup for `after` makes, bit for bit.
    /// Returns the renewed memory, the fresh one and the hierarchy's shape.
    fn assert_renew_is_new(
        c: &Cloth,
        before: Option<&[Mat3A]>,
        after: &[Mat3A],
        changed: &[u32],
    ) -> (Mem, Mem, Info) {
        assert_renew_is_new_with(c, before, after, changed, Options::default())
    }

    fn assert_renew_is_new_with(
        c: &Cloth,
        before: Option<&[Mat3A]>,
        after: &[Mat3A],
        changed: &[u32],
        options: Options,
    ) -> (Mem, Mem, Info) {
        let (mut renewed, info) = built(&c.sys, Some(graph(c)));
        let mut fresh = built(&c.sys, Some(graph(c))).0;
        Multigrid::new(renewed.mem(), c.sys.matrix(), before, options).unwrap();
        Multigrid::renew(renewed.mem(), c.sys.matrix(), Some(after), changed, options).unwrap();
        Multigrid::new(fresh.mem(), c.sys.matrix(), Some(after), options).unwrap();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&renewed.blocks), bits(&fresh.blocks));
        (renewed, fresh, info)
    }

    #[test]
    fn too_small_memory_and_wrong_sizes_are_errors() {
        let mut rng = Lcg(6);
        let sys = System::random(&mut rng, 50, 1.0);
        let (n, nnz) = (50, sys.op.cols.len());
        let mut index = vec![0u32; index_len(n, nnz) - 1];
        let mut scratch = vec![0u32; scratch_len(n, nnz)];
        let mut agg = vec![0u32; n];
        assert_eq!(
            build(
                &sys.op.pattern(),
                &sys.sop.pattern(),
                None,
                &mut agg,
                &mut index,
                &mut scratch,
                usize::MAX
            ),
            Err(MgError::MemoryTooSmall)
        );
        let mut mem = Mem::new(n, nnz);
        assert_eq!(
            Multigrid::new(mem.mem(), sys.matrix(), None, Options::default()).err(),
            Some(MgError::NotBuilt)
        );
        let (mut mem, _) = built(&sys, None);
        let other = System::random(&mut rng, 49, 1.0);
        assert_eq!(
            Multigrid::new(mem.mem(), other.matrix(), None, Options::default()).err(),
            Some(MgError::NotBuilt)
        );
        let f = vec![Mat3A::IDENTITY; n - 1];
        assert_eq!(
            Multigrid::new(mem.mem(), sys.matrix(), Some(&f), Options::default()).err(),
            Some(MgError::LengthMismatch)
        );
    }
}
