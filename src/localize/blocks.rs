//! The bindings block and the frames block: [`Binding`]s and [`VertexFrame`]s in one
//! caller-owned byte block each, behind a small header that says what they were made for.
//!
//! These are the formats the C API hands out (`weft_bind`, `weft_localize_prepare`,
//! `weft_localize`); they live here, with the records they carry, so that the kernel owns
//! them and the C layer only turns pointers into slices.
//!
//! * **Bindings block** (`BINDINGS_ALIGN`-aligned): a [`BindingsHeader`] (16 bytes: a cookie,
//!   the fine vertex count and the [`cloth_key`] of the cloth they were bound to, as four
//!   native-endian `u32`), then one 36-byte [`Binding`] per fine vertex. Plain,
//!   position-independent data: it can be stored with a mesh asset and used with any world made
//!   from the same cloth. [`bind_block`] writes one, [`read_bindings`] checks and views one.
//! * **Frames block** (`FRAMES_ALIGN`-aligned): a [`FramesHeader`] (32 bytes: a cookie, the
//!   coarse vertex count, the cloth key, the [`world_key`] of the world they were prepared from
//!   and the block's own address), then one 80-byte [`VertexFrame`] per coarse vertex.
//!   Per frame and per world; a moved or copied block is refused. [`prepare_block`] fills one,
//!   [`FramesHeader::check`] says whether one may be used with a world.
//!
//! Sizes are [`block_bytes`]: a header plus `n` records, refused beyond `isize::MAX` bytes.

use core::fmt;
use core::mem::{align_of, size_of};

use bytemuck::{Pod, Zeroable};

use super::{bind, prepare, BindError, Binding, LocalizeError, StrainMeasure, VertexFrame};
use crate::blob::{self, Blob};
use crate::strided::Strided;
use crate::world::World;

/// Bytes of a bindings block's header.
pub const BINDINGS_HEADER_SIZE: usize = size_of::<BindingsHeader>();
/// Bytes per fine vertex in a bindings block.
pub const BINDING_SIZE: usize = size_of::<Binding>();
/// Required alignment of a bindings block.
pub const BINDINGS_ALIGN: usize = 4;
/// Bytes of a frames block's header.
pub const FRAMES_HEADER_SIZE: usize = size_of::<FramesHeader>();
/// Bytes per coarse vertex in a frames block.
pub const FRAME_SIZE: usize = size_of::<VertexFrame>();
/// Required alignment of a frames block.
pub const FRAMES_ALIGN: usize = 16;

const BINDINGS_COOKIE: u32 = 0x5742_4E31; // "WBN1"
const FRAMES_COOKIE: u32 = 0x5746_5231; // "WFR1"

const _: () = assert!(BINDINGS_HEADER_SIZE == 16 && BINDING_SIZE == 36);
const _: () = assert!(align_of::<Binding>() <= BINDINGS_ALIGN);
const _: () = assert!(align_of::<BindingsHeader>() <= BINDINGS_ALIGN);
const _: () = assert!(BINDINGS_HEADER_SIZE.is_multiple_of(align_of::<Binding>()));
const _: () = assert!(FRAMES_HEADER_SIZE == 32 && FRAME_SIZE == 80);
const _: () = assert!(align_of::<VertexFrame>() <= FRAMES_ALIGN);
const _: () = assert!(align_of::<FramesHeader>() <= FRAMES_ALIGN);
const _: () = assert!(FRAMES_HEADER_SIZE.is_multiple_of(FRAMES_ALIGN));
const _: () = assert!(FRAME_SIZE.is_multiple_of(FRAMES_ALIGN));

/// The start of a bindings block.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct BindingsHeader {
    /// Says a bindings block was written here.
    pub cookie: u32,
    /// Fine vertices (records) in the block.
    pub count: u32,
    /// The [`cloth_key`] of the cloth bound to, low and high halves.
    pub key_lo: u32,
    pub key_hi: u32,
}

/// The start of a frames block.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct FramesHeader {
    /// Says frames were prepared here.
    pub cookie: u32,
    /// Coarse vertices (records) in the block.
    pub vertex_count: u32,
    /// The [`cloth_key`] of the world's cloth.
    pub cloth_key: u64,
    /// The [`world_key`] of the world they were prepared from.
    pub world_key: u64,
    /// The address of this header when it was written: a moved or copied block is refused.
    pub home: u64,
}

/// Why a block was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockError {
    /// The block's first byte is not aligned for its records.
    Misaligned,
    /// The block has room for `room` records where `needed` are required.
    TooSmall { needed: usize, room: usize },
    /// `n` records would not fit in one block (more than `isize::MAX` bytes).
    TooLarge,
    /// Not a block of this kind (no header, or not written by [`bind_block`]).
    NotBindings,
    /// The block is shorter than its header or than the records its header announces.
    Truncated,
    /// The bindings were made for another cloth.
    OtherCloth,
    /// No frames were prepared in this block (or it was moved or copied since).
    NotPrepared,
    /// The frames were prepared for another world, or another cloth.
    OtherWorld,
    /// Binding failed; nothing was written.
    Bind(BindError),
    /// Preparing the frames failed; nothing was written.
    Localize(LocalizeError),
}

