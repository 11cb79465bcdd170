//! Random adversarial scenes for the runtime step, written as an outside tester would (it found
//! the frozen worlds and blind energy checks fixed on 2026-11-26): meshes (grids, jittered,
//! flipped, fans, discs up to valence 64), materials (the bundled cells and those in
//! `examples/adversarial_cells/`, tables up to 1e6 N/m), pins of every kind (still, moving,
//! teleported, removed), colliders of every shape (still, moving, fast, growing, starting
//! inside), wind, kicks, forces, settings changed mid-run, far-from-origin placement. Each
//! scene prints one `SCENE` line (errors, longest run of refused steps, redone and refused
//! steps, energy rises without input, penetrations, speeds, times) and `ANOMALY` lines.
//!
//! `cargo run --release --example adversarial_scenes -- FIRST_SEED COUNT [--sane] [--trace]
//! [--steps N]` (`--sane`: tolerance 1e-4..1e-2, at least 100 iterations, tables ≤ 1e5 N/m,
//! kicks ≤ 3 m/s). Not a test: it reports, it does not assert. `SOLVER=jacobi|multigrid|lines`
//! starts every scene with that solver (a scene's events may still switch it).
// `6.28` stays (not TAU): it is what the seeds' scenes were drawn with; the rebinding of the
// scene's parts as `mut` mirrors the scene description.
#![allow(clippy::approx_constant, clippy::redundant_locals)]

use std::time::Instant;

use glam::{Quat, Vec3, Vec3A};
use weft::blob::{AlignedBytes, Blob};
use weft::collide::{Collider, Shape};
use weft::world::{
    effects, Capacity, ClothDef, Material, Materials, PinAxes, Settings, Solver, World,
};

static SANE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
fn sane() -> bool {
    SANE.load(std::sync::atomic::Ordering::Relaxed)
}
// ------------------------------------------------------------------ rng
#[derive(Clone)]
pub struct Rng(u64);
#[allow(clippy::should_implement_trait)] // a generator, not an iterator
impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed ^ 0x9E37_79B9_7F4A_7C15)
    }
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    pub fn f(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn range(&mut self, a: f32, b: f32) -> f32 {
        a + (b - a) * self.f()
    }
    pub fn logr(&mut self, a: f32, b: f32) -> f32 {
        (a.ln() + (b.ln() - a.ln()) * self.f()).exp()
    }
    pub fn int(&mut self, a: usize, b: usize) -> usize {
        // inclusive
        a + (self.next() % ((b - a + 1) as u64)) as usize
    }
    pub fn chance(&mut self, p: f32) -> bool {
        self.f() < p
    }
    pub fn dir(&mut self) -> Vec3A {
        loop {
            let v = Vec3A::new(
                self.range(-1., 1.),
                self.range(-1., 1.),
                self.range(-1., 1.),
            );
            let l = v.length();
            if l > 0.1 && l <= 1.0 {
                return v / l;
            }
        }
    }
}

// ------------------------------------------------------------------ meshes
pub struct Mesh {
    pub kind: String,
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

fn grid_mesh(r: &mut Rng, nx: usize, ny: usize, w: f32, h: f32, flip: bool, jitter: f32) -> Mesh {
    let mut uvs = vec![];
    let hx = w / (nx - 1) as f32;
    let hy = h / (ny - 1) as f32;
    for j in 0..ny {
        for i in 0..nx {
            let mut u = hx * i as f32;
            let mut v = hy * j as f32;
            if jitter > 0.0 && i > 0 && j > 0 && i < nx - 1 && j < ny - 1 {
                u += r.range(-jitter, jitter) * hx;
                v += r.range(-jitter, jitter) * hy;
            }
            uvs.push([u, v]);
        }
    }
    let mut tris = vec![];
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = (j * nx + i) as u32;
            let b = a + 1;
            let c = a + nx as u32;
            let d = c + 1;
            if flip && r.chance(0.5) {
                tris.push([a, b, c]);
                tris.push([b, d, c]);
            } else {
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
    }
    let positions = uvs.iter().map(|p| [p[0], p[1], 0.0]).collect();
    Mesh {
        kind: format!(
            "grid{nx}x{ny}{}{}",
            if flip { "f" } else { "" },
            if jitter > 0.0 { "j" } else { "" }
        ),
        positions,
        uvs,
        triangles: tris,
    }
}

/// Grid whose quads are randomly split into 4-triangle fans around an added centre vertex.
fn fan_grid(r: &mut Rng, nx: usize, ny: usize, w: f32, h: f32) -> Mesh {
    let mut m = grid_mesh(r, nx, ny, w, h, false, 0.0);
    let mut tris = vec![];
    let hx = w / (nx - 1) as f32;
    let hy = h / (ny - 1) as f32;
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let a = (j * nx + i) as u32;
            let b = a + 1;
            let c = a + nx as u32;
            let d = c + 1;
            if r.chance(0.3) {
                let k = m.uvs.len() as u32;
                m.uvs.push([hx * (i as f32 + 0.5), hy * (j as f32 + 0.5)]);
                tris.push([a, b, k]);
                tris.push([b, d, k]);
                tris.push([d, c, k]);
                tris.push([c, a, k]);
            } else {
                tris.push([a, b, d]);
                tris.push([a, d, c]);
            }
        }
    }
    m.triangles = tris;
    m.positions = m.uvs.iter().map(|p| [p[0], p[1], 0.0]).collect();
    m.kind = format!("fangrid{nx}x{ny}");
    m
}

/// A disc: centre of valence k, `rings` rings of k vertices each.
fn disc(r: &mut Rng, k: usize, rings: usize, radius: f32, open: bool) -> Mesh {
    let mut uvs = vec![[0.0f32, 0.0]];
    let arc = if open {
        r.range(1.0, 1.9) * std::f32::consts::PI
    } else {
        std::f32::consts::TAU
    };
    let nk = if open { k + 1 } else { k };
    for ring in 1..=rings {
        let rr = radius * ring as f32 / rings as f32;
        for s in 0..nk {
            let a = arc * s as f32 / k as f32;
            uvs.push([rr * a.cos(), rr * a.sin()]);
        }
    }
    let idx = |ring: usize, s: usize| -> u32 { (1 + (ring - 1) * nk + (s % nk)) as u32 };
    let mut tris = vec![];
    for s in 0..k {
        tris.push([0, idx(1, s), idx(1, s + 1)]);
    }
    for ring in 1..rings {
        for s in 0..k {
            let (a, b, c, d) = (
                idx(ring, s),
                idx(ring, s + 1),
                idx(ring + 1, s),
                idx(ring + 1, s + 1),
            );
            tris.push([a, c, d]);
            tris.push([a, d, b]);
        }
    }
    let positions = uvs.iter().map(|p| [p[0], p[1], 0.0]).collect();
    Mesh {
        kind: format!("disc k{k} r{rings}{}", if open { " open" } else { "" }),
        positions,
        uvs,
        triangles: tris,
    }
}

