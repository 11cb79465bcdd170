//! `weft-cell inspect LIB.weft [--json]`: what a blob holds, for people (a table) and for scripts
//! (one JSON object on one line, schema below).
//!
//! JSON: `{"version": N, "cells": [{"name", "size", "height", "pixels": [cols, rows], "refine",
//! "grid": [nu, nv], "nodes", "triangles", "stiffness", "density", "bending", "voigt_bound",
//! "reuss_bound", "anisotropy", "bounds": {"holds", "min_eig_ch_minus_reuss",
//! "min_eig_voigt_minus_ch"}, "chi": {"max_norm": [k=0, 1, 2], "max_abs_mean"}, "materials":
//! [{"c", "density", "bending", "area_fraction"}]}]}` with the tensors as 3×3 row-major arrays
//! (N/m, Voigt `[11, 22, 12]`): everything the table shows, from the same [`Summary`].

use std::fmt::Write as _;
use std::path::Path;

use serde_json::json;
use weft::blob::{load_aligned, Blob, Cell};
use weft::Voigt;

pub fn run(path: &Path, json: bool) -> Result<(), String> {
    let bytes = load_aligned(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let blob = Blob::parse(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
    if json {
        let text = serde_json::to_string(&to_json(&blob)).map_err(|e| e.to_string())?;
        println!("{text}");
    } else {
        print!("{}", table(&blob, path, bytes.len()));
    }
    Ok(())
}

/// What inspect derives from a cell, for the table and the JSON alike.
struct Summary {
    /// `C11 / C22` of `C^H`.
    anisotropy: f64,
    /// Smallest eigenvalues of `C^H − Reuss` and `Voigt − C^H`, relative to the largest of `C^H`.
    lower: f64,
    upper: f64,
    bounds: Bounds,
    /// Largest `|χ^k|` per unit strain k, and the largest `|mean χ|` component (0 for a
    /// well-posed periodic solution), metres.
    max_chi: [f64; 3],
    max_abs_mean_chi: f64,
    /// Fraction of the cell's triangles (= of its area: equal triangles) per material.
    area_fraction: Vec<f64>,
}

/// Whether `Reuss ≤ C^H ≤ Voigt` (in the sense of symmetric matrices) holds.
#[derive(Clone, Copy, PartialEq, Debug)]
enum Bounds {
    /// Both differences positive semidefinite.
    Hold,
    /// A difference has an eigenvalue below zero but above −[`SOLVER_PRECISION`]: the solver's
    /// accuracy, not a violation one can tell.
    WithinSolverPrecision,
    Violated,
}

/// Relative accuracy of the homogenization's `C^H` (its solves stop there).
const SOLVER_PRECISION: f64 = 1e-6;
/// Relative eigenvalues below this are the Jacobi iteration's round-off: shown as 0. A laminate's
/// `C^H` equals a bound exactly in one direction, where this difference is ~1e-16.
const ROUND_OFF: f64 = 1e-12;

impl Summary {
    fn of(c: &Cell) -> Summary {
        let scale = sym_eigenvalues(&c.stiffness)[2];
        let relative = |m: &Voigt| {
            let e = sym_eigenvalues(m)[0] / scale;
            if e.abs() < ROUND_OFF {
                0.0
            } else {
                e
            }
        };
        let lower = relative(&sub(&c.stiffness, &c.reuss_bound));
        let upper = relative(&sub(&c.voigt_bound, &c.stiffness));
        let worst = lower.min(upper);
        let bounds = if worst >= 0.0 {
            Bounds::Hold
        } else if worst > -SOLVER_PRECISION {
            Bounds::WithinSolverPrecision
        } else {
            Bounds::Violated
        };
        let mut max_chi = [0.0f64; 3];
        let mut mean = [0.0f64; 6];
        for x in c.chi {
            for (k, m) in max_chi.iter_mut().enumerate() {
                *m = m.max(f64::from(x[2 * k]).hypot(f64::from(x[2 * k + 1])));
            }
            for (m, v) in mean.iter_mut().zip(x) {
                *m += f64::from(*v) / c.chi.len() as f64;
            }
        }
        let total = c.tri_material.len().max(1) as f64;
        Summary {
            anisotropy: c.stiffness[0][0] / c.stiffness[1][1],
            lower,
            upper,
            bounds,
            max_chi,
            max_abs_mean_chi: mean.iter().fold(0.0f64, |m, v| m.max(v.abs())),
            area_fraction: (0..c.materials.len())
                .map(|m| c.tri_material.iter().filter(|&&t| t as usize == m).count() as f64 / total)
                .collect(),
        }
    }
}

fn to_json(blob: &Blob) -> serde_json::Value {
    let cells: Vec<_> = blob
        .cells()
        .map(|c| {
            let s = Summary::of(&c);
            let materials: Vec<_> = c
                .materials
                .iter()
                .zip(&s.area_fraction)
                .map(|(m, area)| {
                    json!({"c": m.c, "density": m.density, "bending": m.bending,
                           "area_fraction": area})
                })
                .collect();
            json!({
                "name": c.name,
                "size": c.size,
                "height": c.height(),
                "pixels": [c.cols, c.rows],
                "refine": c.refine,
                "grid": [c.nu(), c.nv()],
                "nodes": c.nodes.len(),
                "triangles": c.triangles.len(),
                "stiffness": c.stiffness,
                "density": c.density,
                "bending": c.bending,
                "voigt_bound": c.voigt_bound,
                "reuss_bound": c.reuss_bound,
                "anisotropy": s.anisotropy,
                "bounds": {
                    "holds": match s.bounds {
                        Bounds::Hold => "yes",
                        Bounds::WithinSolverPrecision => "within solver precision",
                        Bounds::Violated => "no",
                    },
                    "min_eig_ch_minus_reuss": s.lower,
                    "min_eig_voigt_minus_ch": s.upper,
                },
                "chi": {"max_norm": s.max_chi, "max_abs_mean": s.max_abs_mean_chi},
                "materials": materials,
            })
        })
        .collect();
    json!({ "version": blob.version(), "cells": cells })
}

/// About five significant digits, fixed-point where that stays short, else scientific.
fn num(x: f64) -> String {
    let a = x.abs();
    if x == 0.0 {
        "0".into()
    } else if (1e-3..1e6).contains(&a) {
        let decimals = (4 - a.log10().floor() as i32).clamp(0, 7) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.4e}")
    }
}

/// Eigenvalues of a symmetric 3×3 matrix by cyclic Jacobi rotations (ascending).
fn sym_eigenvalues(m: &Voigt) -> [f64; 3] {
    let mut a = *m;
    for _ in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        if off <= 1e-30 * (a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2)) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            // smaller root of t² + 2θt - 1 = 0 (rotation angle ≤ π/4, numerically stable)
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let (c, s) = (1.0 / (t * t + 1.0).sqrt(), t / (t * t + 1.0).sqrt());
            // a <- Jᵀ a J with J the rotation in the (p, q) plane
            for row in a.iter_mut() {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (rp, rq) = (a[p], a[q]);
            a[p] = core::array::from_fn(|k| c * rp[k] - s * rq[k]);
            a[q] = core::array::from_fn(|k| s * rp[k] + c * rq[k]);
        }
    }
    let mut e = [a[0][0], a[1][1], a[2][2]];
    e.sort_by(f64::total_cmp);
    e
}

