//! Results and error details: `WeftResult`, `WeftErrorDetail`, their messages, and the
//! kernel's errors as details.

use core::ffi::{c_char, CStr};

use bytemuck::CheckedBitPattern;

use super::WEFT_NONE;
use crate::blob::BlobError;
use crate::mesh::MeshError;
use crate::world::{EditError, InitError, StepError, World};

/// Result of every fallible call. `WEFT_RESULT_OK` (0) is success; `weft_result_string` names
/// any value. Calls that fail write none of their outputs (a `WeftErrorDetail` excepted, which
/// says where the problem is: see each value). Values are stable across versions; 80–99 are
/// reserved for localization.
#[repr(u32)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, CheckedBitPattern)]
pub enum WeftResult {
    /// Success.
    Ok = 0,
    /// A required pointer argument is NULL. `detail.what` names the argument.
    NullPointer = 1,
    /// A def (`WeftWorldDef`, `WeftColliderDef`) was not made by its `weft_default_*` function,
    /// or a `WeftBlob` was not filled by `weft_blob_parse`: uninitialized memory, or a struct
    /// from another version of the header. `detail.what` names the argument.
    Uninitialized = 2,
    /// The `WeftWorld*` is not a live world: never created, destroyed, or its memory block was
    /// moved or overwritten.
    InvalidHandle = 3,
    /// An argument is out of its range: an unknown enum value, a stride smaller than the
    /// element, a flag that is not 0 or 1. `detail.what` names the argument or field.
    InvalidArgument = 4,
    /// A pointer is not aligned for its type, or the world memory block is not
    /// `WEFT_WORLD_MEMORY_ALIGN`-aligned. `detail.what` names the argument.
    Misaligned = 5,
    /// A vertex count argument does not match the world (`weft_world_set_positions` needs
    /// exactly `weft_world_vertex_count`, the getters at least that many).
    /// `detail.needed` is the count required.
    CountMismatch = 6,
    /// An internal consistency check failed (a bug in weft; please report it).
    Internal = 7,

    /// The memory block is smaller than `weft_world_memory_size` says. `detail.what` is
    /// "memory_size".
    MemoryTooSmall = 20,
    /// The capacity's memory size does not fit in `size_t` on this target.
    CapacityTooLarge = 21,
    /// The mesh has more vertices than `capacity.max_vertices`: `detail.needed` vertices,
    /// `detail.capacity` the capacity.
    VertexCapacity = 22,
    /// The mesh has more triangles than `capacity.max_triangles` (`detail.needed`,
    /// `detail.capacity`).
    TriangleCapacity = 23,
    /// The mesh has more unique edges (or interior edges) than `capacity.max_edges`
    /// (`detail.capacity`). Three times the triangle count is always enough.
    EdgeCapacity = 24,
    /// `capacity.max_pins` pins already exist (`detail.capacity`).
    PinCapacity = 25,
    /// `capacity.max_colliders` colliders already exist (`detail.capacity`).
    ColliderCapacity = 26,