// ------------------------------------------------------------------ cells
pub const CELLS: [&str; 8] = [
    "stripes",
    "three",
    "contrast",
    "nearzero",
    "bendy",
    "laminate",
    "light",
    "heavystiff",
];

pub fn build_blob() -> AlignedBytes {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let paths: Vec<_> = CELLS
        .iter()
        .map(|&c| match c {
            "stripes" | "three" => root.join("cells").join(format!("{c}.toml")),
            _ => root
                .join("examples/adversarial_cells")
                .join(format!("{c}.toml")),
        })
        .collect();
    let bytes = weft::homogenize::build_blob(&paths, 1, &mut |_, _| {}).expect("cells");
    AlignedBytes::copy_from(&bytes)
}

// ------------------------------------------------------------------ scene
#[derive(Clone, Copy, Debug)]
enum Motion {
    Static,
    Linear(Vec3A),
    Oscillate(Vec3A, f32),
    Teleport(usize, Vec3A),
}

impl Motion {
    fn offset(&self, t: f32, step: usize) -> Vec3A {
        match *self {
            Motion::Static => Vec3A::ZERO,
            Motion::Linear(v) => v * t,
            Motion::Oscillate(a, w) => a * (w * t).sin(),
            Motion::Teleport(at, d) => {
                if step >= at {
                    d
                } else {
                    Vec3A::ZERO
                }
            }
        }
    }
    fn speed(&self, dt: f32) -> f32 {
        match *self {
            Motion::Static => 0.0,
            Motion::Linear(v) => v.length(),
            Motion::Oscillate(a, w) => a.length() * w,
            Motion::Teleport(_, d) => d.length() / dt,
        }
    }
    fn moves(&self) -> bool {
        !matches!(self, Motion::Static)
    }
}

#[derive(Debug, Clone)]
struct PinPlan {
    vertex: u32,
    axes: PinAxes,
    motion: Motion,
    remove_at: Option<usize>,
}

#[derive(Debug, Clone)]
struct ColPlan {
    shape: Shape,
    friction: f32,
    thickness: f32,
    motion: Motion,
    grow: f32, // radius change per second (sphere/shell/capsule)
    remove_at: Option<usize>,
}

#[derive(Debug, Clone)]
enum Event {
    Kick(f32),              // impulse-kick with a speed scale
    SetVel(f32),            // set_velocities random
    Force(f32),             // add_forces with magnitude (N per vertex)
    ForceSteps(f32, usize), // constant force applied for the next k steps
    Settings(Settings),
    Solver(Solver),
    Transform(Quat, Vec3, bool),
    MassScales(f32),
    Origin(f64),
}

struct Scene {
    seed: u64,
    mesh: Mesh,
    placement: String,
    offset: Vec3,
    mats: MatChoice,
    settings: Settings,
    solver: Solver,
    pins: Vec<PinPlan>,
    cols: Vec<ColPlan>,
    steps: usize,
    events: Vec<(usize, Event)>,
    quiet: bool,
    kick0: f32,
}

#[derive(Debug, Clone)]
enum MatChoice {
    Blob(Vec<u32>), // cell choices (per triangle random among these)
    Table(Vec<Material>),
}

fn random_settings(r: &mut Rng, quiet: bool) -> Settings {
    let mut eff = effects::WARPING;
    for (bit, p) in [
        (effects::GRAVITY, 0.7),
        (effects::BENDING, 0.7),
        (effects::DAMPING, 0.6),
        (effects::PINS, 0.9),
        (effects::COLLISION, 0.85),
        (effects::WIND, 0.3),
        (effects::SLEEP, 0.2),
    ] {
        if r.chance(p) {
            eff |= bit;
        }
    }
    if r.chance(0.08) {
        eff &= !effects::WARPING;
    }
    let time_step = if sane() {
        r.logr(1.0 / 240.0, 1.0 / 30.0)
    } else {
        r.logr(1.0 / 240.0, 1.0 / 10.0)
    };
    let substeps = r.int(1, 8) as u32;
    let tolerance = if sane() {
        r.logr(1e-4, 1e-2)
    } else {
        r.logr(1e-5, 1e-1)
    };
    let max_iterations = if sane() {
        *[100u32, 200, 200, 1000].get(r.int(0, 3)).unwrap()
    } else if r.chance(0.2) {
        *[1u32, 2, 3, 5, 10].get(r.int(0, 4)).unwrap()
    } else {
        *[30u32, 100, 200, 200, 1000, 10000]
            .get(r.int(0, 5))
            .unwrap()
    };
    let gravity = if r.chance(0.8) {
        [0.0, 0.0, -9.81]
    } else {
        (r.dir() * r.range(0.0, 30.0)).to_array()
    };
    let mut s = Settings {
        effects: eff,
        time_step,
        substeps,
        gravity,
        damping_mass: if r.chance(0.3) {
            0.0
        } else {
            r.logr(1e-3, 10.0)
        },
        damping_stiffness: if r.chance(0.3) {
            0.0
        } else {
            r.logr(1e-5, 0.1)
        },
        wind: (r.dir() * r.logr(0.1, 40.0)).to_array(),
        drag: if r.chance(0.2) {
            0.0
        } else {
            r.logr(1e-3, 20.0)
        },
        tolerance,
        max_iterations,
        per_node_warping: false,
        rotation_iterations: 4,
        max_depenetration_speed: if r.chance(0.2) {
            0.0
        } else {
            r.logr(0.01, 100.0)
        },
        sleep_velocity: r.logr(1e-5, 1e-1),
        sleep_frames: r.int(1, 60) as u32,
    };
    if quiet {
        // no external input: no wind (drag only dissipates with zero wind)
        s.wind = [0.0; 3];
        if r.chance(0.5) {
            s.effects &= !effects::GRAVITY;
        }
    }
    s
}

