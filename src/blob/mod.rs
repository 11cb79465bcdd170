//! The cell blob: a versioned, little-endian binary file of homogenized cells, read **in place**.
//!
//! The byte-exact format is specified in `docs/BLOB.md`; this module is its only implementation:
//! the reader here, the writer in `writer.rs`.
//!
//! * Reader (no_std, no allocation, no `unsafe`): [`Blob::parse`] validates the whole blob once
//!   (structure, checksum, counts, indices, finiteness, positivity, SPD tensors, mesh numbering),
//!   after which [`Blob::cell`] hands out [`Cell`] views whose arrays borrow the input bytes.
//!   Whatever the bytes, the reader never panics and never reads out of bounds: every offset is
//!   computed with checked arithmetic and every access goes through `get`.
//! * Writer (`std`, `writer.rs`): [`write()`](fn@write) runs the *same* per-cell validation on
//!   [`CellRecord`]s before it lays anything out, so an invalid blob is never produced;
//!   [`Cell::to_record`] closes the round trip. [`load_aligned`] reads a file into a buffer
//!   aligned for the in-place reader.
//!
//! Arrays are reinterpreted with `bytemuck` (which checks size and alignment), so the in-place
//! view is only correct on a little-endian target; big-endian targets are refused at compile time
//! rather than silently misreading every number.

#[cfg(target_endian = "big")]
compile_error!(
    "weft's cell blob is little-endian and read in place without byte swapping; \
     big-endian targets are not supported (see docs/BLOB.md)"
);

use bytemuck::{Pod, Zeroable};

use crate::lattice;
use crate::membrane::is_spd;

mod error;
use crate::Voigt;
pub use error::{BlobError, Field};

/// Format version written by [`write()`](fn@write) and the only one [`Blob::parse`] accepts.
pub const VERSION: u32 = 1;
/// The first eight bytes of every blob.
pub const MAGIC: [u8; 8] = *b"WEFTCELL";
/// Size of the fixed header in bytes (version 1).
pub const HEADER_SIZE: usize = 64;
/// Size of one section-table entry in bytes.
pub const SECTION_ENTRY_SIZE: usize = 32;
/// Every section (and the end of the blob) sits on a multiple of this, counted from the base.
pub const SECTION_ALIGN: usize = 16;
/// Required alignment of the blob's base address: the strictest element type (`f64`) needs 8.
/// [`AlignedBytes`] provides 16, so that sections are also 16-aligned in memory.
pub const BASE_ALIGN: usize = 8;
/// Longest cell name in bytes; the name field is 64 bytes and always NUL-terminated.
pub const MAX_NAME_LEN: usize = 63;
/// Sections per cell in version 1, one of each [`SectionKind`].
pub const SECTIONS_PER_CELL: usize = 6;
/// Relative tolerance (of the node spacing `h`) on stored node positions, which are `f32`
/// roundings of the exact grid `(i·h, j·h)`: f32 has a 2⁻²⁴ relative error, i.e. `nu·6e-8 h`
/// at the far edge, so 1e-3 accepts every honest writer up to `nu ≈ 16000`.
pub const NODE_TOLERANCE: f64 = 1e-3;

// Header field offsets (docs/BLOB.md, "Header").
const H_VERSION: usize = 8;
const H_HEADER_SIZE: usize = 12;
const H_TOTAL_SIZE: usize = 16;
const H_CELL_COUNT: usize = 24;
const H_SECTION_COUNT: usize = 28;
const H_TABLE_OFFSET: usize = 32;
const H_CHECKSUM: usize = 40;
const H_RESERVED: usize = 44;

/// What a section holds. The discriminant is the `kind` field of its table entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u32)]
pub enum SectionKind {
    /// One `CellInfo` record (docs/BLOB.md): name, dimensions, scalars, `C^H` and bounds.
    Info = 1,
    /// [`MaterialRecord`]s, indexed by `tri_material`.
    Materials = 2,
    /// Node `(u, v)` as `[f32; 2]`.
    Nodes = 3,
    /// Triangles as `[u32; 3]` node indices.
    Triangles = 4,
    /// Material index per triangle, `u32`.
    TriMaterial = 5,
    /// Characteristic displacements per node, `[f32; 6]`.
    Chi = 6,
}

