//! Scene parameters: the [`effects`] a scene calls for and the [`Settings`] of the step.

use super::InitError;

/// Scene effects, a bit set. An effect that is off costs nothing in the step.
pub mod effects {
    pub const GRAVITY: u32 = 1 << 0;
    pub const BENDING: u32 = 1 << 1;
    /// Rayleigh damping `αM + βK`.
    pub const DAMPING: u32 = 1 << 2;
    pub const PINS: u32 = 1 << 3;
    pub const COLLISION: u32 = 1 << 4;
    /// Wind and air drag.
    pub const WIND: u32 = 1 << 5;
    /// The rotation-invariant membrane (Green strain, `membrane::Strain::Green`: the warped
    /// stiffness of §5.2, exactly). Off: plain linear FEM in the rest plane (for the accuracy
    /// study; not rotation invariant, so a cloth turned away from its rest plane stores
    /// spurious strain energy, and releases it).
    pub const WARPING: u32 = 1 << 6;
    /// A cloth at rest goes to sleep and costs nothing until something wakes it.
    pub const SLEEP: u32 = 1 << 7;
    /// Every effect above.
    pub const ALL: u32 = (1 << 8) - 1;
}

/// Scene parameters. Can change between steps ([`super::World::set_settings`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Bit set of [`effects`].
    pub effects: u32,
    /// Frame time step (s) used by [`super::World::step`].
    pub time_step: f32,
    /// Substeps per step (≥ 1).
    pub substeps: u32,
    /// m/s².
    pub gravity: [f32; 3],
    /// Rayleigh damping: mass factor α (1/s) and stiffness factor β (s).
    pub damping_mass: f32,
    pub damping_stiffness: f32,
    /// Wind velocity (m/s) and drag coefficient (kg/(m²·s)): the force on a vertex is
    /// `drag · area · ((wind - v)·n) n`.
    pub wind: [f32; 3],
    pub drag: f32,
    /// PCG relative residual and iteration cap (1..=[`Settings::MAX_ITERATIONS`]). The default
    /// 1e-3: on weft-bench's 21×21 scene the worst edge strain differs from a 1e-4 solve's by
    /// 0.08 % of the rest length at half the cost; a step an inexact solve made gain energy is
    /// redone by the energy balance. Looser is as accurate in motion (the accuracy study: 1e-2
    /// as 1e-3 on every scene) and cheaper (weft-bench 21×21: 7.0 against 15.8 CG iterations a
    /// step at 1e-2), but the balance forgives a step a gain of up to its input energy times
    /// this residual (the input is estimated from the solve's impulses), and a cloth near rest
    /// creeps longer (a drape on a sphere: 1,119 against 452 steps to rest, medians; README,
    /// "The default, re-examined"): for cloth that never rests.
    pub tolerance: f32,
    pub max_iterations: u32,
    /// Warp with the paper's per-node rotations (Eq. 14–17) instead of per-element frames.
    /// A research option (cargo feature `research`; without it `true` is refused): it is
    /// unstable for cloth hanging in 3D and its force is not conservative (see README, "Limits").
    pub per_node_warping: bool,
    /// Rotation extraction iterations per node per substep (warm started), per-node warping
    /// (0..=[`Settings::MAX_ROTATION_ITERATIONS`]).
    pub rotation_iterations: u32,
    /// Largest speed (m/s) at which a contact pushes a vertex out of a collider it is inside
    /// (relative to the collider's surface). Deeper penetration is corrected by position only,
    /// so a cloth found 14 cm inside a floor is put back without being launched off it.
    pub max_depenetration_speed: f32,
    /// Sleep when every vertex is slower than this (m/s) for `sleep_frames` steps.
    pub sleep_velocity: f32,
    pub sleep_frames: u32,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            effects: effects::GRAVITY
                | effects::BENDING
                | effects::DAMPING
                | effects::PINS
                | effects::COLLISION
                | effects::WARPING,
            time_step: 1.0 / 60.0,
            substeps: 1,
            gravity: [0.0, 0.0, -9.81],
            damping_mass: 0.1,
            damping_stiffness: 0.001,
            wind: [0.0; 3],
            drag: 0.0,
            tolerance: Self::DEFAULT_TOLERANCE,
            max_iterations: 200,
            per_node_warping: false,
            rotation_iterations: 4,
            max_depenetration_speed: 1.0,
            sleep_velocity: 1e-3,
            sleep_frames: 30,
        }
    }
}

