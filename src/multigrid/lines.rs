//! The finest level's lines ([`Smoother::Lines`]): vertices chained along couplings that
//! dominate their others, and the exact solve of the smoothing operator's block-tridiagonal
//! part along each line.
//!
//! Why: block Jacobi relaxes each vertex against its neighbours' old values, so an error that
//! is smooth along a strong coupling and rough across a weak one (an anisotropic fabric: its
//! ribs, its stiff direction) is barely reduced, and the aggregates' piecewise constant
//! corrections do not reach it either. Solving along lines of strong couplings removes it at
//! once: the textbook cure for anisotropy (line relaxation). Measured in weft on weft-bench's
//! scene (docs/PERFORMANCE.md, "Line smoothing").
//!
//! The lines are made at every full setup from the matrix itself ([`build`]): each vertex
//! ranks its couplings by `‖A_ij‖² / (tr A_ii tr A_jj)` (scale-free); two vertices are linked
//! where each is among the other's two strongest, the link is at least [`WEAK`] of either end's
//! strongest, and it is [`DOMINANT`] times either end's third strongest, the strongest a line
//! through the vertex leaves out; the links (at most two per vertex) are walked into paths,
//! and a closed loop is cut where the walk meets its start. No graph or geometry is needed,
//! and a cloth whose strong direction turns (a draped, rotated fabric) has lines that follow
//! it. Where no coupling dominates (an isotropic or a weave-like material, whose couplings along
//! and across are alike) a vertex stays alone, and a matrix with no link at all is smoothed by
//! block Jacobi itself: lines across couplings as strong as theirs made the smoother
//! divergent (measured: 225 CG iterations a step on the `woven` cell at 41×41 with every mutual
//! link kept, block Jacobi 37).
//!
//! The factor is the block Thomas algorithm (`T = L D Lᵀ`): per line `S₁ = D̃₁`,
//! `Cₖ = Sₖ⁻¹ B̃ₖ`, `Sₖ₊₁ = D̃ₖ₊₁ − B̃ₖᵀ Cₖ`, with `D̃`, `B̃` the filtered blocks, so that a
//! pinned or contact direction stays decoupled. `D̃` is the diagonal block of `Ã = A − H + |H|`
//! (the scalar couplings lumped, as the Jacobi smoother's when they are weak: their weights on
//! the diagonal) whether or not the residuals lump them: `T` is then the line part of `Ã`, and
//! out of a flat cloth's plane, where only bending couples, the line part of `A` alone (a
//! plate's `[−8, 20, −8]` along a line) leaves `λ_max(T⁻¹A) ≈ 4` and the smoother diverged
//! (a 33 × 33 drape of 5 mm edges: 151 CG iterations a step and 53 of 120 solves unconverged,
//! against block Jacobi's 28 and none; with the weights, 23 and none). The solve runs forward
//! (`yₖ = rₖ − Cₖ₋₁ᵀ yₖ₋₁`) and back (`zₖ = Sₖ⁻¹ yₖ − Cₖ zₖ₊₁`) along each line, [`GROUP`]
//! lines of equal length interleaved so that their independent chains fill the processor's
//! pipeline (one line at a time, the sweep waits on each 3×3 product before the next). A vertex
//! alone on its line keeps block Jacobi's damping (its `S⁻¹` is scaled by `single`, [`factor`]).

use super::cycle::{filtered_coupling, held, inverse_sym, sym_mul, sym_to_mat};
use super::*;

/// Lines solved side by side in one sweep.
const GROUP: usize = 8;

/// No vertex, no coupling.
const END: u32 = u32::MAX;

/// In a coupling code: the block is `off[k]ᵀ` (the line runs from the higher vertex to the
/// lower).
const FLIPPED: u32 = 1 << 31;

/// In a vertex's link flags while the lines are made: not a link.
const CUT: u32 = u32::MAX;

/// A link is weak, and cut, below this fraction of either end's strongest coupling: on
/// weft-bench's `stripes` sheet (2.8:1) the lines are then its rows; with every mutual link
/// kept, a row's end vertex turned into the next row along the border (lines of 42 at 21×21)
/// and the CG took 11.0 iterations a step against 9.5 (0.5: 9.8).
const WEAK: f32 = 0.3;

