//! Why a blob (or a cell record) is refused: one variant per corruption class, with the
//! cell, section or field at fault.

use core::fmt;

use super::{SectionKind, BASE_ALIGN, SECTION_ALIGN, VERSION};

/// Which value a [`BlobError::NonFinite`] or [`BlobError::BadValue`] is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Field {
    Size,
    Density,
    Bending,
    Stiffness,
    VoigtBound,
    ReussBound,
    MaterialStiffness,
    MaterialDensity,
    MaterialBending,
    Nodes,
    Chi,
}

impl Field {
    fn name(self) -> &'static str {
        match self {
            Field::Size => "size",
            Field::Density => "density",
            Field::Bending => "bending",
            Field::Stiffness => "stiffness",
            Field::VoigtBound => "voigt_bound",
            Field::ReussBound => "reuss_bound",
            Field::MaterialStiffness => "material stiffness",
            Field::MaterialDensity => "material density",
            Field::MaterialBending => "material bending",
            Field::Nodes => "node position",
            Field::Chi => "chi",
        }
    }
}

/// Why a blob (or, for the writer, a [`super::CellRecord`]) was rejected. Each corruption class has its
/// own variant so that a caller (and the tests) can tell them apart; `cell` is the cell index,
/// `section` the section-table entry index.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlobError {
    /// Shorter than the header, or than the total size the header announces (or than a part the
    /// section table places in it): `expected` bytes at least, `found` given.
    TooShort { expected: u64, found: u64 },
    /// The first 8 bytes are not [`super::MAGIC`].
    BadMagic,
    /// A version this reader does not know.
    UnsupportedVersion { found: u32 },
    /// Header size field is not [`super::HEADER_SIZE`], or a reserved header byte is not zero.
    BadHeader,
    /// More bytes than the header's total size (`expected`).
    TrailingBytes { expected: u64, found: u64 },
    /// The base address is not a multiple of [`BASE_ALIGN`].
    Misaligned,
    /// CRC-32 of everything after the header differs from the stored one.
    ChecksumMismatch { stored: u32, computed: u32 },
    /// Section count is not 6 per cell, or the table is not right after the header / does not fit.
    BadSectionTable,
    /// Entry `section` is not the (cell, kind) the canonical order puts there.
    UnexpectedSection { section: u32, kind: u32, cell: u32 },
    /// Entry `section` points (partly) outside the blob.
    SectionOutOfRange { section: u32 },
    /// Entry `section` does not start on a multiple of [`SECTION_ALIGN`].
    SectionMisaligned { section: u32 },
    /// Entry `section` starts before the end of the previous section (or of the table).
    SectionOverlap { section: u32 },
    /// Entry `section` leaves a gap after the previous section, or the blob has unused bytes at
    /// its end (`section` = section count); v1 blobs are packed tightly.
    SectionGap { section: u32 },
    /// Entry `section`'s byte length is not its element count times its element size.
    SectionSizeMismatch { section: u32 },
    /// A padding byte (at this absolute offset) is not zero.
    NonZeroPadding { offset: u64 },
    /// Name empty, longer than [`super::MAX_NAME_LEN`], not UTF-8, containing NUL, or not NUL-padded.
    BadName { cell: u32 },
    /// Two cells share a name (cells are looked up by name).
    DuplicateName { cell: u32 },
    /// `cols`, `rows` or `refine` is zero, or the mesh would not be indexable with `u32`.
    BadDimensions { cell: u32 },
    /// A section of the cell holds `found` elements where its dimensions require `expected`.
    CountMismatch {
        cell: u32,
        section: SectionKind,
        expected: u64,
        found: u64,
    },
    /// A NaN or infinity (`index`: element index within the field, else 0).
    NonFinite { cell: u32, field: Field, index: u32 },
    /// A finite value out of its range: size ≤ 0, density ≤ 0 or bending < 0.
    BadValue { cell: u32, field: Field, index: u32 },
    /// The homogenized stiffness `C^H` is not symmetric positive definite.
    NotSpd { cell: u32 },
    /// The Voigt or Reuss bound is not symmetric positive definite.
    BoundNotSpd { cell: u32 },
    /// Material `material`'s stiffness is not symmetric positive definite.
    MaterialNotSpd { cell: u32, material: u32 },
    /// Node `node` is not at its grid position `(i·h, j·h)` (docs/ARCHITECTURE.md).
    NodeOffGrid { cell: u32, node: u32 },
    /// Triangle `triangle` refers to a node index ≥ the node count.
    IndexOutOfRange { cell: u32, triangle: u32 },
    /// Triangle `triangle` is not the one the pixel-mesh numbering puts there.
    TopologyMismatch { cell: u32, triangle: u32 },
    /// Triangle `triangle`'s material index is ≥ the material count.
    MaterialIndexOutOfRange { cell: u32, triangle: u32 },
    /// Triangle `triangle`'s material differs from the rest of its pattern pixel.
    PixelMaterialMismatch { cell: u32, triangle: u32 },
    /// (writer) more cells or bytes than the format's integer fields can describe.
    TooLarge,
}

