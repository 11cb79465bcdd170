//! The C ABI called from Rust, the way C calls it: every pointer check, every error with its
//! detail, outputs untouched on failure, strided unaligned vertex I/O, handles that are not
//! worlds, and bit-for-bit agreement with the safe kernel (the layer only converts and checks).

use std::ffi::CStr;
use std::ptr;
use std::sync::OnceLock;

use weft::blob::AlignedBytes;
use weft::ffi::*;
use weft::mesh;
use weft::world::{Capacity, ClothDef, Materials, Settings, World};

/// `cells/stripes.toml` homogenized at refine 1, 8-aligned.
fn blob_bytes() -> &'static AlignedBytes {
    static BLOB: OnceLock<AlignedBytes> = OnceLock::new();
    BLOB.get_or_init(|| {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("cells/stripes.toml");
        let bytes = weft::homogenize::build_blob(&[path], 1, &mut |_, _| {}).unwrap();
        AlignedBytes::copy_from(&bytes)
    })
}

fn parsed() -> WeftBlob {
    let b = blob_bytes();
    let mut blob = std::mem::MaybeUninit::<WeftBlob>::uninit();
    let r = unsafe {
        weft_blob_parse(
            b.as_ptr().cast(),
            b.len(),
            blob.as_mut_ptr(),
            ptr::null_mut(),
        )
    };
    assert_eq!(r, WeftResult::Ok);
    unsafe { blob.assume_init() }
}

fn what(d: &WeftErrorDetail) -> String {
    unsafe { CStr::from_ptr(d.what) }
        .to_str()
        .unwrap()
        .to_owned()
}

/// A grid cloth in C-style arrays.
struct Mesh {
    positions: Vec<WeftVec3>,
    uvs: Vec<WeftVec2>,
    indices: Vec<u32>,
}

impl Mesh {
    fn grid(n: usize, side: f32, z: f32) -> Mesh {
        let mut p = vec![[0.0f32; 3]; n * n];
        let mut uv = vec![[0.0f32; 2]; n * n];
        let mut t = vec![[0u32; 3]; 2 * (n - 1) * (n - 1)];
        mesh::grid(n, n, side, side, &mut p, &mut uv, &mut t).unwrap();
        Mesh {
            positions: p
                .iter()
                .map(|q| WeftVec3 {
                    x: q[0],
                    y: q[1],
                    z,
                })
                .collect(),
            uvs: uv.iter().map(|q| WeftVec2 { x: q[0], y: q[1] }).collect(),
            indices: t.iter().flatten().copied().collect(),
        }
    }
    fn def(&self) -> WeftWorldDef {
        let mut d = weft_default_world_def();
        d.positions = self.positions.as_ptr().cast();
        d.uvs = self.uvs.as_ptr().cast();
        d.vertex_count = self.positions.len() as u32;
        d.indices = self.indices.as_ptr();
        d.triangle_count = (self.indices.len() / 3) as u32;
        d
    }
}

/// A 16-aligned block for a world of `cap`.
struct Block {
    words: Vec<u128>,
}

impl Block {
    fn for_capacity(cap: &WeftCapacity) -> Block {
        let mut size = 0;
        assert_eq!(
            unsafe { weft_world_memory_size(cap, &mut size) },
            WeftResult::Ok
        );
        Block {
            words: vec![0; size / 16],
        }
    }
    fn ptr(&mut self) -> *mut std::ffi::c_void {
        self.words.as_mut_ptr().cast()
    }
    fn len(&self) -> usize {
        self.words.len() * 16
    }
}

fn small_capacity() -> WeftCapacity {
    WeftCapacity {
        max_vertices: 64,
        max_triangles: 128,
        max_edges: 256,
        max_colliders: 2,
        max_pins: 2,
    }
}

/// Creates a world; returns the result, the handle written (or the sentinel) and the detail.
fn create(def: &WeftWorldDef, block: &mut Block) -> (WeftResult, *mut WeftWorld, WeftErrorDetail) {
    let blob = parsed();
    let sentinel = 0x1234usize as *mut WeftWorld;
    let mut world = sentinel;
    let mut detail = std::mem::MaybeUninit::<WeftErrorDetail>::uninit();
    let r = unsafe {
        weft_world_create(
            def,
            &blob,
            block.ptr(),
            block.len(),
            &mut world,
            detail.as_mut_ptr(),
        )
    };
    let detail = unsafe { detail.assume_init() };
    assert_eq!(detail.result, r);
    if r != WeftResult::Ok {
        assert_eq!(world, sentinel, "a failed create wrote its output");
    }
    (r, world, detail)
}

