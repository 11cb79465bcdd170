//! The solver's kernels alone: `sparse::mul` and one block-Jacobi PCG iteration (`pcg::solve`
//! with and without a constraint filter) on a World-shaped matrix, the hinge couplings stored
//! as the World stores them (scalars on a pattern of their own, `sparse::Scalars`) and, for
//! comparison in the same run, as 3×3 blocks.
//!
//! `cargo run --release --example bench_kernels [-- --grid 21 --reps 15]`
//!
//! The matrix has the World's structure on an N×N grid sheet: full (non-symmetric) 3×3 blocks
//! for the mesh edges, scalar × I blocks for the hinge couplings (the two vertices opposite an
//! interior edge), SPD. Printed: the median over `reps` batches of ns per product / per CG
//! iteration (each batch about 20 ms).

#[cfg(feature = "std")]
fn main() {
    use glam::{Mat3A, Vec3A};
    use std::collections::HashMap;
    use std::time::Instant;
    use weft::pcg::{self, Settings, Work};
    use weft::sparse::{self, add_block, BlockMatrix, Pattern, Scalars};

    let mut grid = 21usize;
    let mut reps = 15usize;
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = || it.next().cloned().unwrap_or_default();
        match a.as_str() {
            "--grid" => grid = val().parse().expect("--grid"),
            "--reps" => reps = val().parse().expect("--reps"),
            _ => panic!("unknown argument {a}"),
        }
    }

    // Deterministic LCG in [-1, 1).
    let mut state = 0x5eed_u64;
    let mut uniform = move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 33) as f64 / (1u64 << 31) as f64 * 2.0 - 1.0) as f32
    };

    let n = grid * grid;
    let mut positions = vec![[0.0f32; 3]; n];
    let mut uvs = vec![[0.0f32; 2]; n];
    let mut tris = vec![[0u32; 3]; 2 * (grid - 1) * (grid - 1)];
    weft::mesh::grid(grid, grid, 1.0, 1.0, &mut positions, &mut uvs, &mut tris).expect("grid");
    let mut opposite: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for t in &tris {
        for k in 0..3 {
            let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
            opposite.entry((a.min(b), a.max(b))).or_default().push(c);
        }
    }
    let mut edges: Vec<[u32; 2]> = opposite.keys().map(|&(a, b)| [a, b]).collect();
    edges.sort_unstable();
    let mut hinges: Vec<[u32; 2]> = opposite
        .values()
        .filter(|o| o.len() == 2)
        .map(|o| [o[0], o[1]])
        .collect();
    hinges.sort_unstable();
    let pairs: Vec<[u32; 2]> = edges.iter().chain(&hinges).copied().collect();
    let mut row_start = vec![0u32; n + 1];
    let mut cols = vec![0u32; sparse::pattern_capacity(&pairs)];
    let nnz = sparse::build_pattern(n, &pairs, &mut row_start, &mut cols).expect("pattern");
    cols.truncate(nnz);
    let p = Pattern {
        row_start: &row_start,
        cols: &cols,
    };
    let mut diag = vec![Mat3A::from_diagonal(glam::Vec3::splat(1.0)); n];
    let mut off = vec![Mat3A::ZERO; nnz];
    let mut mat = || Mat3A::from_cols_array(&core::array::from_fn(|_| uniform()));
    for &[a, b] in &edges {
        let (a, b) = (a as usize, b as usize);
        let l = mat();
        let k = 50.0 * (l * l.transpose() + 0.1 * Mat3A::IDENTITY);
        let t = Mat3A::IDENTITY + 0.3 * mat();
        add_block(&p, &mut diag, &mut off, a, a, k).expect("block");
        add_block(&p, &mut diag, &mut off, b, b, t.transpose() * k * t).expect("block");
        add_block(&p, &mut diag, &mut off, a, b, -(k * t)).expect("block");
    }
    for &[a, b] in &hinges {
        let (a, b) = (a as usize, b as usize);
        let s = 2.0 * Mat3A::IDENTITY;
        add_block(&p, &mut diag, &mut off, a, a, s).expect("block");
        add_block(&p, &mut diag, &mut off, b, b, s).expect("block");
        add_block(&p, &mut diag, &mut off, a, b, -s).expect("block");
    }
    let blocks = BlockMatrix {
        diag: &diag,
        pattern: p,
        off: &off,
        scalars: Scalars::NONE,
    };
    blocks.validate().expect("valid");
    // The same matrix as the World stores it: edge blocks, hinge scalars.
    let mut e_start = vec![0u32; n + 1];
    let mut e_cols = vec![0u32; edges.len()];
    let e_nnz = sparse::build_pattern(n, &edges, &mut e_start, &mut e_cols).expect("edges");
    let mut h_start = vec![0u32; n + 1];
    let mut h_cols = vec![0u32; hinges.len()];
    let h_nnz = sparse::build_pattern(n, &hinges, &mut h_start, &mut h_cols).expect("hinges");
    let (ep, hp) = (
        Pattern {
            row_start: &e_start,
            cols: &e_cols[..e_nnz],
        },
        Pattern {
            row_start: &h_start,
            cols: &h_cols[..h_nnz],
        },
    );
    let e_off: Vec<Mat3A> = (0..n)
        .flat_map(|i| ep.upper(i).map(move |(_, j)| (i, j)))
        .map(|(i, j)| off[p.find(i, j).expect("edge")])
        .collect();
    let h_off: Vec<f32> = (0..n)
        .flat_map(|i| hp.upper(i).map(move |(_, j)| (i, j)))
        .map(|(i, j)| off[p.find(i, j).expect("hinge")].x_axis.x)
        .collect();
    let a = BlockMatrix {
        diag: &diag,
        pattern: ep,
        off: &e_off,
        scalars: Scalars {
            pattern: hp,
            off: &h_off,
            scale: 1.0,
        },
    };
    a.validate().expect("valid");
    let precond: Vec<Mat3A> = diag.iter().map(|&d| pcg::invert_block(d)).collect();
    let x: Vec<Vec3A> = (0..n)
        .map(|_| Vec3A::new(uniform(), uniform(), uniform()))
        .collect();
    let b: Vec<Vec3A> = (0..n)
        .map(|_| Vec3A::new(uniform(), uniform(), uniform()))
        .collect();
    // Two pinned corners and a band of contacts along a tilted normal, the rest free.
    let mut filter = vec![Mat3A::IDENTITY; n];
    filter[n - grid] = Mat3A::ZERO;
    filter[n - 1] = Mat3A::ZERO;
    let nrm = Vec3A::new(0.2, 1.0, -0.3).normalize();
    let nnt = Mat3A::from_cols(nrm * nrm.x, nrm * nrm.y, nrm * nrm.z);
    for f in filter.iter_mut().skip(n / 3).step_by(7).take(grid) {
        *f = Mat3A::IDENTITY - nnt;
    }

    println!(
        "grid {grid}×{grid}: n = {n}, nnz = {nnz} ({} edge, {} hinge blocks), median of {reps} batches",
        edges.len(),
        hinges.len()
    );

    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    // ns per call of `f`, median over batches of ~20 ms.
    let time = |f: &mut dyn FnMut() -> u64| -> f64 {
        let t0 = Instant::now();
        let mut calls = 0u64;
        while t0.elapsed().as_secs_f64() < 0.02 {
            calls += f();
        }
        let per = (calls as f64 / t0.elapsed().as_secs_f64() * 0.02).max(1.0) as u64;
        let mut batches = Vec::new();
        for _ in 0..reps {
            let t = Instant::now();
            let mut c = 0u64;
            while c < per {
                c += f();
            }
            batches.push(t.elapsed().as_secs_f64() * 1e9 / c as f64);
        }
        median(batches)
    };

    for (name, m) in [
        ("mul, hinges as scalars", &a),
        ("mul, hinges as blocks", &blocks),
    ] {
        let mut y = vec![Vec3A::ZERO; n];
        let t_mul = time(&mut || {
            m.mul(&x, &mut y).expect("mul");
            std::hint::black_box(&mut y);
            1
        });
        let checksum: f64 = y.iter().map(|v| v.x as f64 + v.y as f64 + v.z as f64).sum();
        println!(
            "{name:<27} {:8.0} ns  ({:.2} ns/coupling)   checksum {checksum:.6e}",
            t_mul,
            t_mul / (n + nnz) as f64
        );
    }

    let iters = 50u32;
    let settings = Settings {
        tolerance: 0.0,
        max_iterations: iters,
        ..Settings::default()
    };
    let mut w = [(); 5].map(|_| vec![Vec3A::ZERO; n]);
    for (name, f) in [
        ("pcg iteration, free", None),
        ("pcg iteration, filtered", Some(&filter[..])),
    ] {
        let mut xs = vec![Vec3A::ZERO; n];
        let mut last = None;
        let t = time(&mut || {
            xs.fill(Vec3A::ZERO);
            let [r, c, q, s, p] = &mut w;
            let work = Work { r, c, q, s, p };
            let st = pcg::solve(&a, &precond, f, &b, &mut xs, &settings, work).expect("solve");
            last = Some(st);
            u64::from(st.iterations.max(1))
        });
        let st = last.expect("ran");
        let sum: f64 = xs
            .iter()
            .map(|v| v.x as f64 + v.y as f64 + v.z as f64)
            .sum();
        println!(
            "{name:<27} {:8.0} ns  ({} it, residual {:.3e}, checksum {sum:.6e})",
            t, st.iterations, st.residual
        );
    }
}

#[cfg(not(feature = "std"))]
fn main() {}