impl fmt::Display for BlobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use BlobError::*;
        match *self {
            TooShort { expected, found } => write!(
                f,
                "blob is truncated: {found} bytes, expected at least {expected}"
            ),
            BadMagic => write!(f, "not a weft cell blob (bad magic)"),
            UnsupportedVersion { found } => {
                write!(
                    f,
                    "unsupported blob version {found} (this reader knows {VERSION})"
                )
            }
            BadHeader => write!(f, "bad header (size field or reserved bytes)"),
            TrailingBytes { expected, found } => {
                write!(f, "blob has {found} bytes but its header says {expected}")
            }
            Misaligned => write!(f, "blob base address is not {BASE_ALIGN}-byte aligned"),
            ChecksumMismatch { stored, computed } => write!(
                f,
                "checksum mismatch (stored {stored:#010x}, computed {computed:#010x})"
            ),
            BadSectionTable => write!(f, "bad section table (count or position)"),
            UnexpectedSection {
                section,
                kind,
                cell,
            } => write!(
                f,
                "section {section} (kind {kind}, cell {cell}) is out of the canonical order"
            ),
            SectionOutOfRange { section } => write!(f, "section {section} lies outside the blob"),
            SectionMisaligned { section } => {
                write!(f, "section {section} is not {SECTION_ALIGN}-byte aligned")
            }
            SectionOverlap { section } => write!(f, "section {section} overlaps the previous one"),
            SectionGap { section } => write!(f, "unused bytes before section {section}"),
            SectionSizeMismatch { section } => {
                write!(
                    f,
                    "section {section} length does not match its element count"
                )
            }
            NonZeroPadding { offset } => write!(f, "non-zero padding byte at offset {offset}"),
            BadName { cell } => write!(f, "cell {cell}: invalid name"),
            DuplicateName { cell } => {
                write!(f, "cell {cell}: name already used by an earlier cell")
            }
            BadDimensions { cell } => write!(f, "cell {cell}: invalid cols/rows/refine"),
            CountMismatch {
                cell,
                section,
                expected,
                found,
            } => write!(
                f,
                "cell {cell}: {} holds {found} elements, expected {expected}",
                section.name()
            ),
            NonFinite { cell, field, index } => {
                write!(
                    f,
                    "cell {cell}: non-finite {} (element {index})",
                    field.name()
                )
            }
            BadValue { cell, field, index } => {
                write!(
                    f,
                    "cell {cell}: {} out of range (element {index})",
                    field.name()
                )
            }
            NotSpd { cell } => write!(f, "cell {cell}: C^H is not symmetric positive definite"),
            BoundNotSpd { cell } => {
                write!(
                    f,
                    "cell {cell}: a Voigt/Reuss bound is not symmetric positive definite"
                )
            }
            MaterialNotSpd { cell, material } => write!(
                f,
                "cell {cell}: material {material} stiffness is not symmetric positive definite"
            ),
            NodeOffGrid { cell, node } => write!(f, "cell {cell}: node {node} is off the grid"),
            IndexOutOfRange { cell, triangle } => {
                write!(
                    f,
                    "cell {cell}: triangle {triangle} has a node index out of range"
                )
            }
            TopologyMismatch { cell, triangle } => write!(
                f,
                "cell {cell}: triangle {triangle} does not follow the pixel-mesh numbering"
            ),
            MaterialIndexOutOfRange { cell, triangle } => {
                write!(
                    f,
                    "cell {cell}: triangle {triangle} has a material index out of range"
                )
            }
            PixelMaterialMismatch { cell, triangle } => write!(
                f,
                "cell {cell}: triangle {triangle} differs in material from its pixel"
            ),
            TooLarge => write!(f, "too many cells or bytes for the blob format"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for BlobError {}