impl SectionKind {
    const ALL: [SectionKind; SECTIONS_PER_CELL] = [
        SectionKind::Info,
        SectionKind::Materials,
        SectionKind::Nodes,
        SectionKind::Triangles,
        SectionKind::TriMaterial,
        SectionKind::Chi,
    ];

    /// Size in bytes of one element of this section.
    pub const fn element_size(self) -> usize {
        match self {
            SectionKind::Info => core::mem::size_of::<CellInfo>(),
            SectionKind::Materials => core::mem::size_of::<MaterialRecord>(),
            SectionKind::Nodes => 8,
            SectionKind::Triangles => 12,
            SectionKind::TriMaterial => 4,
            SectionKind::Chi => 24,
        }
    }

    /// Kind of the `slot`-th section of a cell (canonical order).
    fn at(slot: usize) -> Option<SectionKind> {
        SectionKind::ALL.get(slot).copied()
    }

    fn name(self) -> &'static str {
        match self {
            SectionKind::Info => "info",
            SectionKind::Materials => "materials",
            SectionKind::Nodes => "nodes",
            SectionKind::Triangles => "triangles",
            SectionKind::TriMaterial => "tri_material",
            SectionKind::Chi => "chi",
        }
    }
}

/// One material of a cell's pattern, stored in place (88 bytes, see docs/BLOB.md).
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
#[repr(C)]
pub struct MaterialRecord {
    /// Membrane stiffness, N/m, Voigt `[11, 22, 12]`, engineering shear.
    pub c: [[f64; 3]; 3],
    /// Areal density, kg/m².
    pub density: f64,
    /// Bending stiffness, N·m.
    pub bending: f64,
}

/// The fixed part of a cell as stored in its [`SectionKind::Info`] section (320 bytes). Field
/// order keeps every `f64` 8-aligned with no padding, which `Pod` requires.
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
#[repr(C)]
struct CellInfo {
    name_len: u32,
    cols: u32,
    rows: u32,
    refine: u32,
    name: [u8; 64],
    size: f64,
    density: f64,
    bending: f64,
    stiffness: [[f64; 3]; 3],
    voigt_bound: [[f64; 3]; 3],
    reuss_bound: [[f64; 3]; 3],
}

const _: () = assert!(core::mem::size_of::<CellInfo>() == 320);
const _: () = assert!(core::mem::size_of::<MaterialRecord>() == 88);
const _: () = assert!(MAX_NAME_LEN < 64);

/// One homogenized cell, borrowed from a validated [`Blob`] (or from a [`CellRecord`]).
///
/// Mesh numbering follows docs/ARCHITECTURE.md ("Pixel mesh numbering", periodic cell):
/// `nu·nv` nodes, node `(i, j)` at index `j·nu + i`, `2·nu·nv` triangles.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cell<'a> {
    /// UTF-8, 1..=63 bytes, no NUL.
    pub name: &'a str,
    /// Width of the cell along u, metres.
    pub size: f64,
    /// Pattern pixels along u.
    pub cols: u32,
    /// Pattern pixels along v.
    pub rows: u32,
    /// Each pixel is split into `refine × refine` squares.
    pub refine: u32,
    /// Homogenized membrane stiffness `C^H`, N/m, Voigt `[11, 22, 12]`.
    pub stiffness: [[f64; 3]; 3],
    /// Mean areal density, kg/m².
    pub density: f64,
    /// Effective bending stiffness, N·m.
    pub bending: f64,
    /// Voigt (arithmetic mean, upper) bound on `C^H`.
    pub voigt_bound: [[f64; 3]; 3],
    /// Reuss (harmonic mean, lower) bound on `C^H`.
    pub reuss_bound: [[f64; 3]; 3],
    /// The pattern's materials, indexed by `tri_material`.
    pub materials: &'a [MaterialRecord],
    /// Node `(u, v)` in metres, `nu·nv` of them.
    pub nodes: &'a [[f32; 2]],
    /// Counter-clockwise node triples, `2·nu·nv` of them.
    pub triangles: &'a [[u32; 3]],
    /// Material index of each triangle.
    pub tri_material: &'a [u32],
    /// Per node `(χ¹u, χ¹v, χ²u, χ²v, χ³u, χ³v)`, metres per unit strain; the micro displacement
    /// under macro strain `Ê` is `w = -(χ¹ Ê1 + χ² Ê2 + χ³ Ê3)` (docs/CONVENTIONS.md).
    pub chi: &'a [[f32; 6]],
}