/// A link is cut unless its strength is this many times either end's third strongest
/// coupling. On weft-bench's scene at 41×41 (CG iterations a step, block Jacobi → lines):
/// at 1.5 the `woven` and `iso1000` cells kept 160 links along their borders and took 77 and
/// 139 iterations (block Jacobi 39 and 38); at 3 they keep none, and `stripes` and `ribbed`
/// keep their rows (31 → 18, 55 → 29); at 6 `stripes` lost most of its links (24).
const DOMINANT: f32 = 3.0;

/// In a line's start: the line is to be factored again ([`factor`] with `only`).
const DIRTY: u32 = 1 << 31;

/// Where the lines live in the aligned blocks pool (offsets in `f32`s): the factor's `C` blocks
/// (a `Mat3A` per position), then the vertices in line order, the coupling of each position to
/// the next, each vertex's line, and the lines' starts.
#[derive(Clone, Copy)]
pub(super) struct Layout {
    c: usize,
    order: usize,
    code: usize,
    line_of: usize,
    starts: usize,
    /// One word: how many lines [`build`] made.
    count: usize,
    n: usize,
}

impl Layout {
    pub(super) fn new(n: usize) -> Self {
        let c = (FINE_FLOATS * n).next_multiple_of(4);
        let order = c + 12 * n;
        Layout {
            c,
            order,
            code: order + n,
            line_of: order + 2 * n,
            starts: order + 3 * n,
            count: order + 4 * n + 1,
            n,
        }
    }
}

fn words(blocks: &[f32], at: usize, len: usize) -> Result<&[u32], MgError> {
    Ok(bytemuck::cast_slice(part(blocks, at, len)?))
}

fn words_mut(blocks: &mut [f32], at: usize, len: usize) -> Result<&mut [u32], MgError> {
    Ok(bytemuck::cast_slice_mut(part_mut(blocks, at, len)?))
}

fn mats(blocks: &[f32], at: usize, len: usize) -> Result<&[Mat3A], MgError> {
    bytemuck::try_cast_slice(part(blocks, at, 12 * len)?).map_err(|_| MgError::Internal)
}

fn mats_mut(blocks: &mut [f32], at: usize, len: usize) -> Result<&mut [Mat3A], MgError> {
    bytemuck::try_cast_slice_mut(part_mut(blocks, at, 12 * len)?).map_err(|_| MgError::Internal)
}

/// The block `A_ij` a coupling code names (`off[k]`, or its transpose).
fn block(off: &[Mat3A], code: u32) -> Result<Mat3A, MgError> {
    let b = *off
        .get((code & !FLIPPED) as usize)
        .ok_or(MgError::LengthMismatch)?;
    Ok(if code & FLIPPED != 0 {
        b.transpose()
    } else {
        b
    })
}

/// A coupling's strength, `‖A_ij‖²_F / (tr A_ii · tr A_jj)`: scale-free, so a heavy or stiff
/// patch does not draw the lines of its lighter neighbours.
fn strength(b: &Mat3A, di: &Mat3A, dj: &Mat3A) -> f32 {
    let tr = |d: &Mat3A| d.x_axis.x + d.y_axis.y + d.z_axis.z;
    let norm = b.x_axis.length_squared() + b.y_axis.length_squared() + b.z_axis.length_squared();
    let scale = tr(di) * tr(dj);
    if scale > 0.0 && norm.is_finite() && scale.is_finite() {
        norm / scale
    } else {
        0.0
    }
}

/// How many lines [`build`] made last (kept in the pool for [`Multigrid::renew`]).
pub(super) fn count(blocks: &[f32], layout: &Layout) -> Result<usize, MgError> {
    let c = *words(blocks, layout.count, 1)?
        .first()
        .ok_or(MgError::Internal)? as usize;
    if c > layout.n {
        return Err(MgError::NotBuilt);
    }
    Ok(c)
}

