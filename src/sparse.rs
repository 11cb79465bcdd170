//! Symmetric 3×3-block sparse matrix on caller-owned slices.
//!
//! Storage (nothing here owns memory; the runtime `World` carves the slices from its block):
//! * `diag: &[Mat3A]`, `n` diagonal blocks `A_ii`;
//! * the strictly-upper blocks in CSR form: [`Pattern`] (`row_start`, `n + 1` entries, and
//!   `cols`, sorted ascending within a row, every column `> row`) plus `off: &[Mat3A]` with
//!   one block `A_ij` (`i < j`) per pattern entry. The lower blocks are implied: `A_ji = A_ijᵀ`.
//!
//! The bending Hessian is a scalar per block times `I3`, so the same pattern also carries a
//! scalar matrix `S` (`diag: &[f32]`, `off: &[f32]`) applied as `S ⊗ I3`
//! ([`mul_scalar_add`], [`add_scalar`]).
//!
//! A stiffness `K` annihilates translations: every row sums to zero, `K_ii = −Σ_j K_ij`.
//! [`BlockMatrix::mul_stiffness`] and [`Scalars::add_differences`] use it to form `K x =
//! Σ_j K_ij (x_j − x_i)` from differences, never `K_ii x_i` from absolute values: for a
//! nearly uniform `x` (a cloth moving as a whole: `K v` in the step's right-hand side) the
//! terms of `K_ii x_i + Σ_j K_ij x_j` are far larger than their sum, and their `f32`
//! cancellation leaves spurious forces, which a rigidly moving cloth then feels; the
//! differences are small and exact (Sterbenz), so `K x` is computed to its own size and a
//! uniform `x` gives exactly zero.
//!
//! Every function is panic-free on any input: lengths are checked up front and every
//! data-dependent index goes through `get`. A structurally invalid [`Pattern`] (built by hand
//! rather than by [`build_pattern`]) gives [`SparseError::InvalidPattern`] or, where no index
//! goes out of range, a well-defined but meaningless result; [`Pattern::validate`] checks one
//! fully, once, at the boundary.
#![deny(
    clippy::indexing_slicing,
    clippy::unwrap_used,
    clippy::expect_used,
    clippy::panic,
    clippy::unreachable
)]

use core::ops::Range;
use glam::{DMat3, DVec3, Mat3A, Vec3A, Vec3Swizzles};

/// Errors of the sparse-matrix functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SparseError {
    /// A vertex index (in a coupling pair or an assembly call) is `>= n`.
    IndexOutOfRange,
    /// `cols` cannot hold the (not yet deduplicated) couplings; see [`build_pattern`].
    CapacityExceeded,
    /// `row_start` is shorter than `n + 1`.
    RowStartTooShort,
    /// Slice lengths disagree with each other or with the pattern.
    LengthMismatch,
    /// [`add_block`] / [`add_scalar`]: the pattern has no entry for this block.
    MissingBlock,
    /// The pattern is not a valid strictly-upper CSR pattern (see [`Pattern::validate`]).
    InvalidPattern,
}

impl core::fmt::Display for SparseError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            SparseError::IndexOutOfRange => "vertex index out of range",
            SparseError::CapacityExceeded => "more couplings than the pattern can hold",
            SparseError::RowStartTooShort => "row_start is shorter than n + 1",
            SparseError::LengthMismatch => "slice lengths disagree with the pattern",
            SparseError::MissingBlock => "the pattern has no entry for this block",
            SparseError::InvalidPattern => "not a valid strictly-upper CSR pattern",
        })
    }
}

/// Strictly-upper CSR sparsity pattern of a symmetric block matrix with `n = row_start.len() - 1`
/// block rows. Row `i`'s entries are `row_start[i]..row_start[i + 1]`, their block columns
/// `cols[k]`; the number of entries is `row_start[n]`, so `cols` may be longer (capacity).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pattern<'a> {
    pub row_start: &'a [u32],
    pub cols: &'a [u32],
}

impl<'a> Pattern<'a> {
    /// Number of block rows (`row_start.len() - 1`, 0 for an empty `row_start`).
    #[inline]
    pub fn n(&self) -> usize {
        self.row_start.len().saturating_sub(1)
    }

    /// Number of strictly-upper entries, `row_start[n]` (0 for an empty `row_start`).
    #[inline]
    pub fn nnz(&self) -> usize {
        self.row_start.last().map_or(0, |&e| e as usize)
    }

    /// Entry range of row `i` (indices into `cols` / `off`), or `None` if `i >= n` or the
    /// range is malformed (decreasing or beyond `cols`).
    #[inline]
    pub fn row_range(&self, i: usize) -> Option<Range<usize>> {
        let a = *self.row_start.get(i)? as usize;
        let b = *self.row_start.get(i.checked_add(1)?)? as usize;
        if a <= b && b <= self.cols.len() {
            Some(a..b)
        } else {
            None
        }
    }

    /// The strictly-upper neighbours of row `i` as `(k, j)`: entry index `k` (into `off`) and
    /// block column `j > i`, ascending in `j`. Empty if `i` is out of range.
    pub fn upper(&self, i: usize) -> impl Iterator<Item = (usize, usize)> + 'a {
        let range = self.row_range(i).unwrap_or(0..0);
        let start = range.start;
        self.cols
            .get(range)
            .unwrap_or(&[])
            .iter()
            .enumerate()
            .map(move |(k, &j)| (start + k, j as usize))
    }

    /// Entry index of block `(i, j)` for `i < j` (binary search within row `i`); `None` if
    /// `i >= j`, `i` is out of range or the pattern lacks the block.
    pub fn find(&self, i: usize, j: usize) -> Option<usize> {
        if i >= j {
            return None;
        }
        let j = u32::try_from(j).ok()?;
        let range = self.row_range(i)?;
        let start = range.start;
        let row = self.cols.get(range)?;
        row.binary_search(&j).ok().map(|k| start + k)
    }

    /// Full structural check: `row_start[0] == 0`, non-decreasing, `row_start[n] <= cols.len()`,
    /// and within each row `i` the columns strictly increase and satisfy `i < j < n`.
    /// Costs one pass over the pattern; meant for the boundary (e.g. `World` init).
    pub fn validate(&self) -> Result<(), SparseError> {
        let n = self.n();
        if self.row_start.first().copied().unwrap_or(1) != 0 {
            return Err(SparseError::InvalidPattern);
        }
        for i in 0..n {
            let range = self.row_range(i).ok_or(SparseError::InvalidPattern)?;
            let row = self.cols.get(range).ok_or(SparseError::InvalidPattern)?;
            let mut prev = i; // columns must exceed the row, then strictly increase
            for &j in row {
                let j = j as usize;
                if j <= prev || j >= n {
                    return Err(SparseError::InvalidPattern);
                }
                prev = j;
            }
        }
        Ok(())
    }
}

/// Strictly-upper couplings that are a scalar times `I3`, on a pattern of their own, times
/// `scale`: the matrix `scale · (S ⊗ I3)` with no diagonal. In the world's step these are the
/// bending couplings of vertices that share no edge (the two vertices opposite a hinge): half
/// of a cloth's couplings, which as 3×3 blocks would cost 12× the memory and ~4× the work of
/// a scalar each.
#[derive(Clone, Copy, Debug)]
pub struct Scalars<'a> {
    pub pattern: Pattern<'a>,
    pub off: &'a [f32],
    pub scale: f32,
}

impl Scalars<'static> {
    /// No scalar couplings (an empty pattern: any `n`).
    pub const NONE: Scalars<'static> = Scalars {
        pattern: Pattern {
            row_start: &[],
            cols: &[],
        },
        off: &[],
        scale: 0.0,
    };
}