impl Cell<'_> {
    /// Width along u in metres (= `size`).
    pub fn width(&self) -> f64 {
        self.size
    }

    /// Height along v in metres: pixels are square, so `size · rows / cols`.
    pub fn height(&self) -> f64 {
        self.size * f64::from(self.rows) / f64::from(self.cols)
    }

    /// Node columns of the periodic micro mesh, `cols · refine`.
    pub fn nu(&self) -> u32 {
        self.cols.saturating_mul(self.refine)
    }

    /// Node rows of the periodic micro mesh, `rows · refine`.
    pub fn nv(&self) -> u32 {
        self.rows.saturating_mul(self.refine)
    }
}

/// A validated blob borrowed in place. Cheap to copy.
#[derive(Debug, Clone, Copy)]
pub struct Blob<'a> {
    bytes: &'a [u8],
    cell_count: usize,
}

impl<'a> Blob<'a> {
    /// Validates `bytes` completely (see docs/BLOB.md, "Validation") and returns a view on them.
    /// `bytes` must start at an address that is a multiple of [`BASE_ALIGN`].
    pub fn parse(bytes: &'a [u8]) -> Result<Self, BlobError> {
        let header = read_header(bytes)?;
        // The arrays are borrowed as `&[f64]`-carrying types: refuse before casting anything.
        if !(bytes.as_ptr() as usize).is_multiple_of(BASE_ALIGN) {
            return Err(BlobError::Misaligned);
        }
        let body = bytes
            .get(HEADER_SIZE..)
            .ok_or(too_short(HEADER_SIZE as u64, bytes))?;
        let computed = crc32(body);
        if computed != header.checksum {
            return Err(BlobError::ChecksumMismatch {
                stored: header.checksum,
                computed,
            });
        }
        check_layout(bytes, &header)?;
        let blob = Blob {
            bytes,
            cell_count: header.cell_count,
        };
        for ci in 0..header.cell_count {
            let index = u32::try_from(ci).map_err(|_| BlobError::BadSectionTable)?;
            let cell = cell_view(bytes, ci, index)?;
            validate_cell(index, &cell)?;
            // Names are lookup keys. Without allocation, uniqueness costs a quadratic scan over
            // the names (not the cells): negligible for the tens of cells a library holds.
            for earlier in 0..ci {
                if cell_name(bytes, earlier) == Some(cell.name.as_bytes()) {
                    return Err(BlobError::DuplicateName { cell: index });
                }
            }
        }
        Ok(blob)
    }

    /// The format version (always [`VERSION`] for a blob that parsed).
    pub fn version(&self) -> u32 {
        VERSION
    }

    /// Number of cells.
    pub fn cell_count(&self) -> usize {
        self.cell_count
    }

    /// Cell `i`, or `None` when `i >= cell_count()`. Everything was validated by `parse`, so this
    /// only re-slices.
    pub fn cell(&self, i: usize) -> Option<Cell<'a>> {
        if i >= self.cell_count {
            return None;
        }
        cell_view(self.bytes, i, u32::try_from(i).ok()?).ok()
    }

    /// The cell named `name`, if any (names are unique within a blob).
    pub fn find(&self, name: &str) -> Option<Cell<'a>> {
        self.cells().find(|c| c.name == name)
    }

    /// All cells in order.
    pub fn cells(&self) -> impl Iterator<Item = Cell<'a>> + 'a {
        let blob = *self;
        (0..self.cell_count).filter_map(move |i| blob.cell(i))
    }

    /// The underlying bytes.
    pub fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }
}

// ---------------------------------------------------------------------------------------------
// CRC-32
// ---------------------------------------------------------------------------------------------

/// CRC-32/IEEE (reflected polynomial 0xEDB88320, init and xor-out 0xFFFFFFFF) lookup table,
/// built at compile time so the no_std reader carries no runtime initialisation.
#[allow(clippy::indexing_slicing)] // i < 256 = table length
const CRC_TABLE: [u32; 256] = {
    let mut table = [0u32; 256];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        table[i] = c;
        i += 1;
    }
    table
};