fn moved_shape(s: &Shape, d: Vec3A, dr: f32) -> Shape {
    match *s {
        Shape::Plane { normal, offset } => Shape::Plane {
            normal,
            offset: offset + normal.dot(d),
        },
        Shape::Sphere { center, radius } => Shape::Sphere {
            center: center + d,
            radius: (radius + dr).max(1e-3),
        },
        Shape::Shell { center, radius } => Shape::Shell {
            center: center + d,
            radius: (radius + dr).max(1e-2),
        },
        Shape::Capsule { a, b, radius } => Shape::Capsule {
            a: a + d,
            b: b + d,
            radius: (radius + dr).max(1e-3),
        },
    }
}

/// The items whose indices `list` names (comma-separated), in order: what the `NOCOL`,
/// `NOPIN` and `NOEV` overrides keep of a scene's colliders, pins and events.
fn keep_listed<T>(items: Vec<T>, list: &str) -> Vec<T> {
    let keep: Vec<usize> = list.split(',').filter_map(|x| x.parse().ok()).collect();
    items
        .into_iter()
        .enumerate()
        .filter(|(i, _)| keep.contains(i))
        .map(|(_, item)| item)
        .collect()
}

/// Overwrites `field` with the environment variable `key`, parsed, when it is set (the
/// debugging overrides of a scene).
fn set_from_env<T: std::str::FromStr>(key: &str, field: &mut T)
where
    T::Err: std::fmt::Debug,
{
    if let Ok(v) = std::env::var(key) {
        *field = v.parse().unwrap();
    }
}

