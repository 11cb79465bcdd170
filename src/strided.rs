//! Strided vertex buffers: views of `[f32; N]` attributes inside caller-owned bytes.
//!
//! An engine's vertex buffer is usually interleaved (position, normal, uv, … per vertex record
//! of `stride` bytes). [`Strided`] reads and [`StridedMut`] writes one `[f32; N]` attribute at
//! byte `offset + i·stride`, little-endian, with no alignment requirement, in the style of
//! meshoptimizer's strided inputs. The constructors validate the layout once (a non-zero
//! stride that holds the attribute, a buffer long enough for `count` records) and return a
//! [`StrideError`] otherwise; after that, element access cannot go out of bounds, and every
//! accessor is checked anyway (`Option`), so nothing here can panic.
//!
//! A plain `&[[f32; N]]` / `&mut [[f32; N]]` is a strided buffer too:
//! [`Strided::from_slice`], [`StridedMut::from_slice`].

use core::fmt;

/// Why a strided view could not be made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StrideError {
    /// The stride is zero or cannot hold the attribute at its offset
    /// (`offset + element > stride`).
    BadStride {
        stride: usize,
        offset: usize,
        element: usize,
    },
    /// The buffer is shorter than `count` records need: `(count-1)·stride + offset + element`
    /// bytes (`needed` saturates at `usize::MAX` when that overflows).
    BufferTooSmall { needed: usize, len: usize },
}

impl fmt::Display for StrideError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            StrideError::BadStride {
                stride,
                offset,
                element,
            } => write!(
                f,
                "stride {stride} cannot hold a {element}-byte attribute at offset {offset}"
            ),
            StrideError::BufferTooSmall { needed, len } => {
                write!(f, "buffer has {len} bytes, the records need {needed}")
            }
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for StrideError {}

/// Bytes needed by `count` records of `stride` bytes with an `element`-byte attribute at
/// `offset`, after checking the stride.
pub fn bytes_needed(
    stride: usize,
    offset: usize,
    element: usize,
    count: usize,
) -> Result<usize, StrideError> {
    let bad = StrideError::BadStride {
        stride,
        offset,
        element,
    };
    match offset.checked_add(element) {
        Some(end) if stride > 0 && end <= stride => {}
        _ => return Err(bad),
    }
    if count == 0 {
        return Ok(0);
    }
    Ok((count - 1)
        .checked_mul(stride)
        .and_then(|b| b.checked_add(offset + element))
        .unwrap_or(usize::MAX))
}

fn check(
    len: usize,
    stride: usize,
    offset: usize,
    element: usize,
    count: usize,
) -> Result<(), StrideError> {
    let needed = bytes_needed(stride, offset, element, count)?;
    if len < needed {
        return Err(StrideError::BufferTooSmall { needed, len });
    }
    Ok(())
}

/// Reads `[f32; N]` little-endian from `bytes[at..at + 4N]`.
#[inline(always)]
pub(crate) fn read<const N: usize>(bytes: &[u8], at: usize) -> Option<[f32; N]> {
    let src = bytes.get(at..at.checked_add(4 * N)?)?;
    let mut out = [0.0f32; N];
    for (o, c) in out.iter_mut().zip(src.chunks_exact(4)) {
        *o = f32::from_le_bytes(c.try_into().ok()?);
    }
    Some(out)
}

/// Writes `[f32; N]` little-endian into `bytes[at..at + 4N]`; false if it does not fit.
#[inline(always)]
pub(crate) fn write<const N: usize>(bytes: &mut [u8], at: usize, v: [f32; N]) -> bool {
    let Some(end) = at.checked_add(4 * N) else {
        return false;
    };
    let Some(dst) = bytes.get_mut(at..end) else {
        return false;
    };
    for (d, x) in dst.chunks_exact_mut(4).zip(v) {
        d.copy_from_slice(&x.to_le_bytes());
    }
    true
}

/// A read-only strided `[f32; N]` attribute: element `i` is at byte `offset + i·stride`.
#[derive(Clone, Copy, Debug)]
pub struct Strided<'a, const N: usize> {
    bytes: &'a [u8],
    stride: usize,
    offset: usize,
    count: usize,
}

impl<'a, const N: usize> Strided<'a, N> {
    /// Size of one element in bytes.
    pub const ELEMENT: usize = 4 * N;

    /// `count` elements at the start of records of `stride` bytes.
    pub fn new(bytes: &'a [u8], stride: usize, count: usize) -> Result<Self, StrideError> {
        Self::with_offset(bytes, stride, 0, count)
    }

    /// `count` elements at byte `offset` of records of `stride` bytes
    /// (`offset + 4N ≤ stride`).
    pub fn with_offset(
        bytes: &'a [u8],
        stride: usize,
        offset: usize,
        count: usize,
    ) -> Result<Self, StrideError> {
        check(bytes.len(), stride, offset, Self::ELEMENT, count)?;
        Ok(Strided {
            bytes,
            stride,
            offset,
            count,
        })
    }