impl fmt::Display for BlockError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            BlockError::Misaligned => write!(f, "block not aligned for its records"),
            BlockError::TooSmall { needed, room } => {
                write!(f, "block holds {room} records, {needed} needed")
            }
            BlockError::TooLarge => write!(f, "too many records for one block"),
            BlockError::NotBindings => write!(f, "not a bindings block"),
            BlockError::Truncated => write!(f, "block shorter than its header says"),
            BlockError::OtherCloth => write!(f, "bindings made for another cloth"),
            BlockError::NotPrepared => write!(f, "no frames prepared in this block"),
            BlockError::OtherWorld => write!(f, "frames prepared for another world"),
            BlockError::Bind(e) => write!(f, "{e}"),
            BlockError::Localize(e) => write!(f, "{e}"),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for BlockError {}

/// Bytes of a block of `header` bytes and `n` records of `record` bytes, if it can be one
/// Rust slice (at most `isize::MAX` bytes).
pub fn block_bytes(header: usize, record: usize, n: usize) -> Option<usize> {
    let b = n.checked_mul(record)?.checked_add(header)?;
    (b <= isize::MAX as usize).then_some(b)
}

/// Bytes of a bindings block for `n` fine vertices.
pub fn bindings_bytes(n: usize) -> Option<usize> {
    block_bytes(BINDINGS_HEADER_SIZE, BINDING_SIZE, n)
}

/// Bytes of a frames block for `n` coarse vertices.
pub fn frames_bytes(n: usize) -> Option<usize> {
    block_bytes(FRAMES_HEADER_SIZE, FRAME_SIZE, n)
}

/// `Ok(bytes)` when a block of `size` bytes holds `n` records after its header.
fn room(header: usize, record: usize, n: usize, size: usize) -> Result<usize, BlockError> {
    let needed = block_bytes(header, record, n).ok_or(BlockError::TooLarge)?;
    if size < needed {
        let room = size.saturating_sub(header) / record;
        return Err(BlockError::TooSmall { needed: n, room });
    }
    Ok(needed)
}

/// Checks that a bindings block of `size` bytes holds `n` fine vertices.
pub fn bindings_room(n: usize, size: usize) -> Result<usize, BlockError> {
    room(BINDINGS_HEADER_SIZE, BINDING_SIZE, n, size)
}

/// Checks that a frames block of `size` bytes holds `n` coarse vertices.
pub fn frames_room(n: usize, size: usize) -> Result<usize, BlockError> {
    room(FRAMES_HEADER_SIZE, FRAME_SIZE, n, size)
}

/// FNV-1a, 64 bits: the cloth key (a check, not a security measure).
struct Fnv(u64);

impl Fnv {
    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
}

/// What bindings depend on: the coarse mesh, its rest (u, v), its materials and the blob (its
/// header holds the checksum of everything else in it). Stable across runs, so bindings stored
/// with a mesh asset still match the same cloth later. O(mesh): compute it once per world.
pub fn cloth_key(world: &World<'_>, blob: &Blob<'_>) -> u64 {
    let mut h = Fnv(0xcbf2_9ce4_8422_2325);
    h.u32(world.vertex_count() as u32);
    h.u32(world.triangle_count() as u32);
    for r in world.rest_positions() {
        h.u32(r.x.to_bits());
        h.u32(r.y.to_bits());
    }
    for t in world.triangles() {
        for &v in t {
            h.u32(v);
        }
    }
    for &m in world.triangle_materials() {
        h.u32(m);
    }
    h.bytes(blob.as_bytes().get(..blob::HEADER_SIZE).unwrap_or(&[]));
    h.0
}

/// Which world this is while it lives: the address of its arrays, which stay where they are
/// for the world's life (a world in the same memory again gets the same key, and the cloth key
/// tells its cloth apart).
pub fn world_key(world: &World<'_>) -> u64 {
    world.rest_positions().as_ptr() as usize as u64
}

