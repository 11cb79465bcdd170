//! Shared test fixtures: grid sheets and materials.
#![allow(dead_code)]

use glam::Vec3A;
use weft::collide::{Collider, Shape};
use weft::mesh;
use weft::world::{Capacity, ClothDef, Material, Materials, Settings, World};

/// An owned grid cloth (positions, uvs, triangles, per-triangle material).
pub struct Sheet {
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
    pub materials: Vec<u32>,
    pub nx: usize,
    pub ny: usize,
}

impl Sheet {
    /// `nx × ny` vertices over `width × height` metres in (u,v), lying flat at z = 0.
    pub fn grid(nx: usize, ny: usize, width: f32, height: f32) -> Sheet {
        let mut positions = vec![[0.0; 3]; nx * ny];
        let mut uvs = vec![[0.0; 2]; nx * ny];
        let mut triangles = vec![[0; 3]; 2 * (nx - 1) * (ny - 1)];
        mesh::grid(
            nx,
            ny,
            width,
            height,
            &mut positions,
            &mut uvs,
            &mut triangles,
        )
        .unwrap();
        let materials = vec![0; triangles.len()];
        Sheet {
            positions,
            uvs,
            triangles,
            materials,
            nx,
            ny,
        }
    }

    pub fn def(&self) -> ClothDef<'_> {
        ClothDef {
            positions: &self.positions,
            uvs: &self.uvs,
            triangles: &self.triangles,
            materials: &self.materials,
        }
    }

    pub fn index(&self, i: usize, j: usize) -> u32 {
        (j * self.nx + i) as u32
    }

    pub fn capacity(&self) -> Capacity {
        Capacity {
            vertices: self.positions.len() as u32,
            triangles: self.triangles.len() as u32,
            edges: (3 * self.triangles.len() as u32).max(16),
            colliders: 8,
            pins: 256,
        }
    }

    /// Maps every position through `f`.
    pub fn transform(&mut self, f: impl Fn([f32; 3]) -> [f32; 3]) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }
}

/// Memory for a world, 16-byte aligned.
pub fn memory(cap: &Capacity) -> Vec<u8> {
    vec![0u8; cap.world_bytes()]
}

pub fn isotropic(stiffness: f64, poisson: f64, density: f64) -> Material {
    Material {
        stiffness: weft::membrane::isotropic(stiffness, poisson),
        density,
        bending: 1e-4,
    }
}

/// A clearly anisotropic material (the stripes laminate of a 1:10 contrast, roughly).
pub fn anisotropic() -> Material {
    Material {
        stiffness: [[600.0, 60.0, 0.0], [60.0, 150.0, 0.0], [0.0, 0.0, 50.0]],
        density: 0.15,
        bending: 1e-4,
    }
}

pub fn settings_quiet() -> Settings {
    Settings {
        effects: weft::world::effects::WARPING,
        ..Settings::default()
    }
}

pub fn world<'a>(
    mem: &'a mut [u8],
    sheet: &Sheet,
    mats: &'a [Material],
    settings: Settings,
) -> World<'a> {
    World::new(
        mem,
        sheet.capacity(),
        &sheet.def(),
        Materials::Table(mats),
        settings,
    )
    .unwrap()
}

/// The cloth's positions in the caller's coordinates (`World::positions` lends the local ones,
/// relative to the world's origin).
pub fn caller_positions(w: &World<'_>) -> Vec<[f32; 3]> {
    w.positions().iter().map(|&x| w.to_world(x)).collect()
}

/// The fastest vertex's speed (m/s).
pub fn top_speed(w: &World<'_>) -> f32 {
    w.velocities()
        .iter()
        .map(|v| v.length())
        .fold(0.0, f32::max)
}

pub fn kinetic_energy(w: &World<'_>) -> f64 {
    w.velocities()
        .iter()
        .zip(w.masses())
        .map(|(v, &m)| 0.5 * m as f64 * v.length_squared() as f64)
        .sum()
}

/// An `n × n` sheet `size` metres square hanging in the x–z plane (a curtain), at rest.
pub fn hanging_sheet(n: usize, size: f32) -> Sheet {
    let mut sheet = Sheet::grid(n, n, size, size);
    sheet.transform(|p| [p[0], 0.0, p[1]]);
    sheet
}

/// Pins the two top corners of a hanging sheet where they are.
pub fn pin_top_corners(w: &mut World<'_>, sheet: &Sheet) -> (u32, u32) {
    let (a, b) = (
        sheet.index(0, sheet.ny - 1),
        sheet.index(sheet.nx - 1, sheet.ny - 1),
    );
    w.set_pin(a, sheet.positions[a as usize]).unwrap();
    w.set_pin(b, sheet.positions[b as usize]).unwrap();
    (a, b)
}