    /// A tightly packed array.
    pub fn from_slice(elements: &'a [[f32; N]]) -> Self {
        Strided {
            bytes: bytemuck::cast_slice(elements),
            stride: Self::ELEMENT.max(1),
            offset: 0,
            count: if N == 0 { 0 } else { elements.len() },
        }
    }

    pub fn count(&self) -> usize {
        self.count
    }
    pub fn stride(&self) -> usize {
        self.stride
    }
    pub fn offset(&self) -> usize {
        self.offset
    }
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Element `i`, or `None` past the end.
    #[inline]
    pub fn get(&self, i: usize) -> Option<[f32; N]> {
        if i >= self.count {
            return None;
        }
        read::<N>(self.bytes, self.offset + i * self.stride)
    }
}

/// A writable strided `[f32; N]` attribute: element `i` is at byte `offset + i·stride`.
///
/// Other attributes of the same records can be reached through the record accessors
/// ([`StridedMut::read_at`], [`StridedMut::write_at`]), which is how the localizer writes a
/// normal next to each position without a second (aliasing) borrow of the same bytes.
#[derive(Debug)]
pub struct StridedMut<'a, const N: usize> {
    bytes: &'a mut [u8],
    stride: usize,
    offset: usize,
    count: usize,
}

impl<'a, const N: usize> StridedMut<'a, N> {
    /// Size of one element in bytes.
    pub const ELEMENT: usize = 4 * N;

    /// `count` elements at the start of records of `stride` bytes.
    pub fn new(bytes: &'a mut [u8], stride: usize, count: usize) -> Result<Self, StrideError> {
        Self::with_offset(bytes, stride, 0, count)
    }

    /// `count` elements at byte `offset` of records of `stride` bytes
    /// (`offset + 4N ≤ stride`).
    pub fn with_offset(
        bytes: &'a mut [u8],
        stride: usize,
        offset: usize,
        count: usize,
    ) -> Result<Self, StrideError> {
        check(bytes.len(), stride, offset, Self::ELEMENT, count)?;
        Ok(StridedMut {
            bytes,
            stride,
            offset,
            count,
        })
    }

    /// A tightly packed array.
    pub fn from_slice(elements: &'a mut [[f32; N]]) -> Self {
        let count = if N == 0 { 0 } else { elements.len() };
        StridedMut {
            bytes: bytemuck::cast_slice_mut(elements),
            stride: Self::ELEMENT.max(1),
            offset: 0,
            count,
        }
    }