fn live(mesh: &Mesh, block: &mut Block) -> *mut WeftWorld {
    let mut def = mesh.def();
    def.capacity = small_capacity();
    let (r, w, d) = create(&def, block);
    assert_eq!(r, WeftResult::Ok, "{d:?} {}", what(&d));
    assert_eq!(
        w.cast::<std::ffi::c_void>(),
        block.ptr(),
        "the handle is the block's start"
    );
    w
}

#[test]
fn result_strings_name_every_value() {
    let mut seen = std::collections::HashSet::new();
    for v in 0..200u32 {
        let s = unsafe { CStr::from_ptr(weft_result_string(v)) }
            .to_str()
            .unwrap();
        if s != "unknown result" {
            assert!(seen.insert(s), "{v}: {s} is not unique");
        }
    }
    assert_eq!(seen.len(), 45, "one string per WeftResult value");
    let unknown = unsafe { CStr::from_ptr(weft_result_string(u32::MAX)) };
    assert_eq!(unknown.to_str().unwrap(), "unknown result");
}

#[test]
fn memory_size_is_checked_and_affine_in_the_capacity() {
    let mut size = 7usize;
    assert_eq!(
        unsafe { weft_world_memory_size(ptr::null(), &mut size) },
        WeftResult::NullPointer
    );
    assert_eq!(size, 7);
    let cap = small_capacity();
    assert_eq!(
        unsafe { weft_world_memory_size(&cap, ptr::null_mut()) },
        WeftResult::NullPointer
    );
    // The overflow-checked evaluation equals the kernel's own count for assorted capacities.
    for (v, t, e, c, p) in [
        (0, 0, 0, 0, 0),
        (1, 2, 3, 4, 5),
        (4096, 8192, 12288, 8, 64),
        (100_000, 7, 0, 300, 1),
    ] {
        let c_cap = WeftCapacity {
            max_vertices: v,
            max_triangles: t,
            max_edges: e,
            max_colliders: c,
            max_pins: p,
        };
        let k = Capacity {
            vertices: v,
            triangles: t,
            edges: e,
            colliders: c,
            pins: p,
        };
        assert_eq!(
            unsafe { weft_world_memory_size(&c_cap, &mut size) },
            WeftResult::Ok
        );
        let expected = (((WEFT_WORLD_HEADER_SIZE + k.world_bytes() + 3) & !3)
            + v as usize * 20
            + t as usize * 16
            + 15)
            & !15;
        assert_eq!(size, expected);
    }
    assert_eq!(weft_world_memory_align(), WEFT_WORLD_MEMORY_ALIGN);
}

#[test]
fn create_checks_pointers_cookies_and_memory() {
    let mesh = Mesh::grid(5, 0.2, 0.0);
    let mut def = mesh.def();
    def.capacity = small_capacity();
    let mut block = Block::for_capacity(&def.capacity);
    let blob = parsed();
    let mut world = ptr::null_mut();
    let mut d = WeftErrorDetail {
        what: ptr::null(),
        ..unsafe { std::mem::zeroed() }
    };

    let r = unsafe {
        weft_world_create(
            ptr::null(),
            &blob,
            block.ptr(),
            block.len(),
            &mut world,
            &mut d,
        )
    };
    assert_eq!((r, what(&d).as_str()), (WeftResult::NullPointer, "def"));
    let r = unsafe {
        weft_world_create(
            &def,
            ptr::null(),
            block.ptr(),
            block.len(),
            &mut world,
            &mut d,
        )
    };
    assert_eq!((r, what(&d).as_str()), (WeftResult::NullPointer, "blob"));
    let r = unsafe {
        weft_world_create(
            &def,
            &blob,
            ptr::null_mut(),
            block.len(),
            &mut world,
            &mut d,
        )
    };
    assert_eq!((r, what(&d).as_str()), (WeftResult::NullPointer, "memory"));
    let r = unsafe {
        weft_world_create(
            &def,
            &blob,
            block.ptr(),
            block.len(),
            ptr::null_mut(),
            &mut d,
        )
    };
    assert_eq!(
        (r, what(&d).as_str()),
        (WeftResult::NullPointer, "out_world")
    );
    assert!(world.is_null());

    // Uninitialized structs are refused before anything they point to is read.
    let garbage_def: WeftWorldDef = unsafe {
        let mut g = std::mem::MaybeUninit::<WeftWorldDef>::uninit();
        ptr::write_bytes(g.as_mut_ptr().cast::<u8>(), 0xa5, size_of_def());
        g.assume_init()
    };
    let (r, _, mut d) = create(&garbage_def, &mut block);
    assert_eq!((r, what(&d).as_str()), (WeftResult::Uninitialized, "def"));
    let mut bad_blob = blob;
    bad_blob.internal_cookie = 0;
    let r = unsafe {
        weft_world_create(
            &def,
            &bad_blob,
            block.ptr(),
            block.len(),
            &mut world,
            &mut d,
        )
    };
    assert_eq!((r, what(&d).as_str()), (WeftResult::Uninitialized, "blob"));

    // Memory: alignment and size.
    let odd = unsafe { block.ptr().cast::<u8>().add(8) }.cast();
    let r = unsafe { weft_world_create(&def, &blob, odd, block.len() - 8, &mut world, &mut d) };
    assert_eq!((r, what(&d).as_str()), (WeftResult::Misaligned, "memory"));
    let r = unsafe {
        weft_world_create(
            &def,
            &blob,
            block.ptr(),
            block.len() - 16,
            &mut world,
            &mut d,
        )
    };
    assert_eq!(
        (r, what(&d).as_str()),
        (WeftResult::MemoryTooSmall, "memory_size")
    );
    assert!(world.is_null());

    // And then it works in the same block, and fills the detail with "no error".
    let (r, w, d) = create(&def, &mut block);
    assert_eq!(r, WeftResult::Ok);
    assert_eq!(what(&d), "");
    assert_eq!(
        WeftErrorDetail {
            what: ptr::null(),
            ..d
        },
        WeftErrorDetail {
            what: ptr::null(),
            ..weft_error_none()
        }
    );
    assert_eq!(unsafe { weft_world_vertex_count(w) }, 25);
    assert_eq!(unsafe { weft_world_triangle_count(w) }, 32);
}