impl Scalars<'_> {
    /// No couplings to apply: an empty pattern, or a zero scale.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.pattern.nnz() == 0 || self.scale == 0.0
    }

    /// `y += scale · (S ⊗ I3) x`. Lengths: `x.len() == y.len() == pattern.n()` and
    /// `off.len() >= nnz`, else [`SparseError::LengthMismatch`] before anything is written;
    /// nothing to do (and no check) when [`Scalars::is_empty`].
    pub fn mul_add(&self, x: &[Vec3A], y: &mut [Vec3A]) -> Result<(), SparseError> {
        if self.is_empty() {
            return Ok(());
        }
        scalar_mul_add(None, &self.pattern, self.off, self.scale, x, y)
    }

    /// `y_i += scale Σ_j s_ij (x_j − x_i)` over every coupling of row `i`: `y += scale ·
    /// (S ⊗ I3) x` for the scalar stiffness `S` whose diagonal is minus its row sums, formed
    /// from differences (module docs). Rows ascending, each scattering to its `j > i`.
    /// Lengths as for [`Scalars::mul_add`]; [`SparseError::InvalidPattern`] if a column is out
    /// of range.
    pub fn add_differences(&self, x: &[Vec3A], y: &mut [Vec3A]) -> Result<(), SparseError> {
        if self.is_empty() {
            return Ok(());
        }
        differences(&self.pattern, self.off, self.scale, x, y)
    }

    /// Pattern validity and `off.len() >= nnz` (an empty pattern is valid for any `n`).
    pub fn validate(&self, n: usize) -> Result<(), SparseError> {
        if self.pattern.row_start.is_empty() {
            return Ok(());
        }
        self.pattern.validate()?;
        if self.pattern.n() != n || self.off.len() < self.pattern.nnz() {
            return Err(SparseError::LengthMismatch);
        }
        Ok(())
    }
}

/// A block matrix viewed as one value: diagonal blocks, pattern, strictly-upper blocks, and
/// the couplings that are a scalar times `I3` ([`Scalars`], on their own pattern).
/// [`BlockMatrix::validate`] checks them once.
#[derive(Clone, Copy, Debug)]
pub struct BlockMatrix<'a> {
    pub diag: &'a [Mat3A],
    pub pattern: Pattern<'a>,
    pub off: &'a [Mat3A],
    pub scalars: Scalars<'a>,
}

impl BlockMatrix<'_> {
    /// `y = A x`: the blocks (as [`mul`]) and the scalar couplings in one pass over `y`.
    /// Errors as for [`mul`]; the scalar couplings' pattern must also have `n` rows (or be
    /// empty).
    #[inline]
    pub fn mul(&self, x: &[Vec3A], y: &mut [Vec3A]) -> Result<(), SparseError> {
        if self.scalars.is_empty() {
            return mul(self.diag, &self.pattern, self.off, x, y);
        }
        mul_with_scalars(self.diag, &self.pattern, self.off, &self.scalars, x, y)
    }

    /// `y = K x = Σ_j A_ij (x_j − x_i)` over the blocks and the scalar couplings, for a
    /// stiffness whose rows sum to zero (module docs): the same product as [`BlockMatrix::mul`]
    /// with `diag_i = −Σ_j A_ij − scale Σ_j s_ij I`, which it never reads, without the
    /// cancellation. Lengths and errors as for [`BlockMatrix::mul`].
    pub fn mul_stiffness(&self, x: &[Vec3A], y: &mut [Vec3A]) -> Result<(), SparseError> {
        let n = x.len();
        let nnz = check_lengths(n, &self.pattern, self.off.len(), n, y.len())?;
        let (Some(cols), Some(off)) = (self.pattern.cols.get(..nnz), self.off.get(..nnz)) else {
            return Err(SparseError::LengthMismatch);
        };
        // Rows from last to first, as in [`mul`]: row `i` forms each difference `d = x_j − x_i`
        // once, gathers `A_ij d` and scatters `−A_ijᵀ d` into the `y_j`, `j > i`, which
        // their own rows have already written.
        let (mut cols, mut off) = (cols, off);
        for (i, &xi) in x.iter().enumerate().rev() {
            let (rc, ro);
            (cols, off, rc, ro) = last_row(self.pattern.row_start.get(i), cols, off)?;
            let mut acc = Vec3A::ZERO;
            for (&j, m) in rc.iter().zip(ro) {
                let (Some(&xj), Some(yj)) = (x.get(j as usize), y.get_mut(j as usize)) else {
                    return Err(SparseError::InvalidPattern);
                };
                let d = xj - xi;
                let (dx, dy, dz) = (d.xxx(), d.yyy(), d.zzz());
                acc += m.x_axis * dx + m.y_axis * dy + m.z_axis * dz;
                *yj -= tmul(m, dx, dy, dz);
            }
            if let Some(yi) = y.get_mut(i) {
                *yi = acc;
            }
        }
        self.scalars.add_differences(x, y)
    }

    /// `Σ_ij A_ij`, the sum of every block in `f64` (the lower blocks as the transposes of
    /// the upper, the scalar couplings as `scale s_ij I3` on both sides), in a fixed order:
    /// `Tᵀ A T` for the three translations `T`, what a rigid shift sees of `A`.
    /// [`SparseError::LengthMismatch`] if `off` or the scalars' values are shorter than their
    /// patterns.
    pub fn block_sum(&self) -> Result<DMat3, SparseError> {
        let off = self
            .off
            .get(..self.pattern.nnz())
            .ok_or(SparseError::LengthMismatch)?;
        let mut sum = DMat3::ZERO;
        for d in self.diag {
            sum += d.as_dmat3();
        }
        for m in off {
            let m = m.as_dmat3();
            sum += m + m.transpose();
        }
        if !self.scalars.is_empty() {
            let s = self
                .scalars
                .off
                .get(..self.scalars.pattern.nnz())
                .ok_or(SparseError::LengthMismatch)?;
            let total: f64 = s.iter().map(|&v| f64::from(v)).sum();
            sum += DMat3::from_diagonal(DVec3::splat(2.0 * total * f64::from(self.scalars.scale)));
        }
        Ok(sum)
    }

    /// Pattern validity plus `diag.len() == n` and `off.len() >= nnz`, for the blocks and
    /// the scalar couplings.
    pub fn validate(&self) -> Result<(), SparseError> {
        self.pattern.validate()?;
        if self.diag.len() != self.pattern.n() || self.off.len() < self.pattern.nnz() {
            return Err(SparseError::LengthMismatch);
        }
        self.scalars.validate(self.diag.len())
    }
}

/// Number of `cols` entries [`build_pattern`] needs for `pairs`: the pairs that are not
/// self-couplings, duplicates included (an upper bound on the final `nnz`; `pairs.len()`
/// always suffices).
pub fn pattern_capacity(pairs: &[[u32; 2]]) -> usize {
    pairs.iter().filter(|p| p[0] != p[1]).count()
}

/// Builds the sorted, deduplicated strictly-upper pattern of the couplings `pairs` in place,
/// without allocating, and returns `nnz`.
///
/// `pairs` may be in any order, in either orientation, with duplicates; self-pairs `(i, i)`
/// are ignored (the diagonal is always stored). On success `row_start[..n + 1]` holds the row
/// starts and `cols[..nnz]` the columns; use `Pattern { row_start: &row_start[..n + 1], cols }`.
/// Entries of `row_start` beyond `n + 1` are left untouched.
///
/// Capacity: `cols` is also the scratch space of the counting sort, so it must hold every
/// non-self pair *before* deduplication ([`pattern_capacity`]); otherwise
/// [`SparseError::CapacityExceeded`]. Other errors: [`SparseError::RowStartTooShort`]
/// (`row_start.len() < n + 1`), [`SparseError::IndexOutOfRange`] (a pair index `>= n`).
/// On error the contents of `row_start` and `cols` are unspecified.
pub fn build_pattern(
    n: usize,
    pairs: &[[u32; 2]],
    row_start: &mut [u32],
    cols: &mut [u32],
) -> Result<usize, SparseError> {
    let len = n.checked_add(1).ok_or(SparseError::RowStartTooShort)?;
    let rs = row_start
        .get_mut(..len)
        .ok_or(SparseError::RowStartTooShort)?;

    // Counting pass: rs[i] = entries of row i (duplicates included). Index checks happen here,
    // before anything is written to `cols`.
    rs.fill(0);
    let mut total: u32 = 0;
    for &[a, b] in pairs {
        if a as usize >= n || b as usize >= n {
            return Err(SparseError::IndexOutOfRange);
        }
        if a == b {
            continue;
        }
        // Checked first so that no per-row count (each <= total) can overflow.
        total = total.checked_add(1).ok_or(SparseError::CapacityExceeded)?;
        let row = rs
            .get_mut(a.min(b) as usize)
            .ok_or(SparseError::IndexOutOfRange)?;
        *row += 1;
    }
    if total as usize > cols.len() {
        return Err(SparseError::CapacityExceeded);
    }

    // Inclusive prefix sum: rs[i] = end of row i. Filling then decrements rs[row] before each
    // write, so afterwards rs[i] = start of row i (the classic in-place counting sort, which
    // needs only n + 1 entries).
    let mut acc: u32 = 0;
    for r in rs.iter_mut() {
        acc += *r; // partial sums of counts, bounded by `total`
        *r = acc;
    }
    for &[a, b] in pairs {
        if a == b {
            continue;
        }
        let slot = rs
            .get_mut(a.min(b) as usize)
            .ok_or(SparseError::IndexOutOfRange)?;
        *slot = slot.checked_sub(1).ok_or(SparseError::InvalidPattern)?;
        *cols
            .get_mut(*slot as usize)
            .ok_or(SparseError::CapacityExceeded)? = a.max(b);
    }
    // rs[n] was the count of row n (always 0) plus all rows: it already equals `total`.

    // Per-row sort, dedup and compaction towards the front. The write cursor `w` never passes
    // the read position, so compacting in place is safe; rs[i] is overwritten only after row i
    // has been read, and rs[i + 1] (row i's end) is still the old value when it is read.
    let mut w: usize = 0;
    for i in 0..n {
        let start = *rs.get(i).ok_or(SparseError::InvalidPattern)? as usize;
        let end = *rs.get(i + 1).ok_or(SparseError::InvalidPattern)? as usize;
        let row = cols
            .get_mut(start..end)
            .ok_or(SparseError::InvalidPattern)?;
        // core's unstable sort: no allocation, insertion sort on short rows, O(k log k) on a
        // pathological long one.
        row.sort_unstable();
        let new_start = w;
        for k in start..end {
            let v = *cols.get(k).ok_or(SparseError::InvalidPattern)?;
            let keep = w == new_start || cols.get(w - 1).is_some_and(|&prev| prev != v);
            if keep {
                *cols.get_mut(w).ok_or(SparseError::InvalidPattern)? = v;
                w += 1;
            }
        }
        *rs.get_mut(i).ok_or(SparseError::InvalidPattern)? = new_start as u32;
    }
    *rs.last_mut().ok_or(SparseError::RowStartTooShort)? = w as u32;
    Ok(w)
}

