//! Cell blob: round trips, the byte layout of docs/BLOB.md, and one rejection test per corruption
//! class. Offsets below are taken from docs/BLOB.md on purpose, so the spec is tested too.

mod cells;

use cells::{laminate, small_cell, two_materials, Axis};
use weft::blob::{
    crc32, load_aligned, write, AlignedBytes, Blob, BlobError, CellRecord, Field, SectionKind,
    HEADER_SIZE, VERSION,
};

// ---- helpers written against docs/BLOB.md -------------------------------------------------------

const HEADER: usize = 64;
const ENTRY: usize = 32;
// CellInfo field offsets
const I_NAME_LEN: usize = 0;
const I_COLS: usize = 4;
const I_REFINE: usize = 12;
const I_NAME: usize = 16;
const I_SIZE: usize = 80;
const I_DENSITY: usize = 88;
const I_BENDING: usize = 96;
const I_STIFFNESS: usize = 104;
const I_VOIGT: usize = 176;
const I_REUSS: usize = 248;

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}
fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}
fn put_u32(b: &mut [u8], at: usize, v: u32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}
fn put_u64(b: &mut [u8], at: usize, v: u64) {
    b[at..at + 8].copy_from_slice(&v.to_le_bytes());
}
fn put_f64(b: &mut [u8], at: usize, v: f64) {
    b[at..at + 8].copy_from_slice(&v.to_le_bytes());
}
fn put_f32(b: &mut [u8], at: usize, v: f32) {
    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

/// Byte offset of table entry `i`.
fn entry(i: usize) -> usize {
    HEADER + ENTRY * i
}

/// Absolute offset of section `kind` of cell `cell`.
fn sec(b: &[u8], cell: usize, kind: SectionKind) -> usize {
    let e = entry(cell * 6 + kind as usize - 1);
    assert_eq!(u32_at(b, e), kind as u32);
    u64_at(b, e + 8) as usize
}

/// Recomputes the checksum so a corruption reaches the checks behind it.
fn reseal(b: &mut [u8]) {
    let c = crc32(&b[HEADER..]);
    put_u32(b, 40, c);
}

fn blob_of(cells: &[CellRecord]) -> AlignedBytes {
    AlignedBytes::copy_from(&write(cells).expect("valid cells"))
}

/// Parses, returning the error (the test wants one).
fn err(b: &[u8]) -> BlobError {
    match Blob::parse(b) {
        Ok(_) => panic!("corrupted blob was accepted"),
        Err(e) => e,
    }
}

/// Applies `f` to a fresh small blob, reseals, and returns the parse error.
fn corrupt(f: impl FnOnce(&mut [u8])) -> BlobError {
    let mut b = blob_of(&[small_cell()]);
    f(&mut b);
    reseal(&mut b);
    err(&b)
}

fn cells_of(b: &Blob) -> Vec<CellRecord> {
    b.cells().map(|c| c.to_record()).collect()
}

// ---- round trips ----------------------------------------------------------------------------

#[test]
fn crc32_is_the_ieee_crc() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
}

#[test]
fn small_cell_has_the_documented_shape() {
    let c = small_cell();
    assert_eq!((c.cols, c.rows, c.refine), (2, 2, 1));
    assert_eq!(c.nodes.len(), 4);
    assert_eq!(c.triangles.len(), 8);
    let v = c.as_cell();
    assert_eq!((v.nu(), v.nv()), (2, 2));
    assert_eq!((v.width(), v.height()), (0.01, 0.01));
}

#[test]
fn round_trip_is_bit_exact() {
    let rec = small_cell();
    let bytes = write(std::slice::from_ref(&rec)).unwrap();
    let aligned = AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&aligned).unwrap();
    assert_eq!(blob.version(), VERSION);
    assert_eq!(blob.cell_count(), 1);
    let cell = blob.cell(0).unwrap();
    // in place: the arrays point into the input
    let range = aligned.as_ptr_range();
    assert!(range.contains(&(cell.chi.as_ptr() as *const u8)));
    assert!(range.contains(&(cell.nodes.as_ptr() as *const u8)));
    let back = cell.to_record();
    assert_eq!(back, rec);
    assert_eq!(write(&[back]).unwrap(), bytes);
    assert!(blob.cell(1).is_none());
}

