//! The hierarchy, built once from the mesh graph: greedy aggregation, level by level (see
//! the module docs of [`super`]).

use super::*;

/// A symmetric adjacency (CSR, both directions): the neighbours of `i` are
/// `adjacency[start[i]..start[i + 1]]`, e.g. a mesh's edge 1-rings.
#[derive(Clone, Copy, Debug)]
pub struct Graph<'a> {
    pub start: &'a [u32],
    pub adjacency: &'a [u32],
}

impl Graph<'_> {
    fn neighbours(&self, i: usize) -> &[u32] {
        match (self.start.get(i), self.start.get(i + 1)) {
            (Some(&a), Some(&b)) => self.adjacency.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    }
}

/// Builds the hierarchy of the fine `pattern` (`n = pattern.n()` vertices) and its scalar
/// couplings' pattern `scalars` (`sparse::Scalars`; empty, or `n` rows) into `mem`, for
/// `nnz = pattern.nnz() + scalars.nnz()` couplings. Every slice must hold its
/// `*_len(n, nnz)` entries ([`MgError::MemoryTooSmall`]). Deterministic; costs a few passes
/// over the pattern per level. The coarse levels couple the aggregates that either pattern
/// couples.
///
/// `graph`, if given, is what the finest level's aggregation walks instead of the full
/// pattern: for a cloth, the mesh edges (the bending stencil also couples the two vertices
/// opposite each edge, which doubles the pattern's degree and would make the aggregates twice
/// as wide — measured: 14× coarsening and iteration counts growing with the mesh, against
/// ~7× and bounded ones on the edges). Its neighbours must be couplings of `pattern` (a
/// neighbour out of range is ignored; the coarse operators are always built from the full
/// pattern).
///
/// `vectors` is how many `Vec3A` the caller will lend as [`Memory::vectors`] at solve time
/// (at most [`vectors_len`] are used): coarse levels that would not fit are dropped, so the
/// hierarchy is shallower (its coarsest level smoothed) rather than unusable.
pub fn build(
    pattern: &Pattern<'_>,
    scalars: &Pattern<'_>,
    graph: Option<Graph<'_>>,
    agg0: &mut [u32],
    index: &mut [u32],
    scratch: &mut [u32],
    vectors: usize,
) -> Result<Info, MgError> {
    pattern.validate().map_err(|_| MgError::InvalidPattern)?;
    let (n0, nnz0) = (pattern.n(), pattern.nnz());
    if !scalars.row_start.is_empty() {
        scalars.validate().map_err(|_| MgError::InvalidPattern)?;
        if scalars.n() != n0 {
            return Err(MgError::InvalidPattern);
        }
    }
    let all = nnz0 + scalars.nnz();
    // what is left of the lent pool after its first `Mat3A` boundary (`Multigrid::new`)
    let blocks_cap = blocks_len(n0, all).saturating_sub(ALIGN_SKIP);
    let vectors_cap = vectors_len(n0, all).min(vectors);
    if index.len() < index_len(n0, all) || agg0.len() < n0 || scratch.len() < scratch_len(n0, all) {
        return Err(MgError::MemoryTooSmall);
    }
    if u32::try_from(index.len()).is_err() || u32::try_from(blocks_cap).is_err() {
        return Err(MgError::MemoryTooSmall); // offsets are stored as u32
    }
    // The header, the finest level's coupling map (filled once level 1 exists), the pool.
    let base = HEADER + all;
    let (head, rest) = index.split_at_mut(HEADER);
    let (map, pool) = rest.split_at_mut(all);
    head.fill(0);

    let mut levels = [Level::default(); MAX_LEVELS];
    if let Some(l0) = levels.first_mut() {
        l0.n = n0;
        l0.nnz = nnz0;
    }
    let mut count = 1;
    let mut used = 0usize;
    while count < MAX_LEVELS {
        let l = count - 1;
        let cur = *levels.get(l).ok_or(MgError::Internal)?;
        if (l > 0 && cur.n <= MAX_DENSE) || cur.n <= 1 {
            break;
        }
        let (front, back) = pool.split_at_mut(used);
        let fine = if l == 0 {
            *pattern
        } else {
            coarse_pattern(front, &cur)?
        };
        // The finest level's aggregate map lives in its own slice, the others in the pool;
        // only it has scalar couplings (a coarse level's blocks hold them).
        let none = Pattern {
            row_start: &[],
            cols: &[],
        };
        let (graph, extra, agg_len) = if l == 0 {
            (graph, *scalars, 0)
        } else {
            (None, none, cur.n)
        };
        let (agg, out) = if l == 0 {
            (&mut *agg0, back)
        } else {
            back.split_at_mut(cur.n.min(back.len()))
        };
        let Some((nc, nnzc)) = coarsen(&fine, &extra, graph.as_ref(), agg, out, scratch)? else {
            break;
        };
        let lv = levels.get_mut(l).ok_or(MgError::Internal)?;
        lv.agg = used;
        let next = Level {
            n: nc,
            nnz: nnzc,
            rs: used + agg_len,
            cols: used + agg_len + nc + 1,
            ..Level::default()
        };
        *levels.get_mut(count).ok_or(MgError::Internal)? = next;
        used += agg_len + nc + 1 + nnzc;
        count += 1;
    }
    // Operators and vectors of the coarse levels (after the finest level's inverse and lumped
    // floats); a level that does not fit the budgets is dropped.
    // (On a `Mat3A` boundary of the aligned pool: `floats()` is a multiple of 4 too.)
    let (mut blk, mut vec) = (fine_floats(n0).next_multiple_of(4), 0usize);
    let mut keep = 1;
    for lv in levels.iter_mut().take(count).skip(1) {
        let need_b = lv.floats();
        let need_v = VECTORS_PER_LEVEL * lv.n;
        if blk + need_b > blocks_cap || vec + need_v > vectors_cap {
            break;
        }
        lv.blk = blk;
        lv.vec = vec;
        blk += need_b;
        vec += need_v;
        keep += 1;
    }
    count = keep;
    let coarsest = levels.get(count - 1).ok_or(MgError::Internal)?;
    let is_dense = count > 1 && coarsest.n <= MAX_DENSE;
    if count > 1 {
        let l1 = levels.get(1).ok_or(MgError::Internal)?;
        map_couplings(pattern, scalars, agg0, &coarse_pattern(pool, l1)?, map)?;
    }
    // Offsets are relative to `pool`; make them relative to `index`.
    for lv in levels.iter_mut().take(count).skip(1) {
        lv.agg += base;
        lv.rs += base;
        lv.cols += base;
    }
    let words = [MAGIC, count as u32, is_dense as u32, scalars.nnz() as u32];
    for (h, w) in head.iter_mut().zip(words) {
        *h = w;
    }
    for (l, lv) in levels.iter().enumerate().take(count) {
        let at = 4 + l * LEVEL_WORDS;
        part_mut(head, at, LEVEL_WORDS)?.copy_from_slice(&lv.to_words());
    }
    let h = read_header(index).ok_or(MgError::Internal)?;
    Ok(info_of(&h.levels, h.count, h.dense))
}