    /// The mesh has no vertices or no triangles.
    MeshEmpty = 30,
    /// Triangle `detail.triangle` names a vertex ≥ `vertex_count`.
    MeshIndexOutOfRange = 31,
    /// Triangle `detail.triangle` uses one vertex twice.
    MeshRepeatedVertex = 32,
    /// Triangle `detail.triangle` has (near) zero area in material (u, v) space.
    MeshDegenerateUv = 33,
    /// Triangle `detail.triangle` has (near) zero area in its initial 3D placement.
    MeshDegenerate3d = 34,
    /// The edge from `detail.vertex` to `detail.vertex_b` is shared by more than two triangles.
    MeshNonManifoldEdge = 35,
    /// The two triangles on the edge `detail.vertex`–`detail.vertex_b` disagree on their
    /// orientation in (u, v): the sheet folds over itself in material space.
    MeshFoldedUv = 36,
    /// The position or (u, v) of vertex `detail.vertex` is NaN or infinite.
    MeshNonFinite = 37,
    /// Triangle `detail.triangle` names material `detail.material`, which is ≥ the blob's cell
    /// count.
    MaterialOutOfRange = 38,
    /// Cell `detail.material` has unusable numbers (cannot happen with a blob that parsed).
    InvalidMaterial = 39,
    /// A `WeftSettings` field is out of range: `detail.what` names it.
    InvalidSetting = 40,
    /// Vertex `detail.vertex` belongs to no triangle (it would have no mass).
    MeshUnusedVertex = 41,
    /// Triangle `detail.triangle` is so large or so small in (u, v) that its area or mass does
    /// not fit a 32-bit float.
    MeshUvOutOfRange = 42,
    /// The initial positions stretch triangle `detail.triangle` so far from its (u, v) that its
    /// elastic force, stiffness or energy does not fit a 32-bit float, so every step would
    /// fail: usually (u, v) and positions in different units (e.g. (u, v) scaled by 1e-15
    /// against positions in metres).
    MeshStrainOutOfRange = 43,

    /// The blob is shorter than its header, or than the size its header announces, or longer
    /// (`detail.what` says which): a truncated or padded file.
    BlobSize = 50,
    /// Not a weft cell blob (its first 8 bytes are not "WEFTCELL").
    BlobBadMagic = 51,
    /// A blob format version this library does not read: `detail.index` is the version found,
    /// `WEFT_BLOB_VERSION` the one it reads.
    BlobVersion = 52,
    /// The blob's first byte is not `WEFT_BLOB_ALIGN`-aligned.
    BlobMisaligned = 53,
    /// The blob's CRC-32 does not match: the file is corrupt.
    BlobChecksum = 54,
    /// The blob's structure is corrupt (header, section table, padding): `detail.what` names
    /// the check, `detail.index` the section (or `WEFT_NONE`).
    BlobCorrupt = 55,
    /// Cell `detail.cell` of the blob holds invalid data: `detail.what` names the check and
    /// `detail.index` the element (node, triangle, material) when there is one.
    BlobInvalidCell = 56,
    /// `weft_blob_cell_info` was asked for a cell ≥ the blob's cell count (`detail.cell`).
    BlobCellOutOfRange = 57,

    /// Vertex `detail.vertex` is ≥ the world's vertex count (for a range, the last vertex
    /// asked for, and `detail.needed` the vertex count).
    VertexOutOfRange = 60,
    /// No collider has the id `detail.index`: it was never added, or it was removed.
    UnknownCollider = 61,
    /// A collider's numbers are invalid: non-finite, radius ≤ 0, a plane normal that is not unit
    /// length (±0.001), friction or thickness < 0. `detail.what` names the field when known.
    InvalidCollider = 62,
    /// An input value is NaN or infinite: `detail.what` names it, `detail.vertex` the vertex
    /// when it is per vertex.
    NonFinite = 63,
    /// `dt` is not a finite number > 0.
    InvalidTimeStep = 64,
    /// The target of the pin on vertex `detail.vertex` is NaN or infinite; the step did nothing.
    NonFinitePin = 65,
    /// The linear solver broke down at every substep count the step tried (up to 8× the
    /// setting's), and holding the cloth still instead (`WeftStepStats.stopped`, what such a
    /// step does otherwise) overflowed too: its pins' targets lie beyond what 32-bit floats
    /// hold. The world kept the state it had before the step.
    SolverBreakdown = 66,
    /// The step produced NaN or infinite positions, or a state whose energy overflows a 32-bit
    /// float, at every substep count the step tried (up to 8× the setting's), and so did
    /// holding the cloth still; the world kept the state it had before. Usually a pin target
    /// out of reach (e.g. moved 1e9 m in one step).
    NonFiniteState = 67,
    /// The step's energy balance is not a number (its energies overflowed `double`). The world
    /// kept the state it had before the step. (A step that gains energy is redone with more
    /// substeps, and as a last resort the cloth is held still for the step:
    /// `WeftStepStats.stopped`.)
    Unstable = 68,
    /// A triangle range reaches past the last triangle: `detail.needed` is the triangle count.
    TriangleOutOfRange = 69,