/// Drops the lines [`build`] made (a probe found them not positive, `Multigrid::new_probed`):
/// the level is smoothed by block Jacobi, and so are the re-setups of the same matrix
/// ([`count`] reads no lines).
pub(super) fn forget(blocks: &mut [f32], layout: &Layout) -> Result<(), MgError> {
    *words_mut(blocks, layout.count, 1)?
        .first_mut()
        .ok_or(MgError::Internal)? = layout.n as u32;
    Ok(())
}

/// One of a vertex's ranked couplings while the lines are made.
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct Ranked {
    strength: f32,
    partner: u32,
    code: u32,
}

/// No coupling.
const UNRANKED: Ranked = Ranked {
    strength: 0.0,
    partner: END,
    code: END,
};

/// A vertex's ranking while the lines are made, in the words of its `C` block (free until
/// the factor): its two strongest couplings, the strength of the third, and whether each of
/// the two is cut (not a link).
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
struct Rank {
    best: [Ranked; 2],
    third: f32,
    cut: [u32; 2],
    unused: [u32; 3],
}

impl Rank {
    const EMPTY: Rank = Rank {
        best: [UNRANKED; 2],
        third: 0.0,
        cut: [CUT; 2],
        unused: [0; 3],
    };

    /// Ranks the coupling `code` to `partner` of strength `s` (ties keep the earlier one:
    /// deterministic).
    fn keep(&mut self, partner: usize, s: f32, code: u32) {
        let entry = Ranked {
            strength: s,
            partner: partner as u32,
            code,
        };
        let [first, second] = &mut self.best;
        let pushed = if first.partner == END || s > first.strength {
            let pushed = (second.partner != END).then_some(second.strength);
            *second = *first;
            *first = entry;
            pushed
        } else if second.partner == END || s > second.strength {
            let pushed = (second.partner != END).then_some(second.strength);
            *second = entry;
            pushed
        } else {
            Some(s)
        };
        if let Some(third) = pushed.filter(|&t| t > self.third) {
            self.third = third;
        }
    }

    /// Whether its coupling of strength `s` is strong enough to be a link ([`WEAK`],
    /// [`DOMINANT`]).
    fn strong(&self, s: f32) -> bool {
        s >= WEAK * self.best[0].strength && s >= DOMINANT * self.third
    }

    /// Whether `partner` is among its two strongest.
    fn ranks(&self, partner: usize) -> bool {
        self.best.iter().any(|r| r.partner == partner as u32)
    }

    /// Its links (partner, code), cut ones left out.
    fn links(&self) -> [(u32, u32); 2] {
        let link = |r: &Ranked, cut: u32| {
            if cut != CUT && r.partner != END {
                (r.partner, r.code)
            } else {
                (END, END)
            }
        };
        let ([a, b], [cut_a, cut_b]) = (&self.best, self.cut);
        [link(a, cut_a), link(b, cut_b)]
    }
}