/// `mᵀ v` as a transpose (three shuffles on SSE2) and a column combination, with the splats
/// of `v` (`vx = v.xxx()` etc.) passed in: the caller hoists them out of its loop over a row.
/// Cheaper than three horizontal dot products, which each need two shuffles and a final
/// gather of three scalars.
#[inline(always)]
pub(crate) fn tmul(m: &Mat3A, vx: Vec3A, vy: Vec3A, vz: Vec3A) -> Vec3A {
    let t = m.transpose();
    t.x_axis * vx + t.y_axis * vy + t.z_axis * vz
}

/// One row of the backward pass of [`mul`] (and of the coarse levels' product,
/// `multigrid::cycle`): returns `acc + Σ_j A_ij x_j` over the row's stored blocks `ro`
/// (columns `rc`), summed in column order, and scatters `A_ijᵀ x_i` into `y_j`.
#[inline(always)]
pub(crate) fn block_row(
    mut acc: Vec3A,
    rc: &[u32],
    ro: &[Mat3A],
    xi: &Vec3A,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<Vec3A, SparseError> {
    let (vx, vy, vz) = (Vec3A::splat(xi.x), Vec3A::splat(xi.y), Vec3A::splat(xi.z));
    for (&j, m) in rc.iter().zip(ro) {
        let j = j as usize;
        let (Some(xj), Some(yj)) = (x.get(j), y.get_mut(j)) else {
            return Err(SparseError::InvalidPattern);
        };
        acc += gather(m, xj);
        *yj += tmul(m, vx, vy, vz);
    }
    Ok(acc)
}

/// `m x`, the sum `Mat3A * Vec3A` forms (the same bits), with each component of `x` splatted
/// from memory: an AVX2 build then broadcasts it with a load (`vbroadcastss`) instead of
/// shuffling a loaded `x`. The products' shuffles (the transpose in [`tmul`] takes five a
/// block) share two of the processor's four floating-point pipes: measured, the blocks-only
/// product took 8.6 % less time without these two (docs/PERFORMANCE.md).
#[inline(always)]
pub(crate) fn gather(m: &Mat3A, x: &Vec3A) -> Vec3A {
    m.x_axis * Vec3A::splat(x.x) + m.y_axis * Vec3A::splat(x.y) + m.z_axis * Vec3A::splat(x.z)
}

/// The scalar twin of [`block_row`]: returns `acc + Σ_j s_ij x_j` and scatters `s_ij sxi`
/// into `y_j` (`sxi` is `x_i`, already scaled as the caller's matrix wants).
#[inline(always)]
fn scalar_row(
    mut acc: Vec3A,
    rc: &[u32],
    ro: &[f32],
    sxi: Vec3A,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<Vec3A, SparseError> {
    for (&j, &s) in rc.iter().zip(ro) {
        let j = j as usize;
        let (Some(&xj), Some(yj)) = (x.get(j), y.get_mut(j)) else {
            return Err(SparseError::InvalidPattern);
        };
        acc += s * xj;
        *yj += s * sxi;
    }
    Ok(acc)
}

crate::cpu::multiversion! {
    /// [`Scalars::add_differences`]: `y_i += scale Σ_j s_ij (x_j − x_i)` and `y_j −= ` the same
    /// term, rows ascending. Row `i`'s sum is kept in a register and stored once: the earlier
    /// rows' scatters into `y_i` are all in by then and its own couplings reach only `j > i`,
    /// so the terms are added in the order the one-at-a-time form added them (the same bits).
    /// Measured before: `y_i` loaded and stored per coupling, no AVX2 build, 4 % of a 21×21
    /// step (its three calls: the bending force's two patterns and `K v`'s edge couplings).
    fn differences, differences_avx2 => differences_body(
        p: &Pattern,
        off: &[f32],
        scale: f32,
        x: &[Vec3A],
        y: &mut [Vec3A],
    ) -> Result<(), SparseError>
}

#[inline(always)]
fn differences_body(
    p: &Pattern,
    off: &[f32],
    scale: f32,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), SparseError> {
    let n = x.len();
    let nnz = check_lengths(n, p, off.len(), n, y.len())?;
    let (Some(cols), Some(off)) = (p.cols.get(..nnz), off.get(..nnz)) else {
        return Err(SparseError::LengthMismatch);
    };
    for (i, (w, &xi)) in p.row_start.windows(2).zip(x).enumerate() {
        let (rc, ro) = row_of(w, cols, off)?;
        let mut acc = *y.get(i).ok_or(SparseError::InvalidPattern)?;
        for (&j, &s) in rc.iter().zip(ro) {
            let j = j as usize;
            let (Some(&xj), Some(yj)) = (x.get(j), y.get_mut(j)) else {
                return Err(SparseError::InvalidPattern);
            };
            let t = s * (xj - xi) * scale;
            acc += t;
            *yj -= t;
        }
        if let Some(yi) = y.get_mut(i) {
            *yi = acc;
        }
    }
    Ok(())
}

/// The columns and values of the row whose window of row starts is `w` (`[start, end]`); a
/// window out of order or beyond `cols` / `vals` is [`SparseError::InvalidPattern`].
#[inline(always)]
pub(crate) fn row_of<'c, T>(
    w: &[u32],
    cols: &'c [u32],
    vals: &'c [T],
) -> Result<(&'c [u32], &'c [T]), SparseError> {
    let &[a, b] = w else {
        return Err(SparseError::InvalidPattern);
    };
    let range = a as usize..b as usize;
    match (cols.get(range.clone()), vals.get(range)) {
        (Some(rc), Some(ro)) => Ok((rc, ro)),
        _ => Err(SparseError::InvalidPattern),
    }
}

/// Checks the lengths shared by [`mul`] and [`mul_scalar_add`] and returns `nnz`.
#[inline]
fn check_lengths(
    n_diag: usize,
    p: &Pattern,
    n_off: usize,
    n_x: usize,
    n_y: usize,
) -> Result<usize, SparseError> {
    let nnz = p.nnz();
    let n = n_diag;
    if p.row_start.len() != n + 1 || n_x != n || n_y != n || nnz > p.cols.len() || nnz > n_off {
        return Err(SparseError::LengthMismatch);
    }
    Ok(nnz)
}

crate::cpu::multiversion! {
    /// `y = A x` for the symmetric block matrix `A` (`diag`, `p`, `off`): each stored upper
    /// block contributes `A_ij x_j` to `y_i` and `A_ijᵀ x_i` to `y_j`. `y` is fully
    /// overwritten.
    ///
    /// Requires `diag.len() == x.len() == y.len() == n`, `p.row_start.len() == n + 1`, and
    /// `cols.len()`, `off.len() >= nnz`; otherwise [`SparseError::LengthMismatch`] before
    /// anything is written. A malformed pattern that indexes out of range gives
    /// [`SparseError::InvalidPattern`], with `y` partially written.
    ///
    /// Summation order is fixed (serial, rows from last to first), so results are
    /// bit-reproducible.
    ///
    /// Runs the AVX2 build of the same code where the processor has it (`crate::cpu`;
    /// bit-identical), as `mul_with_scalars` does. A cloth without bending (no scalar
    /// couplings) takes this product: with only its baseline build, such a step cost 4.5 %
    /// more instructions (weft-bench at 21×21, bending or every effect off).
    pub fn mul, mul_avx2 => mul_body(
        diag: &[Mat3A],
        p: &Pattern,
        off: &[Mat3A],
        x: &[Vec3A],
        y: &mut [Vec3A],
    ) -> Result<(), SparseError>
}

#[inline(always)]
fn mul_body(
    diag: &[Mat3A],
    p: &Pattern,
    off: &[Mat3A],
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), SparseError> {
    let nnz = check_lengths(diag.len(), p, off.len(), x.len(), y.len())?;
    let (Some(cols), Some(off)) = (p.cols.get(..nnz), off.get(..nnz)) else {
        return Err(SparseError::LengthMismatch);
    };

    // One pass, rows from last to first: row i writes y_i = A_ii x_i + Σ_j A_ij x_j (gathered
    // in a register) and scatters A_ijᵀ x_i into y_j, j > i, which its own row has already
    // written. Going backwards is what lets the diagonal join the row pass: forwards, every
    // y_j would need initializing before earlier rows scatter into it (a second pass over y).
    let (mut cols, mut off) = (cols, off);
    for (i, (xi, d)) in x.iter().zip(diag).enumerate().rev() {
        let (rc, ro);
        (cols, off, rc, ro) = last_row(p.row_start.get(i), cols, off)?;
        let acc = block_row(gather(d, xi), rc, ro, xi, x, y)?;
        if let Some(yi) = y.get_mut(i) {
            *yi = acc;
        }
    }
    Ok(())
}

/// Row `i`'s entries split off the end of rows `..=i` (`cols`, `vals`, from `start`, row
/// `i`'s start): returns rows `..i` and row `i`. Walking the rows from last to first, each
/// row costs one row start and one comparison (the previous row's start is its end), not the
/// two starts and four range checks of slicing each row afresh: measured, that was a quarter
/// of the product's instructions on a cloth's rows of a few entries. A malformed pattern
/// (decreasing starts, or beyond `cols`) is [`SparseError::InvalidPattern`].
#[allow(clippy::type_complexity)]
#[inline(always)]
fn last_row<'c, T>(
    start: Option<&u32>,
    cols: &'c [u32],
    vals: &'c [T],
) -> Result<(&'c [u32], &'c [T], &'c [u32], &'c [T]), SparseError> {
    let start = *start.ok_or(SparseError::InvalidPattern)? as usize;
    match (cols.split_at_checked(start), vals.split_at_checked(start)) {
        (Some((head, row)), Some((vhead, vrow))) => Ok((head, vhead, row, vrow)),
        _ => Err(SparseError::InvalidPattern),
    }
}