#[test]
fn several_cells_round_trip() {
    let cells = vec![
        small_cell(),
        laminate(
            "stripes",
            Axis::U,
            &[0, 0, 1, 0],
            3,
            2,
            0.02,
            two_materials(),
        ),
        laminate("bands", Axis::V, &[1, 0, 0], 5, 3, 0.005, two_materials()),
    ];
    let bytes = write(&cells).unwrap();
    let aligned = AlignedBytes::copy_from(&bytes);
    let blob = Blob::parse(&aligned).unwrap();
    assert_eq!(blob.cell_count(), 3);
    assert_eq!(cells_of(&blob), cells);
    assert_eq!(write(&cells_of(&blob)).unwrap(), bytes);
    let bands = blob.find("bands").unwrap();
    assert_eq!((bands.cols, bands.rows, bands.refine), (5, 3, 3));
    assert_eq!((bands.nu(), bands.nv()), (15, 9));
    assert!((bands.height() - 0.005 * 3.0 / 5.0).abs() < 1e-15);
    assert_eq!(bands.nodes.len(), 15 * 9);
    assert_eq!(bands.triangles.len(), 2 * 15 * 9);
    assert!(blob.find("nope").is_none());
    assert!(blob.cell(3).is_none());
}

#[test]
fn empty_blob_is_valid() {
    let bytes = write(&[]).unwrap();
    assert_eq!(bytes.len(), HEADER);
    let aligned = AlignedBytes::copy_from(&bytes);
    assert_eq!(Blob::parse(&aligned).unwrap().cell_count(), 0);
}

#[test]
fn load_aligned_reads_a_file() {
    let bytes = write(&[small_cell()]).unwrap();
    let path = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("blob_load_aligned.weft");
    std::fs::write(&path, &bytes).unwrap();
    let loaded = load_aligned(&path).unwrap();
    assert_eq!(loaded.as_ptr() as usize % 16, 0);
    assert_eq!(&loaded[..], &bytes[..]);
    assert_eq!(
        Blob::parse(&loaded).unwrap().cell(0).unwrap().to_record(),
        small_cell()
    );
    assert!(load_aligned(path.with_extension("missing")).is_err());
}

// ---- layout matches the spec --------------------------------------------------------------------

#[test]
fn layout_follows_the_spec() {
    let cells = [
        small_cell(),
        laminate("odd", Axis::U, &[0, 1, 1], 3, 1, 0.03, two_materials()),
    ];
    let b = write(&cells).unwrap();
    assert_eq!(&b[..8], b"WEFTCELL");
    assert_eq!(u32_at(&b, 8), 1);
    assert_eq!(u32_at(&b, 12), 64);
    assert_eq!(u64_at(&b, 16), b.len() as u64);
    assert_eq!(u32_at(&b, 24), 2);
    assert_eq!(u32_at(&b, 28), 12);
    assert_eq!(u64_at(&b, 32), 64);
    assert_eq!(u32_at(&b, 40), crc32(&b[64..]));
    assert!(b[44..64].iter().all(|&x| x == 0));
    assert_eq!(b.len() % 16, 0);

    let sizes = [320u64, 88, 8, 12, 4, 24];
    let mut cursor = (HEADER + ENTRY * 12) as u64;
    for s in 0..12 {
        let e = entry(s);
        assert_eq!(u32_at(&b, e), (s % 6 + 1) as u32, "kind");
        assert_eq!(u32_at(&b, e + 4), (s / 6) as u32, "cell");
        let (off, len, count) = (u64_at(&b, e + 8), u64_at(&b, e + 16), u64_at(&b, e + 24));
        assert_eq!(off, cursor.div_ceil(16) * 16, "tight, 16-aligned");
        assert_eq!(len, count * sizes[s % 6]);
        cursor = off + len;
    }
    assert_eq!(b.len() as u64, cursor.div_ceil(16) * 16);

    // CellInfo and arrays of cell 1 ("odd": 3x3 pixels, 9 nodes)
    let info = sec(&b, 1, SectionKind::Info);
    let c = &cells[1];
    assert_eq!(u32_at(&b, info + I_NAME_LEN), 3);
    assert_eq!(u32_at(&b, info + I_COLS), 3);
    assert_eq!(u32_at(&b, info + I_REFINE), 1);
    assert_eq!(&b[info + I_NAME..info + I_NAME + 4], b"odd\0");
    assert_eq!(f64_at(&b, info + I_SIZE), c.size);
    assert_eq!(f64_at(&b, info + I_DENSITY), c.density);
    assert_eq!(f64_at(&b, info + I_BENDING), c.bending);
    assert_eq!(f64_at(&b, info + I_STIFFNESS + 8), c.stiffness[0][1]);
    assert_eq!(f64_at(&b, info + I_VOIGT + 24), c.voigt_bound[1][0]);
    assert_eq!(f64_at(&b, info + I_REUSS + 64), c.reuss_bound[2][2]);
    let mats = sec(&b, 1, SectionKind::Materials);
    assert_eq!(f64_at(&b, mats + 88 + 72), c.materials[1].density);
    let tris = sec(&b, 1, SectionKind::Triangles);
    assert_eq!(u32_at(&b, tris + 12 * 5 + 8), c.triangles[5][2]);
    let chi = sec(&b, 1, SectionKind::Chi);
    let at = chi + 24 * 7 + 4 * 3;
    assert_eq!(
        f32::from_le_bytes(b[at..at + 4].try_into().unwrap()),
        c.chi[7][3]
    );
}