fn size_of_def() -> usize {
    std::mem::size_of::<WeftWorldDef>()
}

fn weft_error_none() -> WeftErrorDetail {
    let mut d: WeftErrorDetail = unsafe { std::mem::zeroed() };
    d.result = WeftResult::Ok;
    for f in [
        &mut d.triangle,
        &mut d.vertex,
        &mut d.vertex_b,
        &mut d.material,
        &mut d.cell,
        &mut d.index,
        &mut d.needed,
        &mut d.capacity,
    ] {
        *f = WEFT_NONE;
    }
    // `what` points at the library's static "": compare by content.
    d.what = c"".as_ptr();
    d
}

#[test]
fn create_reports_capacities_and_mesh_faults_with_their_detail() {
    let mesh = Mesh::grid(5, 0.2, 0.0);
    let mut block = Block::for_capacity(&weft_default_capacity());
    let with = |f: &dyn Fn(&mut WeftWorldDef)| {
        let mut def = mesh.def();
        f(&mut def);
        def
    };

    let def = with(&|d| d.capacity.max_vertices = 24);
    let (r, _, d) = create(&def, &mut block);
    assert_eq!(
        (r, d.needed, d.capacity),
        (WeftResult::VertexCapacity, 25, 24)
    );
    let def = with(&|d| d.capacity.max_triangles = 31);
    let (r, _, d) = create(&def, &mut block);
    assert_eq!(
        (r, d.needed, d.capacity),
        (WeftResult::TriangleCapacity, 32, 31)
    );
    let def = with(&|d| d.capacity.max_edges = 10);
    let (r, _, d) = create(&def, &mut block);
    assert_eq!((r, d.capacity), (WeftResult::EdgeCapacity, 10));

    // Mesh faults name the triangle, vertex or edge.
    let mut bad = Mesh::grid(5, 0.2, 0.0);
    bad.indices[3 * 4 + 1] = 25;
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!((r, d.triangle), (WeftResult::MeshIndexOutOfRange, 4));

    let mut bad = Mesh::grid(5, 0.2, 0.0);
    bad.indices[3 * 6 + 2] = bad.indices[3 * 6];
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!((r, d.triangle), (WeftResult::MeshRepeatedVertex, 6));

    let mut bad = Mesh::grid(5, 0.2, 0.0);
    bad.positions[12].z = f32::NAN;
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!((r, d.vertex), (WeftResult::MeshNonFinite, 12));

    let mut bad = Mesh::grid(5, 0.2, 0.0);
    let t = 9;
    let [a, b] = [bad.indices[3 * t], bad.indices[3 * t + 1]];
    bad.uvs[b as usize] = bad.uvs[a as usize];
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!(r, WeftResult::MeshDegenerateUv, "{d:?}");
    assert_ne!(d.triangle, WEFT_NONE);

    let mut bad = Mesh::grid(5, 0.2, 0.0);
    for i in 0..25 {
        bad.positions[i].y = 0.0; // every triangle collapses in 3D
    }
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!(r, WeftResult::MeshDegenerate3d);
    assert_ne!(d.triangle, WEFT_NONE);

    // A third triangle on the interior diagonal 0–6 (triangles 0 and 1 share it).
    let mut bad = Mesh::grid(5, 0.2, 0.0);
    bad.positions.push(WeftVec3 {
        x: 0.1,
        y: 0.0,
        z: 0.1,
    });
    bad.uvs.push(WeftVec2 { x: 0.3, y: -0.1 });
    bad.indices.extend([0, 25, 6]);
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!(
        (r, d.vertex, d.vertex_b),
        (WeftResult::MeshNonManifoldEdge, 0, 6)
    );

    // An interior vertex dragged past its neighbours in (u, v): the sheet folds.
    let mut bad = Mesh::grid(5, 0.2, 0.0);
    bad.uvs[6] = WeftVec2 { x: 0.16, y: 0.16 };
    let (r, _, d) = create(&bad.def(), &mut block);
    assert_eq!(r, WeftResult::MeshFoldedUv);
    assert_ne!((d.vertex, d.vertex_b), (WEFT_NONE, WEFT_NONE));

    let def = with(&|d| d.triangle_count = 0);
    let (r, _, _) = create(&def, &mut block);
    assert_eq!(r, WeftResult::MeshEmpty);

    // Materials: per triangle or one for all.
    let mats: Vec<u32> = (0..32).map(|t| if t == 17 { 3 } else { 0 }).collect();
    let def = with(&|d| d.materials = mats.as_ptr());
    let (r, _, d) = create(&def, &mut block);
    assert_eq!(
        (r, d.triangle, d.material),
        (WeftResult::MaterialOutOfRange, 17, 3)
    );
    let def = with(&|d| d.material = 1);
    let (r, _, d) = create(&def, &mut block);
    assert_eq!(
        (r, d.triangle, d.material),
        (WeftResult::MaterialOutOfRange, 0, 1)
    );
}