/// A deterministic stream of numbers uniform in [-1, 1) (the Knuth MMIX LCG, 24 bits a
/// draw), for random directions and kicks that repeat from run to run.
pub fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
    }
}

/// The drop of `a_cloth_fallen_into_a_pile_comes_to_rest`: a 21×21 1 m curtain a millimetre
/// out of its plane (jitter `seed`), so that it folds as it lands, 0.8 m above a floor.
fn pile_sheet(seed: u64) -> Sheet {
    let mut sheet = hanging_sheet(21, 1.0);
    let mut jitter = uniform(seed);
    for p in &mut sheet.positions {
        *p = [p[0], 2e-3 * jitter(), p[2] + 0.8];
    }
    sheet
}

/// The steps of a pile's drop, and the last ones that [`PileRun`] watches.
pub const PILE_STEPS: u32 = 600;
pub const PILE_TAIL: u32 = 90;

/// What the pile did: CG iterations and the fastest vertex over its last [`PILE_TAIL`] of
/// [`PILE_STEPS`] steps, the highest vertex then (m), and CG iterations over all of them.
pub struct PileRun {
    pub tail_iterations: u32,
    pub fastest: f32,
    pub top: f32,
    pub iterations: u64,
}

impl PileRun {
    /// CG iterations per step over the last [`PILE_TAIL`] steps.
    pub fn tail_per_step(&self) -> f64 {
        f64::from(self.tail_iterations) / f64::from(PILE_TAIL)
    }

    /// CG iterations per step over the whole drop.
    pub fn per_step(&self) -> f64 {
        self.iterations as f64 / f64::from(PILE_STEPS)
    }

    /// At rest over the last [`PILE_TAIL`] steps: no vertex faster than 4e-5 m/s, and fewer than
    /// 5 CG iterations a step (a resting pile's solves start at their answer).
    pub fn at_rest(&self) -> bool {
        self.fastest < 4e-5 && self.tail_per_step() < 5.0
    }
}

/// The drop of [`pile_sheet`]`(seed)` (the tests' anisotropic material) with `settings`.
pub fn drop_pile(seed: u64, settings: Settings) -> PileRun {
    let sheet = pile_sheet(seed);
    let mats = [anisotropic()];
    let mut mem = memory(&sheet.capacity());
    let mut w = world(&mut mem, &sheet, &mats, settings);
    run_pile(&mut w, &sheet)
}

/// Drops `pile_sheet`'s cloth in `w`: held by one top corner for 90 steps, then let go onto a
/// floor of friction 0.3, 600 steps in all.
fn run_pile(w: &mut World<'_>, sheet: &Sheet) -> PileRun {
    let corner = sheet.index(0, sheet.ny - 1);
    w.set_pin(corner, sheet.positions[corner as usize]).unwrap();
    let floor = Shape::Plane {
        normal: Vec3A::Z,
        offset: 0.0,
    };
    w.add_collider(Collider::new(floor, 0.3, 0.005)).unwrap();
    let (steps, last) = (PILE_STEPS, PILE_TAIL);
    let mut run = PileRun {
        tail_iterations: 0,
        fastest: 0.0,
        top: 0.0,
        iterations: 0,
    };
    for step in 0..steps {
        if step == 90 {
            w.remove_pin(corner).unwrap();
        }
        let s = w.step().unwrap_or_else(|e| panic!("step {step}: {e:?}"));
        run.iterations += u64::from(s.iterations);
        if step >= steps - last {
            run.tail_iterations += s.iterations;
            run.fastest = run.fastest.max(top_speed(w));
            run.top = w.positions().iter().map(|x| x.z).fold(run.top, f32::max);
        }
    }
    run
}

/// The sheet of `a_drape_resting_on_a_sphere_is_not_redone_at_every_step`: `n × n` vertices
/// over 1 m, centred over the origin 0.45 m up, turned by `angle` (rad) about the vertical.
pub fn drape_sheet(n: usize, angle: f32) -> Sheet {
    let mut sheet = Sheet::grid(n, n, 1.0, 1.0);
    let (c, s) = (angle.cos(), angle.sin());
    sheet.transform(|p| {
        let (x, y) = (p[0] - 0.5, p[1] - 0.5);
        [c * x - s * y, s * x + c * y, 0.45]
    });
    sheet
}

/// The sphere that sheet drapes over: radius 0.3 m at the origin, friction 0.5.
pub fn drape_sphere() -> Collider {
    let sphere = Shape::Sphere {
        center: Vec3A::ZERO,
        radius: 0.3,
    };
    Collider::new(sphere, 0.5, 0.005)
}