    /// `weft_bind`: fine vertex `detail.vertex` lies outside the coarse cloth's (u, v) layout
    /// (beyond a relative tolerance of 1e-5), or its (u, v) is NaN or infinite.
    BindOutOfDomain = 80,
    /// `weft_bind`: the bindings block is smaller than `weft_bind_memory_size` says:
    /// `detail.needed` fine vertices, room for `detail.capacity`.
    BindMemoryTooSmall = 81,
    /// The bindings block was not written by `weft_bind` (or is truncated or overwritten: its
    /// size disagrees with its vertex count). `detail.what` names the check.
    BindingsInvalid = 82,
    /// The bindings were made for another cloth: a world with a different mesh, rest (u, v),
    /// materials or blob. Bind the render mesh to this world again.
    BindingsMismatch = 83,
    /// Binding `detail.index` names a coarse triangle the world does not have (corrupt binding
    /// data that kept a valid header). Nothing was written.
    BindingOutOfRange = 84,
    /// `first + count` is beyond the bindings: `detail.index` is `first`, `detail.needed`
    /// `first + count` and `detail.capacity` the number of bindings.
    LocalizeRange = 85,
    /// `weft_localize_prepare`: the frames block is smaller than `weft_localize_frames_size`
    /// says: `detail.needed` coarse vertices, room for `detail.capacity`.
    FramesTooSmall = 86,
    /// The frames block was not filled by `weft_localize_prepare`, or was moved or overwritten
    /// since (frames are used where they were prepared).
    FramesNotPrepared = 87,
    /// The frames were prepared for another world (or for a world since destroyed and created
    /// again with another cloth in the same memory).
    FramesMismatch = 88,
    /// `weft_localize`: the normals overlap the positions (interleaved normals need the same
    /// stride and bytes of their own in each record), or an interleaved normal does not fit in
    /// its record. `detail.what` is "output.normals".
    NormalLayout = 89,
    /// `weft_localize` with `WEFT_NORMALS_RECOMPUTED`: fine triangle `detail.triangle` names
    /// vertex `detail.vertex`, which is ≥ `count` (indices are relative to `first`).
    FineIndexOutOfRange = 90,
    /// `weft_tiled_mesh_counts` / `weft_tiled_mesh`: cell `detail.cell` tiled over the cloth
    /// would have more vertices or triangles than a `uint32_t` counts (a tiny cell on a huge
    /// cloth).
    TiledMeshTooLarge = 91,
    /// `weft_tiled_mesh`: an output holds fewer elements than `weft_tiled_mesh_counts` says:
    /// `detail.what` names it, `detail.needed` and `detail.capacity` are the counts.
    TiledMeshCapacity = 92,
}

/// Where a failure is: written by every call that returns a `WeftResult` to its last argument,
/// `out_detail`, when that is not NULL (the one error channel; see the top of this header).
/// Which fields apply is said by each `WeftResult` value; the others are `WEFT_NONE` (indices)
/// or "" (`what`).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WeftErrorDetail {
    /// The result this detail is about (`WEFT_RESULT_OK` when the call succeeded).
    pub result: WeftResult,
    /// The triangle at fault.
    pub triangle: u32,
    /// The vertex at fault (the first end of an edge at fault).
    pub vertex: u32,
    /// The second end of an edge at fault.
    pub vertex_b: u32,
    /// The material (blob cell index) at fault.
    pub material: u32,
    /// The blob cell at fault.
    pub cell: u32,
    /// Another index: a blob section or element, a collider, a version found.
    pub index: u32,
    /// How many were needed (capacity and count errors).
    pub needed: u32,
    /// The capacity that was too small.
    pub capacity: u32,
    /// Zero; reserved (it makes the struct's 64-bit layout free of hidden padding).
    pub reserved: u32,
    /// A static, NUL-terminated string naming the argument, field or check; never NULL, owned
    /// by the library.
    pub what: *const c_char,
}

