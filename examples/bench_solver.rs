//! The step's CG preconditioners side by side: block Jacobi and the multilevel one
//! (`weft::multigrid`), on the World's own step at 21/41/81/161 vertices per side.
//!
//! `cargo run --release --example bench_solver [-- --tolerance 1e-3 --steps 60 --grids 21,41]`
//!
//! Two scenes on a 1 m sheet of the bundled `stripes` cell (homogenized here), dt = 1/60 s,
//! one substep, gravity, bending, damping, per-element warping:
//! * `free`: the sheet starts tilted and falls and swings through wind, no pin, no collider
//!   (the unconstrained solve);
//! * `pinned+contact`: hanging from two pinned corners against a sphere (weft-bench's scene).
//!
//! For each grid and scene a block-Jacobi world and a multigrid world run the same scene in
//! lockstep (alternating which steps first), so both see the same machine load; after 20
//! warm-up steps every step is timed on the thread's CPU clock (Linux; the wall clock
//! elsewhere). Printed: median ms/step, mean CG iterations per solve, the fraction of solves
//! that converged, and the ratio of the medians from the same run.

#[cfg(feature = "std")]
fn main() {
    use std::path::PathBuf;

    use glam::Vec3A;
    use weft::blob::{AlignedBytes, Blob};
    use weft::collide::{Collider, Shape};
    use weft::world::{effects, Capacity, ClothDef, Materials, Settings, Solver, World};

    let mut tolerance = 1e-3f32;
    let mut steps = 0u32;
    let mut grids = vec![21usize, 41, 81, 161];
    let mut scenes = vec!["free", "pinned+contact", "pinned", "contact"];
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut val = || it.next().cloned().unwrap_or_default();
        match a.as_str() {
            "--tolerance" => tolerance = val().parse().expect("--tolerance"),
            "--steps" => steps = val().parse().expect("--steps"),
            "--grids" => {
                grids = val()
                    .split(',')
                    .map(|g| g.parse().expect("--grids"))
                    .collect()
            }
            "--scene" => {
                let v = val();
                scenes.retain(|s| *s == v);
            }
            _ => panic!("unknown argument {a}"),
        }
    }

    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("cells/stripes.toml");
    let bytes = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).expect("blob");
    let bytes = AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&bytes).expect("parse");

    println!(
        "tolerance {tolerance:e}, 1 substep, medians over timed steps (thread CPU time), \
         ratios from the same run"
    );
    println!(
        "{:<16} {:>5} {:>6} | {:>9} {:>7} {:>5} | {:>9} {:>7} {:>5} | {:>7}",
        "scene", "grid", "steps", "BJ ms", "BJ it", "conv", "MG ms", "MG it", "conv", "BJ/MG"
    );
    for &scene in &scenes {
        for &n in &grids {
            let timed = if steps > 0 {
                steps
            } else {
                match n {
                    0..=41 => 120,
                    42..=81 => 60,
                    _ => 24,
                }
            };
            let mut positions = vec![[0.0f32; 3]; n * n];
            let mut uvs = vec![[0.0f32; 2]; n * n];
            let mut triangles = vec![[0u32; 3]; 2 * (n - 1) * (n - 1)];
            weft::mesh::grid(n, n, 1.0, 1.0, &mut positions, &mut uvs, &mut triangles)
                .expect("grid");
            let pinned = scene != "free" && scene != "contact";
            let pins_on = pinned;
            let collide_on = scene == "pinned+contact" || scene == "contact";
            for p in &mut positions {
                *p = if pinned {
                    [p[0], 0.0, p[1]]
                } else {
                    // tilted 30° about x, so it swings as it falls
                    [p[0], 0.5 * p[1], 0.866 * p[1]]
                };
            }
            let materials = vec![0u32; triangles.len()];
            let cap = Capacity::grid(n as u32);
            let def = ClothDef {
                positions: &positions,
                uvs: &uvs,
                triangles: &triangles,
                materials: &materials,
            };
            let settings = Settings {
                effects: effects::GRAVITY
                    | effects::BENDING
                    | effects::DAMPING
                    | effects::WARPING
                    | effects::WIND
                    | if pins_on { effects::PINS } else { 0 }
                    | if collide_on { effects::COLLISION } else { 0 },
                tolerance,
                max_iterations: 200,
                wind: [0.0, 3.0, 0.0],
                drag: 0.2,
                ..Settings::default()
            };
            let mut mem = [vec![0u8; cap.world_bytes()], vec![0u8; cap.world_bytes()]];
            let [m0, m1] = &mut mem;
            let mut worlds = [m0, m1]
                .map(|m| World::new(m, cap, &def, Materials::Blob(&blob), settings).expect("init"));
            worlds[0].set_solver(Solver::BlockJacobi);
            worlds[1].set_solver(Solver::Multigrid);
            for w in &mut worlds {
                if pins_on {
                    let top = (n - 1) * n;
                    for corner in [top, top + n - 1] {
                        w.set_pin(corner as u32, positions[corner]).expect("pin");
                    }
                }
                if collide_on {
                    let center = if pinned {
                        Vec3A::new(0.5, 0.35, 0.3)
                    } else {
                        Vec3A::new(0.5, 0.3, -0.4) // under the falling sheet
                    };
                    w.add_collider(Collider::new(
                        Shape::Sphere {
                            center,
                            radius: 0.3,
                        },
                        0.3,
                        0.005,
                    ))
                    .expect("collider");
                }
                for _ in 0..20 {
                    w.step().expect("warm-up step");
                }
            }
            if std::env::var("MG_INFO").is_ok() {
                println!("{:?}", worlds[1].multigrid_info());
            }
            let mut times = [Vec::new(), Vec::new()];
            let mut iterations = [0u64; 2];
            let mut converged = [0u32; 2];
            for s in 0..timed as usize {
                for k in 0..2 {
                    let k = (k + s) % 2;
                    let t0 = cpu_seconds();
                    let st = worlds[k].step().expect("step");
                    times[k].push(cpu_seconds() - t0);
                    iterations[k] += st.iterations as u64;
                    converged[k] += st.converged as u32;
                }
            }
            let med = |v: &mut Vec<f64>| {
                v.sort_by(f64::total_cmp);
                v[v.len() / 2] * 1e3
            };
            let (bj, mg) = (med(&mut times[0]), med(&mut times[1]));
            let it = |k: usize| iterations[k] as f64 / timed as f64;
            let conv = |k: usize| converged[k] as f64 / timed as f64;
            println!(
                "{:<16} {:>5} {:>6} | {:>9.3} {:>7.1} {:>5.2} | {:>9.3} {:>7.1} {:>5.2} | {:>7.2}",
                scene,
                n,
                timed,
                bj,
                it(0),
                conv(0),
                mg,
                it(1),
                conv(1),
                bj / mg
            );
        }
    }
}

#[cfg(feature = "std")]
fn cpu_seconds() -> f64 {
    use std::sync::OnceLock;
    use std::time::Instant;
    static ORIGIN: OnceLock<Instant> = OnceLock::new();
    thread_cpu_seconds().unwrap_or_else(|| ORIGIN.get_or_init(Instant::now).elapsed().as_secs_f64())
}

#[cfg(all(feature = "std", target_os = "linux", target_pointer_width = "64"))]
fn thread_cpu_seconds() -> Option<f64> {
    #[repr(C)]
    struct Timespec {
        tv_sec: i64,
        tv_nsec: i64,
    }
    extern "C" {
        fn clock_gettime(clock: i32, ts: *mut Timespec) -> i32;
    }
    const CLOCK_THREAD_CPUTIME_ID: i32 = 3;
    let mut ts = Timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec (two 64-bit fields on 64-bit Linux); the call
    // only writes it.
    let rc = unsafe { clock_gettime(CLOCK_THREAD_CPUTIME_ID, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

#[cfg(all(
    feature = "std",
    not(all(target_os = "linux", target_pointer_width = "64"))
))]
fn thread_cpu_seconds() -> Option<f64> {
    None
}

#[cfg(not(feature = "std"))]
fn main() {}
