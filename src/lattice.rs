//! The pixel lattice, once (docs/CONVENTIONS.md, "The pixel lattice"): how nodes and triangles
//! of a grid of squares are numbered, shared by the cell meshes (`cell.rs`), the blob's topology
//! check, point location and the tiled micro mesh (`localize/`) and the coarse grid helper
//! (`mesh::grid`).
//!
//! Node `(i, j)` (`i` along u, `j` along v from the bottom) of a grid `row` nodes wide has index
//! `j·row + i`; square `(i, j)` is split along its lower-left → upper-right diagonal into the
//! counter-clockwise triangles `[ll, lr, ur]` then `[ll, ur, ul]`, with index
//! `2·(j·squares_per_row + i) + {0, 1}`.

/// Index of node `(i, j)` in a grid `row` nodes wide.
#[inline]
pub const fn node(i: usize, j: usize, row: usize) -> usize {
    j * row + i
}

/// The two counter-clockwise triangles of a square with corners `ll, lr, ur, ul`: the lower one
/// `[ll, lr, ur]` below the diagonal, the upper one `[ll, ur, ul]` above it.
#[inline]
pub const fn square_triangles<T: Copy>(ll: T, lr: T, ur: T, ul: T) -> [[T; 3]; 2] {
    [[ll, lr, ur], [ll, ur, ul]]
}

/// The square `(i, j)` that triangle `t` belongs to, in a grid `squares_per_row` wide, and
/// whether it is the upper triangle of the two.
#[inline]
pub const fn square_of_triangle(t: usize, squares_per_row: usize) -> (usize, usize, bool) {
    let s = t / 2;
    (s % squares_per_row, s / squares_per_row, t % 2 == 1)
}

/// The pattern pixel `(row, col)` of square `(i, j)` at refine `k` in a pattern `rows` pixels
/// high: row 0 is the top row, so the bottom squares belong to the last row.
#[inline]
pub const fn pixel_of_square(i: usize, j: usize, k: usize, rows: usize) -> (usize, usize) {
    (rows - 1 - j / k, i / k)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbering_follows_the_conventions() {
        assert_eq!(node(2, 1, 5), 7);
        assert_eq!(square_triangles(0, 1, 6, 5), [[0, 1, 6], [0, 6, 5]]);
        assert_eq!(square_of_triangle(7, 3), (0, 1, true));
        assert_eq!(square_of_triangle(6, 3), (0, 1, false));
        // a 2-row pattern at refine 2: squares j = 0, 1 are row 1 (the bottom), j = 2, 3 row 0
        assert_eq!(pixel_of_square(3, 0, 2, 2), (1, 1));
        assert_eq!(pixel_of_square(0, 3, 2, 2), (0, 0));
    }
}