impl WeftErrorDetail {
    pub(super) const fn of(result: WeftResult) -> WeftErrorDetail {
        WeftErrorDetail {
            result,
            triangle: WEFT_NONE,
            vertex: WEFT_NONE,
            vertex_b: WEFT_NONE,
            material: WEFT_NONE,
            cell: WEFT_NONE,
            index: WEFT_NONE,
            needed: WEFT_NONE,
            capacity: WEFT_NONE,
            reserved: 0,
            what: EMPTY.as_ptr(),
        }
    }
    pub(super) const fn what(mut self, what: &'static CStr) -> Self {
        self.what = what.as_ptr();
        self
    }
    pub(super) const fn triangle(mut self, t: u32) -> Self {
        self.triangle = t;
        self
    }
    pub(super) const fn vertex(mut self, v: u32) -> Self {
        self.vertex = v;
        self
    }
    pub(super) const fn edge(mut self, a: u32, b: u32) -> Self {
        self.vertex = a;
        self.vertex_b = b;
        self
    }
    pub(super) const fn cell(mut self, c: u32) -> Self {
        self.cell = c;
        self
    }
    pub(super) const fn index(mut self, i: u32) -> Self {
        self.index = i;
        self
    }
    pub(super) const fn needed(mut self, n: u32, capacity: u32) -> Self {
        self.needed = n;
        self.capacity = capacity;
        self
    }
}

const EMPTY: &CStr = c"";

pub(super) type Fault = WeftErrorDetail;
pub(super) type FfiResult<T> = Result<T, Fault>;

pub(super) fn fault(result: WeftResult) -> Fault {
    WeftErrorDetail::of(result)
}

pub(super) fn null(what: &'static CStr) -> Fault {
    fault(WeftResult::NullPointer).what(what)
}

pub(super) fn invalid(what: &'static CStr) -> Fault {
    fault(WeftResult::InvalidArgument).what(what)
}

/// A short English description of a `WeftResult` value (any `uint32_t` is accepted; unknown
/// values give "unknown result"). The string is static, NUL-terminated and owned by the
/// library: never free it.
#[no_mangle]
pub extern "C" fn weft_result_string(result: u32) -> *const c_char {
    bytemuck::checked::try_cast::<u32, WeftResult>(result)
        .map_or(c"unknown result", message)
        .as_ptr()
}