fn sub(a: &Voigt, b: &Voigt) -> Voigt {
    core::array::from_fn(|i| {
        core::array::from_fn(|j| 0.5 * (a[i][j] + a[j][i] - b[i][j] - b[j][i]))
    })
}

fn table(blob: &Blob, path: &Path, len: usize) -> String {
    let mut s = String::new();
    let n = blob.cell_count();
    let _ = writeln!(
        s,
        "{}: weft cell blob v{}, {} cell{}, {} bytes",
        path.display(),
        blob.version(),
        n,
        if n == 1 { "" } else { "s" },
        len
    );
    for (i, c) in blob.cells().enumerate() {
        cell_table(&mut s, i, &c);
    }
    s
}

fn cell_table(s: &mut String, index: usize, c: &Cell) {
    let sum = Summary::of(c);
    let _ = writeln!(s, "\ncell {index} \"{}\"", c.name);
    let _ = writeln!(
        s,
        "  pattern    {} x {} pixels, refine {} -> {} x {} grid, {} nodes, {} triangles",
        c.cols,
        c.rows,
        c.refine,
        c.nu(),
        c.nv(),
        c.nodes.len(),
        c.triangles.len()
    );
    let _ = writeln!(
        s,
        "  size       {} m x {} m",
        num(c.width()),
        num(c.height())
    );
    let _ = writeln!(
        s,
        "  density    {} kg/m^2    bending {} N m",
        num(c.density),
        num(c.bending)
    );

    let _ = writeln!(s, "  stiffness (N/m, Voigt [11, 22, 12]):");
    let _ = writeln!(
        s,
        "    {:<38}{:<38}{:<38}",
        "C^H", "Voigt bound", "Reuss bound"
    );
    for r in 0..3 {
        let row = |m: &Voigt| {
            format!(
                "[{:>11} {:>11} {:>11} ]",
                num(m[r][0]),
                num(m[r][1]),
                num(m[r][2])
            )
        };
        let _ = writeln!(
            s,
            "    {:<38}{:<38}{:<38}",
            row(&c.stiffness),
            row(&c.voigt_bound),
            row(&c.reuss_bound)
        );
    }
    let _ = writeln!(s, "  anisotropy C11/C22 = {}", num(sum.anisotropy));

    // Sanity anchors the reader does not enforce (they hold to solver precision only).
    let _ = writeln!(
        s,
        "  Reuss <= C^H <= Voigt: {} (min eigenvalue of C^H - Reuss {}, of Voigt - C^H {}, relative to |C^H|)",
        match sum.bounds {
            Bounds::Hold => "yes".to_string(),
            Bounds::WithinSolverPrecision =>
                format!("within solver precision (> -{SOLVER_PRECISION:e})"),
            Bounds::Violated => "NO".to_string(),
        },
        num(sum.lower),
        num(sum.upper)
    );
    let _ = writeln!(
        s,
        "  chi        max |chi^k| = {} / {} / {} m per unit strain, max |mean| {} m",
        num(sum.max_chi[0]),
        num(sum.max_chi[1]),
        num(sum.max_chi[2]),
        num(sum.max_abs_mean_chi)
    );

    let _ = writeln!(s, "  materials  {}", c.materials.len());
    for (m, (rec, share)) in c.materials.iter().zip(&sum.area_fraction).enumerate() {
        let _ = writeln!(
            s,
            "    #{m:<3} C11 {:>10}  C22 {:>10}  C12 {:>10}  C33 {:>10} N/m   density {} kg/m^2   bending {} N m   area {:.1} %",
            num(rec.c[0][0]),
            num(rec.c[1][1]),
            num(rec.c[0][1]),
            num(rec.c[2][2]),
            num(rec.density),
            num(rec.bending),
            100.0 * share
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_of_a_known_matrix() {
        // [[2,1,0],[1,2,0],[0,0,5]] has eigenvalues 1, 3, 5
        let e = sym_eigenvalues(&[[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]);
        for (got, want) in e.iter().zip([1.0, 3.0, 5.0]) {
            assert!((got - want).abs() < 1e-12, "{e:?}");
        }
        let e = sym_eigenvalues(&[[4.0, 1.0, 2.0], [1.0, 3.0, 0.5], [2.0, 0.5, 6.0]]);
        assert!((e.iter().sum::<f64>() - 13.0).abs() < 1e-12);
        assert!(
            (e.iter().product::<f64>()
                - weft::membrane::det3(&[[4.0, 1.0, 2.0], [1.0, 3.0, 0.5], [2.0, 0.5, 6.0]]))
            .abs()
                < 1e-10
        );
    }

    #[test]
    fn numbers_are_short() {
        assert_eq!(num(2197.8021978), "2197.8");
        assert_eq!(num(0.25), "0.25000");
        assert_eq!(num(2e-5), "2.0000e-5");
        assert_eq!(num(0.0), "0");
    }
}