crate::cpu::multiversion! {
    /// [`mul`] plus the scalar couplings `s`, in the same backward row pass: row `i` gathers
    /// `A_ij x_j` and `s_ij x_j` into one register and scatters `A_ijᵀ x_i` and `s_ij x_i`.
    /// Errors as for [`mul`], and [`SparseError::LengthMismatch`] when `s`'s pattern does not
    /// have `n` rows.
    ///
    /// Runs the AVX2 build of the same code where the processor has it ([`crate::cpu`]):
    /// bit-identical results, ~13% fewer instructions (no register copies before the
    /// destructive SSE2 operations, broadcasts straight from memory).
    fn mul_with_scalars, mul_with_scalars_avx2 => mul_with_scalars_body(
        diag: &[Mat3A],
        p: &Pattern,
        off: &[Mat3A],
        s: &Scalars,
        x: &[Vec3A],
        y: &mut [Vec3A],
    ) -> Result<(), SparseError>
}

#[inline(always)]
fn mul_with_scalars_body(
    diag: &[Mat3A],
    p: &Pattern,
    off: &[Mat3A],
    s: &Scalars,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), SparseError> {
    let nnz = check_lengths(diag.len(), p, off.len(), x.len(), y.len())?;
    let snnz = check_lengths(diag.len(), &s.pattern, s.off.len(), x.len(), y.len())?;
    let (Some(cols), Some(off)) = (p.cols.get(..nnz), off.get(..nnz)) else {
        return Err(SparseError::LengthMismatch);
    };
    let (Some(scols), Some(soff)) = (s.pattern.cols.get(..snnz), s.off.get(..snnz)) else {
        return Err(SparseError::LengthMismatch);
    };
    let scale = s.scale;
    let (mut cols, mut off, mut scols, mut soff) = (cols, off, scols, soff);
    for (i, (xi, d)) in x.iter().zip(diag).enumerate().rev() {
        let (rc, ro, sc, so);
        (cols, off, rc, ro) = last_row(p.row_start.get(i), cols, off)?;
        (scols, soff, sc, so) = last_row(s.pattern.row_start.get(i), scols, soff)?;
        // Both scatters reach rows already written. The blocks' sum is the one [`mul`] forms
        // (diagonal, then the blocks by column) and the small scalar terms come last: a
        // laminate of contrast 1e6 creeping at the f32 noise floor (`tests/hard_cases.rs`)
        // moved at 7.3 mm/s this way and 14 mm/s with the scalars summed first.
        let sacc = scalar_row(Vec3A::ZERO, sc, so, scale * xi, x, y)?;
        let acc = block_row(gather(d, xi), rc, ro, xi, x, y)?;
        if let Some(yi) = y.get_mut(i) {
            *yi = acc + scale * sacc;
        }
    }
    Ok(())
}

/// `y += scale · (S ⊗ I3) x` for the symmetric *scalar* matrix `S` (`diag`, `p`, `off`) on the
/// block pattern, e.g. the constant isometric bending Hessian (a scalar per block times `I3`).
///
/// Length requirements and errors as for [`mul`] (`diag: n`, `off >= nnz`); `y` is accumulated
/// into, not overwritten.
pub fn mul_scalar_add(
    diag: &[f32],
    p: &Pattern,
    off: &[f32],
    scale: f32,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), SparseError> {
    scalar_mul_add(Some(diag), p, off, scale, x, y)
}

/// [`mul_scalar_add`] with the diagonal `diag`, or none (zero; [`Scalars::mul_add`]).
fn scalar_mul_add(
    diag: Option<&[f32]>,
    p: &Pattern,
    off: &[f32],
    scale: f32,
    x: &[Vec3A],
    y: &mut [Vec3A],
) -> Result<(), SparseError> {
    let n_diag = diag.map_or(x.len(), <[f32]>::len);
    let nnz = check_lengths(n_diag, p, off.len(), x.len(), y.len())?;
    let (Some(cols), Some(off)) = (p.cols.get(..nnz), off.get(..nnz)) else {
        return Err(SparseError::LengthMismatch);
    };

    // One pass suffices since y is only accumulated into.
    for (i, (w, &xi)) in p.row_start.windows(2).zip(x).enumerate() {
        let (rc, ro) = row_of(w, cols, off)?;
        let own = diag.and_then(|d| d.get(i)).map_or(Vec3A::ZERO, |&d| d * xi);
        let acc = scalar_row(own, rc, ro, scale * xi, x, y)?;
        if let Some(yi) = y.get_mut(i) {
            *yi += scale * acc;
        }
    }
    Ok(())
}

/// Entry of block `(i, j)` in either orientation: `Ok(None)` for the diagonal, `Ok(Some((k,
/// transposed)))` for an off-diagonal block stored at `off[k]` as `(min, max)`.
fn locate(p: &Pattern, i: usize, j: usize) -> Result<Option<(usize, bool)>, SparseError> {
    let n = p.n();
    if i >= n || j >= n {
        return Err(SparseError::IndexOutOfRange);
    }
    if i == j {
        return Ok(None);
    }
    let k = p
        .find(i.min(j), i.max(j))
        .ok_or(SparseError::MissingBlock)?;
    Ok(Some((k, i > j)))
}

