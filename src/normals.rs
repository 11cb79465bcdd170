//! Area-weighted vertex normals of the coarse cloth: the fallback normal of a collapsed triangle's
//! frame, the wind and drag direction, and the normals that localization blends.

use core::fmt;

use glam::Vec3A;

/// The rest normal of every triangle: the cloth's rest shape is its material space `(u, v, 0)`.
pub const REST_NORMAL: Vec3A = Vec3A::Z;

/// Why [`vertex_normals`] refused its input. Nothing is written when an error is returned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalsError {
    /// `out` or `tri_sign` has the wrong length.
    LengthMismatch,
    /// A triangle names a vertex out of range.
    IndexOutOfRange,
    /// A triangle sign is not exactly `1.0` or `-1.0`.
    BadTriangleSign,
}

impl fmt::Display for NormalsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            NormalsError::LengthMismatch => "slice lengths disagree",
            NormalsError::IndexOutOfRange => "vertex index out of range",
            NormalsError::BadTriangleSign => "triangle sign is not +1 or -1",
        })
    }
}

/// Area-weighted vertex normals, normalized.
///
/// `tri_sign[t]` is `+1` if triangle `t` is counter-clockwise in `(u, v)` and `-1` otherwise,
/// so that every triangle's normal is `+Z` at rest. `out` is read as the previous normals and
/// overwritten. A node whose incident triangles are degenerate (total area-weighted normal below
/// 1e-6 of the largest triangle's), non-finite, or absent keeps its previous normal (or `Z` if
/// the previous one is not a finite unit vector): the previous normal is blended in with that
/// tiny weight, so the transition is continuous. Triangles with non-finite normals are skipped,
/// so a NaN position does not poison its neighbours' normals.
pub fn vertex_normals(
    triangles: &[[u32; 3]],
    tri_sign: &[f32],
    x: &[Vec3A],
    out: &mut [Vec3A],
) -> Result<(), NormalsError> {
    let n = x.len();
    if out.len() != n || tri_sign.len() != triangles.len() {
        return Err(NormalsError::LengthMismatch);
    }
    let tri_normal = |t: &[u32; 3], s: f32| -> Vec3A {
        let [a, b, c] = t.map(|v| x.get(v as usize).copied().unwrap_or(Vec3A::ZERO));
        s * (b - a).cross(c - a)
    };
    // Pass 1, with the checks of the input (nothing is written before it ends): scale of
    // the mesh (largest |2·area|), ignoring non-finite triangles. Squared: `√` is monotone
    // and correctly rounded, so the root of the largest square is the largest length, and
    // a length is finite exactly when its square is; one root instead of one per triangle.
    let (mut bad_index, mut bad_sign) = (false, false);
    let mut largest2 = 0.0f32;
    for (t, &s) in triangles.iter().zip(tri_sign) {
        bad_index |= t.iter().any(|&v| v as usize >= n);
        bad_sign |= s != 1.0 && s != -1.0;
        let l2 = tri_normal(t, s).length_squared();
        if l2.is_finite() && l2 > largest2 {
            largest2 = l2;
        }
    }
    if bad_index {
        return Err(NormalsError::IndexOutOfRange);
    }
    if bad_sign {
        return Err(NormalsError::BadTriangleSign);
    }
    let largest = libm::sqrtf(largest2);
    // 1e-18 keeps tau² a normal f32 so the fallback survives normalization.
    let tau = (1e-6 * largest).max(1e-18);
    // Pass 2: seed with the previous normal, then accumulate the triangles' 2·area·normal.
    for o in out.iter_mut() {
        let l2 = o.length_squared();
        let prev = if o.is_finite() && (0.25..4.0).contains(&l2) {
            *o / libm::sqrtf(l2)
        } else {
            REST_NORMAL
        };
        *o = tau * prev;
    }
    for (t, &s) in triangles.iter().zip(tri_sign) {
        let nt = tri_normal(t, s);
        if !nt.is_finite() {
            continue;
        }
        for &v in t {
            if let Some(o) = out.get_mut(v as usize) {
                *o += nt;
            }
        }
    }
    for o in out.iter_mut() {
        let l2 = o.length_squared();
        *o = if l2 > 0.0 && l2.is_finite() {
            *o / libm::sqrtf(l2)
        } else {
            REST_NORMAL
        };
    }
    Ok(())
}

#[cfg(test)]
#[allow(clippy::indexing_slicing, clippy::unwrap_used)]
mod tests {
    use super::*;
    use glam::Mat3A;

    struct Grid {
        rest: Vec<Vec3A>,
        tris: Vec<[u32; 3]>,
    }

    /// A flat 3×3-node grid, split as in ARCHITECTURE.md.
    fn grid() -> Grid {
        let rest = (0..9)
            .map(|k| Vec3A::new((k % 3) as f32, (k / 3) as f32, 0.0))
            .collect();
        let mut tris = Vec::new();
        for j in 0..2u32 {
            for i in 0..2u32 {
                let (ll, lr, ur, ul) = (3 * j + i, 3 * j + i + 1, 3 * j + i + 4, 3 * j + i + 3);
                tris.push([ll, lr, ur]);
                tris.push([ll, ur, ul]);
            }
        }
        Grid { rest, tris }
    }

    #[test]
    fn vertex_normals_and_validation() {
        let g = grid();
        let mut out = vec![Vec3A::ZERO; 9];
        // Flipped orientation with sign -1 still gives +Z.
        let tris: Vec<[u32; 3]> = g.tris.iter().map(|t| [t[0], t[2], t[1]]).collect();
        vertex_normals(&tris, &vec![-1.0; tris.len()], &g.rest, &mut out).unwrap();
        assert!(out.iter().all(|n| (*n - Vec3A::Z).length() < 1e-6));
        // Rigidly rotated: normals rotate.
        let r = Mat3A::from_rotation_x(2.0);
        let x: Vec<Vec3A> = g.rest.iter().map(|&p| r * p).collect();
        vertex_normals(&g.tris, &vec![1.0; g.tris.len()], &x, &mut out).unwrap();
        assert!(out.iter().all(|n| (*n - r * Vec3A::Z).length() < 1e-6));
        // Collapsed: previous normals kept.
        let prev = Vec3A::new(0.0, 0.6, 0.8);
        let mut out = vec![prev; 9];
        vertex_normals(
            &g.tris,
            &vec![1.0; g.tris.len()],
            &[Vec3A::ONE; 9],
            &mut out,
        )
        .unwrap();
        assert!(out.iter().all(|n| (*n - prev).length() < 1e-6));
        // Garbage previous normal: Z.
        let mut out = vec![Vec3A::NAN; 9];
        vertex_normals(
            &g.tris,
            &vec![1.0; g.tris.len()],
            &[Vec3A::ONE; 9],
            &mut out,
        )
        .unwrap();
        assert!(out.iter().all(|n| *n == Vec3A::Z));
        // Errors.
        let s = vec![1.0; g.tris.len()];
        assert_eq!(
            vertex_normals(&g.tris, &s[1..], &g.rest, &mut out),
            Err(NormalsError::LengthMismatch)
        );
        let mut bad = g.tris.clone();
        bad[0][1] = 9;
        assert_eq!(
            vertex_normals(&bad, &s, &g.rest, &mut out),
            Err(NormalsError::IndexOutOfRange)
        );
        let mut bs = s.clone();
        bs[3] = 0.5;
        assert_eq!(
            vertex_normals(&g.tris, &bs, &g.rest, &mut out),
            Err(NormalsError::BadTriangleSign)
        );
    }
}