/// The message of every result: a match, so a new value does not compile without one.
fn message(result: WeftResult) -> &'static CStr {
    use WeftResult as R;
    match result {
        R::Ok => c"ok",
        R::NullPointer => c"a required pointer argument is NULL",
        R::Uninitialized => c"def or blob not initialized by weft_default_*_def / weft_blob_parse",
        R::InvalidHandle => c"not a live world handle",
        R::InvalidArgument => c"argument out of range",
        R::Misaligned => c"pointer or memory block misaligned",
        R::CountMismatch => c"vertex count does not match the world",
        R::Internal => c"internal error (a bug in weft)",
        R::MemoryTooSmall => c"memory block smaller than weft_world_memory_size",
        R::CapacityTooLarge => c"capacity too large for this target",
        R::VertexCapacity => c"more vertices than capacity.max_vertices",
        R::TriangleCapacity => c"more triangles than capacity.max_triangles",
        R::EdgeCapacity => c"more edges than capacity.max_edges",
        R::PinCapacity => c"pin capacity exhausted",
        R::ColliderCapacity => c"collider capacity exhausted",
        R::MeshEmpty => c"mesh has no vertices or no triangles",
        R::MeshIndexOutOfRange => c"triangle vertex index out of range",
        R::MeshRepeatedVertex => c"triangle repeats a vertex",
        R::MeshDegenerateUv => c"triangle degenerate in (u, v)",
        R::MeshDegenerate3d => c"triangle degenerate in 3D",
        R::MeshNonManifoldEdge => c"edge shared by more than two triangles",
        R::MeshFoldedUv => c"mesh folds over itself in (u, v)",
        R::MeshNonFinite => c"vertex position or (u, v) not finite",
        R::MaterialOutOfRange => c"triangle material is not a cell of the blob",
        R::InvalidMaterial => c"material has invalid numbers",
        R::InvalidSetting => c"setting out of range",
        R::MeshUnusedVertex => c"a vertex belongs to no triangle",
        R::MeshUvOutOfRange => c"a triangle's (u, v) size does not fit a 32-bit float",
        R::MeshStrainOutOfRange => {
            c"a triangle is stretched from its (u, v) beyond what a 32-bit float holds"
        }
        R::BlobSize => c"blob size does not match its header",
        R::BlobBadMagic => c"not a weft cell blob",
        R::BlobVersion => c"unsupported blob version",
        R::BlobMisaligned => c"blob data not 8-byte aligned",
        R::BlobChecksum => c"blob checksum mismatch",
        R::BlobCorrupt => c"blob structure corrupt",
        R::BlobInvalidCell => c"blob cell holds invalid data",
        R::BlobCellOutOfRange => c"blob cell index out of range",
        R::VertexOutOfRange => c"vertex index out of range",
        R::TriangleOutOfRange => c"triangle range out of range",
        R::UnknownCollider => c"no collider has that id (never added, or removed)",
        R::InvalidCollider => c"invalid collider",
        R::NonFinite => c"value not finite",
        R::InvalidTimeStep => c"time step not finite and positive",
        R::NonFinitePin => c"pin target not finite",
        R::SolverBreakdown => c"linear solver broke down",
        R::NonFiniteState => c"step produced non-finite state",
        R::Unstable => c"the step's energy balance is not a number (unstable)",
        R::BindOutOfDomain => c"fine vertex outside the coarse cloth's (u, v)",
        R::BindMemoryTooSmall => c"bindings block smaller than weft_bind_memory_size",
        R::BindingsInvalid => c"not a bindings block written by weft_bind",
        R::BindingsMismatch => c"bindings were made for another cloth",
        R::BindingOutOfRange => c"binding names a coarse triangle that does not exist",
        R::LocalizeRange => c"first + count beyond the bindings",
        R::FramesTooSmall => c"frames block smaller than weft_localize_frames_size",
        R::FramesNotPrepared => c"frames not prepared by weft_localize_prepare (or moved since)",
        R::FramesMismatch => c"frames were prepared for another world",
        R::NormalLayout => c"normals overlap the positions or leave their record",
        R::FineIndexOutOfRange => c"fine triangle vertex index out of range",
        R::TiledMeshTooLarge => c"tiled mesh too large for 32-bit indices",
        R::TiledMeshCapacity => c"output smaller than weft_tiled_mesh_counts",
    }
}

fn setting_name(field: &str) -> &'static CStr {
    match field {
        "time_step" => c"time_step",
        "substeps" => c"substeps",
        "gravity" => c"gravity",
        "damping_mass" => c"damping_mass",
        "damping_stiffness" => c"damping_stiffness",
        "wind" => c"wind",
        "drag" => c"drag",
        "tolerance" => c"tolerance",
        "max_iterations" => c"max_iterations",
        "rotation_iterations" => c"rotation_iterations",
        "sleep_velocity" => c"sleep_velocity",
        "max_depenetration_speed" => c"max_depenetration_speed",
        "effects" => c"effects",
        _ => c"settings",
    }
}

