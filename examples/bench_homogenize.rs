//! Times the cell problem on deterministic 3-material cells (`homogenize::bench_cell`) of
//! 16×16, 64×64 and 256×256 pixels at refine 1, single-threaded.
//!
//! Run with `cargo run --release --example bench_homogenize`. Prints the median of a few runs
//! of meshing and of `homogenize` (assembly + sparse Cholesky + 3 solves + C^H) in ms, and the
//! median split of `homogenize` between its progress reports: assembly, AMD ordering and
//! symbolic analysis, numeric factorization, and solves + C^H.

#[cfg(feature = "std")]
fn main() {
    use std::time::Instant;
    use weft::cell::mesh_cell;
    use weft::homogenize::{bench_cell, homogenize};

    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "{:>9} {:>8} {:>9} {:>14} {:>9} {:>9} {:>9} {:>9}",
        "cell", "dofs", "mesh ms", "homogenize ms", "assemble", "order", "factor", "solve"
    );
    for (n, runs) in [(16usize, 21usize), (64, 11), (256, 5)] {
        let desc = bench_cell(n);
        let (mut t_mesh, mut t_solve) = (Vec::new(), Vec::new());
        let mut phases: [Vec<f64>; 4] = Default::default();
        let mut dofs = 0;
        for _ in 0..runs {
            let t0 = Instant::now();
            let mesh = mesh_cell(&desc, 1);
            let t1 = Instant::now();
            let mut marks = Vec::new();
            let h = homogenize(&desc, &mesh, &mut |f| marks.push((f, Instant::now())))
                .expect("homogenize");
            let t2 = Instant::now();
            std::hint::black_box(&h);
            dofs = 2 * (mesh.nodes.len() - 1);
            t_mesh.push((t1 - t0).as_secs_f64() * 1e3);
            t_solve.push((t2 - t1).as_secs_f64() * 1e3);
            // progress marks: 0, 0.25 (assembled), 0.35 (ordered), 0.8 (factored), 0.9, 1
            let at = |f: f64| marks.iter().find(|m| m.0 >= f).map_or(t2, |m| m.1);
            let edges = [at(0.0), at(0.25), at(0.35), at(0.8), at(1.0)];
            for (p, w) in phases.iter_mut().zip(edges.windows(2)) {
                p.push((w[1] - w[0]).as_secs_f64() * 1e3);
            }
        }
        let [a, o, f, s] = phases.map(|mut p| median(&mut p));
        println!(
            "{:>9} {:>8} {:>9.2} {:>14.2} {:>9.2} {:>9.2} {:>9.2} {:>9.2}",
            format!("{n}x{n}"),
            dofs,
            median(&mut t_mesh),
            median(&mut t_solve),
            a,
            o,
            f,
            s
        );
    }
}

#[cfg(not(feature = "std"))]
fn main() {}
