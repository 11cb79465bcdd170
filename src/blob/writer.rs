//! The cell blob's writer (`std`): [`CellRecord`] (the owned cell, and [`Cell::to_record`] back
//! from a view), [`write()`] (the reader's per-cell validation, then the version-1 layout of
//! `docs/BLOB.md`), [`AlignedBytes`] and [`load_aligned`] (bytes aligned for the in-place reader).

// The writer indexes buffers whose lengths it computed itself from validated records; a panic
// there would be a bug in this file, not a reaction to input bytes.
#![allow(clippy::indexing_slicing)]

use super::*;
use std::vec::Vec;

/// An owned cell, the writer's input and [`Cell::to_record`]'s output. Fields mean the same
/// as in [`Cell`].
#[derive(Debug, Clone, PartialEq)]
pub struct CellRecord {
    pub name: String,
    pub size: f64,
    pub cols: u32,
    pub rows: u32,
    pub refine: u32,
    pub stiffness: [[f64; 3]; 3],
    pub density: f64,
    pub bending: f64,
    pub voigt_bound: [[f64; 3]; 3],
    pub reuss_bound: [[f64; 3]; 3],
    pub materials: Vec<MaterialRecord>,
    pub nodes: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
    pub tri_material: Vec<u32>,
    pub chi: Vec<[f32; 6]>,
}

impl CellRecord {
    /// A borrowed view, e.g. to validate or to hand to code written against [`Cell`].
    pub fn as_cell(&self) -> Cell<'_> {
        Cell {
            name: &self.name,
            size: self.size,
            cols: self.cols,
            rows: self.rows,
            refine: self.refine,
            stiffness: self.stiffness,
            density: self.density,
            bending: self.bending,
            voigt_bound: self.voigt_bound,
            reuss_bound: self.reuss_bound,
            materials: &self.materials,
            nodes: &self.nodes,
            triangles: &self.triangles,
            tri_material: &self.tri_material,
            chi: &self.chi,
        }
    }
}

impl Cell<'_> {
    /// An owned copy (bit-exact: `write(&[c.to_record()])` reproduces the cell's bytes).
    pub fn to_record(&self) -> CellRecord {
        CellRecord {
            name: self.name.into(),
            size: self.size,
            cols: self.cols,
            rows: self.rows,
            refine: self.refine,
            stiffness: self.stiffness,
            density: self.density,
            bending: self.bending,
            voigt_bound: self.voigt_bound,
            reuss_bound: self.reuss_bound,
            materials: self.materials.to_vec(),
            nodes: self.nodes.to_vec(),
            triangles: self.triangles.to_vec(),
            tri_material: self.tri_material.to_vec(),
            chi: self.chi.to_vec(),
        }
    }
}

fn pad_to_align(out: &mut Vec<u8>) {
    while !out.len().is_multiple_of(SECTION_ALIGN) {
        out.push(0);
    }
}