pub(super) fn mesh_fault(e: MeshError) -> Fault {
    use WeftResult as R;
    match e {
        MeshError::Empty => fault(R::MeshEmpty),
        MeshError::VertexCapacity { needed, capacity } => {
            fault(R::VertexCapacity).needed(needed, capacity)
        }
        MeshError::TriangleCapacity { needed, capacity } => {
            fault(R::TriangleCapacity).needed(needed, capacity)
        }
        MeshError::EdgeCapacity { capacity } => fault(R::EdgeCapacity).needed(WEFT_NONE, capacity),
        MeshError::IndexOutOfRange { triangle } => fault(R::MeshIndexOutOfRange).triangle(triangle),
        MeshError::RepeatedVertex { triangle } => fault(R::MeshRepeatedVertex).triangle(triangle),
        MeshError::DegenerateUv { triangle } => fault(R::MeshDegenerateUv).triangle(triangle),
        MeshError::Degenerate3d { triangle } => fault(R::MeshDegenerate3d).triangle(triangle),
        MeshError::NonManifoldEdge { a, b } => fault(R::MeshNonManifoldEdge).edge(a, b),
        MeshError::FoldedUv { a, b } => fault(R::MeshFoldedUv).edge(a, b),
        MeshError::NonFinite { vertex } => fault(R::MeshNonFinite).vertex(vertex),
        MeshError::UnusedVertex { vertex } => fault(R::MeshUnusedVertex).vertex(vertex),
        MeshError::UvOutOfRange { triangle } => fault(R::MeshUvOutOfRange).triangle(triangle),
        // The FFI always hands the kernel buffers of matching length.
        MeshError::BufferTooSmall => fault(R::Internal).what(c"mesh buffer"),
    }
}

pub(super) fn init_fault(e: InitError) -> Fault {
    use WeftResult as R;
    match e {
        InitError::MemoryTooSmall => fault(R::MemoryTooSmall).what(c"memory_size"),
        InitError::CapacityTooLarge => fault(R::CapacityTooLarge),
        InitError::VertexCapacity { needed, capacity } => {
            fault(R::VertexCapacity).needed(needed, capacity)
        }
        InitError::TriangleCapacity { needed, capacity } => {
            fault(R::TriangleCapacity).needed(needed, capacity)
        }
        InitError::EdgeCapacity { capacity } => fault(R::EdgeCapacity).needed(WEFT_NONE, capacity),
        InitError::Mesh(m) => mesh_fault(m),
        InitError::MaterialCount => fault(R::Internal).what(c"material count"),
        InitError::MaterialOutOfRange { triangle, material } => {
            let mut f = fault(R::MaterialOutOfRange).triangle(triangle);
            f.material = material;
            f
        }
        InitError::InvalidMaterial { material } => {
            let mut f = fault(R::InvalidMaterial);
            f.material = material;
            f
        }
        InitError::InvalidSetting { field } => fault(R::InvalidSetting).what(setting_name(field)),
        InitError::StrainOutOfRange { triangle } => {
            fault(R::MeshStrainOutOfRange).triangle(triangle)
        }
        InitError::Internal => fault(R::Internal),
    }
}

pub(super) fn step_fault(e: StepError) -> Fault {
    use WeftResult as R;
    match e {
        StepError::InvalidTimeStep => fault(R::InvalidTimeStep).what(c"dt"),
        StepError::NonFinitePin { vertex } => fault(R::NonFinitePin).vertex(vertex),
        StepError::SolverBreakdown => fault(R::SolverBreakdown),
        StepError::NonFiniteState => fault(R::NonFiniteState),
        StepError::Unstable => fault(R::Unstable),
    }
}