// ---- exhaustive corruption ----------------------------------------------------------------------

#[test]
fn every_truncation_is_rejected() {
    let b = blob_of(&[small_cell()]);
    for len in 0..b.len() {
        // Below the header the header is what is missing; past it, the announced total.
        let expected = if len < HEADER_SIZE {
            HEADER_SIZE
        } else {
            b.len()
        };
        assert_eq!(
            Blob::parse(&b[..len]).err(),
            Some(BlobError::TooShort {
                expected: expected as u64,
                found: len as u64
            }),
            "len {len}"
        );
    }
    assert!(Blob::parse(&b).is_ok());
}

#[test]
fn every_byte_flip_is_rejected_or_reencodes_exactly() {
    // The 3x3 cell has padding after several sections; the small one has none.
    for cells in [
        vec![small_cell()],
        vec![laminate(
            "odd",
            Axis::U,
            &[0, 1, 1],
            3,
            1,
            0.03,
            two_materials(),
        )],
    ] {
        let original = blob_of(&cells);
        let mut accepted = 0;
        for p in 0..original.len() {
            for mask in [0x01u8, 0x80, 0xFF] {
                let mut b = original.clone();
                b[p] ^= mask;
                // Without a new checksum every flip must be caught.
                assert!(Blob::parse(&b).is_err(), "unsealed flip at {p} accepted");
                if (40..44).contains(&p) {
                    continue;
                }
                reseal(&mut b);
                // With it, the deeper checks run; they must not panic, and anything they
                // accept must be a different but canonical blob (nothing is ignored).
                if let Ok(blob) = Blob::parse(&b) {
                    accepted += 1;
                    let again = write(&cells_of(&blob)).unwrap();
                    assert_eq!(&again[..], &b[..], "flip at {p} accepted but not canonical");
                }
            }
        }
        // Some float payload flips are legitimately valid cells; make sure the check ran.
        assert!(accepted > 0);
    }
}

// ---- one targeted corruption per class ---------------------------------------------------------

#[test]
fn header_corruptions() {
    let b = blob_of(&[small_cell()]);

    let mut x = b.clone();
    x[0] = b'X';
    assert_eq!(err(&x), BlobError::BadMagic);
    assert_eq!(err(b"NOTWEFT!"), BlobError::BadMagic);

    let mut x = b.clone();
    put_u32(&mut x, 8, 2);
    assert_eq!(err(&x), BlobError::UnsupportedVersion { found: 2 });

    let mut x = b.clone();
    put_u32(&mut x, 12, 80);
    assert_eq!(err(&x), BlobError::BadHeader);
    let mut x = b.clone();
    x[60] = 1;
    assert_eq!(err(&x), BlobError::BadHeader);

    let mut x = b.clone();
    let last = x.len() - 1;
    x[last] ^= 0x10;
    assert!(matches!(err(&x), BlobError::ChecksumMismatch { .. }));
    let mut x = b.clone();
    x[40] ^= 1;
    assert!(matches!(err(&x), BlobError::ChecksumMismatch { .. }));

    let mut longer = b.to_vec();
    longer.extend([0u8; 16]);
    let longer = AlignedBytes::copy_from(&longer);
    assert_eq!(
        err(&longer),
        BlobError::TrailingBytes {
            expected: b.len() as u64,
            found: b.len() as u64 + 16
        }
    );
}