#[test]
fn create_checks_strides_buffers_and_settings() {
    let mesh = Mesh::grid(5, 0.2, 0.0);
    let mut block = Block::for_capacity(&weft_default_capacity());
    type Edit = Box<dyn Fn(&mut WeftWorldDef)>;
    let cases: Vec<(Edit, WeftResult, &str)> = vec![
        (
            Box::new(|d| d.positions = ptr::null()),
            WeftResult::NullPointer,
            "def.positions",
        ),
        (
            Box::new(|d| d.uvs = ptr::null()),
            WeftResult::NullPointer,
            "def.uvs",
        ),
        (
            Box::new(|d| d.indices = ptr::null()),
            WeftResult::NullPointer,
            "def.indices",
        ),
        (
            Box::new(|d| d.position_stride = 8),
            WeftResult::InvalidArgument,
            "def.position_stride",
        ),
        (
            Box::new(|d| d.uv_stride = 0),
            WeftResult::InvalidArgument,
            "def.uv_stride",
        ),
        (
            Box::new(|d| d.position_stride = usize::MAX / 4),
            WeftResult::InvalidArgument,
            "def.position_stride",
        ),
        (
            Box::new(|d| d.indices = unsafe { d.indices.cast::<u8>().add(1).cast() }),
            WeftResult::Misaligned,
            "def.indices",
        ),
        (
            Box::new(|d| d.settings.substeps = 0),
            WeftResult::InvalidSetting,
            "substeps",
        ),
        (
            Box::new(|d| d.settings.gravity.y = f32::NAN),
            WeftResult::InvalidSetting,
            "gravity",
        ),
        (
            Box::new(|d| d.settings.tolerance = -1.0),
            WeftResult::InvalidSetting,
            "tolerance",
        ),
        (
            Box::new(|d| d.settings.drag = f32::INFINITY),
            WeftResult::InvalidSetting,
            "drag",
        ),
        (
            Box::new(|d| d.settings.effects = 1 << 20),
            WeftResult::InvalidSetting,
            "effects",
        ),
        (
            Box::new(|d| d.settings.max_iterations = 0),
            WeftResult::InvalidSetting,
            "max_iterations",
        ),
        (
            Box::new(|d| d.settings.per_node_warping = 2),
            WeftResult::InvalidSetting,
            "per_node_warping",
        ),
        (
            Box::new(|d| d.settings.sleep_velocity = -1.0),
            WeftResult::InvalidSetting,
            "sleep_velocity",
        ),
        (
            Box::new(|d| d.settings.damping_mass = -1.0),
            WeftResult::InvalidSetting,
            "damping_mass",
        ),
        (
            Box::new(|d| d.settings.damping_stiffness = f32::NAN),
            WeftResult::InvalidSetting,
            "damping_stiffness",
        ),
        (
            Box::new(|d| d.settings.wind.x = f32::NAN),
            WeftResult::InvalidSetting,
            "wind",
        ),
    ];
    for (edit, want, name) in cases {
        let mut def = mesh.def();
        edit(&mut def);
        let (r, _, d) = create(&def, &mut block);
        assert_eq!((r, what(&d).as_str()), (want, name));
    }
}