/// CRC-32/IEEE (the zlib / PNG / Ethernet CRC) of `bytes`; `crc32(b"123456789") == 0xCBF43926`.
/// The blob stores it over everything after the header.
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        // A u8 index into a 256-entry table cannot be out of bounds.
        #[allow(clippy::indexing_slicing)]
        let t = CRC_TABLE[usize::from((c as u8) ^ b)];
        c = t ^ (c >> 8);
    }
    !c
}

// ---------------------------------------------------------------------------------------------
// Reader internals
// ---------------------------------------------------------------------------------------------

struct Header {
    cell_count: usize,
    section_count: usize,
    table_offset: usize,
    checksum: u32,
}

fn read_u32(bytes: &[u8], at: usize) -> Option<u32> {
    let b: [u8; 4] = bytes.get(at..at.checked_add(4)?)?.try_into().ok()?;
    Some(u32::from_le_bytes(b))
}

fn too_short(expected: u64, bytes: &[u8]) -> BlobError {
    BlobError::TooShort {
        expected,
        found: bytes.len() as u64,
    }
}

fn read_u64(bytes: &[u8], at: usize) -> Option<u64> {
    let b: [u8; 8] = bytes.get(at..at.checked_add(8)?)?.try_into().ok()?;
    Some(u64::from_le_bytes(b))
}

/// Header checks that need neither alignment nor the checksum (so a wrong file or a truncated
/// download is reported as such, not as a checksum error).
fn read_header(bytes: &[u8]) -> Result<Header, BlobError> {
    if bytes.get(..MAGIC.len()).is_some_and(|m| m != MAGIC) {
        return Err(BlobError::BadMagic);
    }
    let short = too_short(HEADER_SIZE as u64, bytes);
    if bytes.len() < HEADER_SIZE {
        return Err(short);
    }
    let r32 = |at| read_u32(bytes, at).ok_or(short);
    let r64 = |at| read_u64(bytes, at).ok_or(short);
    let version = r32(H_VERSION)?;
    if version != VERSION {
        return Err(BlobError::UnsupportedVersion { found: version });
    }
    let reserved = bytes.get(H_RESERVED..HEADER_SIZE).ok_or(short)?;
    if r32(H_HEADER_SIZE)? as usize != HEADER_SIZE || reserved.iter().any(|&b| b != 0) {
        return Err(BlobError::BadHeader);
    }
    let total = r64(H_TOTAL_SIZE)?;
    let len = bytes.len() as u64;
    if len < total {
        return Err(too_short(total, bytes));
    }
    if len > total {
        return Err(BlobError::TrailingBytes {
            expected: total,
            found: len,
        });
    }
    let to_usize = |v: u64| usize::try_from(v).map_err(|_| BlobError::BadSectionTable);
    Ok(Header {
        cell_count: r32(H_CELL_COUNT)? as usize,
        section_count: r32(H_SECTION_COUNT)? as usize,
        table_offset: to_usize(r64(H_TABLE_OFFSET)?)?,
        checksum: r32(H_CHECKSUM)?,
    })
}

/// One decoded section-table entry.
struct Entry {
    kind: u32,
    cell: u32,
    offset: u64,
    len: u64,
    count: u64,
}

fn read_entry(bytes: &[u8], section: usize) -> Option<Entry> {
    let at = HEADER_SIZE.checked_add(section.checked_mul(SECTION_ENTRY_SIZE)?)?;
    Some(Entry {
        kind: read_u32(bytes, at)?,
        cell: read_u32(bytes, at.checked_add(4)?)?,
        offset: read_u64(bytes, at.checked_add(8)?)?,
        len: read_u64(bytes, at.checked_add(16)?)?,
        count: read_u64(bytes, at.checked_add(24)?)?,
    })
}

fn align_up(v: u64) -> Option<u64> {
    let a = SECTION_ALIGN as u64;
    Some(v.checked_add(a - 1)? / a * a)
}

fn check_zero(bytes: &[u8], from: u64, to: u64) -> Result<(), BlobError> {
    let (f, t) = (usize::try_from(from), usize::try_from(to));
    let pad = match (f, t) {
        (Ok(f), Ok(t)) => bytes.get(f..t),
        _ => None,
    }
    .ok_or(too_short(to, bytes))?;
    match pad.iter().position(|&b| b != 0) {
        None => Ok(()),
        Some(p) => Err(BlobError::NonZeroPadding {
            offset: from + p as u64,
        }),
    }
}