/// Validates every cell with the reader's rules and lays them out as a version-1 blob
/// (docs/BLOB.md). The result parses with [`Blob::parse`] once placed at an aligned address
/// (e.g. through [`AlignedBytes::copy_from`]).
pub fn write(cells: &[CellRecord]) -> Result<Vec<u8>, BlobError> {
    let cell_count = u32::try_from(cells.len()).map_err(|_| BlobError::TooLarge)?;
    let section_count = cells
        .len()
        .checked_mul(SECTIONS_PER_CELL)
        .and_then(|n| u32::try_from(n).ok())
        .ok_or(BlobError::TooLarge)?;
    for (ci, rec) in cells.iter().enumerate() {
        let index = ci as u32; // < cell_count
        validate_cell(index, &rec.as_cell())?;
        if cells.iter().take(ci).any(|other| other.name == rec.name) {
            return Err(BlobError::DuplicateName { cell: index });
        }
    }

    let table_end = HEADER_SIZE + SECTION_ENTRY_SIZE * section_count as usize;
    let mut out = vec![0u8; table_end];
    let mut table = Vec::with_capacity(section_count as usize * SECTION_ENTRY_SIZE);
    for (ci, rec) in cells.iter().enumerate() {
        let mut name = [0u8; 64];
        name[..rec.name.len()].copy_from_slice(rec.name.as_bytes());
        let info = CellInfo {
            name_len: rec.name.len() as u32,
            cols: rec.cols,
            rows: rec.rows,
            refine: rec.refine,
            name,
            size: rec.size,
            density: rec.density,
            bending: rec.bending,
            stiffness: rec.stiffness,
            voigt_bound: rec.voigt_bound,
            reuss_bound: rec.reuss_bound,
        };
        let sections: [(&[u8], usize); SECTIONS_PER_CELL] = [
            (bytemuck::bytes_of(&info), 1),
            (bytemuck::cast_slice(&rec.materials), rec.materials.len()),
            (bytemuck::cast_slice(&rec.nodes), rec.nodes.len()),
            (bytemuck::cast_slice(&rec.triangles), rec.triangles.len()),
            (
                bytemuck::cast_slice(&rec.tri_material),
                rec.tri_material.len(),
            ),
            (bytemuck::cast_slice(&rec.chi), rec.chi.len()),
        ];
        for (kind, (data, count)) in SectionKind::ALL.iter().zip(sections) {
            pad_to_align(&mut out);
            table.extend_from_slice(&(*kind as u32).to_le_bytes());
            table.extend_from_slice(&(ci as u32).to_le_bytes());
            table.extend_from_slice(&(out.len() as u64).to_le_bytes());
            table.extend_from_slice(&(data.len() as u64).to_le_bytes());
            table.extend_from_slice(&(count as u64).to_le_bytes());
            out.extend_from_slice(data);
        }
    }
    pad_to_align(&mut out);
    out[HEADER_SIZE..table_end].copy_from_slice(&table);

    out[..8].copy_from_slice(&MAGIC);
    out[H_VERSION..H_VERSION + 4].copy_from_slice(&VERSION.to_le_bytes());
    out[H_HEADER_SIZE..H_HEADER_SIZE + 4].copy_from_slice(&(HEADER_SIZE as u32).to_le_bytes());
    let total = out.len() as u64;
    out[H_TOTAL_SIZE..H_TOTAL_SIZE + 8].copy_from_slice(&total.to_le_bytes());
    out[H_CELL_COUNT..H_CELL_COUNT + 4].copy_from_slice(&cell_count.to_le_bytes());
    out[H_SECTION_COUNT..H_SECTION_COUNT + 4].copy_from_slice(&section_count.to_le_bytes());
    out[H_TABLE_OFFSET..H_TABLE_OFFSET + 8].copy_from_slice(&(HEADER_SIZE as u64).to_le_bytes());
    let crc = crc32(&out[HEADER_SIZE..]);
    out[H_CHECKSUM..H_CHECKSUM + 4].copy_from_slice(&crc.to_le_bytes());
    Ok(out)
}

/// 16 bytes with 16-byte alignment: the storage unit of [`AlignedBytes`].
#[derive(Clone, Copy, Pod, Zeroable)]
#[repr(C, align(16))]
struct Chunk([u8; 16]);

/// A byte buffer whose start is 16-byte aligned (≥ [`BASE_ALIGN`]), for [`Blob::parse`].
/// Derefs to exactly the bytes it was made from.
#[derive(Clone)]
pub struct AlignedBytes {
    chunks: Vec<Chunk>,
    len: usize,
}

impl AlignedBytes {
    /// `len` zero bytes.
    pub fn zeroed(len: usize) -> Self {
        AlignedBytes {
            chunks: vec![Chunk([0; 16]); len.div_ceil(16)],
            len,
        }
    }

    /// An aligned copy of `bytes`.
    pub fn copy_from(bytes: &[u8]) -> Self {
        let mut a = Self::zeroed(bytes.len());
        a.copy_from_slice(bytes);
        a
    }
}

impl core::ops::Deref for AlignedBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        let all: &[u8] = bytemuck::cast_slice(&self.chunks);
        all.get(..self.len).unwrap_or_default()
    }
}

impl core::ops::DerefMut for AlignedBytes {
    fn deref_mut(&mut self) -> &mut [u8] {
        let all: &mut [u8] = bytemuck::cast_slice_mut(&mut self.chunks);
        all.get_mut(..self.len).unwrap_or_default()
    }
}

impl core::fmt::Debug for AlignedBytes {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "AlignedBytes({} bytes)", self.len)
    }
}

/// Reads the file at `path` into a 16-byte-aligned buffer (no second copy).
pub fn load_aligned(path: impl AsRef<std::path::Path>) -> std::io::Result<AlignedBytes> {
    use std::io::Read;
    let mut file = std::fs::File::open(path)?;
    let len = usize::try_from(file.metadata()?.len())
        .map_err(|_| std::io::Error::other("file too large for memory"))?;
    let mut buf = AlignedBytes::zeroed(len);
    file.read_exact(&mut buf)?;
    // A file that grew while we read it would otherwise be silently cut.
    let mut probe = [0u8; 1];
    if file.read(&mut probe)? != 0 {
        return Err(std::io::Error::other("file changed size while being read"));
    }
    Ok(buf)
}