#[test]
fn misaligned_base_is_rejected() {
    let b = blob_of(&[small_cell()]);
    for shift in [1usize, 4] {
        let mut buf = AlignedBytes::zeroed(b.len() + shift);
        buf[shift..].copy_from_slice(&b);
        assert_eq!(err(&buf[shift..]), BlobError::Misaligned, "shift {shift}");
    }
    // 8-aligned but not 16-aligned is enough (docs/BLOB.md)
    let mut buf = AlignedBytes::zeroed(b.len() + 8);
    buf[8..].copy_from_slice(&b);
    assert!(Blob::parse(&buf[8..]).is_ok());
}

#[test]
fn section_table_corruptions() {
    use BlobError::*;
    let nodes = entry(2); // cell 0, kind 3
    assert_eq!(corrupt(|b| put_u32(b, 28, 5)), BadSectionTable);
    assert_eq!(corrupt(|b| put_u32(b, 24, 2)), BadSectionTable);
    assert_eq!(corrupt(|b| put_u64(b, 32, 128)), BadSectionTable);
    assert_eq!(
        corrupt(|b| put_u32(b, nodes, 4)),
        UnexpectedSection {
            section: 2,
            kind: 4,
            cell: 0
        }
    );
    assert_eq!(
        corrupt(|b| put_u32(b, nodes + 4, 1)),
        UnexpectedSection {
            section: 2,
            kind: 3,
            cell: 1
        }
    );
    let total = corrupt_total();
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 8, total)),
        SectionOutOfRange { section: 2 }
    );
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 8, u64::MAX - 8)),
        SectionOutOfRange { section: 2 }
    );
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 16, 1 << 40)),
        SectionOutOfRange { section: 2 }
    );
    let off = |b: &[u8]| u64_at(b, nodes + 8);
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 8, off(b) + 8)),
        SectionMisaligned { section: 2 }
    );
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 8, off(b) - 16)),
        SectionOverlap { section: 2 }
    );
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 8, off(b) + 16)),
        SectionGap { section: 2 }
    );
    assert_eq!(
        corrupt(|b| put_u64(b, nodes + 24, u64_at(b, nodes + 24) + 1)),
        SectionSizeMismatch { section: 2 }
    );
    // Both length and count grown consistently: the section then runs into the next one.
    assert_eq!(
        corrupt(|b| {
            put_u64(b, nodes + 16, u64_at(b, nodes + 16) + 16);
            put_u64(b, nodes + 24, u64_at(b, nodes + 24) + 2);
        }),
        SectionOverlap { section: 3 }
    );
    // An empty info section (length consistent) leaves the 320 bytes after it unaccounted for.
    assert_eq!(
        corrupt(|b| {
            put_u64(b, entry(0) + 16, 0);
            put_u64(b, entry(0) + 24, 0);
        }),
        SectionGap { section: 1 }
    );
}

fn corrupt_total() -> u64 {
    write(&[small_cell()]).unwrap().len() as u64
}

#[test]
fn nonzero_padding_is_rejected() {
    // 9 nodes = 72 bytes: 8 padding bytes after the nodes section and at the end of the blob.
    let cells = [laminate(
        "odd",
        Axis::U,
        &[0, 1, 1],
        3,
        1,
        0.03,
        two_materials(),
    )];
    let mut b = blob_of(&cells);
    let pad = sec(&b, 0, SectionKind::Nodes) + 72;
    b[pad + 3] = 7;
    reseal(&mut b);
    assert_eq!(
        err(&b),
        BlobError::NonZeroPadding {
            offset: pad as u64 + 3
        }
    );

    let mut b = blob_of(&cells);
    let last = b.len() - 1;
    b[last] = 1;
    reseal(&mut b);
    assert_eq!(
        err(&b),
        BlobError::NonZeroPadding {
            offset: last as u64
        }
    );
}

#[test]
fn name_corruptions() {
    use BlobError::BadName;
    let info = |b: &[u8]| sec(b, 0, SectionKind::Info);
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            b[i + I_NAME] = 0xFF
        }),
        BadName { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_u32(b, i + I_NAME_LEN, 64)
        }),
        BadName { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            b[i + I_NAME + 40] = b'x'
        }),
        BadName { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            b[i + I_NAME + 1] = 0
        }),
        BadName { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_u32(b, i + I_NAME_LEN, 0);
            b[i + I_NAME..i + I_NAME + 64].fill(0);
        }),
        BadName { cell: 0 }
    );
    // Duplicate names: "a" and "b" with the second renamed in place.
    let mut a = small_cell();
    a.name = "a".into();
    let mut c = small_cell();
    c.name = "b".into();
    let mut b = blob_of(&[a, c]);
    let i = sec(&b, 1, SectionKind::Info);
    b[i + I_NAME] = b'a';
    reseal(&mut b);
    assert_eq!(err(&b), BlobError::DuplicateName { cell: 1 });
}