/// Where each coupling of the finest level lands in level 1's operator (see [`index_len`]):
/// for the block pattern's entries in order, then the scalar pattern's, the coarse block
/// `(I, J)` of their aggregates, [`TRANSPOSED`] when `I > J`, or [`SAME`].
fn map_couplings(
    pattern: &Pattern<'_>,
    scalars: &Pattern<'_>,
    agg: &[u32],
    coarse: &Pattern<'_>,
    map: &mut [u32],
) -> Result<(), MgError> {
    let nnz = pattern.nnz();
    let (blocks, rest) = map.split_at_mut(nnz.min(map.len()));
    for (p, out) in [(pattern, blocks), (scalars, rest)] {
        for i in 0..p.n() {
            let big_i = *agg.get(i).ok_or(MgError::Internal)? as usize;
            for (k, j) in p.upper(i) {
                let big_j = *agg.get(j).ok_or(MgError::Internal)? as usize;
                *out.get_mut(k).ok_or(MgError::Internal)? = coupling_code(coarse, big_i, big_j)?;
            }
        }
    }
    Ok(())
}

/// One coarsening step of the level with pattern `p` and the scalar couplings' pattern
/// `extra` (empty, or `n` rows): writes its aggregate map to `agg[..n]` and the coarse
/// pattern (row starts, then columns) to `out`. Returns `(coarse vertices, coarse
/// couplings)`, or `None` if coarsening stalls or `out` is full.
fn coarsen(
    p: &Pattern<'_>,
    extra: &Pattern<'_>,
    graph: Option<&Graph<'_>>,
    agg: &mut [u32],
    out: &mut [u32],
    scratch: &mut [u32],
) -> Result<Option<(usize, usize)>, MgError> {
    let (n, nnz) = (p.n(), p.nnz() + extra.nnz());
    if agg.len() < n || scratch.len() < 4 * n + nnz + 2 {
        return Ok(None);
    }
    let agg = agg.get_mut(..n).ok_or(MgError::Internal)?;
    // Every strictly-upper coupling of either pattern (`extra.upper` is empty for an empty
    // pattern).
    let upper = |i: usize| p.upper(i).chain(extra.upper(i)).map(|(_, j)| j);
    // Lower (transposed) pattern, so that every vertex sees all its neighbours.
    let (lo_start, scratch) = scratch.split_at_mut(n + 1);
    let (lo_rows, scratch) = scratch.split_at_mut(nnz);
    lo_start.fill(0);
    for i in 0..n {
        for j in upper(i) {
            *lo_start.get_mut(j + 1).ok_or(MgError::InvalidPattern)? += 1;
        }
    }
    let mut acc = 0u32;
    for s in lo_start.iter_mut() {
        acc += *s;
        *s = acc;
    }
    // lo_start[j + 1] counts down... fill with a cursor per row: use lo_start[j] as the cursor
    // and restore by shifting afterwards.
    // After the prefix sum lo_start[j] = start of row j (since entry j + 1 held row j's count).
    for i in 0..n {
        for j in upper(i) {
            let c = lo_start.get_mut(j).ok_or(MgError::InvalidPattern)?;
            *lo_rows.get_mut(*c as usize).ok_or(MgError::Internal)? = i as u32;
            *c += 1;
        }
    }
    // Now lo_start[j] = end of row j = start of row j + 1: shift right by one.
    for j in (1..=n).rev() {
        let prev = *lo_start.get(j - 1).ok_or(MgError::Internal)?;
        *lo_start.get_mut(j).ok_or(MgError::Internal)? = prev;
    }
    if let Some(s) = lo_start.first_mut() {
        *s = 0;
    }
    let lower = |i: usize| -> &[u32] {
        match (lo_start.get(i), lo_start.get(i + 1)) {
            (Some(&a), Some(&b)) => lo_rows.get(a as usize..b as usize).unwrap_or(&[]),
            _ => &[],
        }
    };

    // The aggregation's neighbours: the graph's, or all of the patterns'. Out-of-range
    // graph neighbours are dropped.
    let near = |i: usize| {
        let (up, lo, g): (_, &[u32], &[u32]) = match graph {
            Some(g) => (upper(usize::MAX), &[], g.neighbours(i)),
            None => (upper(i), lower(i), &[]),
        };
        up.chain(lo.iter().chain(g).map(|&j| j as usize))
            .filter(move |&j| j < n && j != i)
    };

    // Step 1: roots with all neighbours free take them all.
    agg.fill(NONE);
    let mut nc = 0u32;
    for i in 0..n {
        if agg.get(i) != Some(&NONE) {
            continue;
        }
        if !near(i).all(|j| agg.get(j).is_some_and(|&a| a == NONE)) {
            continue;
        }
        for j in near(i) {
            *agg.get_mut(j).ok_or(MgError::Internal)? = nc;
        }
        *agg.get_mut(i).ok_or(MgError::Internal)? = nc;
        nc += 1;
    }
    // Step 2: the rest join their first neighbour's step-1 aggregate (flagged meanwhile so
    // that nobody joins a step-2 member).
    for i in 0..n {
        if agg.get(i) != Some(&NONE) {
            continue;
        }
        let first = near(i)
            .filter_map(|j| agg.get(j).copied())
            .find(|&a| a != NONE && a & PASS2 == 0);
        let a = match first {
            Some(a) => a | PASS2,
            None => {
                // Unreachable for a vertex with neighbours (it would have been a root);
                // kept as a singleton for safety.
                nc += 1;
                (nc - 1) | PASS2
            }
        };
        *agg.get_mut(i).ok_or(MgError::Internal)? = a;
    }
    for a in agg.iter_mut() {
        *a &= !PASS2;
    }
    let nc = nc as usize;
    if nc * 10 > n * 9 || nc == 0 {
        return Ok(None);
    }

    // Members of each aggregate (counting sort) and a marker per coarse vertex.
    let (m_start, scratch) = scratch.split_at_mut(nc + 1);
    let (members, scratch) = scratch.split_at_mut(n);
    let mark = scratch.get_mut(..nc).ok_or(MgError::Internal)?;
    m_start.fill(0);
    for &a in agg.iter() {
        *m_start.get_mut(a as usize + 1).ok_or(MgError::Internal)? += 1;
    }
    let mut acc = 0u32;
    for s in m_start.iter_mut() {
        acc += *s;
        *s = acc;
    }
    for (i, &a) in agg.iter().enumerate() {
        let c = m_start.get_mut(a as usize).ok_or(MgError::Internal)?;
        *members.get_mut(*c as usize).ok_or(MgError::Internal)? = i as u32;
        *c += 1;
    }
    for j in (1..=nc).rev() {
        let prev = *m_start.get(j - 1).ok_or(MgError::Internal)?;
        *m_start.get_mut(j).ok_or(MgError::Internal)? = prev;
    }
    if let Some(s) = m_start.first_mut() {
        *s = 0;
    }

    // Coarse pattern: row I holds every J > I adjacent to one of I's members.
    if out.len() < nc + 1 {
        return Ok(None);
    }
    let (rs, cols) = out.split_at_mut(nc + 1);
    mark.fill(NONE);
    let mut w = 0usize;
    for big_i in 0..nc {
        *rs.get_mut(big_i).ok_or(MgError::Internal)? = w as u32;
        let (a, b) = (
            *m_start.get(big_i).ok_or(MgError::Internal)? as usize,
            *m_start.get(big_i + 1).ok_or(MgError::Internal)? as usize,
        );
        for &i in members.get(a..b).ok_or(MgError::Internal)? {
            let i = i as usize;
            for j in upper(i).chain(lower(i).iter().map(|&j| j as usize)) {
                let big_j = *agg.get(j).ok_or(MgError::Internal)?;
                if big_j as usize <= big_i {
                    continue;
                }
                let m = mark.get_mut(big_j as usize).ok_or(MgError::Internal)?;
                if *m == big_i as u32 {
                    continue;
                }
                *m = big_i as u32;
                let Some(slot) = cols.get_mut(w) else {
                    return Ok(None); // pool full: no further level
                };
                *slot = big_j;
                w += 1;
            }
        }
        let start = *rs.get(big_i).ok_or(MgError::Internal)? as usize;
        cols.get_mut(start..w)
            .ok_or(MgError::Internal)?
            .sort_unstable();
    }
    *rs.get_mut(nc).ok_or(MgError::Internal)? = w as u32;
    Ok(Some((nc, w)))
}
