//! Times the cell problem on deterministic 3-material cells (`homogenize::bench_cell`) of
//! 16×16, 64×64 and 256×256 pixels at refine 1, single-threaded.
//!
//! Run with `cargo run --release --example bench_homogenize`. Prints the median of a few runs
//! of meshing and of `homogenize` (assembly + sparse Cholesky + 3 solves + C^H) in ms.

#[cfg(feature = "std")]
fn main() {
    use std::time::Instant;
    use weft::cell::mesh_cell;
    use weft::homogenize::{bench_cell, homogenize};

    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    println!(
        "{:>9} {:>8} {:>10} {:>14}",
        "cell", "dofs", "mesh ms", "homogenize ms"
    );
    for (n, runs) in [(16usize, 21usize), (64, 11), (256, 5)] {
        let desc = bench_cell(n);
        let (mut t_mesh, mut t_solve) = (Vec::new(), Vec::new());
        let mut dofs = 0;
        for _ in 0..runs {
            let t0 = Instant::now();
            let mesh = mesh_cell(&desc, 1);
            let t1 = Instant::now();
            let h = homogenize(&desc, &mesh, &mut |_| {}).expect("homogenize");
            let t2 = Instant::now();
            std::hint::black_box(&h);
            dofs = 2 * (mesh.nodes.len() - 1);
            t_mesh.push((t1 - t0).as_secs_f64() * 1e3);
            t_solve.push((t2 - t1).as_secs_f64() * 1e3);
        }
        println!(
            "{:>9} {:>8} {:>10.2} {:>14.2}",
            format!("{n}x{n}"),
            dofs,
            median(t_mesh),
            median(t_solve)
        );
    }
}

#[cfg(not(feature = "std"))]
fn main() {}