    pub fn count(&self) -> usize {
        self.count
    }
    pub fn stride(&self) -> usize {
        self.stride
    }
    pub fn offset(&self) -> usize {
        self.offset
    }
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// A read-only view of the same attribute.
    pub fn as_strided(&self) -> Strided<'_, N> {
        Strided {
            bytes: self.bytes,
            stride: self.stride,
            offset: self.offset,
            count: self.count,
        }
    }

    /// Element `i`, or `None` past the end.
    #[inline]
    pub fn get(&self, i: usize) -> Option<[f32; N]> {
        if i >= self.count {
            return None;
        }
        read::<N>(self.bytes, self.offset + i * self.stride)
    }

    /// Writes element `i`; false (and nothing written) past the end.
    #[inline]
    pub fn set(&mut self, i: usize, v: [f32; N]) -> bool {
        if i >= self.count {
            return false;
        }
        write::<N>(self.bytes, self.offset + i * self.stride, v)
    }

    /// Splits into records `[0, mid)` and `[mid, count)` (`mid` is clamped to `count`), e.g. to
    /// hand disjoint ranges of one vertex buffer to different jobs.
    pub fn split_at(self, mid: usize) -> (StridedMut<'a, N>, StridedMut<'a, N>) {
        let mid = mid.min(self.count);
        // mid·stride ≤ (count-1)·stride + stride; clamp to the buffer for the last record,
        // which may be shorter than a full stride.
        let at = (mid * self.stride).min(self.bytes.len());
        let (head, tail) = self.bytes.split_at_mut(at);
        (
            StridedMut {
                bytes: head,
                stride: self.stride,
                offset: self.offset,
                count: mid,
            },
            StridedMut {
                bytes: tail,
                stride: self.stride,
                offset: self.offset,
                count: self.count - mid,
            },
        )
    }

    /// The raw parts `(bytes, stride, offset, count)`, for the crate's inner loops that walk
    /// the records themselves (the layout was validated by the constructor).
    #[inline(always)]
    pub(crate) fn parts_mut(&mut self) -> (&mut [u8], usize, usize, usize) {
        (self.bytes, self.stride, self.offset, self.count)
    }

    /// Reads `[f32; M]` at byte `at` of record `i` (any attribute of the record, not only
    /// this one); `None` past the end or when it does not fit in the record.
    pub fn read_at<const M: usize>(&self, i: usize, at: usize) -> Option<[f32; M]> {
        if i >= self.count || at.checked_add(4 * M)? > self.stride {
            return None;
        }
        read::<M>(self.bytes, i * self.stride + at)
    }

    /// Writes `[f32; M]` at byte `at` of record `i`; false (nothing written) past the end or
    /// when it does not fit in the record.
    pub fn write_at<const M: usize>(&mut self, i: usize, at: usize, v: [f32; M]) -> bool {
        match at.checked_add(4 * M) {
            Some(end) if i < self.count && end <= self.stride => {
                write::<M>(self.bytes, i * self.stride + at, v)
            }
            _ => false,
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;

    #[test]
    fn layout_validation() {
        let bytes = [0u8; 64];
        // stride too small, zero, attribute past the record
        assert!(matches!(
            Strided::<3>::new(&bytes, 8, 2),
            Err(StrideError::BadStride { .. })
        ));
        assert!(matches!(
            Strided::<3>::new(&bytes, 0, 0),
            Err(StrideError::BadStride { .. })
        ));
        assert!(matches!(
            Strided::<2>::with_offset(&bytes, 16, 12, 1),
            Err(StrideError::BadStride { .. })
        ));
        // exactly long enough: (count-1)·stride + offset + element
        assert!(Strided::<3>::with_offset(&bytes, 20, 4, 3).is_ok()); // 40 + 4 + 12 = 56
        assert!(Strided::<3>::with_offset(&bytes[..56], 20, 4, 3).is_ok());
        assert_eq!(
            Strided::<3>::with_offset(&bytes[..55], 20, 4, 3).err(),
            Some(StrideError::BufferTooSmall {
                needed: 56,
                len: 55
            })
        );
        // overflow saturates instead of wrapping
        assert_eq!(
            Strided::<3>::new(&bytes, 16, usize::MAX).err(),
            Some(StrideError::BufferTooSmall {
                needed: usize::MAX,
                len: 64
            })
        );
        // an empty view of an empty buffer is fine
        assert_eq!(Strided::<3>::new(&[], 12, 0).map(|s| s.count()), Ok(0));
    }

    #[test]
    fn read_write_interleaved_unaligned() {
        // 3 records of 21 bytes (deliberately odd): uv at 1, position at 9
        let mut bytes = [0xAAu8; 63];
        {
            let mut p = StridedMut::<3>::with_offset(&mut bytes, 21, 9, 3).unwrap();
            for i in 0..3 {
                assert!(p.set(i, [i as f32, 0.5, -1.0]));
                assert!(p.write_at::<2>(i, 1, [10.0 + i as f32, 20.0]));
            }
            assert!(!p.set(3, [0.0; 3]));
            assert!(!p.write_at::<2>(0, 20, [0.0; 2]));
            assert_eq!(p.read_at::<2>(2, 1), Some([12.0, 20.0]));
        }
        let uv = Strided::<2>::with_offset(&bytes, 21, 1, 3).unwrap();
        let p = Strided::<3>::with_offset(&bytes, 21, 9, 3).unwrap();
        assert_eq!(uv.get(1), Some([11.0, 20.0]));
        assert_eq!(p.get(2), Some([2.0, 0.5, -1.0]));
        assert_eq!(p.get(3), None);
        // untouched bytes stay untouched
        assert_eq!(bytes[0], 0xAA);
        assert_eq!(bytes[21], 0xAA);
        // little-endian on the wire
        assert_eq!(&bytes[9 + 21..9 + 21 + 4], &1.0f32.to_le_bytes());
    }

    #[test]
    fn slices_and_split() {
        let mut v = vec![[0.0f32; 3]; 5];
        let s = StridedMut::from_slice(&mut v);
        let (mut a, mut b) = s.split_at(2);
        assert_eq!((a.count(), b.count()), (2, 3));
        assert!(a.set(1, [1.0, 2.0, 3.0]));
        assert!(!a.set(2, [9.0; 3]));
        assert!(b.set(0, [4.0, 5.0, 6.0]));
        assert_eq!(v[1], [1.0, 2.0, 3.0]);
        assert_eq!(v[2], [4.0, 5.0, 6.0]);
        let r = Strided::from_slice(&v);
        assert_eq!((r.count(), r.stride()), (5, 12));
        assert_eq!(r.get(2), Some([4.0, 5.0, 6.0]));
        // split of a buffer whose last record is shorter than the stride
        let mut bytes = [0u8; 2 * 32 + 12];
        let s = StridedMut::<3>::new(&mut bytes, 32, 3).unwrap();
        let (a, mut b) = s.split_at(10);
        assert_eq!((a.count(), b.count()), (3, 0));
        assert!(!b.set(0, [0.0; 3]));
    }
}