/// Binds `fine_uv` to the world's cloth ([`bind()`]) into a bindings block: the header (with
/// `cloth_key`, from [`cloth_key`]) and one record per fine vertex. Everything is checked
/// before anything is written; bytes past the records are left alone.
pub fn bind_block(
    world: &World<'_>,
    blob: &Blob<'_>,
    cloth_key: u64,
    fine_uv: &Strided<'_, 2>,
    block: &mut [u8],
) -> Result<(), BlockError> {
    let n = fine_uv.count();
    let count = u32::try_from(n).map_err(|_| BlockError::TooLarge)?;
    let bytes = bindings_room(n, block.len())?;
    let (head, records) = block
        .get_mut(..bytes)
        .ok_or(BlockError::Truncated)?
        .split_at_mut(BINDINGS_HEADER_SIZE);
    let head: &mut BindingsHeader =
        bytemuck::try_from_bytes_mut(head).map_err(|_| BlockError::Misaligned)?;
    let records: &mut [Binding] =
        bytemuck::try_cast_slice_mut(records).map_err(|_| BlockError::Misaligned)?;
    bind(world, blob, fine_uv, records).map_err(BlockError::Bind)?;
    *head = BindingsHeader {
        cookie: BINDINGS_COOKIE,
        count,
        key_lo: cloth_key as u32,
        key_hi: (cloth_key >> 32) as u32,
    };
    Ok(())
}

/// A bindings block's cloth key and records, after checking its header against its size.
pub fn read_bindings(block: &[u8]) -> Result<(u64, &[Binding]), BlockError> {
    let head = block
        .get(..BINDINGS_HEADER_SIZE)
        .ok_or(BlockError::Truncated)?;
    let head: &BindingsHeader =
        bytemuck::try_from_bytes(head).map_err(|_| BlockError::Misaligned)?;
    if head.cookie != BINDINGS_COOKIE {
        return Err(BlockError::NotBindings);
    }
    let n = head.count as usize;
    let bytes = bindings_bytes(n).ok_or(BlockError::Truncated)?;
    let records = block
        .get(BINDINGS_HEADER_SIZE..bytes)
        .ok_or(BlockError::Truncated)?;
    let records: &[Binding] =
        bytemuck::try_cast_slice(records).map_err(|_| BlockError::Misaligned)?;
    let key = u64::from(head.key_lo) | (u64::from(head.key_hi) << 32);
    Ok((key, records))
}

impl FramesHeader {
    /// Whether the frames after this header (at its address) were prepared from `world`, whose
    /// cloth key is `cloth_key`, and may be read as `world.vertex_count()` records.
    pub fn check(&self, world: &World<'_>, cloth_key: u64) -> Result<(), BlockError> {
        if self.cookie != FRAMES_COOKIE || self.home != address(self) {
            return Err(BlockError::NotPrepared);
        }
        let same = self.world_key == world_key(world)
            && self.vertex_count as usize == world.vertex_count()
            && self.cloth_key == cloth_key;
        if !same {
            return Err(BlockError::OtherWorld);
        }
        Ok(())
    }
}

fn address(h: &FramesHeader) -> u64 {
    core::ptr::from_ref(h) as usize as u64
}

/// Prepares the world's frames ([`prepare`]) into a frames block, given as its header (at the
/// block's start) and its records (`world.vertex_count()` of them, right after the header).
/// The header is written last, only on success.
pub fn prepare_block(
    world: &World<'_>,
    cloth_key: u64,
    measure: StrainMeasure,
    header: &mut FramesHeader,
    frames: &mut [VertexFrame],
) -> Result<(), BlockError> {
    let n = world.vertex_count();
    let vertex_count = u32::try_from(n).map_err(|_| BlockError::TooLarge)?;
    if frames.len() != n {
        return Err(BlockError::TooSmall {
            needed: n,
            room: frames.len(),
        });
    }
    prepare(world, measure, frames).map_err(BlockError::Localize)?;
    let home = address(header);
    *header = FramesHeader {
        cookie: FRAMES_COOKIE,
        vertex_count,
        cloth_key,
        world_key: world_key(world),
        home,
    };
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(bindings_bytes(0), Some(16));
        assert_eq!(bindings_bytes(3), Some(16 + 3 * 36));
        assert_eq!(frames_bytes(2), Some(32 + 160));
        assert_eq!(block_bytes(16, 36, usize::MAX), None);
        assert_eq!(
            bindings_room(2, 16 + 36),
            Err(BlockError::TooSmall { needed: 2, room: 1 })
        );
        assert_eq!(
            bindings_room(2, 3),
            Err(BlockError::TooSmall { needed: 2, room: 0 })
        );
        assert_eq!(bindings_room(2, 200), Ok(88));
    }

    #[test]
    fn bindings_header_checks() {
        let mut words = [0u32; 4 + 9 * 2];
        words[0] = BINDINGS_COOKIE;
        words[1] = 2;
        words[2] = 7;
        words[3] = 1;
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        let (key, records) = read_bindings(bytes).unwrap();
        assert_eq!((key, records.len()), ((1 << 32) | 7, 2));
        assert_eq!(read_bindings(&bytes[..16 + 36]), Err(BlockError::Truncated));
        assert_eq!(read_bindings(&bytes[..8]), Err(BlockError::Truncated));
        words[0] = 0;
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        assert_eq!(read_bindings(bytes), Err(BlockError::NotBindings));
    }
}