#[test]
fn blob_parse_reports_each_fault() {
    let good = blob_bytes();
    let mut out = std::mem::MaybeUninit::<WeftBlob>::uninit();
    let mut d = weft_error_none();
    let parse =
        |bytes: &[u8], out: &mut std::mem::MaybeUninit<WeftBlob>, d: &mut WeftErrorDetail| unsafe {
            weft_blob_parse(bytes.as_ptr().cast(), bytes.len(), out.as_mut_ptr(), d)
        };

    let r = unsafe { weft_blob_parse(ptr::null(), 64, out.as_mut_ptr(), &mut d) };
    assert_eq!(
        (r, what(&d).as_str()),
        (WeftResult::NullPointer, "blob.data")
    );
    let r = unsafe { weft_blob_parse(good.as_ptr().cast(), good.len(), ptr::null_mut(), &mut d) };
    assert_eq!(
        (r, what(&d).as_str()),
        (WeftResult::NullPointer, "out_blob")
    );

    assert_eq!(
        parse(&good[..good.len() - 1], &mut out, &mut d),
        WeftResult::BlobSize
    );
    assert_eq!(parse(&good[..10], &mut out, &mut d), WeftResult::BlobSize);

    let mut v = AlignedBytes::copy_from(good);
    v[8] = 2; // the version field
    assert_eq!(parse(&v, &mut out, &mut d), WeftResult::BlobVersion);
    assert_eq!(d.index, 2);

    let mut v = AlignedBytes::copy_from(good);
    v[0] = b'X';
    assert_eq!(parse(&v, &mut out, &mut d), WeftResult::BlobBadMagic);

    let mut v = AlignedBytes::copy_from(good);
    let mid = v.len() / 2;
    v[mid] ^= 1;
    assert_eq!(parse(&v, &mut out, &mut d), WeftResult::BlobChecksum);

    // A valid blob at an odd address.
    let mut shifted = AlignedBytes::zeroed(good.len() + 8);
    shifted[1..1 + good.len()].copy_from_slice(good);
    assert_eq!(
        parse(&shifted[1..1 + good.len()], &mut out, &mut d),
        WeftResult::BlobMisaligned
    );

    // Success fills the struct; cell info works and checks the index.
    assert_eq!(parse(good, &mut out, &mut d), WeftResult::Ok);
    let blob = unsafe { out.assume_init() };
    assert_eq!(
        (blob.version, blob.cell_count, blob.size),
        (WEFT_BLOB_VERSION, 1, good.len())
    );
    let mut info = std::mem::MaybeUninit::<WeftCellInfo>::uninit();
    assert_eq!(
        unsafe { weft_blob_cell_info(&blob, 0, info.as_mut_ptr()) },
        WeftResult::Ok
    );
    let info = unsafe { info.assume_init() };
    let name = unsafe { CStr::from_ptr(info.name.as_ptr()) };
    assert_eq!(name.to_str().unwrap(), "stripes");
    assert!((info.width - 0.01).abs() < 1e-12);
    assert!(
        info.stiffness[0][0] > info.stiffness[1][1],
        "stripes are stiffer along u"
    );
    let mut info2 = std::mem::MaybeUninit::<WeftCellInfo>::uninit();
    assert_eq!(
        unsafe { weft_blob_cell_info(&blob, 1, info2.as_mut_ptr()) },
        WeftResult::BlobCellOutOfRange
    );
    assert_eq!(
        unsafe { weft_blob_cell_info(ptr::null(), 0, info2.as_mut_ptr()) },
        WeftResult::NullPointer
    );
}