fn gen_scene(seed: u64, steps_override: Option<usize>) -> Scene {
    let mut r = Rng::new(seed);
    let quiet = r.chance(0.35);
    // mesh
    let size = if r.chance(0.1) {
        r.logr(1e-2, 30.0)
    } else {
        r.logr(0.2, 2.0)
    };
    let kind = r.int(0, 9);
    let mut mesh = match kind {
        0..=4 => {
            let nx = r.int(3, 41);
            let ny = if r.chance(0.5) { nx } else { r.int(3, 41) };
            let aspect = if r.chance(0.7) {
                (ny - 1) as f32 / (nx - 1) as f32
            } else {
                r.logr(0.2, 5.0)
            };
            let flip = r.chance(0.3);
            let jitter = if r.chance(0.3) {
                r.range(0.0, 0.2)
            } else {
                0.0
            };
            grid_mesh(&mut r, nx, ny, size, size * aspect, flip, jitter)
        }
        5..=6 => {
            let nx = r.int(3, 30);
            let ny = r.int(3, 30);
            fan_grid(
                &mut r,
                nx,
                ny,
                size,
                size * (ny - 1) as f32 / (nx - 1) as f32,
            )
        }
        7 => {
            let k = r.int(1, 6);
            disc(&mut r, 64, k, size * 0.5, false)
        }
        _ => {
            let k = r.int(3, 64);
            let rings = r.int(1, 12);
            let open = r.chance(0.3);
            disc(&mut r, k, rings, size * 0.5, open)
        }
    };
    // placement
    let placement = *["flat", "hanging", "rotated", "crumpled"]
        .get(r.int(0, 3))
        .unwrap();
    let q = match placement {
        "flat" => Quat::IDENTITY,
        "hanging" => Quat::from_rotation_x(std::f32::consts::FRAC_PI_2),
        _ => Quat::from_axis_angle(Vec3::from(r.dir()), r.range(0.0, 6.28)),
    };
    let offset = if r.chance(0.15) {
        Vec3::from(r.dir()) * r.logr(10.0, 1e5)
    } else {
        Vec3::ZERO
    };
    let amp = size * 0.1;
    for p in mesh.positions.iter_mut() {
        let mut v = Vec3::from(*p);
        if placement == "crumpled" {
            v.z += amp * (7.0 * v.x / size).sin() * (5.0 * v.y / size).cos();
        }
        v = q * v + offset;
        *p = v.to_array();
    }
    // materials
    let mats = if sane() && r.chance(0.6) {
        let k = r.int(1, 3);
        MatChoice::Blob(
            (0..k)
                .map(|_| *[0u32, 1, 2, 3, 4, 6].get(r.int(0, 5)).unwrap())
                .collect(),
        )
    } else if sane() {
        let k = r.int(1, 2);
        MatChoice::Table(
            (0..k)
                .map(|_| {
                    let mut c = weft::membrane::isotropic(
                        r.logr(100.0, 1e5) as f64,
                        r.range(0.0, 0.45) as f64,
                    );
                    let an = r.logr(1.0, 10.0) as f64;
                    c[0][0] *= an;
                    Material {
                        stiffness: c,
                        density: r.logr(0.05, 1.0) as f64,
                        bending: r.logr(1e-6, 1e-2) as f64,
                    }
                })
                .collect(),
        )
    } else if r.chance(0.75) {
        let k = r.int(1, 3);
        MatChoice::Blob((0..k).map(|_| r.int(0, CELLS.len() - 1) as u32).collect())
    } else {
        let k = r.int(1, 3);
        MatChoice::Table(
            (0..k)
                .map(|_| {
                    let e = r.logr(10.0, 1e6) as f64;
                    let nu = r.range(0.0, 0.45) as f64;
                    let mut c = weft::membrane::isotropic(e, nu);
                    if r.chance(0.5) {
                        let an = r.logr(1.0, 100.0) as f64;
                        c[0][0] *= an;
                        c[0][1] *= an.sqrt();
                        c[1][0] *= an.sqrt();
                    }
                    Material {
                        stiffness: c,
                        density: r.logr(1e-3, 5.0) as f64,
                        bending: if r.chance(0.2) {
                            0.0
                        } else {
                            r.logr(1e-8, 1.0) as f64
                        },
                    }
                })
                .collect(),
        )
    };
    let settings = random_settings(&mut r, quiet);
    let solver = if r.chance(0.5) {
        Solver::Multigrid
    } else {
        Solver::BlockJacobi
    };
    // Events are scheduled over the drawn length, so `--steps N` runs the same scene for
    // another number of steps (it used to schedule them over N: another scene).
    let drawn = r.int(100, 300);
    let steps = steps_override.unwrap_or(drawn);
    let n = mesh.positions.len();
    let dt = settings.time_step;
    let random_motion = |r: &mut Rng, fast: bool| -> Motion {
        match r.int(0, 3) {
            0 => Motion::Static,
            1 => Motion::Linear(
                r.dir()
                    * if fast {
                        r.logr(1.0, if sane() { 10.0 } else { 50.0 })
                    } else {
                        r.logr(0.01, 2.0)
                    },
            ),
            2 => Motion::Oscillate(r.dir() * size * r.range(0.05, 0.5), r.range(0.5, 20.0)),
            _ => Motion::Teleport(r.int(0, drawn), r.dir() * r.logr(0.01, 20.0)),
        }
    };
    // pins
    let mut pins = vec![];
    let npins = r.int(0, 4);
    for _ in 0..npins {
        let vertex = r.int(0, n - 1) as u32;
        if pins.iter().any(|p: &PinPlan| p.vertex == vertex) {
            continue;
        }
        let axes = match r.int(0, 5) {
            0 => PinAxes::Plane {
                normal: r.dir().to_array(),
            },
            1 => PinAxes::Line {
                direction: r.dir().to_array(),
            },
            _ => PinAxes::Point,
        };
        let motion = if quiet {
            Motion::Static
        } else {
            {
                let f = r.chance(0.2);
                random_motion(&mut r, f)
            }
        };
        let remove_at = if r.chance(0.15) {
            Some(r.int(0, drawn))
        } else {
            None
        };
        pins.push(PinPlan {
            vertex,
            axes,
            motion,
            remove_at,
        });
    }
    // colliders
    let mut cols = vec![];
    let ncol = r.int(0, 4);
    let (lo, hi) = mesh.positions.iter().fold(
        (Vec3A::splat(f32::MAX), Vec3A::splat(f32::MIN)),
        |(lo, hi), p| (lo.min(Vec3A::from(*p)), hi.max(Vec3A::from(*p))),
    );
    let center = (lo + hi) * 0.5;
    let ext = (hi - lo).length().max(1e-3);
    for _ in 0..ncol {
        let inside = !sane() && r.chance(0.25);
        let c = if inside {
            Vec3A::from(mesh.positions[r.int(0, n - 1)])
        } else {
            center + r.dir() * ext * r.range(0.3, 1.0)
        };
        let rad = ext * r.logr(0.005, 0.6);
        let shape = match r.int(0, 3) {
            0 => {
                let nn = if r.chance(0.5) { Vec3A::Z } else { r.dir() };
                let below = if inside {
                    0.0
                } else {
                    -ext * r.range(0.05, 0.6)
                };
                Shape::Plane {
                    normal: nn,
                    offset: nn.dot(center) + below,
                }
            }
            1 => Shape::Sphere {
                center: c,
                radius: rad,
            },
            2 => {
                let d = r.dir() * ext * r.range(0.05, 1.0);
                Shape::Capsule {
                    a: c - d,
                    b: c + d,
                    radius: rad * 0.5,
                }
            }
            _ => {
                if sane() || r.chance(0.7) {
                    // the cloth starts inside the shell (not touching)
                    let far = mesh
                        .positions
                        .iter()
                        .map(|p| (Vec3A::from(*p) - center).length())
                        .fold(0.0, f32::max);
                    Shape::Shell {
                        center,
                        radius: far * r.range(1.02, 1.5) + 0.01,
                    }
                } else {
                    Shape::Shell {
                        center: if inside { center } else { c },
                        radius: ext * r.range(0.2, 1.5),
                    }
                }
            }
        };
        let motion = if quiet {
            Motion::Static
        } else {
            {
                let f = r.chance(0.3);
                random_motion(&mut r, f)
            }
        };
        let grow = if !quiet && r.chance(0.2) {
            ext * r.range(-0.5, 0.5)
        } else {
            0.0
        };
        let remove_at = if r.chance(0.1) {
            Some(r.int(0, drawn))
        } else {
            None
        };
        cols.push(ColPlan {
            shape,
            friction: if r.chance(0.2) {
                0.0
            } else {
                r.logr(0.01, 2.0)
            },
            thickness: if r.chance(0.1) {
                0.0
            } else {
                (ext * r.logr(1e-4, 0.05)).min(0.05)
            },
            motion,
            grow,
            remove_at,
        });
    }
    // events
    let mut events = vec![];
    let nev = r.int(0, 6);
    for _ in 0..nev {
        let at = r.int(0, drawn - 1);
        let ev = match r.int(0, 8) {
            0 => Event::Kick(r.logr(0.01, if sane() { 3.0 } else { 20.0 })),
            1 => Event::SetVel(r.logr(0.01, if sane() { 3.0 } else { 20.0 })),
            2 if !quiet => Event::Force(r.logr(1e-4, if sane() { 1e-2 } else { 10.0 })),
            3 if !quiet => {
                Event::ForceSteps(r.logr(1e-4, if sane() { 1e-2 } else { 10.0 }), r.int(1, 60))
            }
            4 => {
                let mut s = random_settings(&mut r, quiet);
                if r.chance(0.5) {
                    // only toggle effects of the current settings
                    s = Settings {
                        effects: s.effects,
                        ..settings
                    };
                }
                Event::Settings(s)
            }
            5 => Event::Solver(if r.chance(0.5) {
                Solver::Multigrid
            } else {
                Solver::BlockJacobi
            }),
            6 => Event::Transform(
                Quat::from_axis_angle(Vec3::from(r.dir()), r.range(0.0, 6.28)),
                Vec3::from(r.dir()) * r.logr(0.01, 1e4),
                r.chance(0.5),
            ),
            7 => Event::MassScales(r.logr(0.1, 10.0)),
            _ => Event::Origin(r.logr(1.0, if sane() { 10.0 } else { 1e4 }) as f64),
        };
        events.push((at, ev));
    }
    let kick0 = if r.chance(0.4) {
        r.logr(0.01, if sane() { 2.0 } else { 10.0 })
    } else {
        0.0
    };
    let _ = dt;
    let env = |k: &str| std::env::var(k).ok();
    let mut settings = settings;
    let mut pins = pins;
    let mut cols = cols;
    let mut events = events;
    let mut kick0 = kick0;
    let mut mats = mats;
    set_from_env("MAXIT", &mut settings.max_iterations);
    set_from_env("TOL", &mut settings.tolerance);
    set_from_env("SUB", &mut settings.substeps);
    set_from_env("DT", &mut settings.time_step);
    set_from_env("EFF", &mut settings.effects);
    if let Some(v) = env("DAMP") {
        settings.damping_mass = v.parse().unwrap();
        settings.damping_stiffness = 0.0;
    }
    set_from_env("DAMPK", &mut settings.damping_stiffness);
    set_from_env("DAMPM", &mut settings.damping_mass);
    set_from_env("DEPEN", &mut settings.max_depenetration_speed);
    set_from_env("DRAG", &mut settings.drag);
    if env("DEFAULTS").is_some() {
        settings = Settings {
            effects: settings.effects,
            ..Settings::default()
        };
    }
    if let Some(v) = env("NOCOL") {
        cols = keep_listed(cols, &v);
    }
    if let Some(v) = env("NOPIN") {
        pins = keep_listed(pins, &v);
    }
    if let Some(v) = env("NOEV") {
        events = keep_listed(events, &v);
    }
    set_from_env("KICK0", &mut kick0);
    let mut solver = solver;
    match env("SOLVER").as_deref() {
        Some("jacobi") => solver = Solver::BlockJacobi,
        Some("multigrid") => solver = Solver::Multigrid,
        Some("lines") => solver = Solver::MultigridLines,
        _ => {}
    }
    if let Some(v) = env("CELLS") {
        mats = MatChoice::Blob(v.split(',').map(|x| x.parse().unwrap()).collect());
    }
    Scene {
        seed,
        mesh,
        placement: placement.to_string(),
        offset,
        mats,
        settings,
        solver,
        pins,
        cols,
        steps,
        events,
        quiet,
        kick0,
    }
}