#[test]
fn value_corruptions() {
    use BlobError::*;
    let info = |b: &[u8]| sec(b, 0, SectionKind::Info);
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_u32(b, i + I_COLS, 0)
        }),
        BadDimensions { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_u32(b, i + I_REFINE, 1 << 16)
        }),
        BadDimensions { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_u32(b, i + I_COLS, 3)
        }),
        CountMismatch {
            cell: 0,
            section: SectionKind::Nodes,
            expected: 6,
            found: 4
        }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_SIZE, f64::NAN)
        }),
        NonFinite {
            cell: 0,
            field: Field::Size,
            index: 0
        }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_SIZE, -0.01)
        }),
        BadValue {
            cell: 0,
            field: Field::Size,
            index: 0
        }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_DENSITY, 0.0)
        }),
        BadValue {
            cell: 0,
            field: Field::Density,
            index: 0
        }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_BENDING, -1e-9)
        }),
        BadValue {
            cell: 0,
            field: Field::Bending,
            index: 0
        }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_VOIGT + 32, f64::INFINITY)
        }),
        NonFinite {
            cell: 0,
            field: Field::VoigtBound,
            index: 0
        }
    );
    // C^H not SPD: negative C11, and (separately) asymmetric.
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_STIFFNESS, -1.0)
        }),
        NotSpd { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_STIFFNESS + 8, 123.0)
        }),
        NotSpd { cell: 0 }
    );
    assert_eq!(
        corrupt(|b| {
            let i = info(b);
            put_f64(b, i + I_REUSS + 64, 0.0)
        }),
        BoundNotSpd { cell: 0 }
    );
    // Material 1: C22 negative, then density zero.
    let mats = |b: &[u8]| sec(b, 0, SectionKind::Materials);
    assert_eq!(
        corrupt(|b| {
            let m = mats(b) + 88;
            put_f64(b, m + 32, -5.0)
        }),
        MaterialNotSpd {
            cell: 0,
            material: 1
        }
    );
    assert_eq!(
        corrupt(|b| {
            let m = mats(b) + 88;
            put_f64(b, m + 72, 0.0)
        }),
        BadValue {
            cell: 0,
            field: Field::MaterialDensity,
            index: 1
        }
    );
    assert_eq!(
        corrupt(|b| {
            let m = mats(b);
            put_f64(b, m + 80, f64::NAN)
        }),
        NonFinite {
            cell: 0,
            field: Field::MaterialBending,
            index: 0
        }
    );
}

#[test]
fn mesh_corruptions() {
    use BlobError::*;
    let s = |b: &[u8], k| sec(b, 0, k);
    // node 3 = (1, 1) moved by half a spacing; node 2 infinite
    let h = (0.01 / 2.0) as f32;
    assert_eq!(
        corrupt(|b| {
            let n = s(b, SectionKind::Nodes) + 8 * 3;
            put_f32(b, n, 1.5 * h)
        }),
        NodeOffGrid { cell: 0, node: 3 }
    );
    assert_eq!(
        corrupt(|b| {
            let n = s(b, SectionKind::Nodes) + 8 * 2 + 4;
            put_f32(b, n, f32::INFINITY)
        }),
        NonFinite {
            cell: 0,
            field: Field::Nodes,
            index: 2
        }
    );
    // triangle 3 -> node 4 (there are 4 nodes), then a valid but wrong node order
    assert_eq!(
        corrupt(|b| {
            let t = s(b, SectionKind::Triangles) + 12 * 3 + 4;
            put_u32(b, t, 4)
        }),
        IndexOutOfRange {
            cell: 0,
            triangle: 3
        }
    );
    assert_eq!(
        corrupt(|b| {
            let t = s(b, SectionKind::Triangles) + 12 * 6;
            put_u32(b, t, u32::MAX)
        }),
        IndexOutOfRange {
            cell: 0,
            triangle: 6
        }
    );
    assert_eq!(
        corrupt(|b| {
            let t = s(b, SectionKind::Triangles) + 12 * 5;
            let (x, y) = (u32_at(b, t), u32_at(b, t + 4));
            put_u32(b, t, y);
            put_u32(b, t + 4, x);
        }),
        TopologyMismatch {
            cell: 0,
            triangle: 5
        }
    );
    // material index 2 of 2 materials; then the second triangle of pixel 0 differing
    assert_eq!(
        corrupt(|b| {
            let m = s(b, SectionKind::TriMaterial) + 4 * 5;
            put_u32(b, m, 2)
        }),
        MaterialIndexOutOfRange {
            cell: 0,
            triangle: 5
        }
    );
    assert_eq!(
        corrupt(|b| {
            let m = s(b, SectionKind::TriMaterial) + 4;
            put_u32(b, m, 1 - u32_at(b, m));
        }),
        PixelMaterialMismatch {
            cell: 0,
            triangle: 1
        }
    );
    // NaN in chi of node 2, component χ²v
    assert_eq!(
        corrupt(|b| {
            let c = s(b, SectionKind::Chi) + 24 * 2 + 12;
            put_f32(b, c, f32::NAN)
        }),
        NonFinite {
            cell: 0,
            field: Field::Chi,
            index: 2
        }
    );
}