#[test]
fn handles_that_are_not_worlds_are_refused() {
    let mesh = Mesh::grid(4, 0.2, 0.0);
    let mut block = Block::for_capacity(&small_capacity());
    let w = live(&mesh, &mut block);
    assert_eq!(
        unsafe { weft_world_step(ptr::null_mut(), 0.01, ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(unsafe { weft_world_vertex_count(ptr::null()) }, 0);
    assert!(!unsafe { weft_world_is_asleep(ptr::null()) });

    // Memory that never held a world.
    let mut junk = vec![0x5au128; WEFT_WORLD_HEADER_SIZE / 16];
    let junk_world = junk.as_mut_ptr().cast::<WeftWorld>();
    assert_eq!(
        unsafe { weft_world_step(junk_world, 0.01, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
    assert_eq!(unsafe { weft_world_vertex_count(junk_world) }, 0);
    // A misaligned handle.
    let odd = unsafe { w.cast::<u8>().add(4) }.cast::<WeftWorld>();
    assert_eq!(unsafe { weft_world_wake(odd) }, WeftResult::InvalidHandle);

    // A block copied elsewhere is not a world: its arrays still point into the original.
    let mut copy = block.words.clone();
    let copied = copy.as_mut_ptr().cast::<WeftWorld>();
    assert_eq!(
        unsafe { weft_world_step(copied, 0.01, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );

    // A destroyed world.
    assert_eq!(
        unsafe { weft_world_step(w, 0.01, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(unsafe { weft_world_destroy(w) }, WeftResult::Ok);
    assert_eq!(
        unsafe { weft_world_step(w, 0.01, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
    assert_eq!(unsafe { weft_world_destroy(w) }, WeftResult::InvalidHandle);
}

/// An interleaved, packed vertex buffer: 1 flag byte, position, (u, v), 2 bytes of padding.
const STRIDE: usize = 23;
const POS: usize = 1;
const UV: usize = 13;

fn interleave(mesh: &Mesh) -> Vec<u8> {
    let mut buf = vec![0xeeu8; mesh.positions.len() * STRIDE];
    for (i, (p, uv)) in mesh.positions.iter().zip(&mesh.uvs).enumerate() {
        let at = i * STRIDE;
        for (k, c) in [p.x, p.y, p.z].iter().enumerate() {
            buf[at + POS + 4 * k..at + POS + 4 * k + 4].copy_from_slice(&c.to_ne_bytes());
        }
        for (k, c) in [uv.x, uv.y].iter().enumerate() {
            buf[at + UV + 4 * k..at + UV + 4 * k + 4].copy_from_slice(&c.to_ne_bytes());
        }
    }
    buf
}

fn read_pos(buf: &[u8], i: usize) -> [f32; 3] {
    let at = i * STRIDE + POS;
    std::array::from_fn(|k| f32::from_ne_bytes(buf[at + 4 * k..at + 4 * k + 4].try_into().unwrap()))
}

#[test]
fn strided_unaligned_vertex_io_matches_the_kernel_bit_for_bit() {
    // Flat at 1 m, held by two corners of its far edge.
    let mesh = Mesh::grid(6, 0.3, 1.0);
    let buf = interleave(&mesh);
    let mut def = mesh.def();
    def.positions = buf[POS..].as_ptr().cast();
    def.position_stride = STRIDE;
    def.uvs = buf[UV..].as_ptr().cast();
    def.uv_stride = STRIDE;
    def.capacity = small_capacity();
    def.settings.substeps = 2;
    let mut block = Block::for_capacity(&def.capacity);
    let (r, w, _) = create(&def, &mut block);
    assert_eq!(r, WeftResult::Ok);
    let (corner_a, corner_b) = (30u32, 35u32);
    for c in [corner_a, corner_b] {
        let p = mesh.positions[c as usize];
        assert_eq!(unsafe { weft_world_set_pin(w, c, p) }, WeftResult::Ok);
    }

    // The same cloth through the safe kernel.
    let blob_bytes = blob_bytes();
    let blob = weft::blob::Blob::parse(blob_bytes).unwrap();
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| [p.x, p.y, p.z]).collect();
    let uvs: Vec<[f32; 2]> = mesh.uvs.iter().map(|p| [p.x, p.y]).collect();
    let triangles: Vec<[u32; 3]> = mesh.indices.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    let materials = vec![0u32; triangles.len()];
    let cap = Capacity {
        vertices: 64,
        triangles: 128,
        edges: 256,
        colliders: 2,
        pins: 2,
    };
    let mut mem = vec![0u8; cap.world_bytes()];
    let settings = Settings {
        substeps: 2,
        ..Settings::default()
    };
    let cloth = ClothDef {
        positions: &positions,
        uvs: &uvs,
        triangles: &triangles,
        materials: &materials,
    };
    let mut k = World::new(&mut mem, cap, &cloth, Materials::Blob(&blob), settings).unwrap();
    for c in [corner_a, corner_b] {
        k.set_pin(c, positions[c as usize]).unwrap();
    }

    let mut out = vec![0xeeu8; buf.len()];
    for _ in 0..30 {
        let mut stats = WeftStepStats::default();
        assert_eq!(
            unsafe { weft_world_step(w, 1.0 / 60.0, &mut stats) },
            WeftResult::Ok
        );
        let ks = k.step_dt(1.0 / 60.0).unwrap();
        assert_eq!(
            (stats.iterations, stats.converged, stats.substeps),
            (ks.iterations, ks.converged, ks.substeps)
        );
    }
    let r = unsafe { weft_world_get_positions(w, out[POS..].as_mut_ptr().cast(), 36, STRIDE) };
    assert_eq!(r, WeftResult::Ok);
    for (i, p) in k.positions().iter().enumerate() {
        assert_eq!(read_pos(&out, i), [p.x, p.y, p.z], "vertex {i}");
        // nothing but the position bytes was written
        let at = i * STRIDE;
        assert_eq!(out[at], 0xee);
        assert!(out[at + UV..at + STRIDE].iter().all(|&b| b == 0xee));
    }
    let moved = k.positions()[0] - glam::Vec3A::new(0.0, 0.0, 1.0);
    assert!(moved.length() > 0.1, "the free edge swung: {moved}");

    // Velocities, tightly packed.
    let mut vel = vec![WeftVec3::default(); 36];
    let r = unsafe { weft_world_get_velocities(w, vel.as_mut_ptr().cast(), 36, 12) };
    assert_eq!(r, WeftResult::Ok);
    for (a, b) in vel.iter().zip(k.velocities()) {
        assert_eq!([a.x, a.y, a.z], [b.x, b.y, b.z]);
    }

    // Set positions from the strided buffer: a round trip, and a teleport.
    let r = unsafe { weft_world_set_positions(w, buf[POS..].as_ptr().cast(), 36, STRIDE) };
    assert_eq!(r, WeftResult::Ok);
    let mut back = vec![WeftVec3::default(); 36];
    let r = unsafe { weft_world_get_positions(w, back.as_mut_ptr().cast(), 40, 12) };
    assert_eq!(r, WeftResult::Ok, "a larger buffer is fine");
    assert_eq!(back, mesh.positions);
}

#[test]
fn vertex_io_checks_counts_strides_and_values() {
    let mesh = Mesh::grid(4, 0.2, 0.0);
    let mut block = Block::for_capacity(&small_capacity());
    let w = live(&mesh, &mut block);
    let mut buf = vec![WeftVec3::default(); 16];
    let p = buf.as_mut_ptr().cast();
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 15, 12) },
        WeftResult::CountMismatch
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 11) },
        WeftResult::InvalidArgument
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, ptr::null_mut(), 16, 12) },
        WeftResult::NullPointer
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, usize::MAX / 8) },
        WeftResult::InvalidArgument
    );
    assert_eq!(
        unsafe { weft_world_set_positions(w, p, 17, 12) },
        WeftResult::CountMismatch
    );
    let mut d = weft_error_none();
    assert_eq!(
        unsafe { weft_world_last_error_detail(w, &mut d) },
        WeftResult::Ok
    );
    assert_eq!((d.result, d.needed), (WeftResult::CountMismatch, 16));

    // A NaN anywhere: refused with its vertex, and nothing changed.
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 12) },
        WeftResult::Ok
    );
    let before = buf.clone();
    let mut edited = buf.clone();
    edited[3].x = 5.0;
    edited[9].y = f32::NAN;
    let r = unsafe { weft_world_set_positions(w, edited.as_ptr().cast(), 16, 12) };
    assert_eq!(r, WeftResult::NonFinite);
    assert_eq!(
        unsafe { weft_world_last_error_detail(w, &mut d) },
        WeftResult::Ok
    );
    assert_eq!((d.vertex, what(&d).as_str()), (9, "positions"));
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 12) },
        WeftResult::Ok
    );
    assert_eq!(buf, before);
    let r = unsafe { weft_world_set_velocities(w, edited.as_ptr().cast(), 16, 12) };
    assert_eq!(r, WeftResult::NonFinite);
    edited[9].y = 0.0;
    assert_eq!(
        unsafe { weft_world_set_velocities(w, edited.as_ptr().cast(), 16, 12) },
        WeftResult::Ok
    );
    let mut vel = vec![WeftVec3::default(); 16];
    assert_eq!(
        unsafe { weft_world_get_velocities(w, vel.as_mut_ptr().cast(), 16, 12) },
        WeftResult::Ok
    );
    assert_eq!(vel, edited);
}