impl Settings {
    /// Largest accepted `max_iterations`: far beyond where block-Jacobi PCG stops gaining in
    /// f32, and it bounds the cost of one step (a caller's `u32::MAX` would mean a step that
    /// never ends on a system that does not converge).
    pub const MAX_ITERATIONS: u32 = 10_000;
    /// Largest accepted `substeps`.
    pub const MAX_SUBSTEPS: u32 = 1000;
    /// The default `tolerance`, and the tightest one a redo of a gaining step asks for.
    pub const DEFAULT_TOLERANCE: f32 = 1e-3;
    /// Largest accepted `rotation_iterations` (the extraction is warm started; a few suffice).
    pub const MAX_ROTATION_ITERATIONS: u32 = 100;

    /// Checks every field; `Err` names the first bad one.
    pub fn validate(&self) -> Result<(), InitError> {
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        let bad = |field| Err(InitError::InvalidSetting { field });
        if !(self.time_step.is_finite() && self.time_step > 0.0) {
            return bad("time_step");
        }
        if self.substeps == 0 || self.substeps > Self::MAX_SUBSTEPS {
            return bad("substeps");
        }
        if !finite(&self.gravity) {
            return bad("gravity");
        }
        if !(self.damping_mass.is_finite() && self.damping_mass >= 0.0) {
            return bad("damping_mass");
        }
        if !(self.damping_stiffness.is_finite() && self.damping_stiffness >= 0.0) {
            return bad("damping_stiffness");
        }
        if !finite(&self.wind) {
            return bad("wind");
        }
        if !(self.drag.is_finite() && self.drag >= 0.0) {
            return bad("drag");
        }
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return bad("tolerance");
        }
        if self.max_iterations == 0 || self.max_iterations > Self::MAX_ITERATIONS {
            return bad("max_iterations");
        }
        if self.per_node_warping && !cfg!(feature = "research") {
            return bad("per_node_warping");
        }
        if self.rotation_iterations > Self::MAX_ROTATION_ITERATIONS {
            return bad("rotation_iterations");
        }
        if !(self.max_depenetration_speed.is_finite() && self.max_depenetration_speed >= 0.0) {
            return bad("max_depenetration_speed");
        }
        if !(self.sleep_velocity.is_finite() && self.sleep_velocity >= 0.0) {
            return bad("sleep_velocity");
        }
        if self.effects & !effects::ALL != 0 {
            return bad("effects");
        }
        Ok(())
    }
}

/// The preconditioner of the step's CG ([`super::World::set_solver`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Solver {
    /// The inverse 3×3 diagonal blocks: cheap per iteration, but the iteration count grows
    /// with the mesh resolution. A step whose solves did not converge and that gained
    /// energy is redone with [`Solver::Multigrid`] (see [`super::World::step_dt`]).
    BlockJacobi,
    /// The multilevel preconditioner of [`crate::multigrid`]: a K-cycle per iteration, an
    /// iteration count that grows little with the mesh (measured on weft-bench's scene at
    /// tolerance 1e-3, 2026-11-27: 14.6 / 14.5 / 14.3 / 12.2 per solve and 15.5 / 18.5 / 21.6 /
    /// 36.6 per step at 21 / 41 / 81 / 161 vertices per side; a step has more solves where
    /// contacts are let go). Per-node warping
    /// ([`Settings::per_node_warping`]) always uses block Jacobi.
    #[default]
    Multigrid,
    /// [`Solver::Multigrid`] with its finest level smoothed along lines of vertices whose
    /// couplings dominate their others (`multigrid::Smoother::Lines`), where a material is
    /// much stiffer along one direction than across it; elsewhere it is [`Solver::Multigrid`],
    /// bit for bit. Measured on weft-bench's scene at tolerance 1e-3 (2026-11-29), CG
    /// iterations a step at 21 / 41 / 81 per side: the `ribbed` cell (23:1) 28.5 / 49.2 / 85.4
    /// → 9.3 / 16.4 / 25.6, `stripes` (2.8:1) 16.4 / 23.5 / 29.9 → 9.7 / 14.5 / 21.9; the
    /// isotropic and weave-like cells make no lines. A step it has to redo is redone with
    /// [`Solver::Multigrid`]. Experimental: its lines need not make a positive cycle; a probe
    /// at every setup (one power step of the smoother) smooths with block Jacobi where it
    /// finds them unsound, and a solve whose CG still breaks down is retried with block-Jacobi
    /// smoothing. At 161×161 it loses to the default (`ribbed` redoes every step at tolerance
    /// 1e-3, none at 1e-4; README, "Line smoothing").
    MultigridLines,
}

impl Solver {
    /// Whether the multilevel preconditioner runs (with either smoother).
    pub fn is_multilevel(self) -> bool {
        matches!(self, Solver::Multigrid | Solver::MultigridLines)
    }
}
