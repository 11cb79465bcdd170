//! The Voigt type of membrane stiffness and its helpers: order `[11, 22, 12]`, engineering
//! shear (docs/CONVENTIONS.md). One home for what the cell problem, the blob, the runtime
//! element and the tools all use.
#![allow(clippy::needless_range_loop)] // index loops mirror the matrix formulas

/// A 3×3 Voigt stiffness (or compliance) tensor, row-major, order `[11, 22, 12]`, engineering shear.
pub type Voigt = [[f64; 3]; 3];

/// Isotropic membrane stiffness (docs/CONVENTIONS.md): `Y/(1-ν²) [[1, ν, 0], [ν, 1, 0], [0, 0, (1-ν)/2]]`.
pub fn isotropic(stiffness: f64, poisson: f64) -> Voigt {
    let f = stiffness / (1.0 - poisson * poisson);
    [
        [f, f * poisson, 0.0],
        [f * poisson, f, 0.0],
        [0.0, 0.0, f * (1.0 - poisson) * 0.5],
    ]
}

/// True when `c` is finite, symmetric (to a relative 1e-9) and positive definite (Sylvester's
/// criterion on the leading minors).
pub fn is_spd(c: &Voigt) -> bool {
    let scale = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if !scale.is_finite() || scale <= 0.0 || c.iter().flatten().any(|v| !v.is_finite()) {
        return false;
    }
    // lower against upper triangle, (1, 0), (2, 0), (2, 1)
    let [[_, c01, c02], [c10, _, c12], [c20, c21, _]] = *c;
    for (lower, upper) in [(c10, c01), (c20, c02), (c21, c12)] {
        if (lower - upper).abs() > 1e-9 * scale {
            return false;
        }
    }
    let m1 = c[0][0];
    let m2 = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    let m3 = det3(c);
    let tol = 1e-14;
    m1 > tol * scale && m2 > tol * scale * scale && m3 > tol * scale * scale * scale
}

/// Determinant of a 3×3 matrix.
pub fn det3(m: &Voigt) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
        - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Inverse of a 3×3 matrix, `None` when singular or non-finite.
pub fn inverse3(m: &Voigt) -> Option<Voigt> {
    let d = det3(m);
    if !d.is_finite() || d == 0.0 {
        return None;
    }
    let at = |i: usize, j: usize| m.get(i).and_then(|row| row.get(j)).copied();
    let mut r = [[0.0; 3]; 3];
    for (i, ri) in r.iter_mut().enumerate() {
        for (j, rij) in ri.iter_mut().enumerate() {
            let (i1, i2) = ((j + 1) % 3, (j + 2) % 3);
            let (j1, j2) = ((i + 1) % 3, (i + 2) % 3);
            *rij = (at(i1, j1)? * at(i2, j2)? - at(i1, j2)? * at(i2, j1)?) / d;
        }
    }
    Some(r)
}