/// Section table and layout: canonical order, bounds, alignment, tight packing, zero padding.
/// After this, every section of every cell is a validly-placed slice of `bytes`.
fn check_layout(bytes: &[u8], h: &Header) -> Result<(), BlobError> {
    let total = bytes.len() as u64;
    if h.cell_count.checked_mul(SECTIONS_PER_CELL) != Some(h.section_count)
        || h.table_offset != HEADER_SIZE
    {
        return Err(BlobError::BadSectionTable);
    }
    let table_end = h
        .section_count
        .checked_mul(SECTION_ENTRY_SIZE)
        .and_then(|t| t.checked_add(HEADER_SIZE))
        .filter(|&end| end as u64 <= total)
        .ok_or(BlobError::BadSectionTable)? as u64;
    let mut cursor = table_end;
    for s in 0..h.section_count {
        let section = u32::try_from(s).map_err(|_| BlobError::BadSectionTable)?;
        let e = read_entry(bytes, s).ok_or(BlobError::BadSectionTable)?;
        let kind = SectionKind::at(s % SECTIONS_PER_CELL).ok_or(BlobError::BadSectionTable)?;
        if e.kind != kind as u32 || e.cell as usize != s / SECTIONS_PER_CELL {
            return Err(BlobError::UnexpectedSection {
                section,
                kind: e.kind,
                cell: e.cell,
            });
        }
        match e.offset.checked_add(e.len) {
            Some(end) if end <= total => {}
            _ => return Err(BlobError::SectionOutOfRange { section }),
        }
        if e.offset % SECTION_ALIGN as u64 != 0 {
            return Err(BlobError::SectionMisaligned { section });
        }
        let expected = align_up(cursor).ok_or(BlobError::SectionOutOfRange { section })?;
        if e.offset < expected {
            return Err(BlobError::SectionOverlap { section });
        }
        if e.offset > expected {
            return Err(BlobError::SectionGap { section });
        }
        if e.count.checked_mul(kind.element_size() as u64) != Some(e.len) {
            return Err(BlobError::SectionSizeMismatch { section });
        }
        check_zero(bytes, cursor, e.offset)?;
        cursor = e.offset + e.len; // no overflow: checked against `total` above
    }
    let section = u32::try_from(h.section_count).map_err(|_| BlobError::BadSectionTable)?;
    match align_up(cursor) {
        Some(end) if end == total => check_zero(bytes, cursor, total),
        _ => Err(BlobError::SectionGap { section }),
    }
}

/// The bytes and element count of section `slot` of cell `ci` (layout already checked).
fn section(bytes: &[u8], ci: usize, slot: usize) -> Option<(&[u8], u64)> {
    let e = read_entry(bytes, ci.checked_mul(SECTIONS_PER_CELL)?.checked_add(slot)?)?;
    let start = usize::try_from(e.offset).ok()?;
    let end = start.checked_add(usize::try_from(e.len).ok()?)?;
    Some((bytes.get(start..end)?, e.count))
}

/// The name bytes of cell `ci` (layout and name already checked).
fn cell_name(bytes: &[u8], ci: usize) -> Option<&[u8]> {
    let info: &CellInfo = bytemuck::try_from_bytes(section(bytes, ci, 0)?.0).ok()?;
    info.name.get(..info.name_len as usize)
}

/// Builds the borrowed view of cell `ci`. Structural problems the layout check cannot have
/// left map to `BadSectionTable`; the info count is the one content check needed to cast.
fn cell_view(bytes: &[u8], ci: usize, index: u32) -> Result<Cell<'_>, BlobError> {
    let get = |slot| section(bytes, ci, slot).ok_or(BlobError::BadSectionTable);
    let cast_err = |_| BlobError::Misaligned;
    let (info_bytes, info_count) = get(0)?;
    if info_count != 1 {
        return Err(BlobError::CountMismatch {
            cell: index,
            section: SectionKind::Info,
            expected: 1,
            found: info_count,
        });
    }
    let info: &CellInfo = bytemuck::try_from_bytes(info_bytes).map_err(cast_err)?;
    let name_len = info.name_len as usize;
    let bad_name = BlobError::BadName { cell: index };
    if name_len > MAX_NAME_LEN {
        return Err(bad_name);
    }
    let (name_bytes, name_pad) = info.name.split_at(name_len);
    // Zero padding keeps the field NUL-terminated (handy across the C ABI) and the encoding unique.
    if name_pad.iter().any(|&b| b != 0) {
        return Err(bad_name);
    }
    let name = core::str::from_utf8(name_bytes).map_err(|_| bad_name)?;
    Ok(Cell {
        name,
        size: info.size,
        cols: info.cols,
        rows: info.rows,
        refine: info.refine,
        stiffness: info.stiffness,
        density: info.density,
        bending: info.bending,
        voigt_bound: info.voigt_bound,
        reuss_bound: info.reuss_bound,
        materials: bytemuck::try_cast_slice(get(1)?.0).map_err(cast_err)?,
        nodes: bytemuck::try_cast_slice(get(2)?.0).map_err(cast_err)?,
        triangles: bytemuck::try_cast_slice(get(3)?.0).map_err(cast_err)?,
        tri_material: bytemuck::try_cast_slice(get(4)?.0).map_err(cast_err)?,
        chi: bytemuck::try_cast_slice(get(5)?.0).map_err(cast_err)?,
    })
}