/// Chains the vertices of `a` into lines (see the module docs), into `blocks` at `layout`.
/// Returns the number of lines (also kept, [`count`]): `n` where no vertex is linked.
/// Deterministic; one pass over the couplings and two over the vertices.
pub(super) fn build(
    a: &BlockMatrix<'_>,
    blocks: &mut [f32],
    layout: &Layout,
) -> Result<usize, MgError> {
    let n = layout.n;
    let region = words_mut(blocks, layout.c, layout.count + 1 - layout.c)?;
    let (best, rest) = region.split_at_mut(12 * n);
    let (order, rest) = rest.split_at_mut(n);
    let (code, rest) = rest.split_at_mut(n);
    let (line_of, rest) = rest.split_at_mut(n);
    let (starts, count) = rest.split_at_mut(n + 1);
    let ranks: &mut [Rank] = bytemuck::try_cast_slice_mut(best).map_err(|_| MgError::Internal)?;
    ranks.fill(Rank::EMPTY);
    for (i, di) in a.diag.iter().enumerate() {
        for (k, j) in a.pattern.upper(i) {
            let dj = a.diag.get(j).ok_or(MgError::LengthMismatch)?;
            let b = a.off.get(k).ok_or(MgError::LengthMismatch)?;
            let s = strength(b, di, dj);
            ranks
                .get_mut(i)
                .ok_or(MgError::Internal)?
                .keep(j, s, k as u32);
            let flipped = k as u32 | FLIPPED;
            ranks
                .get_mut(j)
                .ok_or(MgError::LengthMismatch)?
                .keep(i, s, flipped);
        }
    }
    // A link is mutual (each end among the other's two), not weak beside either end's
    // strongest ([`WEAK`]) and dominant over either end's third ([`DOMINANT`]); the others
    // stay cut. The checks read only rankings, which no cut changes, so their order does not
    // matter.
    let mut linked = false;
    for i in 0..n {
        let ri = *ranks.get(i).ok_or(MgError::Internal)?;
        for (slot, r) in ri.best.iter().enumerate() {
            let link = r.partner != END
                && ri.strong(r.strength)
                && ranks
                    .get(r.partner as usize)
                    .is_some_and(|q| q.ranks(i) && q.strong(r.strength));
            linked |= link;
            if let Some(cut) = ranks.get_mut(i).and_then(|q| q.cut.get_mut(slot)) {
                *cut = if link { 0 } else { CUT };
            }
        }
    }
    if !linked {
        *count.first_mut().ok_or(MgError::Internal)? = n as u32;
        return Ok(n);
    }
    let links = |ranks: &[Rank], i: usize| ranks.get(i).map_or([(END, END); 2], Rank::links);
    line_of.fill(END);
    let (mut lines, mut pos) = (0usize, 0usize);
    // Paths from their ends first (a vertex with at most one link), then what is left: loops,
    // cut where the walk comes back to its start.
    for pass in 0..2 {
        for first in 0..n {
            if line_of.get(first) != Some(&END) {
                continue;
            }
            let degree = links(ranks, first)
                .iter()
                .filter(|(p, _)| *p != END)
                .count();
            if pass == 0 && degree > 1 {
                continue;
            }
            *starts.get_mut(lines).ok_or(MgError::Internal)? = pos as u32;
            let mut cur = first;
            loop {
                *line_of.get_mut(cur).ok_or(MgError::Internal)? = lines as u32;
                *order.get_mut(pos).ok_or(MgError::Internal)? = cur as u32;
                let next = links(ranks, cur)
                    .into_iter()
                    .find(|&(p, _)| p != END && line_of.get(p as usize) == Some(&END));
                *code.get_mut(pos).ok_or(MgError::Internal)? = next.map_or(END, |(_, c)| c);
                pos += 1;
                match next {
                    Some((p, _)) => cur = p as usize,
                    None => break,
                }
            }
            lines += 1;
        }
    }
    if pos != n {
        return Err(MgError::Internal);
    }
    *starts.get_mut(lines).ok_or(MgError::Internal)? = n as u32;
    *count.first_mut().ok_or(MgError::Internal)? = lines as u32;
    Ok(lines)
}