// ------------------------------------------------------------------ run
#[derive(Default, Debug)]
struct Outcome {
    steps: usize,
    errors: std::collections::BTreeMap<String, usize>,
    max_consec_err: usize,
    /// Steps the world held still (`StepStats::stopped`), and the longest run of them.
    stopped: usize,
    max_consec_stop: usize,
    redone: usize,
    removed: usize,
    unconverged: usize,
    asleep: usize,
    energy_rises: usize,
    diverged_accepted: usize,
    rise_classes: std::collections::BTreeMap<String, usize>,
    worst_reasonable_rel: f64,
    worst_reasonable: String,
    worst_rise: f64,
    worst_rise_rel: f64,
    worst_rise_step: usize,
    max_speed: f32,
    speed_violations: usize,
    penetrations: usize,
    worst_pen: f32,
    step_times: Vec<f64>,
    final_hash: u64,
    anomalies: Vec<String>,
    init_error: Option<String>,
    first_err_hint: String,
}

/// The world's energy with its gravitational part measured from the caller's zero instead of
/// the world's origin (`World::energy`'s, which moves when a step follows the cloth to a new
/// origin or the scene sets one: a jump of `M g·Δorigin` no step made).
fn caller_total(w: &World<'_>, e: &weft::world::Energy) -> f64 {
    let settings = *w.settings();
    if settings.effects & effects::GRAVITY == 0 {
        return e.total();
    }
    let mass: f64 = w.masses().iter().map(|&m| f64::from(m)).sum();
    let g = Vec3::from(settings.gravity).as_dvec3();
    e.total() - mass * g.dot(w.origin())
}

fn hash_state(w: &World) -> u64 {
    let mut h: u64 = 1469598103934665603;
    for p in w.positions().iter().chain(w.velocities()) {
        for c in p.to_array() {
            h ^= c.to_bits() as u64;
            h = h.wrapping_mul(1099511628211);
        }
    }
    h
}