pub(super) fn edit_fault(e: EditError, w: &World<'_>) -> Fault {
    use WeftResult as R;
    let cap = w.capacity();
    match e {
        EditError::VertexOutOfRange => fault(R::VertexOutOfRange),
        EditError::NonFinite => fault(R::NonFinite),
        EditError::PinCapacity => fault(R::PinCapacity).needed(cap.pins + 1, cap.pins),
        EditError::ColliderCapacity => {
            fault(R::ColliderCapacity).needed(cap.colliders + 1, cap.colliders)
        }
        EditError::UnknownCollider => fault(R::UnknownCollider),
        EditError::InvalidCollider => fault(R::InvalidCollider),
        EditError::InvalidMassScale { vertex } => invalid(c"scales").vertex(vertex),
        EditError::InvalidAxis => invalid(c"axis"),
        EditError::InvalidRotation => invalid(c"rotation"),
        EditError::TriangleOutOfRange => fault(R::TriangleOutOfRange),
    }
}

pub(super) fn blob_fault(e: BlobError) -> Fault {
    use WeftResult as R;
    let corrupt = |what: &'static CStr| fault(R::BlobCorrupt).what(what);
    let cell = |cell: u32, what: &'static CStr| fault(R::BlobInvalidCell).cell(cell).what(what);
    match e {
        BlobError::TooShort { .. } => fault(R::BlobSize).what(c"truncated"),
        BlobError::TrailingBytes { .. } => fault(R::BlobSize).what(c"trailing bytes"),
        BlobError::BadMagic => fault(R::BlobBadMagic),
        BlobError::UnsupportedVersion { found } => fault(R::BlobVersion).index(found),
        BlobError::BadHeader => corrupt(c"header"),
        BlobError::Misaligned => fault(R::BlobMisaligned).what(c"data"),
        BlobError::ChecksumMismatch { .. } => fault(R::BlobChecksum),
        BlobError::BadSectionTable => corrupt(c"section table"),
        BlobError::UnexpectedSection { section, .. } => corrupt(c"section order").index(section),
        BlobError::SectionOutOfRange { section } => corrupt(c"section range").index(section),
        BlobError::SectionMisaligned { section } => corrupt(c"section alignment").index(section),
        BlobError::SectionOverlap { section } => corrupt(c"section overlap").index(section),
        BlobError::SectionGap { section } => corrupt(c"section gap").index(section),
        BlobError::SectionSizeMismatch { section } => corrupt(c"section size").index(section),
        BlobError::NonZeroPadding { .. } => corrupt(c"padding"),
        BlobError::BadName { cell: c } => cell(c, c"name"),
        BlobError::DuplicateName { cell: c } => cell(c, c"duplicate name"),
        BlobError::BadDimensions { cell: c } => cell(c, c"dimensions"),
        BlobError::CountMismatch { cell: c, .. } => cell(c, c"section count"),
        BlobError::NonFinite { cell: c, index, .. } => cell(c, c"non-finite value").index(index),
        BlobError::BadValue { cell: c, index, .. } => cell(c, c"value out of range").index(index),
        BlobError::NotSpd { cell: c } => cell(c, c"stiffness not SPD"),
        BlobError::BoundNotSpd { cell: c } => cell(c, c"bound not SPD"),
        BlobError::MaterialNotSpd { cell: c, material } => {
            cell(c, c"material stiffness not SPD").index(material)
        }
        BlobError::NodeOffGrid { cell: c, node } => cell(c, c"node off grid").index(node),
        BlobError::IndexOutOfRange { cell: c, triangle } => {
            cell(c, c"node index out of range").index(triangle)
        }
        BlobError::TopologyMismatch { cell: c, triangle } => cell(c, c"topology").index(triangle),
        BlobError::MaterialIndexOutOfRange { cell: c, triangle } => {
            cell(c, c"material index out of range").index(triangle)
        }
        BlobError::PixelMaterialMismatch { cell: c, triangle } => {
            cell(c, c"pixel material").index(triangle)
        }
        BlobError::TooLarge => corrupt(c"too large"),
    }
}