#[test]
fn pins_colliders_settings_and_steps_report_their_faults() {
    let mesh = Mesh::grid(4, 0.2, 0.5);
    let mut block = Block::for_capacity(&small_capacity());
    let w = live(&mesh, &mut block);
    let mut d = weft_error_none();
    let detail = |d: &mut WeftErrorDetail| {
        assert_eq!(
            unsafe { weft_world_last_error_detail(w, d) },
            WeftResult::Ok
        );
    };
    let v = |x, y, z| WeftVec3 { x, y, z };

    // Pins.
    assert_eq!(
        unsafe { weft_world_set_pin(w, 16, v(0.0, 0.0, 0.0)) },
        WeftResult::VertexOutOfRange
    );
    detail(&mut d);
    assert_eq!(d.vertex, 16);
    assert_eq!(
        unsafe { weft_world_set_pin(w, 3, v(f32::NAN, 0.0, 0.0)) },
        WeftResult::NonFinite
    );
    detail(&mut d);
    assert_eq!((d.vertex, what(&d).as_str()), (3, "target"));
    assert_eq!(
        unsafe { weft_world_set_pin(w, 0, v(0.0, 0.0, 0.5)) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 1, v(0.1, 0.0, 0.5)) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 1, v(0.1, 0.0, 0.6)) },
        WeftResult::Ok,
        "moving a pin"
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 2, v(0.1, 0.0, 0.5)) },
        WeftResult::PinCapacity
    );
    detail(&mut d);
    assert_eq!((d.capacity, d.needed), (2, 3));
    assert_eq!(unsafe { weft_world_pin_count(w) }, 2);
    assert_eq!(unsafe { weft_world_remove_pin(w, 1) }, WeftResult::Ok);
    assert_eq!(
        unsafe { weft_world_remove_pin(w, 1) },
        WeftResult::Ok,
        "no pin is fine"
    );
    assert_eq!(
        unsafe { weft_world_remove_pin(w, 99) },
        WeftResult::VertexOutOfRange
    );
    assert_eq!(unsafe { weft_world_pin_count(w) }, 1);

    // Colliders.
    let mut c = weft_default_collider_def();
    let mut index = 77u32;
    c.shape.kind = 4; // not a WEFT_SHAPE_* value
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::InvalidArgument
    );
    detail(&mut d);
    assert_eq!(what(&d), "shape.kind");
    c.shape = weft_shape_plane(v(0.0, 0.0, 2.0), 0.0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::InvalidCollider
    );
    c.shape = weft_shape_sphere(v(0.0, 0.0, 0.0), -1.0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::InvalidCollider
    );
    c.shape = weft_shape_capsule(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), 0.1);
    c.friction = -0.1;
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::InvalidCollider
    );
    detail(&mut d);
    assert_eq!(what(&d), "friction");
    c.friction = 0.2;
    c.internal_cookie = 0;
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::Uninitialized
    );
    c.internal_cookie = weft_default_collider_def().internal_cookie;
    assert_eq!(
        unsafe { weft_world_add_collider(w, ptr::null(), &mut index) },
        WeftResult::NullPointer
    );
    assert_eq!(index, 77, "outputs are untouched on failure");
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::Ok
    );
    assert_eq!(index, 0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index) },
        WeftResult::ColliderCapacity
    );
    assert_eq!(unsafe { weft_world_collider_count(w) }, 2);
    let s = weft_shape_sphere(v(0.0, 0.0, 0.0), 0.1);
    assert_eq!(
        unsafe { weft_world_set_collider(w, 2, &s) },
        WeftResult::ColliderOutOfRange
    );
    detail(&mut d);
    assert_eq!(d.index, 2);
    assert_eq!(
        unsafe { weft_world_set_collider(w, 1, &s) },
        WeftResult::Ok,
        "a change of kind"
    );
    assert_eq!(unsafe { weft_world_clear_colliders(w) }, WeftResult::Ok);
    assert_eq!(unsafe { weft_world_collider_count(w) }, 0);

    // Settings round trip; a bad one changes nothing.
    let mut s = weft_default_settings();
    assert_eq!(
        unsafe { weft_world_get_settings(w, &mut s) },
        WeftResult::Ok
    );
    assert_eq!(s, weft_default_settings());
    s.substeps = 3;
    s.wind = v(1.0, 0.0, 0.0);
    assert_eq!(unsafe { weft_world_set_settings(w, &s) }, WeftResult::Ok);
    let mut bad = s;
    bad.sleep_velocity = f32::NAN;
    assert_eq!(
        unsafe { weft_world_set_settings(w, &bad) },
        WeftResult::InvalidSetting
    );
    let mut now = weft_default_settings();
    assert_eq!(
        unsafe { weft_world_get_settings(w, &mut now) },
        WeftResult::Ok
    );
    assert_eq!(now, s);
    assert_eq!(
        unsafe { weft_world_set_effects(w, WEFT_EFFECT_ALL) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_effects(w, WEFT_EFFECT_ALL + 1) },
        WeftResult::InvalidSetting
    );

    // Steps.
    let mut stats = WeftStepStats {
        iterations: 12345,
        ..WeftStepStats::default()
    };
    for dt in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            unsafe { weft_world_step(w, dt, &mut stats) },
            WeftResult::InvalidTimeStep
        );
    }
    assert_eq!(stats.iterations, 12345, "outputs are untouched on failure");
    assert_eq!(
        unsafe { weft_world_step(w, 1.0 / 60.0, &mut stats) },
        WeftResult::Ok
    );
    assert_eq!(stats.substeps, 3);
    assert!(stats.iterations > 0 && stats.converged);
    assert_eq!(unsafe { weft_world_wake(w) }, WeftResult::Ok);
}