fn all_finite(m: &Voigt) -> bool {
    m.iter().flatten().all(|v| v.is_finite())
}

/// Content validation of one cell, shared by the reader and the writer so both enforce exactly
/// the same rules (docs/BLOB.md, "Validation"). Order: name, dimensions, scalars, tensors,
/// materials, counts, nodes, triangles, materials per triangle, chi.
fn validate_cell(cell: u32, c: &Cell<'_>) -> Result<(), BlobError> {
    if c.name.is_empty() || c.name.len() > MAX_NAME_LEN || c.name.bytes().any(|b| b == 0) {
        return Err(BlobError::BadName { cell });
    }

    // Dimensions: every node and triangle index must fit in u32.
    let bad_dims = BlobError::BadDimensions { cell };
    if c.cols == 0 || c.rows == 0 || c.refine == 0 {
        return Err(bad_dims);
    }
    let nu = u64::from(c.cols) * u64::from(c.refine);
    let nv = u64::from(c.rows) * u64::from(c.refine);
    let n_nodes = nu.checked_mul(nv).ok_or(bad_dims)?;
    let n_tris = n_nodes
        .checked_mul(2)
        .filter(|&t| t <= u64::from(u32::MAX))
        .ok_or(bad_dims)?;
    // Both fit in u32, hence in usize on every target weft supports (≥ 32-bit).
    let (nu, nv) = (
        usize::try_from(nu).map_err(|_| bad_dims)?,
        usize::try_from(nv).map_err(|_| bad_dims)?,
    );

    // Scalars.
    for (field, v, positive) in [
        (Field::Size, c.size, true),
        (Field::Density, c.density, true),
        (Field::Bending, c.bending, false),
    ] {
        if !v.is_finite() {
            return Err(BlobError::NonFinite {
                cell,
                field,
                index: 0,
            });
        }
        if (positive && v <= 0.0) || v < 0.0 {
            return Err(BlobError::BadValue {
                cell,
                field,
                index: 0,
            });
        }
    }

    // Tensors.
    for (field, m) in [
        (Field::Stiffness, &c.stiffness),
        (Field::VoigtBound, &c.voigt_bound),
        (Field::ReussBound, &c.reuss_bound),
    ] {
        if !all_finite(m) {
            return Err(BlobError::NonFinite {
                cell,
                field,
                index: 0,
            });
        }
    }
    if !is_spd(&c.stiffness) {
        return Err(BlobError::NotSpd { cell });
    }
    if !is_spd(&c.voigt_bound) || !is_spd(&c.reuss_bound) {
        return Err(BlobError::BoundNotSpd { cell });
    }

    // Materials.
    for (i, m) in c.materials.iter().enumerate() {
        let index = u32::try_from(i).map_err(|_| bad_dims)?;
        for (field, finite) in [
            (Field::MaterialStiffness, all_finite(&m.c)),
            (Field::MaterialDensity, m.density.is_finite()),
            (Field::MaterialBending, m.bending.is_finite()),
        ] {
            if !finite {
                return Err(BlobError::NonFinite { cell, field, index });
            }
        }
        if m.density <= 0.0 {
            return Err(BlobError::BadValue {
                cell,
                field: Field::MaterialDensity,
                index,
            });
        }
        if m.bending < 0.0 {
            return Err(BlobError::BadValue {
                cell,
                field: Field::MaterialBending,
                index,
            });
        }
        if !is_spd(&m.c) {
            return Err(BlobError::MaterialNotSpd {
                cell,
                material: index,
            });
        }
    }

    // Counts.
    for (section, expected, found) in [
        (SectionKind::Nodes, n_nodes, c.nodes.len()),
        (SectionKind::Triangles, n_tris, c.triangles.len()),
        (SectionKind::TriMaterial, n_tris, c.tri_material.len()),
        (SectionKind::Chi, n_nodes, c.chi.len()),
    ] {
        if found as u64 != expected {
            return Err(BlobError::CountMismatch {
                cell,
                section,
                expected,
                found: found as u64,
            });
        }
    }

    // Nodes: finite and on the grid (i·h, j·h), h = size / nu.
    let h = c.size / nu as f64;
    let tol = NODE_TOLERANCE * h;
    for (n, p) in c.nodes.iter().enumerate() {
        let index = n as u32; // n < n_nodes ≤ u32::MAX
        if !p.iter().all(|v| v.is_finite()) {
            return Err(BlobError::NonFinite {
                cell,
                field: Field::Nodes,
                index,
            });
        }
        let (i, j) = (n % nu, n / nu);
        let du = f64::from(p[0]) - i as f64 * h;
        let dv = f64::from(p[1]) - j as f64 * h;
        // Without `f64::abs`: no_std code only has it since Rust 1.84 (rust-lang/rust#139066),
        // and Cargo.toml declares 1.80.
        let near = |d: f64| -tol <= d && d <= tol;
        if !(near(du) && near(dv)) {
            return Err(BlobError::NodeOffGrid { cell, node: index });
        }
    }

    // Triangles: in range, then exactly the pixel-mesh numbering (two CCW triangles per square,
    // indices wrapped periodically), so the runtime may locate points by arithmetic alone.
    for (t, tri) in c.triangles.iter().enumerate() {
        let triangle = t as u32; // t < n_tris ≤ u32::MAX
        if tri.iter().any(|&v| u64::from(v) >= n_nodes) {
            return Err(BlobError::IndexOutOfRange { cell, triangle });
        }
        if *tri != canonical_triangle(nu, nv, t) {
            return Err(BlobError::TopologyMismatch { cell, triangle });
        }
    }

    // Material per triangle: in range and constant over each pattern pixel (k×k squares).
    let k = c.refine as usize;
    for (t, &m) in c.tri_material.iter().enumerate() {
        let triangle = t as u32;
        if m as usize >= c.materials.len() {
            return Err(BlobError::MaterialIndexOutOfRange { cell, triangle });
        }
        let (i, j, _) = lattice::square_of_triangle(t, nu);
        let first = 2 * lattice::node(i / k * k, j / k * k, nu);
        if c.tri_material.get(first) != Some(&m) {
            return Err(BlobError::PixelMaterialMismatch { cell, triangle });
        }
    }

    // Chi.
    for (n, x) in c.chi.iter().enumerate() {
        if !x.iter().all(|v| v.is_finite()) {
            return Err(BlobError::NonFinite {
                cell,
                field: Field::Chi,
                index: n as u32,
            });
        }
    }
    Ok(())
}

/// Triangle `t` of the periodic `nu × nv` pixel mesh (docs/ARCHITECTURE.md): square
/// `(i, j) = (t/2 mod nu, t/2 div nu)`, `[ll, lr, ur]` then `[ll, ur, ul]`. Requires `nu, nv ≥ 1`
/// and the node count to fit in u32 (checked by the caller).
fn canonical_triangle(nu: usize, nv: usize, t: usize) -> [u32; 3] {
    let (i, j, upper) = lattice::square_of_triangle(t, nu);
    let (i1, j1) = ((i + 1) % nu, (j + 1) % nv);
    let id = |i: usize, j: usize| lattice::node(i, j, nu) as u32;
    let [lower_tri, upper_tri] =
        lattice::square_triangles(id(i, j), id(i1, j), id(i1, j1), id(i, j1));
    if upper {
        upper_tri
    } else {
        lower_tri
    }
}

// ---------------------------------------------------------------------------------------------
// Writer (std): `writer.rs`
// ---------------------------------------------------------------------------------------------

#[cfg(feature = "std")]
mod writer;
#[cfg(feature = "std")]
pub use writer::{load_aligned, write, AlignedBytes, CellRecord};