/// Factors the lines (see the module docs) of the smoothing operator whose filtered diagonal
/// blocks `diagonal` gives (from the pool, which it may read), its couplings `off` filtered by
/// `filter` on both sides: `Sₖ⁻¹` into `inv` (6 floats per position) and `Cₖ` into `blocks` at
/// `layout`. A vertex alone on its line gets `single · D̃⁻¹` (the line damping times `single`
/// is block Jacobi's). With `only`, the lines flagged [`DIRTY`] (their flags cleared).
#[allow(clippy::too_many_arguments)]
pub(super) fn factor(
    off: &[Mat3A],
    filter: Option<&[Mat3A]>,
    diagonal: impl Fn(&[f32], usize) -> Result<Mat3A, MgError>,
    blocks: &mut [f32],
    layout: &Layout,
    lines: usize,
    single: f32,
    only: bool,
) -> Result<(), MgError> {
    let n = layout.n;
    for l in 0..lines {
        let starts = words_mut(blocks, layout.starts, n + 1)?;
        let (Some(&a), Some(&b)) = (starts.get(l), starts.get(l + 1)) else {
            return Err(MgError::Internal);
        };
        if only && a & DIRTY == 0 {
            continue;
        }
        if let Some(f) = starts.get_mut(l) {
            *f = a & !DIRTY;
        }
        let (start, end) = ((a & !DIRTY) as usize, (b & !DIRTY) as usize);
        let mut carried = Mat3A::ZERO;
        for t in start..end {
            let order = words(blocks, layout.order, n)?;
            let i = *order.get(t).ok_or(MgError::Internal)? as usize;
            let next = order.get(t + 1).copied();
            let code = *words(blocks, layout.code, n)?
                .get(t)
                .ok_or(MgError::Internal)?;
            let d = diagonal(blocks, i)?;
            let mut schur = d - carried;
            if t > start && !kept(&schur, &d) {
                // the line is cut before `i`: decoupled from the vertex before it
                schur = d;
                if let Some(c) = mats_mut(blocks, layout.c, n)?.get_mut(t - 1) {
                    *c = Mat3A::ZERO;
                }
            }
            let mut inv = inverse_sym(&schur);
            if end == start + 1 {
                inv = inv.map(|v| v * single);
            }
            part_mut(blocks, 6 * t, 6)?.copy_from_slice(&inv);
            let c = if code == END {
                carried = Mat3A::ZERO;
                Mat3A::ZERO
            } else {
                let j = next.ok_or(MgError::Internal)? as usize;
                let bt = filtered_coupling(held(filter, i), &block(off, code)?, held(filter, j));
                let c = sym_to_mat(&inv) * bt;
                carried = bt.transpose() * c;
                c
            };
            *mats_mut(blocks, layout.c, n)?
                .get_mut(t)
                .ok_or(MgError::Internal)? = c;
        }
    }
    Ok(())
}

/// Whether the Schur complement `schur` of a line's block at a vertex with diagonal block `d`
/// is kept: positive definite (its leading minors, in `f64`), and every diagonal entry at least
/// [`KEPT`] of `d`'s (not numerically singular). `A`'s block-tridiagonal part along a line need
/// not be positive: bending couples a vertex to the next but one with the sign opposite to the
/// next (a plate's `[1, −4, 6, −4, 1]`), and the tridiagonal `[−4, 6, −4]` is indefinite;
/// solved through, it made the smoother useless (a flat cloth falling under gravity, bending its
/// only out-of-plane coupling, took 89 CG iterations for a solve block Jacobi did in 2). Where
/// the complement would fall below it, the line is cut there.
fn kept(schur: &Mat3A, d: &Mat3A) -> bool {
    let [m00, m10, m20, m01, m11, m21, m02, m12, m22] = schur.to_cols_array().map(f64::from);
    let (xy, xz, yz) = (0.5 * (m01 + m10), 0.5 * (m02 + m20), 0.5 * (m12 + m21));
    let minor2 = m00 * m11 - xy * xy;
    let det = m00 * (m11 * m22 - yz * yz) - xy * (xy * m22 - yz * xz) + xz * (xy * yz - m11 * xz);
    let floor = |m: f64, dd: f32| m >= f64::from(KEPT) * f64::from(dd);
    m00 > 0.0
        && minor2 > 0.0
        && det > 0.0
        && floor(m00, d.x_axis.x)
        && floor(m11, d.y_axis.y)
        && floor(m22, d.z_axis.z)
}

/// The least fraction of a vertex's diagonal block that its line's Schur complement keeps
/// ([`kept`]): only a complement `f32` cannot invert well is cut. At the free end of a chain
/// of springs the complement is all that holds the chain against a shift along itself, the
/// error the line solve is for, and it is small: at 0.25 every row of weft-bench's `ribbed`
/// sheet was cut before its last vertex (the complement there 0.17 of the diagonal at 41×41),
/// and the CG took 13.1 / 24.2 / 44.0 iterations a step at 21 / 41 / 81 per side against
/// 9.3 / 16.3 / 25.6 now; the drapes, the falling cloths and `stripes` did not change.
const KEPT: f32 = 1e-3;

