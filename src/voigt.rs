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

/// Why a tensor is not symmetric positive definite, in the order [`check_spd`] tests.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpdProblem {
    /// An entry is NaN or infinite.
    NotFinite,
    /// Entry `(row, col)` (below the diagonal) differs from `(col, row)` by more than a relative
    /// 1e-9 of the largest entry.
    Asymmetric { row: usize, col: usize },
    /// Symmetric, but a leading minor is not positive (the tensor would let some strain store
    /// no or negative energy).
    NotPositiveDefinite,
}

/// `Ok` when `c` is finite, symmetric (to a relative 1e-9) and positive definite (Sylvester's
/// criterion on the leading minors); else the first problem found.
pub fn check_spd(c: &Voigt) -> Result<(), SpdProblem> {
    if c.iter().flatten().any(|v| !v.is_finite()) {
        return Err(SpdProblem::NotFinite);
    }
    let scale = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    let [[_, c01, c02], [c10, _, c12], [c20, c21, _]] = *c;
    for (row, col, lower, upper) in [(1, 0, c10, c01), (2, 0, c20, c02), (2, 1, c21, c12)] {
        if (lower - upper).abs() > 1e-9 * scale {
            return Err(SpdProblem::Asymmetric { row, col });
        }
    }
    let m1 = c[0][0];
    let m2 = c[0][0] * c[1][1] - c[0][1] * c[1][0];
    let m3 = det3(c);
    let tol = 1e-14;
    let positive = scale > 0.0
        && m1 > tol * scale
        && m2 > tol * scale * scale
        && m3 > tol * scale * scale * scale;
    if positive {
        Ok(())
    } else {
        Err(SpdProblem::NotPositiveDefinite)
    }
}

/// True when `c` is finite, symmetric (to a relative 1e-9) and positive definite: [`check_spd`].
pub fn is_spd(c: &Voigt) -> bool {
    check_spd(c).is_ok()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spd_problems_are_told_apart() {
        // An anisotropic SPD tensor (coupled shear), then one defect at a time.
        let c = [[300.0, 40.0, 10.0], [40.0, 90.0, 5.0], [10.0, 5.0, 30.0]];
        assert_eq!(check_spd(&c), Ok(()));
        let mut asym = c;
        asym[2][1] = 6.0;
        assert_eq!(
            check_spd(&asym),
            Err(SpdProblem::Asymmetric { row: 2, col: 1 })
        );
        // within the relative 1e-9: decimal round-off in a file, accepted
        asym[2][1] = 5.0 + 1e-8;
        assert_eq!(check_spd(&asym), Ok(()));
        let mut indefinite = c;
        indefinite[0][1] = 200.0;
        indefinite[1][0] = 200.0; // 300·90 − 200² < 0
        assert_eq!(check_spd(&indefinite), Err(SpdProblem::NotPositiveDefinite));
        assert_eq!(
            check_spd(&[[0.0; 3]; 3]),
            Err(SpdProblem::NotPositiveDefinite)
        );
        let mut nan = c;
        nan[1][1] = f64::NAN;
        assert_eq!(check_spd(&nan), Err(SpdProblem::NotFinite));
        assert!(is_spd(&c) && !is_spd(&indefinite));
    }
}