fn run_scene(sc: &Scene, blob: &Blob, trace: bool) -> Outcome {
    let mut out = Outcome::default();
    let mut r = Rng::new(sc.seed.wrapping_mul(31).wrapping_add(7));
    let m = &sc.mesh;
    let nt = m.triangles.len();
    let materials: Vec<u32> = match &sc.mats {
        MatChoice::Blob(c) => (0..nt).map(|_| c[r.int(0, c.len() - 1)]).collect(),
        MatChoice::Table(t) => (0..nt).map(|_| r.int(0, t.len() - 1) as u32).collect(),
    };
    let cap = Capacity {
        vertices: m.positions.len() as u32,
        triangles: nt as u32,
        edges: (3 * nt as u32).max(16),
        colliders: 8,
        pins: 64,
    };
    let mut mem = vec![0u8; cap.world_bytes()];
    let def = ClothDef {
        positions: &m.positions,
        uvs: &m.uvs,
        triangles: &m.triangles,
        materials: &materials,
    };
    let table;
    let mats = match &sc.mats {
        MatChoice::Blob(_) => Materials::Blob(blob),
        MatChoice::Table(t) => {
            table = t.clone();
            Materials::Table(&table)
        }
    };
    let mut w = match World::new(&mut mem, cap, &def, mats, sc.settings) {
        Ok(w) => w,
        Err(e) => {
            out.init_error = Some(format!("{e:?}"));
            return out;
        }
    };
    w.set_solver(sc.solver);
    let n = w.vertex_count();
    let mut settings = sc.settings;
    // pins: targets in caller coordinates
    let mut pin_base: Vec<Vec3A> = vec![];
    for p in &sc.pins {
        let x = Vec3A::from(m.positions[p.vertex as usize]);
        pin_base.push(x);
        w.set_pin_axes(p.vertex, x.to_array(), p.axes).unwrap();
    }
    let mut pins_live: Vec<bool> = vec![true; sc.pins.len()];
    let mut col_ids = vec![];
    for c in &sc.cols {
        let id = w
            .add_collider(Collider::new(c.shape, c.friction, c.thickness))
            .unwrap();
        col_ids.push(Some(id));
    }
    if sc.kick0 > 0.0 {
        let v: Vec<[f32; 3]> = (0..n)
            .map(|_| (r.dir() * sc.kick0 * r.f()).to_array())
            .collect();
        w.set_velocities(&v).unwrap();
    }
    let mut driver_speed: f32 = sc.kick0;
    let mut force_steps: Vec<(f32, usize, Vec<[f32; 3]>)> = vec![];
    let mut t = 0.0f32;
    let mut consec = 0usize;
    let mut consec_stop = 0usize;
    let mut col_static_for: Vec<usize> = vec![0; sc.cols.len()];
    let mut transformed = false; // pins/colliders relative to cloth invalid after transform
    let mut last_stats: Option<weft::world::StepStats> = None;
    let scene_start = Instant::now();
    // (`WEFT_SCENE_TIMEOUT` seconds to follow a slow scene to its end; 12 by default)
    let timeout = std::env::var("WEFT_SCENE_TIMEOUT")
        .ok()
        .and_then(|t| t.parse::<f64>().ok())
        .unwrap_or(12.0);
    for step in 0..sc.steps {
        if scene_start.elapsed().as_secs_f64() > timeout {
            out.anomalies.push(format!("TIMEOUT at step {step}"));
            break;
        }
        if consec >= 25 {
            break;
        }
        let mut input = false;
        // events
        for (at, ev) in &sc.events {
            if *at != step {
                continue;
            }
            match ev {
                Event::Kick(s) => {
                    let imp: Vec<[f32; 3]> = (0..n)
                        .map(|i| (r.dir() * *s * r.f() * w.masses()[i]).to_array())
                        .collect();
                    w.add_impulses(0, &weft::strided::Strided::from_slice(&imp))
                        .unwrap();
                    driver_speed = driver_speed.max(*s + out.max_speed);
                }
                Event::SetVel(s) => {
                    let v: Vec<[f32; 3]> =
                        (0..n).map(|_| (r.dir() * *s * r.f()).to_array()).collect();
                    w.set_velocities(&v).unwrap();
                    driver_speed = driver_speed.max(*s);
                }
                Event::Force(f) => {
                    let fv: Vec<[f32; 3]> = (0..n).map(|_| (r.dir() * *f).to_array()).collect();
                    w.add_forces(0, &weft::strided::Strided::from_slice(&fv))
                        .unwrap();
                    let mmin = w.masses().iter().cloned().fold(f32::MAX, f32::min);
                    driver_speed = driver_speed.max(*f / mmin * settings.time_step * 2.0);
                }
                Event::ForceSteps(f, k) => {
                    let fv: Vec<[f32; 3]> = (0..n).map(|_| (r.dir() * *f).to_array()).collect();
                    force_steps.push((*f, step + k, fv));
                    let mmin = w.masses().iter().cloned().fold(f32::MAX, f32::min);
                    driver_speed =
                        driver_speed.max(*f / mmin * settings.time_step * (*k as f32 + 1.0));
                }
                Event::Settings(s) => {
                    if w.set_settings(*s).is_ok() {
                        // Pins switched on start where their vertices are and move to their
                        // targets over the next step: input (seed 6001's pins, off since its
                        // start, were switched on metres from their targets).
                        let pins_on = |e: u32| e & effects::PINS != 0;
                        if pins_on(s.effects)
                            && !pins_on(settings.effects)
                            && pins_live.iter().any(|&live| live)
                        {
                            input = true;
                        }
                        settings = *s;
                    }
                }
                Event::Solver(s) => w.set_solver(*s),
                Event::Transform(q, tr, keep) => {
                    // colliders stay where they are: drop them, or the cloth lands inside a
                    // plane's half-space or outside a shell
                    w.clear_colliders();
                    for id in col_ids.iter_mut() {
                        *id = None;
                    }
                    w.transform(*q, tr.to_array(), *keep).unwrap();
                    transformed = true;
                }
                Event::MassScales(s) => {
                    let sc1: Vec<[f32; 1]> = (0..n).map(|_| [*s * r.range(0.5, 1.5)]).collect();
                    let _ = w.set_mass_scales(0, &weft::strided::Strided::from_slice(&sc1));
                }
                Event::Origin(d) => {
                    let o = w.origin() + glam::DVec3::new(*d, -*d * 0.5, *d * 0.25);
                    let _ = w.set_origin(o);
                }
            }
        }
        let dt = settings.time_step;
        let t1 = t + dt;
        // lasting forces
        force_steps.retain(|(_, until, _)| *until > step);
        for (_, _, fv) in &force_steps {
            w.add_forces(0, &weft::strided::Strided::from_slice(fv))
                .unwrap();
            input = true;
        }
        if w.applied_forces().iter().any(|f| *f != [0.0; 3]) {
            input = true;
        }
        // pins
        for (k, p) in sc.pins.iter().enumerate() {
            if !pins_live[k] {
                continue;
            }
            if p.remove_at == Some(step) {
                w.remove_pin(p.vertex).unwrap();
                pins_live[k] = false;
                continue;
            }
            if p.motion.moves() && !transformed {
                let target = pin_base[k] + p.motion.offset(t1, step);
                w.set_pin_axes(p.vertex, target.to_array(), p.axes).unwrap();
                let prev = pin_base[k] + p.motion.offset(t, step.saturating_sub(1));
                if (target - prev).length() > 0.0 {
                    input = true;
                }
                driver_speed = driver_speed.max(p.motion.speed(dt));
            }
        }
        // colliders
        for (k, c) in sc.cols.iter().enumerate() {
            let Some(id) = col_ids[k] else { continue };
            if c.remove_at == Some(step) {
                w.remove_collider(id).unwrap();
                col_ids[k] = None;
                continue;
            }
            if (c.motion.moves() || c.grow != 0.0) && !transformed {
                let s1 = moved_shape(&c.shape, c.motion.offset(t1, step), c.grow * t1);
                let s0 = moved_shape(
                    &c.shape,
                    c.motion.offset(t, step.saturating_sub(1)),
                    c.grow * t,
                );
                w.set_collider_shape(id, s1).unwrap();
                if s1 != s0 {
                    input = true;
                    col_static_for[k] = 0;
                }
                let grow_speed = c.grow.abs();
                driver_speed = driver_speed.max(c.motion.speed(dt) + grow_speed);
            }
        }
        if settings.effects & effects::WIND != 0 && settings.wind != [0.0; 3] && settings.drag > 0.0
        {
            input = true;
        }
        // penetration at start (collisions on): input-ish
        let coll_on = settings.effects & effects::COLLISION != 0;
        if coll_on {
            for id in col_ids.iter().flatten() {
                if let Some(c) = w.collider(*id) {
                    let c = *c;
                    if w.positions().iter().any(|x| {
                        c.shape.proximity(*x).distance < c.thickness * 0.999 - 1e-6
                            || c.previous.proximity(*x).distance < c.thickness * 0.999 - 1e-6
                    }) {
                        input = true;
                    }
                }
            }
        }
        let e0 = w.energy();
        let tot0 = caller_total(&w, &e0);
        let inplay0 = e0.kinetic + e0.elastic + e0.bending + e0.gravity.abs();
        let before_hash = hash_state(&w);
        let started = Instant::now();
        let res = w.step();
        let el = started.elapsed().as_secs_f64();
        out.step_times.push(el);
        out.steps += 1;
        match res {
            Ok(s) => {
                consec = 0;
                last_stats = Some(s);
                if s.stopped {
                    out.stopped += 1;
                    consec_stop += 1;
                    out.max_consec_stop = out.max_consec_stop.max(consec_stop);
                } else {
                    consec_stop = 0;
                }
                if s.redone > 0 {
                    out.redone += 1;
                }
                if s.energy_removed > 0.0 {
                    out.removed += 1;
                }
                if !s.converged {
                    out.unconverged += 1;
                }
                if s.asleep {
                    out.asleep += 1;
                }
                if s.residual > 1.0 {
                    out.diverged_accepted += 1;
                    if out.diverged_accepted == 1 {
                        out.anomalies.push(format!("step {step}: accepted step with residual {} (gain {:.3e}, removed {:.3e})", s.residual, s.energy_gain, s.energy_removed));
                    }
                }
                if trace {
                    let e = w.energy();
                    println!(
                        "  step {step} ok stopped={} it={} solves={} res={:.2e} conv={} sub={} redone={} removed={:.3e} gain={:.3e} contacts={} asleep={} E: k={:.6e} el={:.6e} b={:.6e} g={:.6e} tot {:.9e} -> {:.9e} input={input} vmax={:.3e} t={:.2}ms origin={:?}",
                        s.stopped, s.iterations, s.solves, s.residual, s.converged, s.substeps, s.redone,
                        s.energy_removed, s.energy_gain, s.contacts, s.asleep, e.kinetic, e.elastic,
                        e.bending, e.gravity, tot0, caller_total(&w, &e),
                        w.velocities().iter().map(|v| v.length()).fold(0.0, f32::max), el * 1e3,
                        w.origin()
                    );
                }
            }
            Err(e) => {
                let key = format!("{e:?}");
                *out.errors.entry(key.clone()).or_default() += 1;
                consec += 1;
                out.max_consec_err = out.max_consec_err.max(consec);
                if hash_state(&w) != before_hash {
                    out.anomalies
                        .push(format!("step {step}: error {key} changed the state"));
                }
                if trace {
                    println!("  step {step} ERR {key}");
                }
                if consec == 1 {
                    out.first_err_hint = format!(
                        "step {step} events_here={:?} input={input}",
                        sc.events
                            .iter()
                            .filter(|(a, _)| *a + 1 >= step && *a <= step)
                            .map(|(a, e)| format!(
                                "{a}:{}",
                                format!("{e:?}").chars().take(40).collect::<String>()
                            ))
                            .collect::<Vec<_>>()
                    );
                }
            }
        }
        // checks
        let finite = w
            .positions()
            .iter()
            .chain(w.velocities())
            .all(|p| p.is_finite());
        if !finite {
            out.anomalies.push(format!("step {step}: non-finite state"));
            break;
        }
        let e1 = w.energy();
        let tot1 = caller_total(&w, &e1);
        if !input && res.is_ok() {
            let rise = tot1 - tot0;
            let rel = rise / inplay0.max(1e-30);
            if rise > 1e-6 * inplay0 + 1e-9 {
                out.energy_rises += 1;
                let st = last_stats.unwrap();
                let class = if st.energy_removed > 0.0 {
                    "partial_removal"
                } else if st.energy_gain > 0.0 {
                    "within_floor"
                } else {
                    "monitor_disagrees"
                };
                let reasonable = settings.max_iterations >= 30 && settings.tolerance <= 1e-2;
                *out.rise_classes
                    .entry(format!(
                        "{class}{}",
                        if reasonable { "" } else { "_unreasonable" }
                    ))
                    .or_default() += 1;
                if reasonable && rel > out.worst_reasonable_rel {
                    out.worst_reasonable_rel = rel;
                    out.worst_reasonable = format!("step {step} {class} rise {rise:.3e} rel {rel:.3e} tot {tot0:.6e}->{tot1:.6e} gain {:.3e} removed {:.3e} redone {}", st.energy_gain, st.energy_removed, st.redone);
                }
                if rise > out.worst_rise {
                    out.worst_rise = rise;
                    out.worst_rise_rel = rel;
                    out.worst_rise_step = step;
                }
            }
        }
        let vmax = w
            .velocities()
            .iter()
            .map(|v| v.length())
            .fold(0.0, f32::max);
        out.max_speed = out.max_speed.max(vmax);
        let g = if settings.effects & effects::GRAVITY != 0 {
            Vec3A::from(settings.gravity).length()
        } else {
            0.0
        };
        let wind = if settings.effects & effects::WIND != 0 {
            Vec3A::from(settings.wind).length()
        } else {
            0.0
        };
        let bound = 100.0 + g * t1 + 3.0 * driver_speed + 3.0 * wind;
        if vmax > bound {
            out.speed_violations += 1;
            if out.speed_violations == 1 {
                out.anomalies
                    .push(format!("step {step}: speed {vmax} > bound {bound}"));
            }
        }
        // penetration into static colliders
        if coll_on && res.is_ok() {
            let live: Vec<(usize, Collider)> = col_ids
                .iter()
                .enumerate()
                .filter_map(|(k, id)| id.and_then(|id| w.collider(id).map(|c| (k, *c))))
                .collect();
            for (k, c) in &live {
                if col_static_for[*k] < 3 {
                    continue;
                }
                for (i, x) in w.positions().iter().enumerate() {
                    if settings.effects & effects::PINS != 0
                        && sc
                            .pins
                            .iter()
                            .zip(&pins_live)
                            .any(|(p, l)| *l && p.vertex as usize == i)
                    {
                        continue;
                    }
                    let d = c.shape.proximity(*x).distance;
                    // overlapping colliders: skip vertices also within another
                    let margin = 1e-4f32.max(1e-5 * x.abs().max_element());
                    if d < -margin {
                        let other = live.iter().any(|(k2, c2)| {
                            k2 != k && c2.shape.proximity(*x).distance < c2.thickness + 1e-3
                        });
                        if !other {
                            out.penetrations += 1;
                            if -d > out.worst_pen {
                                out.worst_pen = -d;
                                if out.penetrations < 3 {
                                    out.anomalies.push(format!(
                                        "step {step}: vertex {i} {d} inside static collider {k} ({:?}) thickness {}",
                                        c.shape, c.thickness
                                    ));
                                }
                            }
                        }
                    }
                }
            }
        }
        for s in col_static_for.iter_mut() {
            *s += 1;
        }
        if res.is_ok() {
            t = t1;
        }
    }
    if out.max_consec_stop >= 25 {
        out.anomalies.push(format!(
            "persistent stop: held still at {} consecutive steps",
            out.max_consec_stop
        ));
    }
    if out.max_consec_err >= 5 {
        out.anomalies.push(format!(
            "persistent refusal: {} consecutive errors; last started {}",
            out.max_consec_err, out.first_err_hint
        ));
    }
    out.final_hash = hash_state(&w);
    out
}