/// Assembly helper: adds `m` to block `(i, j)`. `i == j` adds to `diag[i]`; `i < j` adds `m`
/// to the stored upper block; `i > j` adds `mᵀ` to the stored block `(j, i)` (since
/// `A_ji = A_ijᵀ`). Errors: [`SparseError::IndexOutOfRange`] (`i` or `j >= n`),
/// [`SparseError::MissingBlock`], [`SparseError::LengthMismatch`] (`diag`/`off` too short).
/// Nothing is written on error.
pub fn add_block(
    p: &Pattern,
    diag: &mut [Mat3A],
    off: &mut [Mat3A],
    i: usize,
    j: usize,
    m: Mat3A,
) -> Result<(), SparseError> {
    let target = match locate(p, i, j)? {
        None => (diag.get_mut(i), m),
        Some((k, false)) => (off.get_mut(k), m),
        Some((k, true)) => (off.get_mut(k), m.transpose()),
    };
    let (Some(slot), m) = target else {
        return Err(SparseError::LengthMismatch);
    };
    *slot += m;
    Ok(())
}

/// Scalar twin of [`add_block`] for a matrix `S ⊗ I3` (symmetric, so the orientation does not
/// matter).
pub fn add_scalar(
    p: &Pattern,
    diag: &mut [f32],
    off: &mut [f32],
    i: usize,
    j: usize,
    s: f32,
) -> Result<(), SparseError> {
    let slot = match locate(p, i, j)? {
        None => diag.get_mut(i),
        Some((k, _)) => off.get_mut(k),
    };
    *slot.ok_or(SparseError::LengthMismatch)? += s;
    Ok(())
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
pub(crate) mod tests {
    use super::*;

    /// Deterministic LCG (Numerical Recipes constants), uniform in [-1, 1).
    pub(crate) struct Lcg(pub u64);
    impl Lcg {
        pub(crate) fn next_u32(&mut self) -> u32 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) as u32
        }
        pub(crate) fn uniform(&mut self) -> f32 {
            (self.next_u32() as f64 / (1u64 << 31) as f64 * 2.0 - 1.0) as f32
        }
        pub(crate) fn below(&mut self, n: u32) -> u32 {
            self.next_u32() % n
        }
        pub(crate) fn mat(&mut self) -> Mat3A {
            Mat3A::from_cols_array(&core::array::from_fn(|_| self.uniform()))
        }
        pub(crate) fn vec(&mut self) -> Vec3A {
            Vec3A::new(self.uniform(), self.uniform(), self.uniform())
        }
    }

    /// An owned pattern built by `build_pattern`.
    pub(crate) struct OwnedPattern {
        pub row_start: Vec<u32>,
        pub cols: Vec<u32>,
    }
    impl OwnedPattern {
        pub(crate) fn build(n: usize, pairs: &[[u32; 2]]) -> Self {
            let mut row_start = vec![0; n + 1];
            let mut cols = vec![0; pattern_capacity(pairs)];
            let nnz = build_pattern(n, pairs, &mut row_start, &mut cols).unwrap();
            cols.truncate(nnz);
            Self { row_start, cols }
        }
        pub(crate) fn pattern(&self) -> Pattern<'_> {
            Pattern {
                row_start: &self.row_start,
                cols: &self.cols,
            }
        }
    }

    /// Random couplings: a ring (so every vertex is coupled) plus random extras, with
    /// duplicates, both orientations and self pairs.
    pub(crate) fn random_pairs(rng: &mut Lcg, n: usize, extra: usize) -> Vec<[u32; 2]> {
        let n32 = n as u32;
        let mut pairs: Vec<[u32; 2]> = (0..n32).map(|i| [i, (i + 1) % n32]).collect();
        for _ in 0..extra {
            pairs.push([rng.below(n32), rng.below(n32)]);
        }
        pairs
    }

    /// Cloth-like: mass `mass` per vertex (±20 %), per coupling a stiff 3D spring along the
    /// segment between `pos` (random directions if None) plus a weak isotropic part, added as
    /// `k` on both diagonal blocks and `−k` between them: every row of the stiffness sums to
    /// zero, as a cloth's does (module docs).
    pub(crate) fn spring_system(
        rng: &mut Lcg,
        n: usize,
        pairs: &[[u32; 2]],
        stiffness: f32,
        mass: f32,
        pos: Option<&[Vec3A]>,
    ) -> (OwnedPattern, Vec<Mat3A>, Vec<Mat3A>) {
        let op = OwnedPattern::build(n, pairs);
        let mut diag: Vec<Mat3A> = (0..n)
            .map(|_| Mat3A::from_diagonal(glam::Vec3::splat(mass * (1.0 + 0.2 * rng.uniform()))))
            .collect();
        let mut off = vec![Mat3A::ZERO; op.cols.len()];
        let p = op.pattern();
        for &[a, b] in pairs {
            if a == b {
                continue;
            }
            let (a, b) = (a as usize, b as usize);
            let d = match pos {
                Some(x) => (x[b] - x[a]).normalize(),
                None => rng.vec().normalize(),
            };
            let k =
                stiffness * (Mat3A::from_cols(d * d.x, d * d.y, d * d.z) + 0.01 * Mat3A::IDENTITY);
            add_block(&p, &mut diag, &mut off, a, a, k).unwrap();
            add_block(&p, &mut diag, &mut off, b, b, k).unwrap();
            add_block(&p, &mut diag, &mut off, a, b, -k).unwrap();
        }
        (op, diag, off)
    }

    /// Dense 3n×3n row-major f64 expansion of a block matrix.
    pub(crate) fn dense(diag: &[Mat3A], p: &Pattern, off: &[Mat3A]) -> Vec<f64> {
        let n = diag.len();
        let m = 3 * n;
        let mut a = vec![0.0; m * m];
        let mut put = |bi: usize, bj: usize, blk: &Mat3A, transposed: bool| {
            for r in 0..3 {
                for c in 0..3 {
                    // Mat3A is column-major: col(c)[r] is row r, column c.
                    let v = if transposed {
                        blk.col(r)[c]
                    } else {
                        blk.col(c)[r]
                    };
                    a[(3 * bi + r) * m + 3 * bj + c] += v as f64;
                }
            }
        };
        for (i, d) in diag.iter().enumerate() {
            put(i, i, d, false);
        }
        for i in 0..n {
            for (k, j) in p.upper(i) {
                put(i, j, &off[k], false);
                put(j, i, &off[k], true);
            }
        }
        a
    }

    fn dense_mul(a: &[f64], x: &[Vec3A]) -> Vec<f64> {
        let m = 3 * x.len();
        let xf: Vec<f64> = x.iter().flat_map(|v| v.to_array()).map(f64::from).collect();
        (0..m)
            .map(|r| (0..m).map(|c| a[r * m + c] * xf[c]).sum())
            .collect()
    }

    fn assert_close(y: &[Vec3A], want: &[f64], tol: f64) {
        let scale = want.iter().fold(1.0f64, |s, v| s.max(v.abs()));
        for (i, v) in y.iter().enumerate() {
            for c in 0..3 {
                let d = (v[c] as f64 - want[3 * i + c]).abs();
                assert!(
                    d <= tol * scale,
                    "entry {i}.{c}: {} vs {} (scale {scale})",
                    v[c],
                    want[3 * i + c]
                );
            }
        }
    }

    #[test]
    fn build_pattern_sorts_dedups_and_ignores_self_pairs() {
        // Both orientations, duplicates, self pairs, any order.
        let pairs = [
            [3, 1],
            [1, 3],
            [0, 2],
            [2, 2],
            [2, 0],
            [1, 0],
            [3, 1],
            [0, 3],
            [4, 4],
            [0, 1],
        ];
        let mut row_start = [99u32; 6 + 2];
        let mut cols = [77u32; 10];
        let nnz = build_pattern(5, &pairs, &mut row_start, &mut cols).unwrap();
        assert_eq!(nnz, 4);
        assert_eq!(&row_start[..6], &[0, 3, 4, 4, 4, 4]);
        assert_eq!(&cols[..nnz], &[1, 2, 3, 3]);
        assert_eq!(&row_start[6..], &[99, 99], "beyond n + 1 left untouched");
        let p = Pattern {
            row_start: &row_start[..6],
            cols: &cols[..nnz],
        };
        p.validate().unwrap();
        assert_eq!(p.n(), 5);
        assert_eq!(p.nnz(), 4);
        assert_eq!(p.find(0, 1), Some(0));
        assert_eq!(p.find(0, 3), Some(2));
        assert_eq!(p.find(1, 3), Some(3));
        assert_eq!(p.find(3, 1), None, "only i < j");
        assert_eq!(p.find(2, 2), None);
        assert_eq!(p.find(1, 2), None);
        assert_eq!(p.find(9, 10), None);
        assert_eq!(p.upper(0).collect::<Vec<_>>(), vec![(0, 1), (1, 2), (2, 3)]);
        assert_eq!(p.upper(1).collect::<Vec<_>>(), vec![(3, 3)]);
        assert_eq!(p.upper(4).count(), 0);
        assert_eq!(p.upper(17).count(), 0);
    }

    #[test]
    fn build_pattern_matches_a_set_reference_on_random_input() {
        let mut rng = Lcg(7);
        for trial in 0..20 {
            let n = 1 + rng.below(40) as usize;
            let pairs = random_pairs(&mut rng, n, 5 * n);
            let op = OwnedPattern::build(n, &pairs);
            op.pattern().validate().unwrap();
            let mut want = std::collections::BTreeSet::new();
            for &[a, b] in &pairs {
                if a != b {
                    want.insert((a.min(b) as usize, a.max(b) as usize));
                }
            }
            let got: std::collections::BTreeSet<_> = (0..n)
                .flat_map(|i| op.pattern().upper(i).map(move |(_, j)| (i, j)))
                .collect();
            assert_eq!(got, want, "trial {trial}");
            assert_eq!(op.cols.len(), want.len());
        }
    }

    #[test]
    fn build_pattern_errors() {
        let pairs = [[0u32, 1], [1, 0], [1, 2], [2, 2]];
        let mut rs = [0u32; 4];
        // Capacity counts duplicates (3 non-self pairs) even though nnz is 2.
        assert_eq!(pattern_capacity(&pairs), 3);
        let mut cols = [0u32; 2];
        assert_eq!(
            build_pattern(3, &pairs, &mut rs, &mut cols),
            Err(SparseError::CapacityExceeded)
        );
        let mut cols = [0u32; 3];
        assert_eq!(build_pattern(3, &pairs, &mut rs, &mut cols), Ok(2));
        assert_eq!(
            build_pattern(3, &pairs, &mut rs[..3], &mut cols),
            Err(SparseError::RowStartTooShort)
        );
        assert_eq!(
            build_pattern(usize::MAX, &pairs, &mut rs, &mut cols),
            Err(SparseError::RowStartTooShort)
        );
        assert_eq!(
            build_pattern(2, &pairs, &mut rs, &mut cols),
            Err(SparseError::IndexOutOfRange)
        );
        // Out of range even as a self pair.
        assert_eq!(
            build_pattern(3, &[[5, 5]], &mut rs, &mut cols),
            Err(SparseError::IndexOutOfRange)
        );
        // Empty matrix.
        let mut rs0 = [9u32; 1];
        assert_eq!(build_pattern(0, &[], &mut rs0, &mut []), Ok(0));
        assert_eq!(rs0, [0]);
    }

    #[test]
    fn validate_rejects_malformed_patterns() {
        let ok = Pattern {
            row_start: &[0, 2, 3, 3],
            cols: &[1, 2, 2],
        };
        ok.validate().unwrap();
        for (rs, cols) in [
            (&[1u32, 2, 3, 3][..], &[1u32, 2, 2][..]), // does not start at 0
            (&[0, 2, 1, 3], &[1, 2, 2]),               // decreasing
            (&[0, 2, 3, 4], &[1, 2, 2]),               // beyond cols
            (&[0, 2, 3, 3], &[2, 1, 2]),               // unsorted
            (&[0, 2, 3, 3], &[1, 1, 2]),               // duplicate
            (&[0, 2, 3, 3], &[0, 2, 2]),               // diagonal
            (&[0, 2, 3, 3], &[1, 2, 1]),               // lower
            (&[0, 2, 3, 3], &[1, 3, 2]),               // column >= n
            (&[], &[]),                                // no row_start at all
        ] {
            let p = Pattern {
                row_start: rs,
                cols,
            };
            assert_eq!(
                p.validate(),
                Err(SparseError::InvalidPattern),
                "{rs:?} {cols:?}"
            );
        }
    }

    fn random_matrix(rng: &mut Lcg, n: usize) -> (OwnedPattern, Vec<Mat3A>, Vec<Mat3A>) {
        let pairs = random_pairs(rng, n, 3 * n);
        let op = OwnedPattern::build(n, &pairs);
        let diag: Vec<Mat3A> = (0..n)
            .map(|_| {
                let m = rng.mat();
                m + m.transpose()
            })
            .collect();
        let off: Vec<Mat3A> = (0..op.cols.len()).map(|_| rng.mat()).collect();
        (op, diag, off)
    }

    #[test]
    fn mul_matches_dense_reference() {
        let mut rng = Lcg(42);
        for n in [1usize, 2, 3, 7, 30, 64] {
            let (op, diag, off) = random_matrix(&mut rng, n);
            let p = op.pattern();
            let a = dense(&diag, &p, &off);
            // The dense expansion is symmetric by construction of the storage.
            for r in 0..3 * n {
                for c in 0..3 * n {
                    assert_eq!(a[r * 3 * n + c], a[c * 3 * n + r]);
                }
            }
            let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let mut y = vec![Vec3A::splat(f32::NAN); n]; // must be fully overwritten
            mul(&diag, &p, &off, &x, &mut y).unwrap();
            assert_close(&y, &dense_mul(&a, &x), 1e-5);
            let mut y2 = vec![Vec3A::ZERO; n];
            BlockMatrix {
                diag: &diag,
                pattern: p,
                off: &off,
                scalars: Scalars::NONE,
            }
            .mul(&x, &mut y2)
            .unwrap();
            assert_eq!(y, y2);
        }
    }

    /// Blocks plus scalar couplings on a second pattern (overlapping the first in places, as
    /// a hinge's opposite vertices may also share an edge on a coarse mesh) against the dense
    /// matrix of both.
    #[test]
    fn mul_with_scalar_couplings_matches_dense_reference() {
        let mut rng = Lcg(7);
        for n in [1usize, 2, 5, 30, 64] {
            let (op, diag, off) = random_matrix(&mut rng, n);
            let p = op.pattern();
            let spairs = random_pairs(&mut rng, n, 2 * n);
            let sop = OwnedPattern::build(n, &spairs);
            let soff: Vec<f32> = (0..sop.cols.len()).map(|_| rng.uniform()).collect();
            let scale = 0.7f32;
            let mut a = dense(&diag, &p, &off);
            let m = 3 * n;
            for i in 0..n {
                for (k, j) in sop.pattern().upper(i) {
                    for c in 0..3 {
                        let v = f64::from(scale * soff[k]);
                        a[(3 * i + c) * m + 3 * j + c] += v;
                        a[(3 * j + c) * m + 3 * i + c] += v;
                    }
                }
            }
            let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let scalars = Scalars {
                pattern: sop.pattern(),
                off: &soff,
                scale,
            };
            let bm = BlockMatrix {
                diag: &diag,
                pattern: p,
                off: &off,
                scalars,
            };
            bm.validate().unwrap();
            let mut y = vec![Vec3A::splat(f32::NAN); n]; // must be fully overwritten
            bm.mul(&x, &mut y).unwrap();
            assert_close(&y, &dense_mul(&a, &x), 1e-5);
            // The same as the blocks alone plus `Scalars::mul_add`.
            let mut y2 = vec![Vec3A::ZERO; n];
            mul(&diag, &p, &off, &x, &mut y2).unwrap();
            scalars.mul_add(&x, &mut y2).unwrap();
            assert_close(&y2, &dense_mul(&a, &x), 1e-5);
            // A scalar pattern of the wrong size is an error, not a panic.
            if n > 1 {
                let short = Scalars {
                    pattern: Pattern {
                        row_start: &sop.row_start[..n],
                        cols: &sop.cols,
                    },
                    ..scalars
                };
                let bad = BlockMatrix {
                    scalars: short,
                    ..bm
                };
                assert!(bad.mul(&x, &mut y).is_err());
            }
        }
    }

    /// A stiffness (rows summing to zero: element terms `[[k, −k], [−k, k]]` and scalar
    /// couplings) applied from differences: the dense product; exactly zero for a uniform `x`;
    /// and for a nearly uniform one (a cloth moving as a whole at 3 m/s, 1e-6 m/s apart) `K x`
    /// to its own size, where the diagonal form's round-off is larger than `K x` itself.
    #[test]
    fn stiffness_from_differences_is_exact_for_uniform_motion() {
        let mut rng = Lcg(5);
        for n in [2usize, 9, 40] {
            let pairs = random_pairs(&mut rng, n, 3 * n);
            let op = OwnedPattern::build(n, &pairs);
            let p = op.pattern();
            let (mut diag, mut off) = (vec![Mat3A::ZERO; n], vec![Mat3A::ZERO; op.cols.len()]);
            for &[a, b] in &pairs {
                if a == b {
                    continue;
                }
                let l = rng.mat();
                let k = 1e4 * (l * l.transpose() + 0.1 * Mat3A::IDENTITY);
                let (a, b) = (a as usize, b as usize);
                add_block(&p, &mut diag, &mut off, a, a, k).unwrap();
                add_block(&p, &mut diag, &mut off, b, b, k).unwrap();
                add_block(&p, &mut diag, &mut off, a, b, -k).unwrap();
            }
            let spairs = random_pairs(&mut rng, n, n);
            let sop = OwnedPattern::build(n, &spairs);
            let soff: Vec<f32> = (0..sop.cols.len()).map(|_| -rng.uniform()).collect();
            let scale = 30.0f32;
            let mut a = dense(&diag, &p, &off);
            let m = 3 * n;
            for i in 0..n {
                for (k, j) in sop.pattern().upper(i) {
                    let v = f64::from(scale * soff[k]);
                    for c in 0..3 {
                        a[(3 * i + c) * m + 3 * j + c] += v;
                        a[(3 * j + c) * m + 3 * i + c] += v;
                        a[(3 * i + c) * m + 3 * i + c] -= v;
                        a[(3 * j + c) * m + 3 * j + c] -= v;
                    }
                }
            }
            // The stiffness itself: diagonal blocks exactly minus their rows' couplings (the
            // f32 `diag` holds them rounded).
            for i in 0..n {
                for r in 3 * i..3 * i + 3 {
                    for c in 0..3 {
                        let others: f64 = (0..n)
                            .filter(|&j| j != i)
                            .map(|j| a[r * m + 3 * j + c])
                            .sum();
                        a[r * m + 3 * i + c] = -others;
                    }
                }
            }
            let k = BlockMatrix {
                diag: &diag,
                pattern: p,
                off: &off,
                scalars: Scalars {
                    pattern: sop.pattern(),
                    off: &soff,
                    scale,
                },
            };
            let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
            let mut y = vec![Vec3A::splat(f32::NAN); n]; // must be fully overwritten
            k.mul_stiffness(&x, &mut y).unwrap();
            assert_close(&y, &dense_mul(&a, &x), 1e-5);
            // Uniform: exactly zero.
            let v = vec![Vec3A::new(3.0, -1.25, 0.7); n];
            k.mul_stiffness(&v, &mut y).unwrap();
            assert!(y.iter().all(|yi| *yi == Vec3A::ZERO), "{y:?}");
            // Nearly uniform: within f32 of the exact product, as it stands (~1e-2).
            let v: Vec<Vec3A> = (0..n)
                .map(|_| Vec3A::new(3.0, -1.25, 0.7) + 1e-6 * rng.vec())
                .collect();
            let exact = dense_mul(&a, &v);
            let err = |y: &[Vec3A]| {
                y.iter()
                    .flat_map(|v| v.to_array())
                    .zip(&exact)
                    .map(|(g, w)| (f64::from(g) - w).abs())
                    .fold(0.0, f64::max)
            };
            let size = exact.iter().fold(0.0f64, |s, w| s.max(w.abs()));
            k.mul_stiffness(&v, &mut y).unwrap();
            assert!(err(&y) < 1e-4 * size, "error {} of {size}", err(&y));
            // The same product with its diagonal blocks: round-off beyond the result.
            k.mul(&v, &mut y).unwrap();
            assert!(err(&y) > size, "diagonal form: error {} of {size}", err(&y));
        }
    }

    /// `block_sum` is `Tᵀ A T` for the translations `T`: the sum over rows of `A` times each
    /// axis, scalar couplings included.
    #[test]
    fn block_sum_is_what_the_product_gives_translations() {
        let mut rng = Lcg(5);
        for n in [1usize, 6, 40] {
            let (op, diag, off) = random_matrix(&mut rng, n);
            let pairs = random_pairs(&mut rng, n, n);
            let sop = OwnedPattern::build(n, &pairs);
            let soff: Vec<f32> = (0..sop.cols.len()).map(|_| rng.uniform()).collect();
            let a = BlockMatrix {
                diag: &diag,
                pattern: op.pattern(),
                off: &off,
                scalars: Scalars {
                    pattern: sop.pattern(),
                    off: &soff,
                    scale: 0.37,
                },
            };
            let sum = a.block_sum().unwrap();
            let mut y = vec![Vec3A::ZERO; n];
            for (k, axis) in [Vec3A::X, Vec3A::Y, Vec3A::Z].into_iter().enumerate() {
                a.mul(&vec![axis; n], &mut y).unwrap();
                let want: DVec3 = y.iter().map(|v| v.as_dvec3()).sum();
                let scale: f64 = y.iter().map(|v| v.as_dvec3().length()).sum::<f64>() + 1.0;
                assert!(
                    (sum.col(k) - want).length() < 1e-5 * scale,
                    "n {n} axis {k}: {} against {want}",
                    sum.col(k)
                );
            }
            // short values are an error, not a panic
            let short = BlockMatrix { off: &[], ..a };
            if op.pattern().nnz() > 0 {
                assert_eq!(short.block_sum(), Err(SparseError::LengthMismatch));
            }
        }
    }

    /// A value of either sign spread over 40 binades around 1 (where a contracted `a·b + c` or
    /// another order of sums would show in the bits).
    fn spread(rng: &mut Lcg) -> f32 {
        (rng.uniform() - 0.5) * 2f32.powi(rng.below(40) as i32 - 20)
    }

    /// `n` vectors of [`spread`] components.
    fn spread_vecs(rng: &mut Lcg, n: usize) -> Vec<Vec3A> {
        (0..n)
            .map(|_| Vec3A::new(spread(rng), spread(rng), spread(rng)))
            .collect()
    }

    fn same_bits(a: &[Vec3A], b: &[Vec3A]) -> bool {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits))
    }

    /// The AVX2 builds of the products (`crate::cpu`) give the same bits as the baseline ones,
    /// on values spread over many binades (a contracted `a·b + c` would show).
    #[test]
    fn the_avx2_product_is_bit_identical() {
        #[cfg(target_arch = "x86_64")]
        if crate::cpu::avx2() {
            let mut rng = Lcg(21);
            for n in [1usize, 7, 60] {
                let (op, diag, off) = random_matrix(&mut rng, n);
                let pairs = random_pairs(&mut rng, n, 2 * n);
                let sop = OwnedPattern::build(n, &pairs);
                let soff: Vec<f32> = (0..sop.cols.len()).map(|_| spread(&mut rng)).collect();
                let scalars = Scalars {
                    pattern: sop.pattern(),
                    off: &soff,
                    scale: 0.37,
                };
                let x = spread_vecs(&mut rng, n);
                let p = op.pattern();
                let (mut y, mut wide) = (vec![Vec3A::ZERO; n], vec![Vec3A::ZERO; n]);
                mul_with_scalars_body(&diag, &p, &off, &scalars, &x, &mut y).unwrap();
                // SAFETY: the processor supports AVX2 (checked above).
                unsafe { mul_with_scalars_avx2(&diag, &p, &off, &scalars, &x, &mut wide) }.unwrap();
                assert!(same_bits(&y, &wide));
                // and the block product alone
                mul_body(&diag, &p, &off, &x, &mut y).unwrap();
                // SAFETY: as above.
                unsafe { mul_avx2(&diag, &p, &off, &x, &mut wide) }.unwrap();
                assert!(same_bits(&y, &wide));
                // and the scalar couplings' difference form, accumulating into y
                wide.copy_from_slice(&y);
                differences_body(&sop.pattern(), &soff, 0.37, &x, &mut y).unwrap();
                // SAFETY: as above.
                unsafe { differences_avx2(&sop.pattern(), &soff, 0.37, &x, &mut wide) }.unwrap();
                assert!(same_bits(&y, &wide));
            }
        }
    }

    /// The difference form keeps each row's sum in a register: the same bits as adding every
    /// term to `y` in memory as it comes, on values spread over many binades and a `y` that
    /// already holds some (the kernel accumulates).
    #[test]
    fn differences_summed_in_a_register_are_the_terms_added_one_at_a_time() {
        let mut rng = Lcg(5);
        for n in [1usize, 9, 80] {
            let pairs = random_pairs(&mut rng, n, 3 * n);
            let sop = OwnedPattern::build(n, &pairs);
            let off: Vec<f32> = (0..sop.cols.len()).map(|_| spread(&mut rng)).collect();
            let (x, start) = (spread_vecs(&mut rng, n), spread_vecs(&mut rng, n));
            let mut want = start.clone();
            let p = sop.pattern();
            for i in 0..n {
                for k in p.row_range(i).unwrap() {
                    let j = p.cols[k] as usize;
                    let t = off[k] * (x[j] - x[i]) * -1.0;
                    want[i] += t;
                    want[j] -= t;
                }
            }
            let mut y = start;
            let scalars = Scalars {
                pattern: p,
                off: &off,
                scale: -1.0,
            };
            scalars.add_differences(&x, &mut y).unwrap();
            assert!(same_bits(&y, &want));
        }
    }

    #[test]
    fn mul_scalar_add_matches_dense_reference() {
        let mut rng = Lcg(3);
        let n = 25;
        let pairs = random_pairs(&mut rng, n, 60);
        let op = OwnedPattern::build(n, &pairs);
        let p = op.pattern();
        let sd: Vec<f32> = (0..n).map(|_| rng.uniform()).collect();
        let so: Vec<f32> = (0..op.cols.len()).map(|_| rng.uniform()).collect();
        // The same matrix as blocks s·I3, through the block path.
        let bd: Vec<Mat3A> = sd
            .iter()
            .map(|&s| Mat3A::from_diagonal(glam::Vec3::splat(s)))
            .collect();
        let bo: Vec<Mat3A> = so
            .iter()
            .map(|&s| Mat3A::from_diagonal(glam::Vec3::splat(s)))
            .collect();
        let a = dense(&bd, &p, &bo);
        let x: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
        let y0: Vec<Vec3A> = (0..n).map(|_| rng.vec()).collect();
        let scale = -2.5;
        let mut y = y0.clone();
        mul_scalar_add(&sd, &p, &so, scale, &x, &mut y).unwrap();
        let ax = dense_mul(&a, &x);
        let want: Vec<f64> = (0..3 * n)
            .map(|k| y0[k / 3][k % 3] as f64 + scale as f64 * ax[k])
            .collect();
        assert_close(&y, &want, 1e-5);
    }

    #[test]
    fn length_and_pattern_errors_never_panic() {
        let mut rng = Lcg(5);
        let (op, diag, off) = random_matrix(&mut rng, 6);
        let p = op.pattern();
        let x = vec![Vec3A::ONE; 6];
        let mut y = vec![Vec3A::ZERO; 6];
        let e = Err(SparseError::LengthMismatch);
        assert_eq!(mul(&diag[..5], &p, &off, &x, &mut y), e);
        assert_eq!(mul(&diag, &p, &off[..off.len() - 1], &x, &mut y), e);
        assert_eq!(mul(&diag, &p, &off, &x[..5], &mut y), e);
        assert_eq!(mul(&diag, &p, &off, &x, &mut y[..5]), e);
        let short = Pattern {
            row_start: &op.row_start[..6],
            cols: &op.cols,
        };
        assert_eq!(mul(&diag, &short, &off, &x, &mut y), e);
        let sd = vec![1.0f32; 6];
        let so = vec![1.0f32; op.cols.len()];
        assert_eq!(mul_scalar_add(&sd[..5], &p, &so, 1.0, &x, &mut y), e);
        assert_eq!(mul_scalar_add(&sd, &p, &so[..1], 1.0, &x, &mut y), e);
        // Hand-made garbage: column out of range, row ranges decreasing.
        let bad_col = Pattern {
            row_start: &[0, 1, 1],
            cols: &[7],
        };
        let d2 = [Mat3A::IDENTITY; 2];
        let o1 = [Mat3A::IDENTITY; 1];
        let (x2, mut y2) = ([Vec3A::ONE; 2], [Vec3A::ZERO; 2]);
        assert_eq!(
            mul(&d2, &bad_col, &o1, &x2, &mut y2),
            Err(SparseError::InvalidPattern)
        );
        assert_eq!(
            mul_scalar_add(&[1.0; 2], &bad_col, &[1.0], 1.0, &x2, &mut y2),
            Err(SparseError::InvalidPattern)
        );
        let decreasing = Pattern {
            row_start: &[0, 1, 0],
            cols: &[1],
        };
        assert_eq!(
            mul(&d2, &decreasing, &[Mat3A::IDENTITY; 1], &x2, &mut y2),
            Err(SparseError::InvalidPattern),
            "nnz = row_start[n] = 0 but row 0 claims an entry"
        );
        let decreasing = Pattern {
            row_start: &[0, 2, 1],
            cols: &[1, 1],
        };
        assert_eq!(
            mul(&d2, &decreasing, &[Mat3A::IDENTITY; 2], &x2, &mut y2),
            Err(SparseError::InvalidPattern)
        );
        // Empty matrix is fine.
        let empty = Pattern {
            row_start: &[0],
            cols: &[],
        };
        assert_eq!(mul(&[], &empty, &[], &[], &mut []), Ok(()));
    }

    #[test]
    fn add_block_and_add_scalar_assemble_in_either_orientation() {
        let op = OwnedPattern::build(4, &[[0, 1], [2, 1], [3, 0]]);
        let p = op.pattern();
        let mut diag = vec![Mat3A::ZERO; 4];
        let mut off = vec![Mat3A::ZERO; op.cols.len()];
        let m = Mat3A::from_cols_array(&[1., 2., 3., 4., 5., 6., 7., 8., 9.]);
        add_block(&p, &mut diag, &mut off, 1, 1, m).unwrap();
        add_block(&p, &mut diag, &mut off, 0, 1, m).unwrap();
        add_block(&p, &mut diag, &mut off, 2, 1, m).unwrap(); // stored as (1, 2): mᵀ
        add_block(&p, &mut diag, &mut off, 1, 2, m).unwrap();
        assert_eq!(diag[1], m);
        assert_eq!(off[p.find(0, 1).unwrap()], m);
        assert_eq!(off[p.find(1, 2).unwrap()], m + m.transpose());
        // Dense view: block (2, 1) is the transpose of (1, 2), i.e. m + mᵀ again, and the
        // block added as (2, 1) = m lands where it was put.
        let a = dense(&diag, &p, &off);
        let at = |r: usize, c: usize| a[r * 12 + c];
        assert_eq!(at(6, 3), (m + m.transpose()).col(0)[0] as f64);
        assert_eq!(at(6 + 1, 3), (m + m.transpose()).col(0)[1] as f64);

        let e = add_block(&p, &mut diag, &mut off, 0, 2, m);
        assert_eq!(e, Err(SparseError::MissingBlock));
        let e = add_block(&p, &mut diag, &mut off, 0, 4, m);
        assert_eq!(e, Err(SparseError::IndexOutOfRange));
        let e = add_block(&p, &mut diag[..1], &mut off, 2, 2, m);
        assert_eq!(e, Err(SparseError::LengthMismatch));
        let e = add_block(&p, &mut diag, &mut off[..0], 0, 1, m);
        assert_eq!(e, Err(SparseError::LengthMismatch));

        let mut sd = vec![0.0f32; 4];
        let mut so = vec![0.0f32; op.cols.len()];
        add_scalar(&p, &mut sd, &mut so, 3, 3, 2.0).unwrap();
        add_scalar(&p, &mut sd, &mut so, 0, 3, 1.0).unwrap();
        add_scalar(&p, &mut sd, &mut so, 3, 0, 0.5).unwrap();
        assert_eq!(sd, [0.0, 0.0, 0.0, 2.0]);
        assert_eq!(so[p.find(0, 3).unwrap()], 1.5);
        assert_eq!(
            add_scalar(&p, &mut sd, &mut so, 2, 3, 1.0),
            Err(SparseError::MissingBlock)
        );
        assert_eq!(
            add_scalar(&p, &mut sd, &mut so, 9, 3, 1.0),
            Err(SparseError::IndexOutOfRange)
        );
    }
}