/// Flags the lines of the vertices `changed` [`DIRTY`] for [`factor`] with `only`.
pub(super) fn mark(blocks: &mut [f32], layout: &Layout, changed: &[u32]) -> Result<(), MgError> {
    let n = layout.n;
    for &v in changed {
        let l = *words(blocks, layout.line_of, n)?
            .get(v as usize)
            .ok_or(MgError::LengthMismatch)? as usize;
        *words_mut(blocks, layout.starts, n + 1)?
            .get_mut(l)
            .ok_or(MgError::Internal)? |= DIRTY;
    }
    Ok(())
}

/// `z ← ω T̃⁻¹ t`, or `z += ω T̃⁻¹ t` with `add` (`t` filtered, and so the result; `t` is
/// scratch: it holds the forward sweep on return). Inlined into the cycle, so that it is
/// compiled with the cycle's instruction set.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn solve(
    blocks: &[f32],
    layout: &Layout,
    lines: usize,
    t: &mut [Vec3A],
    z: &mut [Vec3A],
    omega: f32,
    add: bool,
) -> Result<(), MgError> {
    let n = layout.n;
    let order = words(blocks, layout.order, n)?;
    let starts = words(blocks, layout.starts, lines + 1)?;
    let c = mats(blocks, layout.c, n)?;
    let inv = part(blocks, 0, 6 * n)?;
    let (Some(order), Some(c), Some(t), Some(z)) =
        (order.get(..n), c.get(..n), t.get_mut(..n), z.get_mut(..n))
    else {
        return Err(MgError::LengthMismatch);
    };
    let mut put = |i: usize, v: Vec3A| -> Result<(), MgError> {
        let zi = z.get_mut(i).ok_or(MgError::LengthMismatch)?;
        *zi = if add { *zi + omega * v } else { omega * v };
        Ok(())
    };
    let mut l0 = 0;
    while l0 < lines {
        let start = |l: usize| starts.get(l).map(|&s| s as usize).ok_or(MgError::Internal);
        let (s0, e0) = (start(l0)?, start(l0 + 1)?);
        let len = e0.checked_sub(s0).ok_or(MgError::Internal)?;
        // the next lines of the same length, side by side
        let mut base = [0usize; GROUP];
        let mut group = 0;
        while group < GROUP && l0 + group < lines {
            let s = start(l0 + group)?;
            if start(l0 + group + 1)? != s + len || s + len > n {
                break;
            }
            *base.get_mut(group).ok_or(MgError::Internal)? = s;
            group += 1;
        }
        if group == 0 || len == 0 {
            return Err(MgError::Internal);
        }
        let bases = base.get(..group).ok_or(MgError::Internal)?;
        // forward: `yₖ = tₖ − Cₖ₋₁ᵀ yₖ₋₁`, into `t`
        let mut carried = [Vec3A::ZERO; GROUP];
        for (y, &b) in carried.iter_mut().zip(bases) {
            let i = *order.get(b).ok_or(MgError::Internal)? as usize;
            *y = *t.get(i).ok_or(MgError::LengthMismatch)?;
        }
        for k in 1..len {
            for (y, &b) in carried.iter_mut().zip(bases) {
                let (Some(&i), Some(cp)) = (order.get(b + k), c.get(b + k - 1)) else {
                    return Err(MgError::Internal);
                };
                let ti = t.get_mut(i as usize).ok_or(MgError::LengthMismatch)?;
                *ti -= Vec3A::new(cp.x_axis.dot(*y), cp.y_axis.dot(*y), cp.z_axis.dot(*y));
                *y = *ti;
            }
        }
        // back: `zₖ = Sₖ⁻¹ yₖ − Cₖ zₖ₊₁`, carried, and put into `z`
        for k in (0..len).rev() {
            for (x, &b) in carried.iter_mut().zip(bases) {
                let p = b + k;
                let i = *order.get(p).ok_or(MgError::Internal)? as usize;
                let d = inv.get(6 * p..6 * p + 6).ok_or(MgError::Internal)?;
                let y = sym_mul(d, *t.get(i).ok_or(MgError::LengthMismatch)?);
                // (the last position's `y` is the forward's, carried: `C` is zero there)
                *x = if k + 1 == len {
                    y
                } else {
                    y - *c.get(p).ok_or(MgError::Internal)? * *x
                };
                put(i, *x)?;
            }
        }
        l0 += group;
    }
    Ok(())
}