// ---- the writer refuses what the reader would refuse ------------------------------------------

#[test]
fn writer_validates() {
    use BlobError::*;
    let check = |f: &dyn Fn(&mut CellRecord), expected: BlobError| {
        let mut c = small_cell();
        f(&mut c);
        assert_eq!(write(&[c]), Err(expected));
    };
    check(&|c| c.name = "x".repeat(64), BadName { cell: 0 });
    check(&|c| c.name.clear(), BadName { cell: 0 });
    check(&|c| c.name = "a\0b".into(), BadName { cell: 0 });
    check(&|c| c.refine = 0, BadDimensions { cell: 0 });
    check(
        &|c| {
            c.nodes.pop();
        },
        CountMismatch {
            cell: 0,
            section: SectionKind::Nodes,
            expected: 4,
            found: 3,
        },
    );
    check(
        &|c| {
            c.chi.push([0.0; 6]);
        },
        CountMismatch {
            cell: 0,
            section: SectionKind::Chi,
            expected: 4,
            found: 5,
        },
    );
    check(
        &|c| c.tri_material.truncate(2),
        CountMismatch {
            cell: 0,
            section: SectionKind::TriMaterial,
            expected: 8,
            found: 2,
        },
    );
    check(
        &|c| c.triangles[7][1] = 9,
        IndexOutOfRange {
            cell: 0,
            triangle: 7,
        },
    );
    check(
        &|c| c.triangles[0] = [0, 2, 3],
        TopologyMismatch {
            cell: 0,
            triangle: 0,
        },
    );
    check(
        &|c| c.tri_material[4] = 7,
        MaterialIndexOutOfRange {
            cell: 0,
            triangle: 4,
        },
    );
    check(
        &|c| c.chi[1][0] = f32::NAN,
        NonFinite {
            cell: 0,
            field: Field::Chi,
            index: 1,
        },
    );
    check(&|c| c.stiffness[2][2] = 0.0, NotSpd { cell: 0 });
    check(&|c| c.voigt_bound[0][1] = 1e9, BoundNotSpd { cell: 0 });
    check(
        &|c| c.materials[0].c[1][1] = -1.0,
        MaterialNotSpd {
            cell: 0,
            material: 0,
        },
    );
    check(
        &|c| c.materials.truncate(1),
        MaterialIndexOutOfRange {
            cell: 0,
            triangle: 2,
        },
    );
    check(&|c| c.nodes[1][0] += 1e-3, NodeOffGrid { cell: 0, node: 1 });
    check(
        &|c| c.bending = f64::NEG_INFINITY,
        NonFinite {
            cell: 0,
            field: Field::Bending,
            index: 0,
        },
    );

    // duplicate names across cells
    assert_eq!(
        write(&[small_cell(), small_cell()]),
        Err(DuplicateName { cell: 1 })
    );
    // a 64-byte name and the refused record never produce bytes; a 63-byte one is fine
    let mut c = small_cell();
    c.name = "é".repeat(31) + "x"; // 63 bytes of UTF-8
    let b = blob_of(&[c.clone()]);
    assert_eq!(Blob::parse(&b).unwrap().cell(0).unwrap().name, c.name);
}

#[test]
fn errors_display() {
    let e = BlobError::CountMismatch {
        cell: 2,
        section: SectionKind::Chi,
        expected: 9,
        found: 8,
    };
    assert_eq!(e.to_string(), "cell 2: chi holds 8 elements, expected 9");
    assert!(BlobError::Misaligned.to_string().contains("8-byte"));
}