/// The size of the mesh's bounding box (m), per axis.
fn extent(positions: &[[f32; 3]]) -> [f32; 3] {
    let (lo, hi) = positions.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), &p| (lo.min(Vec3::from(p)), hi.max(Vec3::from(p))),
    );
    (hi - lo).to_array()
}

fn describe(sc: &Scene) -> String {
    format!(
        "seed {} quiet={} mesh={} n={} nt={} extent={:?} place={} offset={:?} mats={:?} solver={:?} steps={} kick0={}\n  settings={:?}\n  pins={:?}\n  cols={:?}\n  events={:?}",
        sc.seed,
        sc.quiet,
        sc.mesh.kind,
        sc.mesh.positions.len(),
        sc.mesh.triangles.len(),
        extent(&sc.mesh.positions),
        sc.placement,
        sc.offset,
        sc.mats,
        sc.solver,
        sc.steps,
        sc.kick0,
        sc.settings,
        sc.pins,
        sc.cols,
        sc.events
    )
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let first: u64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(0);
    let count: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let trace = args.iter().any(|a| a == "--trace");
    let desc = args.iter().any(|a| a == "--describe");
    let steps = args
        .iter()
        .position(|a| a == "--steps")
        .and_then(|i| args.get(i + 1))
        .and_then(|s| s.parse().ok());
    if args.iter().any(|a| a == "--sane") {
        SANE.store(true, std::sync::atomic::Ordering::Relaxed);
    }
    let bytes = build_blob();
    let blob = Blob::parse(&bytes).unwrap();
    for seed in first..first + count {
        let sc = gen_scene(seed, steps);
        if desc || trace {
            println!("{}", describe(&sc));
        }
        if args.iter().any(|a| a == "--dump") {
            let m = &sc.mesh;
            println!("const UV: [[f32; 2]; {}] = {:?};", m.uvs.len(), m.uvs);
            println!(
                "const POS: [[f32; 3]; {}] = {:?};",
                m.positions.len(),
                m.positions
            );
            println!(
                "const TRI: [[u32; 3]; {}] = {:?};",
                m.triangles.len(),
                m.triangles
            );
            println!("cols {:?}", sc.cols);
            continue;
        }
        if args.iter().any(|a| a == "--only-describe") {
            continue;
        }
        let t0 = Instant::now();
        let res = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            run_scene(&sc, &blob, trace)
        }));
        let wall = t0.elapsed().as_secs_f64();
        match res {
            Err(_) => println!(
                "SCENE {seed} PANIC mesh={} n={}",
                sc.mesh.kind,
                sc.mesh.positions.len()
            ),
            Ok(o) => {
                let mut ts = o.step_times.clone();
                ts.sort_by(|a, b| a.total_cmp(b));
                let med = ts.get(ts.len() / 2).copied().unwrap_or(0.0);
                let max = ts.last().copied().unwrap_or(0.0);
                let argmax = o.step_times.iter().position(|&x| x == max).unwrap_or(0);
                println!(
                    "SCENE {seed} quiet={} mesh={} n={} sub={} dt={:.4} tol={:.1e} maxit={} solver={:?} pins={} cols={} steps={} init={:?} errors={:?} maxconsec={} stopped={} maxstop={} redone={} removed={} unconv={} asleep={} rises={} worst_rise={:.3e} rel={:.3e} at={} vmax={:.3} vviol={} pen={} worstpen={:.3e} med_ms={:.3} max_ms={:.3} argmax={} wall={:.2} hash={:016x}",
                    sc.quiet as usize,
                    sc.mesh.kind.replace(' ', "_"),
                    sc.mesh.positions.len(),
                    sc.settings.substeps,
                    sc.settings.time_step,
                    sc.settings.tolerance,
                    sc.settings.max_iterations,
                    sc.solver,
                    sc.pins.len(),
                    sc.cols.len(),
                    o.steps,
                    o.init_error,
                    o.errors,
                    o.max_consec_err,
                    o.stopped,
                    o.max_consec_stop,
                    o.redone,
                    o.removed,
                    o.unconverged,
                    o.asleep,
                    o.energy_rises,
                    o.worst_rise,
                    o.worst_rise_rel,
                    o.worst_rise_step,
                    o.max_speed,
                    o.speed_violations,
                    o.penetrations,
                    o.worst_pen,
                    med * 1e3,
                    max * 1e3,
                    argmax,
                    wall,
                    o.final_hash
                );
                if !o.rise_classes.is_empty() {
                    println!(
                        "  RISES seed {seed}: {:?} worst_reasonable: {}",
                        o.rise_classes, o.worst_reasonable
                    );
                }
                for a in &o.anomalies {
                    println!("  ANOMALY seed {seed}: {a}");
                }
            }
        }
    }
}
