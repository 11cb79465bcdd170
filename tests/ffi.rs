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
            unsafe { weft_world_memory_size(cap, &mut size, ptr::null_mut()) },
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
    assert_eq!(seen.len(), 60, "one string per WeftResult value");
    // Localization's results are 80–99.
    for v in 80..=92u32 {
        let s = unsafe { CStr::from_ptr(weft_result_string(v)) };
        assert_ne!(s.to_str().unwrap(), "unknown result", "{v}");
    }
    let unknown = unsafe { CStr::from_ptr(weft_result_string(u32::MAX)) };
    assert_eq!(unknown.to_str().unwrap(), "unknown result");
}

#[test]
fn memory_size_is_checked_and_affine_in_the_capacity() {
    let mut size = 7usize;
    assert_eq!(
        unsafe { weft_world_memory_size(ptr::null(), &mut size, ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(size, 7);
    let cap = small_capacity();
    assert_eq!(
        unsafe { weft_world_memory_size(&cap, ptr::null_mut(), ptr::null_mut()) },
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
            unsafe { weft_world_memory_size(&c_cap, &mut size, ptr::null_mut()) },
            WeftResult::Ok
        );
        // The header and the kernel's arrays: no staging area (the kernel reads the caller's
        // strided input in place).
        let expected = (WEFT_WORLD_HEADER_SIZE + k.world_bytes() + 15) & !15;
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
            Box::new(|d| d.settings.max_iterations = 10_001),
            WeftResult::InvalidSetting,
            "max_iterations",
        ),
        (
            Box::new(|d| d.settings.rotation_iterations = 101),
            WeftResult::InvalidSetting,
            "rotation_iterations",
        ),
        (
            Box::new(|d| d.settings.sleep_velocity = -1.0),
            WeftResult::InvalidSetting,
            "sleep_velocity",
        ),
        (
            Box::new(|d| d.settings.max_depenetration_speed = f32::NAN),
            WeftResult::InvalidSetting,
            "max_depenetration_speed",
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
        unsafe { weft_blob_cell_info(&blob, 0, info.as_mut_ptr(), ptr::null_mut()) },
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
        unsafe { weft_blob_cell_info(&blob, 1, info2.as_mut_ptr(), ptr::null_mut()) },
        WeftResult::BlobCellOutOfRange
    );
    assert_eq!(
        unsafe { weft_blob_cell_info(ptr::null(), 0, info2.as_mut_ptr(), ptr::null_mut()) },
        WeftResult::NullPointer
    );
}

#[test]
fn handles_that_are_not_worlds_are_refused() {
    let mesh = Mesh::grid(4, 0.2, 0.0);
    let mut block = Block::for_capacity(&small_capacity());
    let w = live(&mesh, &mut block);
    assert_eq!(
        unsafe { weft_world_step(ptr::null_mut(), 0.01, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(unsafe { weft_world_vertex_count(ptr::null()) }, 0);
    assert!(!unsafe { weft_world_is_asleep(ptr::null()) });

    // Memory that never held a world.
    let mut junk = vec![0x5au128; WEFT_WORLD_HEADER_SIZE / 16];
    let junk_world = junk.as_mut_ptr().cast::<WeftWorld>();
    assert_eq!(
        unsafe { weft_world_step(junk_world, 0.01, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
    assert_eq!(unsafe { weft_world_vertex_count(junk_world) }, 0);
    // A misaligned handle.
    let odd = unsafe { w.cast::<u8>().add(4) }.cast::<WeftWorld>();
    assert_eq!(
        unsafe { weft_world_wake(odd, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );

    // A block copied elsewhere is not a world: its arrays still point into the original.
    let mut copy = block.words.clone();
    let copied = copy.as_mut_ptr().cast::<WeftWorld>();
    assert_eq!(
        unsafe { weft_world_step(copied, 0.01, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::InvalidHandle
    );

    // A destroyed world.
    assert_eq!(
        unsafe { weft_world_step(w, 0.01, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_destroy(w, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_step(w, 0.01, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
    assert_eq!(
        unsafe { weft_world_destroy(w, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
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
        assert_eq!(
            unsafe { weft_world_set_pin(w, c, p, ptr::null_mut()) },
            WeftResult::Ok
        );
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
            unsafe { weft_world_step(w, 1.0 / 60.0, &mut stats, ptr::null_mut()) },
            WeftResult::Ok
        );
        let ks = k.step_dt(1.0 / 60.0).unwrap();
        assert_eq!(
            (stats.iterations, stats.converged, stats.substeps),
            (ks.iterations, u32::from(ks.converged), ks.substeps)
        );
    }
    let r = unsafe {
        weft_world_get_positions(
            w,
            out[POS..].as_mut_ptr().cast(),
            36,
            STRIDE,
            ptr::null_mut(),
        )
    };
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
    let r =
        unsafe { weft_world_get_velocities(w, vel.as_mut_ptr().cast(), 36, 12, ptr::null_mut()) };
    assert_eq!(r, WeftResult::Ok);
    for (a, b) in vel.iter().zip(k.velocities()) {
        assert_eq!([a.x, a.y, a.z], [b.x, b.y, b.z]);
    }

    // Set positions from the strided buffer: a round trip, and a teleport.
    let r = unsafe {
        weft_world_set_positions(w, buf[POS..].as_ptr().cast(), 36, STRIDE, ptr::null_mut())
    };
    assert_eq!(r, WeftResult::Ok);
    let mut back = vec![WeftVec3::default(); 36];
    let r =
        unsafe { weft_world_get_positions(w, back.as_mut_ptr().cast(), 40, 12, ptr::null_mut()) };
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
        unsafe { weft_world_get_positions(w, p, 15, 12, ptr::null_mut()) },
        WeftResult::CountMismatch
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 11, ptr::null_mut()) },
        WeftResult::InvalidArgument
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, ptr::null_mut(), 16, 12, ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, usize::MAX / 8, ptr::null_mut()) },
        WeftResult::InvalidArgument
    );
    let mut d = weft_error_none();
    assert_eq!(
        unsafe { weft_world_set_positions(w, p, 17, 12, &mut d) },
        WeftResult::CountMismatch
    );
    assert_eq!((d.result, d.needed), (WeftResult::CountMismatch, 16));
    // one channel for const calls too: a short output names the count it needs, and a
    // success leaves an OK detail
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 15, 12, &mut d) },
        WeftResult::CountMismatch
    );
    assert_eq!(
        (d.result, d.needed, what(&d).as_str()),
        (WeftResult::CountMismatch, 16, "count")
    );
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 12, &mut d) },
        WeftResult::Ok
    );
    assert_eq!((d.result, d.needed), (WeftResult::Ok, WEFT_NONE));

    // A NaN anywhere: refused with its vertex, and nothing changed.
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 12, ptr::null_mut()) },
        WeftResult::Ok
    );
    let before = buf.clone();
    let mut edited = buf.clone();
    edited[3].x = 5.0;
    edited[9].y = f32::NAN;
    let r = unsafe { weft_world_set_positions(w, edited.as_ptr().cast(), 16, 12, &mut d) };
    assert_eq!(r, WeftResult::NonFinite);
    assert_eq!((d.vertex, what(&d).as_str()), (9, "positions"));
    assert_eq!(
        unsafe { weft_world_get_positions(w, p, 16, 12, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(buf, before);
    let r =
        unsafe { weft_world_set_velocities(w, edited.as_ptr().cast(), 16, 12, ptr::null_mut()) };
    assert_eq!(r, WeftResult::NonFinite);
    edited[9].y = 0.0;
    assert_eq!(
        unsafe { weft_world_set_velocities(w, edited.as_ptr().cast(), 16, 12, ptr::null_mut()) },
        WeftResult::Ok
    );
    let mut vel = vec![WeftVec3::default(); 16];
    assert_eq!(
        unsafe { weft_world_get_velocities(w, vel.as_mut_ptr().cast(), 16, 12, ptr::null_mut()) },
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
    let v = |x, y, z| WeftVec3 { x, y, z };

    // The solver.
    assert_eq!(
        unsafe { weft_world_set_solver(w, 7, &mut d) },
        WeftResult::InvalidArgument
    );
    assert_eq!(what(&d), "solver");
    assert_eq!(
        unsafe { weft_world_set_solver(w, WEFT_SOLVER_BLOCK_JACOBI, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_solver(w, WEFT_SOLVER_MULTIGRID_LINES, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_solver(w, WEFT_SOLVER_MULTIGRID, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_solver(ptr::null_mut(), WEFT_SOLVER_MULTIGRID, ptr::null_mut()) },
        WeftResult::NullPointer
    );

    // Pins.
    assert_eq!(
        unsafe { weft_world_set_pin(w, 16, v(0.0, 0.0, 0.0), &mut d) },
        WeftResult::VertexOutOfRange
    );
    assert_eq!(d.vertex, 16);
    assert_eq!(
        unsafe { weft_world_set_pin(w, 3, v(f32::NAN, 0.0, 0.0), &mut d) },
        WeftResult::NonFinite
    );
    assert_eq!((d.vertex, what(&d).as_str()), (3, "target"));
    assert_eq!(
        unsafe { weft_world_set_pin(w, 0, v(0.0, 0.0, 0.5), ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 1, v(0.1, 0.0, 0.5), ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 1, v(0.1, 0.0, 0.6), ptr::null_mut()) },
        WeftResult::Ok,
        "moving a pin"
    );
    assert_eq!(
        unsafe { weft_world_set_pin(w, 2, v(0.1, 0.0, 0.5), &mut d) },
        WeftResult::PinCapacity
    );
    assert_eq!((d.capacity, d.needed), (2, 3));
    assert_eq!(unsafe { weft_world_pin_count(w) }, 2);
    assert_eq!(
        unsafe { weft_world_remove_pin(w, 1, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_remove_pin(w, 1, ptr::null_mut()) },
        WeftResult::Ok,
        "no pin is fine"
    );
    assert_eq!(
        unsafe { weft_world_remove_pin(w, 99, ptr::null_mut()) },
        WeftResult::VertexOutOfRange
    );
    assert_eq!(unsafe { weft_world_pin_count(w) }, 1);

    // Colliders.
    let mut c = weft_default_collider_def();
    let mut index = 77u32;
    c.shape.kind = 4; // not a WEFT_SHAPE_* value
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, &mut d) },
        WeftResult::InvalidArgument
    );
    assert_eq!(what(&d), "shape.kind");
    c.shape = weft_shape_plane(v(0.0, 0.0, 2.0), 0.0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, ptr::null_mut()) },
        WeftResult::InvalidCollider
    );
    c.shape = weft_shape_sphere(v(0.0, 0.0, 0.0), -1.0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, ptr::null_mut()) },
        WeftResult::InvalidCollider
    );
    c.shape = weft_shape_capsule(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), 0.1);
    c.friction = -0.1;
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, &mut d) },
        WeftResult::InvalidCollider
    );
    assert_eq!(what(&d), "friction");
    c.friction = 0.2;
    c.internal_cookie = 0;
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, ptr::null_mut()) },
        WeftResult::Uninitialized
    );
    c.internal_cookie = weft_default_collider_def().internal_cookie;
    assert_eq!(
        unsafe { weft_world_add_collider(w, ptr::null(), &mut index, ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(index, 77, "outputs are untouched on failure");
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(index, 0);
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_add_collider(w, &c, &mut index, ptr::null_mut()) },
        WeftResult::ColliderCapacity
    );
    assert_eq!(unsafe { weft_world_collider_count(w) }, 2);
    let s = weft_shape_sphere(v(0.0, 0.0, 0.0), 0.1);
    assert_eq!(
        unsafe { weft_world_set_collider(w, 2, &s, &mut d) },
        WeftResult::UnknownCollider
    );
    assert_eq!(d.index, 2);
    assert_eq!(
        unsafe { weft_world_set_collider(w, 1, &s, ptr::null_mut()) },
        WeftResult::Ok,
        "a change of kind"
    );
    assert_eq!(
        unsafe { weft_world_clear_colliders(w, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(unsafe { weft_world_collider_count(w) }, 0);

    // Settings round trip; a bad one changes nothing.
    let mut s = weft_default_settings();
    assert_eq!(
        unsafe { weft_world_get_settings(w, &mut s, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(s, weft_default_settings());
    s.substeps = 3;
    s.wind = v(1.0, 0.0, 0.0);
    assert_eq!(
        unsafe { weft_world_set_settings(w, &s, ptr::null_mut()) },
        WeftResult::Ok
    );
    let mut bad = s;
    bad.sleep_velocity = f32::NAN;
    assert_eq!(
        unsafe { weft_world_set_settings(w, &bad, ptr::null_mut()) },
        WeftResult::InvalidSetting
    );
    let mut now = weft_default_settings();
    assert_eq!(
        unsafe { weft_world_get_settings(w, &mut now, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(now, s);
    assert_eq!(
        unsafe { weft_world_set_effects(w, WEFT_EFFECT_ALL, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        unsafe { weft_world_set_effects(w, WEFT_EFFECT_ALL + 1, ptr::null_mut()) },
        WeftResult::InvalidSetting
    );

    // Steps.
    let mut stats = WeftStepStats {
        iterations: 12345,
        ..WeftStepStats::default()
    };
    for dt in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        assert_eq!(
            unsafe { weft_world_step(w, dt, &mut stats, ptr::null_mut()) },
            WeftResult::InvalidTimeStep
        );
    }
    assert_eq!(stats.iterations, 12345, "outputs are untouched on failure");
    assert_eq!(
        unsafe { weft_world_step(w, 1.0 / 60.0, &mut stats, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(stats.substeps, 3);
    assert!(stats.iterations > 0 && stats.converged == 1);
    assert_eq!(
        unsafe { weft_world_wake(w, ptr::null_mut()) },
        WeftResult::Ok
    );
}

/// A world created 10 km away simulates around the origin it chose; positions in and out are
/// the caller's; `weft_world_set_origin` and `weft_world_shift_origin` behave as the kernel's
/// and refuse non-finite origins.
#[test]
fn origin_is_chosen_at_create_and_converts_vertex_io() {
    let mut mesh = Mesh::grid(4, 0.5, 1.0);
    for p in &mut mesh.positions {
        p.x += 10_000.0;
    }
    let mut block = Block::for_capacity(&small_capacity());
    let w = live(&mesh, &mut block);
    let mut o = WeftDVec3::default();
    assert_eq!(
        unsafe { weft_world_get_origin(w, &mut o, ptr::null_mut()) },
        WeftResult::Ok
    );
    // the centre (10000.25, 0.5, 0) to the grid
    assert_eq!((o.x, o.y, o.z), (10_000.0, 0.0, 0.0));
    assert_eq!(WEFT_ORIGIN_GRID, 4.0);
    let get = || {
        let mut out = vec![WeftVec3::default(); mesh.positions.len()];
        let n = out.len() as u32;
        let r =
            unsafe { weft_world_get_positions(w, out.as_mut_ptr().cast(), n, 12, ptr::null_mut()) };
        assert_eq!(r, WeftResult::Ok);
        out
    };
    assert_eq!(get(), mesh.positions, "the caller's positions, bit for bit");
    // a range in and out, in the caller's coordinates
    let mut range = [WeftVec3::default(); 3];
    let get_range = |range: &mut [WeftVec3; 3]| unsafe {
        weft_world_get_positions_range(w, 2, 3, range.as_mut_ptr().cast(), 12, ptr::null_mut())
    };
    assert_eq!(get_range(&mut range), WeftResult::Ok);
    assert_eq!(range[..], mesh.positions[2..5]);
    let lifted = range.map(|p| WeftVec3 { z: p.z + 0.25, ..p });
    let r = unsafe {
        weft_world_set_positions_range(w, 2, 3, lifted.as_ptr().cast(), 12, ptr::null_mut())
    };
    assert_eq!(r, WeftResult::Ok);
    assert_eq!(get_range(&mut range), WeftResult::Ok);
    assert_eq!(range, lifted);
    let r = unsafe {
        let n = mesh.positions.len() as u32;
        weft_world_set_positions(w, mesh.positions.as_ptr().cast(), n, 12, ptr::null_mut())
    };
    assert_eq!(r, WeftResult::Ok);
    // a teleport 5 km along x and back: exact here, and the origin follows the cloth
    let teleport = |dx: f32| unsafe {
        let identity = WeftQuat {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        };
        let t = WeftVec3 {
            x: dx,
            y: 0.0,
            z: 0.0,
        };
        weft_world_transform(w, identity, t, 0, ptr::null_mut())
    };
    assert_eq!(teleport(5_000.0), WeftResult::Ok);
    let there: Vec<WeftVec3> = mesh
        .positions
        .iter()
        .map(|p| WeftVec3 {
            x: p.x + 5_000.0,
            ..*p
        })
        .collect();
    assert_eq!(get(), there);
    assert_eq!(
        unsafe { weft_world_get_origin(w, &mut o, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!((o.x, o.y, o.z), (15_000.0, 0.0, 0.0));
    assert_eq!(teleport(-5_000.0), WeftResult::Ok);
    assert_eq!(get(), mesh.positions);
    // another origin than the one it chose
    let here = WeftDVec3 {
        x: 10_016.0,
        y: 0.0,
        z: 0.0,
    };
    assert_eq!(
        unsafe { weft_world_set_origin(w, here, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(get(), mesh.positions);
    assert_eq!(
        unsafe { weft_world_shift_origin(w, here, ptr::null_mut()) },
        WeftResult::Ok
    );
    let shifted: Vec<WeftVec3> = mesh
        .positions
        .iter()
        .map(|p| WeftVec3 {
            x: p.x - 10_016.0,
            ..*p
        })
        .collect();
    assert_eq!(get(), shifted);
    let bad = WeftDVec3 {
        x: f64::NAN,
        ..here
    };
    assert_eq!(
        unsafe { weft_world_set_origin(w, bad, ptr::null_mut()) },
        WeftResult::NonFinite
    );
    assert_eq!(
        unsafe { weft_world_shift_origin(w, bad, ptr::null_mut()) },
        WeftResult::NonFinite
    );
    assert_eq!(
        unsafe { weft_world_get_origin(w, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(
        unsafe { weft_world_get_origin(w, &mut o, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!((o.x, o.y, o.z), (0.0, 0.0, 0.0));
}

// ---------------------------------------------------------------------------------------------
// Localization
// ---------------------------------------------------------------------------------------------

use glam::Vec3A;
use weft::collide::{Collider, ColliderSet, Shape};
use weft::localize::{self, Binding, NormalTarget, StrainMeasure, VertexFrame};
use weft::strided::{Strided, StridedMut};

/// A 16-aligned buffer of `size` bytes filled with `fill`.
struct Buf {
    words: Vec<u128>,
    size: usize,
}

impl Buf {
    fn new(size: usize, fill: u8) -> Buf {
        let mut b = Buf {
            words: vec![0; size.div_ceil(16) + 1],
            size,
        };
        b.bytes_mut().fill(fill);
        b
    }
    fn ptr(&mut self) -> *mut std::ffi::c_void {
        self.words.as_mut_ptr().cast()
    }
    fn bytes(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.size]
    }
    fn bytes_mut(&mut self) -> &mut [u8] {
        &mut bytemuck::cast_slice_mut(&mut self.words)[..self.size]
    }
}

/// A C world hanging from two corners of its far edge, stepped `frames` frames, and the blob's
/// cell 0 tiled over it (uvs, indices, materials).
struct Scene {
    mesh: Mesh,
    /// The world's memory (the handle points into it).
    _block: Block,
    w: *mut WeftWorld,
    fine_uv: Vec<WeftVec2>,
    fine_idx: Vec<u32>,
    fine_mat: Vec<u32>,
}

fn scene(n: usize, side: f32, frames: usize) -> Scene {
    let mesh = Mesh::grid(n, side, 0.5);
    let mut def = mesh.def();
    def.capacity = small_capacity();
    def.settings.substeps = 2;
    let mut block = Block::for_capacity(&def.capacity);
    let (r, w, d) = create(&def, &mut block);
    assert_eq!(r, WeftResult::Ok, "{d:?}");
    for c in [(n * (n - 1)) as u32, (n * n - 1) as u32] {
        let p = mesh.positions[c as usize];
        assert_eq!(
            unsafe { weft_world_set_pin(w, c, p, ptr::null_mut()) },
            WeftResult::Ok
        );
    }
    for _ in 0..frames {
        assert_eq!(
            unsafe { weft_world_step(w, 1.0 / 60.0, ptr::null_mut(), ptr::null_mut()) },
            WeftResult::Ok
        );
    }
    let (mut nv, mut nt) = (0u32, 0u32);
    let r = unsafe { weft_tiled_mesh_counts(w, 0, &mut nv, &mut nt, ptr::null_mut()) };
    assert_eq!(r, WeftResult::Ok);
    let mut fine_uv = vec![WeftVec2::default(); nv as usize];
    let mut fine_idx = vec![0u32; 3 * nt as usize];
    let mut fine_mat = vec![0u32; nt as usize];
    let r = unsafe {
        weft_tiled_mesh(
            w,
            0,
            fine_uv.as_mut_ptr(),
            nv,
            fine_idx.as_mut_ptr(),
            nt,
            fine_mat.as_mut_ptr(),
            ptr::null_mut(),
        )
    };
    assert_eq!(r, WeftResult::Ok);
    Scene {
        mesh,
        _block: block,
        w,
        fine_uv,
        fine_idx,
        fine_mat,
    }
}

impl Scene {
    fn nv(&self) -> u32 {
        self.fine_uv.len() as u32
    }
    /// Binds the tiled mesh: the block and its size.
    fn bind(&self) -> (Vec<u32>, usize) {
        let mut size = 0;
        assert_eq!(
            unsafe { weft_bind_memory_size(self.nv(), &mut size, ptr::null_mut()) },
            WeftResult::Ok
        );
        let mut block = vec![0u32; size / 4];
        let r = unsafe {
            weft_bind(
                self.w,
                self.fine_uv.as_ptr().cast(),
                self.nv(),
                8,
                block.as_mut_ptr().cast(),
                size,
                ptr::null_mut(),
            )
        };
        assert_eq!(r, WeftResult::Ok);
        (block, size)
    }
    fn frames(&self, measure: u32) -> Buf {
        let mut size = 0;
        assert_eq!(
            unsafe { weft_localize_frames_size(self.w, &mut size, ptr::null_mut()) },
            WeftResult::Ok
        );
        let mut f = Buf::new(size, 0xcd);
        let r = unsafe { weft_localize_prepare(self.w, measure, f.ptr(), size, ptr::null_mut()) };
        assert_eq!(r, WeftResult::Ok);
        f
    }
    fn positions(&self) -> Vec<[f32; 3]> {
        let n = self.mesh.positions.len();
        let mut out = vec![[0.0f32; 3]; n];
        let r = unsafe {
            weft_world_get_positions(
                self.w,
                out.as_mut_ptr().cast(),
                n as u32,
                12,
                ptr::null_mut(),
            )
        };
        assert_eq!(r, WeftResult::Ok);
        out
    }
    fn triangles(&self) -> Vec<[u32; 3]> {
        self.mesh
            .indices
            .chunks(3)
            .map(|t| [t[0], t[1], t[2]])
            .collect()
    }
    /// The same cloth as a kernel world at rest (for the kernel's bind and tiled mesh, which
    /// only read the rest shape), handed to `f`.
    fn with_kernel_world<R>(&self, f: impl FnOnce(&World<'_>, &weft::blob::Blob<'_>) -> R) -> R {
        let blob = weft::blob::Blob::parse(blob_bytes()).unwrap();
        let positions: Vec<[f32; 3]> = self
            .mesh
            .positions
            .iter()
            .map(|p| [p.x, p.y, p.z])
            .collect();
        let uvs: Vec<[f32; 2]> = self.mesh.uvs.iter().map(|p| [p.x, p.y]).collect();
        let triangles = self.triangles();
        let materials = vec![0u32; triangles.len()];
        let cap = Capacity {
            vertices: 64,
            triangles: 128,
            edges: 256,
            colliders: 2,
            pins: 2,
        };
        let mut mem = vec![0u8; cap.world_bytes()];
        let cloth = ClothDef {
            positions: &positions,
            uvs: &uvs,
            triangles: &triangles,
            materials: &materials,
        };
        let k = World::new(
            &mut mem,
            cap,
            &cloth,
            Materials::Blob(&blob),
            Settings::default(),
        )
        .unwrap();
        f(&k, &blob)
    }
    /// The kernel's frames for the C world's current positions.
    fn kernel_frames(&self, measure: StrainMeasure) -> Vec<VertexFrame> {
        let rest: Vec<Vec3A> = self
            .mesh
            .uvs
            .iter()
            .map(|q| Vec3A::new(q.x, q.y, 0.0))
            .collect();
        let pos: Vec<Vec3A> = self.positions().iter().map(|&p| Vec3A::from(p)).collect();
        let mut frames = vec![VertexFrame::REST; pos.len()];
        localize::prepare_mesh(&rest, &pos, &self.triangles(), measure, &mut frames).unwrap();
        frames
    }
}

fn frames_of(f: &Buf, n: usize) -> Vec<VertexFrame> {
    let p = f.bytes()[WEFT_LOCALIZE_FRAMES_HEADER_SIZE..].as_ptr();
    (0..n)
        .map(|i| unsafe { p.cast::<VertexFrame>().add(i).read() })
        .collect()
}

fn read3(buf: &[u8], at: usize) -> [f32; 3] {
    std::array::from_fn(|k| f32::from_ne_bytes(buf[at + 4 * k..at + 4 * k + 4].try_into().unwrap()))
}

fn localize_into(
    s: &Scene,
    frames: &mut Buf,
    bindings: &[u32],
    size: usize,
    first: u32,
    count: u32,
    out: &WeftLocalizeOutput,
) -> (WeftResult, WeftErrorDetail) {
    let mut d = weft_error_none();
    let r = unsafe {
        weft_localize(
            s.w,
            frames.ptr(),
            bindings.as_ptr().cast(),
            size,
            first,
            count,
            out,
            &mut d,
        )
    };
    assert_eq!(d.result, r);
    (r, d)
}

/// Interleaved fine records of 31 bytes: a flag byte, the position at 1, the normal at 13, six
/// untouched bytes (every float unaligned).
const FSTRIDE: usize = 31;

#[test]
fn localization_matches_the_kernel_bit_for_bit() {
    let s = scene(7, 0.03, 40);
    let nv = s.nv() as usize;
    let tris = s.triangles();

    // The tiled mesh and the bindings are the kernel's.
    let (kb, kuv, ktri, kmat) = s.with_kernel_world(|k, blob| {
        let (n, t) = localize::tiled_mesh_counts(k, blob, 0).unwrap();
        let mut uv = vec![[0.0f32; 2]; n];
        let mut tri = vec![[0u32; 3]; t];
        let mut mat = vec![0u32; t];
        localize::tiled_mesh(k, blob, 0, &mut uv, &mut tri, Some(&mut mat)).unwrap();
        let mut b = vec![Binding::ZERO; n];
        localize::bind(k, blob, &Strided::from_slice(&uv), &mut b).unwrap();
        (b, uv, tri, mat)
    });
    assert_eq!(nv, kuv.len());
    assert_eq!(nv, 25 * 25, "a 3 cm cloth on the stripes' 1.25 mm lattice");
    assert!(s.fine_uv.iter().zip(&kuv).all(|(a, b)| [a.x, a.y] == *b));
    assert_eq!(
        s.fine_idx,
        ktri.iter().flatten().copied().collect::<Vec<_>>()
    );
    assert_eq!(s.fine_mat, kmat);
    assert!(
        s.fine_mat.contains(&0) && s.fine_mat.contains(&1),
        "both layers"
    );

    let (bindings, bsize) = s.bind();
    assert_eq!(bsize, WEFT_BIND_HEADER_SIZE + WEFT_BIND_VERTEX_SIZE * nv);
    let records: &[u8] = &bytemuck::cast_slice(&bindings)[WEFT_BIND_HEADER_SIZE..];
    assert_eq!(records, bytemuck::cast_slice::<Binding, u8>(&kb));
    let mut count = 0;
    assert_eq!(
        unsafe {
            weft_bind_vertex_count(bindings.as_ptr().cast(), bsize, &mut count, ptr::null_mut())
        },
        WeftResult::Ok
    );
    assert_eq!(count as usize, nv);

    // Frames: the kernel's for the world's current positions.
    let mut frames = s.frames(WEFT_STRAIN_COROTATED);
    let mut fsize = 0;
    assert_eq!(
        unsafe { weft_localize_frames_size(s.w, &mut fsize, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(fsize, WEFT_LOCALIZE_FRAMES_HEADER_SIZE + 80 * 49);
    let kf = s.kernel_frames(StrainMeasure::Corotated);
    assert_eq!(frames_of(&frames, 49), kf);

    // Kernel positions and blended normals.
    let mut kp = vec![[0.0f32; 3]; nv];
    let mut kn = vec![[0.0f32; 3]; nv];
    localize::localize(
        &kf,
        &tris,
        &kb,
        0,
        &mut StridedMut::from_slice(&mut kp),
        Some(NormalTarget::Buffer(&mut StridedMut::from_slice(&mut kn))),
    )
    .unwrap();

    // Through C: an interleaved, packed, unaligned vertex buffer.
    let mut vb = vec![0xeeu8; nv * FSTRIDE];
    let mut out = weft_default_localize_output();
    out.positions = unsafe { vb.as_mut_ptr().add(1) }.cast();
    out.position_stride = FSTRIDE;
    out.normals = unsafe { vb.as_mut_ptr().add(13) }.cast();
    out.normal_stride = FSTRIDE;
    let (r, d) = localize_into(&s, &mut frames, &bindings, bsize, 0, nv as u32, &out);
    assert_eq!(r, WeftResult::Ok, "{d:?} {}", what(&d));
    for i in 0..nv {
        let at = i * FSTRIDE;
        assert_eq!(read3(&vb, at + 1), kp[i], "position {i}");
        assert_eq!(read3(&vb, at + 13), kn[i], "normal {i}");
        assert_eq!(vb[at], 0xee);
        assert!(vb[at + 25..at + FSTRIDE].iter().all(|&b| b == 0xee));
    }

    // Ranges compose into the whole call, sequentially and from two threads at once.
    let mut pieces = vec![0xeeu8; nv * FSTRIDE];
    for (first, end) in [(0, nv / 3), (nv / 3, nv / 2), (nv / 2, nv)] {
        let mut o = out;
        let base = unsafe { pieces.as_mut_ptr().add(first * FSTRIDE) };
        o.positions = unsafe { base.add(1) }.cast();
        o.normals = unsafe { base.add(13) }.cast();
        let (r, _) = localize_into(
            &s,
            &mut frames,
            &bindings,
            bsize,
            first as u32,
            (end - first) as u32,
            &o,
        );
        assert_eq!(r, WeftResult::Ok);
    }
    assert_eq!(pieces, vb);
    let mut threaded = vec![0xeeu8; nv * FSTRIDE];
    let (world, fr, bp) = (
        s.w as usize,
        frames.ptr() as usize,
        bindings.as_ptr() as usize,
    );
    let (lo, hi) = threaded.split_at_mut((nv / 2) * FSTRIDE);
    std::thread::scope(|sc| {
        for (first, part) in [(0, lo), (nv / 2, hi)] {
            sc.spawn(move || {
                let count = part.len() / FSTRIDE;
                let mut o = weft_default_localize_output();
                let base = part.as_mut_ptr();
                o.positions = unsafe { base.add(1) }.cast();
                o.position_stride = FSTRIDE;
                o.normals = unsafe { base.add(13) }.cast();
                o.normal_stride = FSTRIDE;
                let r = unsafe {
                    weft_localize(
                        world as *const WeftWorld,
                        fr as *const std::ffi::c_void,
                        bp as *const std::ffi::c_void,
                        bsize,
                        first as u32,
                        count as u32,
                        &o,
                        ptr::null_mut(),
                    )
                };
                assert_eq!(r, WeftResult::Ok);
            });
        }
    });
    assert_eq!(threaded, vb);

    // Recomputed normals, interleaved, from the fine triangles: the kernel's.
    let mut kr = vec![[0.0f32; 3]; nv];
    localize::recompute_normals(
        &ktri,
        &mut StridedMut::from_slice(&mut kp),
        NormalTarget::Buffer(&mut StridedMut::from_slice(&mut kr)),
    )
    .unwrap();
    let mut rb = vec![0u8; nv * FSTRIDE];
    let mut o = out;
    o.positions = unsafe { rb.as_mut_ptr().add(1) }.cast();
    o.normals = unsafe { rb.as_mut_ptr().add(13) }.cast();
    o.normal_mode = WEFT_NORMALS_RECOMPUTED;
    o.fine_indices = s.fine_idx.as_ptr();
    o.fine_triangle_count = (s.fine_idx.len() / 3) as u32;
    let (r, _) = localize_into(&s, &mut frames, &bindings, bsize, 0, nv as u32, &o);
    assert_eq!(r, WeftResult::Ok);
    for i in 0..nv {
        assert_eq!(read3(&rb, i * FSTRIDE + 1), kp[i]);
        assert_eq!(read3(&rb, i * FSTRIDE + 13), kr[i], "recomputed normal {i}");
    }
    // The micro pattern shows in the recomputed normals, not in the blended ones.
    let spread = |n: &[[f32; 3]]| {
        n.iter()
            .map(|a| Vec3A::from(*a).dot(Vec3A::from(n[nv / 2])))
            .fold(1.0f32, f32::min)
    };
    assert!(spread(&kr) <= spread(&kn));

    // Normals before the positions in the record, and a separate normals buffer.
    let mut swapped = vec![0u8; nv * 24];
    let mut o = weft_default_localize_output();
    o.positions = unsafe { swapped.as_mut_ptr().add(12) }.cast();
    o.position_stride = 24;
    o.normals = swapped.as_mut_ptr().cast();
    o.normal_stride = 24;
    assert_eq!(
        localize_into(&s, &mut frames, &bindings, bsize, 0, nv as u32, &o).0,
        WeftResult::Ok
    );
    let mut sep_p = vec![[0.0f32; 3]; nv];
    let mut sep_n = vec![[0.0f32; 3]; nv];
    let mut o = weft_default_localize_output();
    o.positions = sep_p.as_mut_ptr().cast();
    o.normals = sep_n.as_mut_ptr().cast();
    assert_eq!(
        localize_into(&s, &mut frames, &bindings, bsize, 0, nv as u32, &o).0,
        WeftResult::Ok
    );
    for i in 0..nv {
        assert_eq!(
            (read3(&swapped, 24 * i + 12), read3(&swapped, 24 * i)),
            (kp[i], kn[i])
        );
        assert_eq!((sep_p[i], sep_n[i]), (kp[i], kn[i]));
    }

    // Green strain: the kernel's too.
    let mut green = s.frames(WEFT_STRAIN_GREEN);
    let kg = s.kernel_frames(StrainMeasure::Green);
    assert_eq!(frames_of(&green, 49), kg);
    let mut gp = vec![[0.0f32; 3]; nv];
    let mut kgp = vec![[0.0f32; 3]; nv];
    localize::localize(
        &kg,
        &tris,
        &kb,
        0,
        &mut StridedMut::from_slice(&mut kgp),
        None,
    )
    .unwrap();
    let mut o = weft_default_localize_output();
    o.positions = gp.as_mut_ptr().cast();
    assert_eq!(
        localize_into(&s, &mut green, &bindings, bsize, 0, nv as u32, &o).0,
        WeftResult::Ok
    );
    assert_eq!(gp, kgp);

    // Real numbers: the fine mesh spans the hanging coarse cloth, to within the micro
    // displacement (well under 0.1 mm here), and it did move off its rest plane.
    let bbox = |pts: &mut dyn Iterator<Item = [f32; 3]>| {
        pts.fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        })
    };
    let coarse = bbox(&mut s.positions().into_iter());
    let fine = bbox(&mut sep_p.iter().copied());
    for k in 0..3 {
        assert!(
            (coarse.0[k] - fine.0[k]).abs() < 1e-4,
            "{coarse:?} {fine:?}"
        );
        assert!(
            (coarse.1[k] - fine.1[k]).abs() < 1e-4,
            "{coarse:?} {fine:?}"
        );
    }
    assert!(coarse.0[2] < 0.5 - 0.01, "the cloth hangs: {coarse:?}");
}

/// `WEFT_COLLIDERS_OUTSIDE` pushes the fine vertices out of the world's colliders exactly as
/// the kernel's `localize_colliding` does; `WEFT_COLLIDERS_IGNORED` is the plain placement.
#[test]
fn localization_outside_colliders_matches_the_kernel_bit_for_bit() {
    let s = scene(7, 0.03, 40);
    let nv = s.nv() as usize;
    let tris = s.triangles();
    let middle = s.positions()[3 * 7 + 3];
    let mut def = weft_default_collider_def();
    let [x, y, z] = middle;
    def.shape = weft_shape_sphere(WeftVec3 { x, y, z }, 0.008);
    assert_eq!(
        unsafe { weft_world_add_collider(s.w, &def, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::Ok
    );
    let centre = Vec3A::from(middle);
    let sphere = Shape::Sphere {
        center: centre,
        radius: 0.008,
    };
    let colliders = [Collider::new(sphere, def.friction, def.thickness)];
    let kb = s.with_kernel_world(|k, blob| {
        let mut b = vec![Binding::ZERO; nv];
        let uv: Vec<[f32; 2]> = s.fine_uv.iter().map(|q| [q.x, q.y]).collect();
        localize::bind(k, blob, &Strided::from_slice(&uv), &mut b).unwrap();
        b
    });
    let kf = s.kernel_frames(StrainMeasure::Corotated);
    let coarse = localize::Coarse {
        frames: &kf,
        triangles: &tris,
    };
    let kernel = |set: ColliderSet<'_>| {
        let mut kp = vec![[0.0f32; 3]; nv];
        let mut pos = StridedMut::from_slice(&mut kp);
        localize::localize_colliding(coarse, &kb, 0, &mut pos, None, set).unwrap();
        kp
    };
    let (bindings, bsize) = s.bind();
    let mut frames = s.frames(WEFT_STRAIN_COROTATED);
    let mut through_c = |mode: u32| {
        let mut p = vec![[f32::NAN; 3]; nv];
        let mut out = weft_default_localize_output();
        out.positions = p.as_mut_ptr().cast();
        out.collider_mode = mode;
        let (r, d) = localize_into(&s, &mut frames, &bindings, bsize, 0, nv as u32, &out);
        assert_eq!(r, WeftResult::Ok, "{d:?} {}", what(&d));
        p
    };
    let ignored = through_c(WEFT_COLLIDERS_IGNORED);
    let outside = through_c(WEFT_COLLIDERS_OUTSIDE);
    assert_eq!(ignored, kernel(ColliderSet::new(&[])));
    assert_eq!(outside, kernel(ColliderSet::new(&colliders)));
    let inside = |p: &[f32; 3]| (Vec3A::from(*p) - centre).length() < 0.008;
    let pushed = ignored.iter().filter(|p| inside(p)).count();
    assert!(pushed > 10, "the sphere holds {pushed} fine vertices");
    assert!(!outside.iter().any(inside));
}

#[test]
fn localization_errors_name_their_cause_and_write_nothing() {
    let s = scene(5, 0.02, 5);
    let nv = s.nv();
    let (bindings, bsize) = s.bind();
    let mut frames = s.frames(WEFT_STRAIN_COROTATED);
    let mut d = weft_error_none();
    let junk = vec![0x5au128; WEFT_WORLD_HEADER_SIZE / 16];
    let junk_world = junk.as_ptr().cast::<WeftWorld>();

    // --- weft_bind_memory_size, weft_bind
    let mut size = 7usize;
    assert_eq!(
        unsafe { weft_bind_memory_size(3, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(
        unsafe { weft_bind_memory_size(0, &mut size, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(size, WEFT_BIND_HEADER_SIZE);
    let mut out = Buf::new(bsize + 64, 0xab);
    let pristine = out.bytes().to_vec();
    let uv = s.fine_uv.clone();
    let bind = |world: *const WeftWorld,
                uv: *const WeftVec2,
                n: u32,
                stride: usize,
                out: *mut std::ffi::c_void,
                size: usize,
                d: &mut WeftErrorDetail| unsafe {
        let r = weft_bind(world, uv.cast(), n, stride, out, size, d);
        assert_eq!(d.result, r);
        r
    };
    let op = out.ptr();
    let odd_out = unsafe { op.cast::<u8>().add(2).cast() };
    let up = uv.as_ptr();
    type Call<'a> = &'a dyn Fn(&mut WeftErrorDetail) -> WeftResult;
    let cases: [(WeftResult, &str, Call); 7] = [
        (WeftResult::NullPointer, "world", &|d| {
            bind(ptr::null(), up, nv, 8, op, bsize, d)
        }),
        (WeftResult::InvalidHandle, "", &|d| {
            bind(junk_world, up, nv, 8, op, bsize, d)
        }),
        (WeftResult::NullPointer, "fine_uvs", &|d| {
            bind(s.w, ptr::null(), nv, 8, op, bsize, d)
        }),
        (WeftResult::NullPointer, "out_bindings", &|d| {
            bind(s.w, up, nv, 8, ptr::null_mut(), bsize, d)
        }),
        (WeftResult::Misaligned, "out_bindings", &|d| {
            bind(s.w, up, nv, 8, odd_out, bsize, d)
        }),
        (WeftResult::InvalidArgument, "uv_stride", &|d| {
            bind(s.w, up, nv, 4, op, bsize, d)
        }),
        (WeftResult::InvalidArgument, "uv_stride", &|d| {
            bind(s.w, up, nv, usize::MAX / 2, op, bsize, d)
        }),
    ];
    for (want, name, run) in cases {
        let got = run(&mut d);
        assert_eq!((got, what(&d).as_str()), (want, name));
        assert_eq!(out.bytes(), pristine, "{want:?} wrote its output");
    }
    // Too small: the detail says how many were asked for and how many fit.
    let r = bind(s.w, uv.as_ptr(), nv, 8, op, bsize - 1, &mut d);
    assert_eq!(
        (r, d.needed, d.capacity),
        (WeftResult::BindMemoryTooSmall, nv, nv - 1)
    );
    let r = bind(s.w, uv.as_ptr(), nv, 8, op, 3, &mut d);
    assert_eq!((r, d.capacity), (WeftResult::BindMemoryTooSmall, 0));
    // Out of the cloth's (u, v), or not finite: the lowest such vertex is named.
    for (i, bad) in [
        (17usize, [0.021f32, 0.01]),
        (3, [f32::NAN, 0.0]),
        (9, [0.01, -0.5]),
    ] {
        let mut uv = s.fine_uv.clone();
        uv[i] = WeftVec2 {
            x: bad[0],
            y: bad[1],
        };
        uv[i + 20] = WeftVec2 { x: 5.0, y: 5.0 };
        let r = bind(s.w, uv.as_ptr(), nv, 8, op, bsize, &mut d);
        assert_eq!((r, d.vertex), (WeftResult::BindOutOfDomain, i as u32));
        assert_eq!(out.bytes(), pristine);
    }
    // Strided input: every other (u, v) of the tiled mesh, read at a 16-byte stride.
    let r = bind(s.w, uv.as_ptr(), nv / 2, 16, op, bsize, &mut d);
    assert_eq!(r, WeftResult::Ok);
    assert_eq!(
        d,
        WeftErrorDetail {
            what: d.what,
            ..weft_error_none()
        }
    );
    let mut count = 0u32;
    assert_eq!(
        unsafe { weft_bind_vertex_count(op, bsize, &mut count, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(count, nv / 2);
    let stride2: &[u8] = &out.bytes()[WEFT_BIND_HEADER_SIZE..];
    let all: &[u8] = &bytemuck::cast_slice(&bindings)[WEFT_BIND_HEADER_SIZE..];
    for k in 0..(nv / 2) as usize {
        let a = &stride2[k * 36..k * 36 + 36];
        let b = &all[2 * k * 36..2 * k * 36 + 36];
        assert_eq!(a, b, "binding {k} of the strided input");
    }
    // No fine vertices is fine too.
    assert_eq!(bind(s.w, ptr::null(), 0, 0, op, 16, &mut d), WeftResult::Ok);

    // --- weft_bind_vertex_count on blocks that are not bindings
    let garbage = vec![0x77u32; 64];
    for (p, size, want) in [
        (garbage.as_ptr().cast(), 256, WeftResult::BindingsInvalid),
        (bindings.as_ptr().cast(), 15, WeftResult::BindingsInvalid),
        (
            bindings.as_ptr().cast(),
            bsize - 1,
            WeftResult::BindingsInvalid,
        ),
        (ptr::null(), bsize, WeftResult::NullPointer),
        (
            unsafe { bindings.as_ptr().cast::<u8>().add(1).cast() },
            bsize,
            WeftResult::Misaligned,
        ),
    ] {
        let mut c = 99u32;
        assert_eq!(
            unsafe { weft_bind_vertex_count(p, size, &mut c, ptr::null_mut()) },
            want
        );
        assert_eq!(c, 99);
    }
    assert_eq!(
        unsafe {
            weft_bind_vertex_count(
                bindings.as_ptr().cast(),
                bsize,
                ptr::null_mut(),
                ptr::null_mut(),
            )
        },
        WeftResult::NullPointer
    );

    // --- weft_localize_frames_size, weft_localize_prepare
    assert_eq!(
        unsafe { weft_localize_frames_size(s.w, ptr::null_mut(), ptr::null_mut()) },
        WeftResult::NullPointer
    );
    assert_eq!(
        unsafe { weft_localize_frames_size(junk_world, &mut size, ptr::null_mut()) },
        WeftResult::InvalidHandle
    );
    let fsize = WEFT_LOCALIZE_FRAMES_HEADER_SIZE + 25 * WEFT_LOCALIZE_FRAME_SIZE;
    let mut fb = Buf::new(fsize + 32, 0x33);
    let fpristine = fb.bytes().to_vec();
    let fp = fb.ptr();
    let prepare = |measure: u32, p: *mut std::ffi::c_void, size: usize, d: &mut WeftErrorDetail| unsafe {
        let r = weft_localize_prepare(s.w, measure, p, size, d);
        assert_eq!(d.result, r);
        r
    };
    assert_eq!(prepare(2, fp, fsize, &mut d), WeftResult::InvalidArgument);
    assert_eq!(what(&d), "strain_measure");
    assert_eq!(
        prepare(u32::MAX, fp, fsize, &mut d),
        WeftResult::InvalidArgument
    );
    assert_eq!(
        prepare(0, ptr::null_mut(), fsize, &mut d),
        WeftResult::NullPointer
    );
    assert_eq!(what(&d), "frames");
    let odd = unsafe { fp.cast::<u8>().add(8).cast() };
    assert_eq!(prepare(0, odd, fsize, &mut d), WeftResult::Misaligned);
    assert_eq!(
        prepare(0, fp, fsize - 1, &mut d),
        WeftResult::FramesTooSmall
    );
    assert_eq!((d.needed, d.capacity), (25, 24));
    assert_eq!(
        unsafe { weft_localize_prepare(junk_world, 0, fp, fsize, &mut d) },
        WeftResult::InvalidHandle
    );
    assert_eq!(fb.bytes(), fpristine, "a failed prepare wrote its frames");

    // --- weft_localize
    let n = nv as usize;
    let mut vb = vec![0xeeu8; n * FSTRIDE];
    let vpristine = vb.clone();
    let mut good = weft_default_localize_output();
    good.positions = unsafe { vb.as_mut_ptr().add(1) }.cast();
    good.position_stride = FSTRIDE;
    good.normals = unsafe { vb.as_mut_ptr().add(13) }.cast();
    good.normal_stride = FSTRIDE;
    let bp: *const std::ffi::c_void = bindings.as_ptr().cast();
    let call = |world: *const WeftWorld,
                frames: *const std::ffi::c_void,
                b: *const std::ffi::c_void,
                bs: usize,
                first: u32,
                count: u32,
                o: *const WeftLocalizeOutput,
                d: &mut WeftErrorDetail| unsafe {
        let r = weft_localize(world, frames, b, bs, first, count, o, d);
        assert_eq!(d.result, r);
        r
    };
    let fr = frames.ptr();
    let with = |f: &dyn Fn(&mut WeftLocalizeOutput)| {
        let mut o = good;
        f(&mut o);
        o
    };
    let mut zeroed: WeftLocalizeOutput = unsafe { std::mem::zeroed() };
    zeroed.positions = good.positions;
    let unprepared = Buf::new(fsize, 0);
    // A copy of prepared frames somewhere else is not prepared frames.
    let mut moved = Buf::new(frames.size, 0);
    moved.bytes_mut().copy_from_slice(frames.bytes());
    // Frames and bindings of another world: a 4 × 4 cloth.
    let other = scene(4, 0.02, 0);
    let (other_b, other_bs) = other.bind();
    let mut other_f = other.frames(WEFT_STRAIN_COROTATED);
    let other_fp = other_f.ptr();
    // A binding damaged in storage (its header intact).
    let mut damaged = bindings.clone();
    damaged[WEFT_BIND_HEADER_SIZE / 4 + 9 * 9] = 1000; // binding 9's triangle
    let bad_tri = [0u32, 1, 2, 3, 4, 5, 6, 7, nv];
    type Case<'a> = (
        &'a str,
        WeftResult,
        Box<dyn Fn(&mut WeftErrorDetail) -> WeftResult + 'a>,
    );
    let mut_moved = moved.ptr();
    let mut_unprepared = unprepared.words.as_ptr().cast::<std::ffi::c_void>();
    let cases: Vec<Case> = vec![
        (
            "world",
            WeftResult::NullPointer,
            Box::new(|d| call(ptr::null(), fr, bp, bsize, 0, nv, &good, d)),
        ),
        (
            "",
            WeftResult::InvalidHandle,
            Box::new(|d| call(junk_world, fr, bp, bsize, 0, nv, &good, d)),
        ),
        (
            "output",
            WeftResult::NullPointer,
            Box::new(|d| call(s.w, fr, bp, bsize, 0, nv, ptr::null(), d)),
        ),
        (
            "output",
            WeftResult::Uninitialized,
            Box::new(|d| call(s.w, fr, bp, bsize, 0, nv, &zeroed, d)),
        ),
        (
            "output.normal_mode",
            WeftResult::InvalidArgument,
            Box::new(|d| {
                let o = with(&|o| o.normal_mode = 2);
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.collider_mode",
            WeftResult::InvalidArgument,
            Box::new(|d| {
                let o = with(&|o| o.collider_mode = 2);
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "frames",
            WeftResult::NullPointer,
            Box::new(|d| call(s.w, ptr::null(), bp, bsize, 0, nv, &good, d)),
        ),
        (
            "frames",
            WeftResult::Misaligned,
            Box::new(|d| {
                let odd = unsafe { fr.cast::<u8>().add(4).cast() };
                call(s.w, odd, bp, bsize, 0, nv, &good, d)
            }),
        ),
        (
            "frames",
            WeftResult::FramesNotPrepared,
            Box::new(|d| call(s.w, mut_unprepared, bp, bsize, 0, nv, &good, d)),
        ),
        (
            "frames",
            WeftResult::FramesNotPrepared,
            Box::new(|d| call(s.w, mut_moved, bp, bsize, 0, nv, &good, d)),
        ),
        (
            "frames",
            WeftResult::FramesMismatch,
            Box::new(|d| call(s.w, other_fp, bp, bsize, 0, nv, &good, d)),
        ),
        (
            "bindings",
            WeftResult::NullPointer,
            Box::new(|d| call(s.w, fr, ptr::null(), bsize, 0, nv, &good, d)),
        ),
        (
            "bindings",
            WeftResult::Misaligned,
            Box::new(|d| {
                let odd = unsafe { bp.cast::<u8>().add(2).cast() };
                call(s.w, fr, odd, bsize, 0, nv, &good, d)
            }),
        ),
        (
            "bindings",
            WeftResult::BindingsInvalid,
            Box::new(|d| call(s.w, fr, garbage.as_ptr().cast(), 256, 0, 1, &good, d)),
        ),
        (
            "bindings_size",
            WeftResult::BindingsInvalid,
            Box::new(|d| call(s.w, fr, bp, bsize - 36, 0, nv - 1, &good, d)),
        ),
        (
            "bindings_size",
            WeftResult::BindingsInvalid,
            Box::new(|d| call(s.w, fr, bp, 8, 0, 0, &good, d)),
        ),
        (
            "bindings",
            WeftResult::BindingsMismatch,
            Box::new(|d| call(s.w, fr, other_b.as_ptr().cast(), other_bs, 0, 4, &good, d)),
        ),
        (
            "bindings",
            WeftResult::BindingOutOfRange,
            Box::new(|d| call(s.w, fr, damaged.as_ptr().cast(), bsize, 0, nv, &good, d)),
        ),
        (
            "",
            WeftResult::LocalizeRange,
            Box::new(|d| call(s.w, fr, bp, bsize, 1, nv, &good, d)),
        ),
        (
            "",
            WeftResult::LocalizeRange,
            Box::new(|d| call(s.w, fr, bp, bsize, u32::MAX, 2, &good, d)),
        ),
        (
            "output.positions",
            WeftResult::NullPointer,
            Box::new(|d| {
                let o = with(&|o| o.positions = ptr::null_mut());
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.position_stride",
            WeftResult::InvalidArgument,
            Box::new(|d| {
                let o = with(&|o| o.position_stride = 11);
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.normal_stride",
            WeftResult::InvalidArgument,
            Box::new(|d| {
                let o = with(&|o| o.normal_stride = usize::MAX / 4);
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            // the normal overlaps the position inside each record
            "output.normals",
            WeftResult::NormalLayout,
            Box::new(|d| {
                let o = with(&|o| o.normals = unsafe { o.positions.cast::<u8>().add(8).cast() });
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            // the normal does not fit in its record
            "output.normals",
            WeftResult::NormalLayout,
            Box::new(|d| {
                let o = with(&|o| o.normals = unsafe { o.positions.cast::<u8>().add(20).cast() });
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            // overlapping buffers of different strides
            "output.normals",
            WeftResult::NormalLayout,
            Box::new(|d| {
                let o = with(&|o| o.normal_stride = 24);
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.fine_indices",
            WeftResult::NullPointer,
            Box::new(|d| {
                let o = with(&|o| {
                    o.normal_mode = WEFT_NORMALS_RECOMPUTED;
                    o.fine_triangle_count = 1;
                });
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.fine_indices",
            WeftResult::Misaligned,
            Box::new(|d| {
                let o = with(&|o| {
                    o.normal_mode = WEFT_NORMALS_RECOMPUTED;
                    o.fine_indices = unsafe { s.fine_idx.as_ptr().cast::<u8>().add(1).cast() };
                    o.fine_triangle_count = 1;
                });
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            "output.fine_indices",
            WeftResult::FineIndexOutOfRange,
            Box::new(|d| {
                let o = with(&|o| {
                    o.normal_mode = WEFT_NORMALS_RECOMPUTED;
                    o.fine_indices = bad_tri.as_ptr();
                    o.fine_triangle_count = 3;
                });
                call(s.w, fr, bp, bsize, 0, nv, &o, d)
            }),
        ),
        (
            // indices are relative to `first`: a whole-mesh triangle list is out of range
            // for a range that starts later
            "output.fine_indices",
            WeftResult::FineIndexOutOfRange,
            Box::new(|d| {
                let o = with(&|o| {
                    o.normal_mode = WEFT_NORMALS_RECOMPUTED;
                    o.fine_indices = s.fine_idx.as_ptr();
                    o.fine_triangle_count = (s.fine_idx.len() / 3) as u32;
                });
                call(s.w, fr, bp, bsize, 1, nv - 1, &o, d)
            }),
        ),
    ];
    for (name, want, run) in &cases {
        let mut d = weft_error_none();
        let got = run(&mut d);
        assert_eq!((got, what(&d).as_str()), (*want, *name), "{d:?}");
        assert_eq!(vb, vpristine, "{want:?} wrote an output");
    }
    // The details of range, damaged-binding and index faults.
    let mut d = weft_error_none();
    call(s.w, fr, bp, bsize, 5, nv, &good, &mut d);
    assert_eq!((d.index, d.needed, d.capacity), (5, nv + 5, nv));
    call(
        s.w,
        fr,
        damaged.as_ptr().cast(),
        bsize,
        0,
        nv,
        &good,
        &mut d,
    );
    assert_eq!(d.index, 9);
    call(
        s.w,
        fr,
        damaged.as_ptr().cast(),
        bsize,
        10,
        5,
        &good,
        &mut d,
    );
    assert_eq!(
        d.result,
        WeftResult::Ok,
        "the damaged binding is outside the range"
    );
    vb.copy_from_slice(&vpristine);
    cases[cases.len() - 2].2(&mut d);
    assert_eq!((d.triangle, d.vertex), (2, nv));

    // An empty range writes nothing and needs no buffers.
    let empty = weft_default_localize_output();
    assert_eq!(
        call(s.w, fr, bp, bsize, nv, 0, &empty, &mut d),
        WeftResult::Ok
    );

    // The same cloth in another world (same mesh, same blob) takes the bindings as they are:
    // the block is position-independent, e.g. stored with the mesh asset.
    let twin = scene(5, 0.02, 0);
    let mut twin_f = twin.frames(WEFT_STRAIN_COROTATED);
    let copy = bindings.clone();
    assert_eq!(
        call(
            twin.w,
            twin_f.ptr(),
            copy.as_ptr().cast(),
            bsize,
            0,
            nv,
            &good,
            &mut d
        ),
        WeftResult::Ok
    );
    // ... but not the frames of the first world.
    assert_eq!(
        call(twin.w, fr, bp, bsize, 0, nv, &good, &mut d),
        WeftResult::FramesMismatch
    );
    // The same mesh with a different blob is another cloth.
    let path = |f: &str| {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("cells")
            .join(f)
    };
    let two = weft::homogenize::build_blob(
        &[path("stripes.toml"), path("three.toml")],
        1,
        &mut |_, _| {},
    )
    .unwrap();
    let two = AlignedBytes::copy_from(&two);
    let mut two_blob = std::mem::MaybeUninit::<WeftBlob>::uninit();
    assert_eq!(
        unsafe {
            weft_blob_parse(
                two.as_ptr().cast(),
                two.len(),
                two_blob.as_mut_ptr(),
                ptr::null_mut(),
            )
        },
        WeftResult::Ok
    );
    let two_blob = unsafe { two_blob.assume_init() };
    let mut def = twin.mesh.def();
    def.capacity = small_capacity();
    let mut block = Block::for_capacity(&def.capacity);
    let mut w2 = ptr::null_mut();
    let r = unsafe {
        weft_world_create(
            &def,
            &two_blob,
            block.ptr(),
            block.len(),
            &mut w2,
            ptr::null_mut(),
        )
    };
    assert_eq!(r, WeftResult::Ok);
    let mut f2 = Buf::new(fsize, 0);
    assert_eq!(
        unsafe { weft_localize_prepare(w2, 0, f2.ptr(), fsize, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        call(w2, f2.ptr(), bp, bsize, 0, nv, &good, &mut d),
        WeftResult::BindingsMismatch
    );
    // A destroyed world's frames are refused with its handle.
    assert_eq!(
        unsafe { weft_world_destroy(w2, ptr::null_mut()) },
        WeftResult::Ok
    );
    assert_eq!(
        call(w2, f2.ptr(), bp, bsize, 0, nv, &good, &mut d),
        WeftResult::InvalidHandle
    );
    drop(other_f);
}

#[test]
fn tiled_mesh_reports_its_faults() {
    let s = scene(4, 0.02, 0);
    let mut d = weft_error_none();
    let (mut nv, mut nt) = (0u32, 0u32);
    assert_eq!(
        unsafe { weft_tiled_mesh_counts(s.w, 0, &mut nv, &mut nt, &mut d) },
        WeftResult::Ok
    );
    assert_eq!((nv, nt), (17 * 17, 2 * 16 * 16));
    let (mut v2, mut t2) = (7u32, 7u32);
    assert_eq!(
        unsafe { weft_tiled_mesh_counts(s.w, 1, &mut v2, &mut t2, &mut d) },
        WeftResult::BlobCellOutOfRange
    );
    assert_eq!((d.cell, v2, t2), (1, 7, 7));
    assert_eq!(
        unsafe { weft_tiled_mesh_counts(s.w, 0, ptr::null_mut(), &mut t2, &mut d) },
        WeftResult::NullPointer
    );
    assert_eq!(what(&d), "out_vertex_count");
    assert_eq!(
        unsafe { weft_tiled_mesh_counts(ptr::null(), 0, &mut v2, &mut t2, &mut d) },
        WeftResult::NullPointer
    );

    let mut uv = vec![WeftVec2 { x: -1.0, y: -1.0 }; nv as usize + 1];
    let mut idx = vec![u32::MAX; 3 * nt as usize + 3];
    let mut mat = vec![u32::MAX; nt as usize + 1];
    let tiled = |uv: &mut [WeftVec2],
                 uc: u32,
                 idx: &mut [u32],
                 tc: u32,
                 mat: *mut u32,
                 d: &mut WeftErrorDetail| unsafe {
        let r = weft_tiled_mesh(s.w, 0, uv.as_mut_ptr(), uc, idx.as_mut_ptr(), tc, mat, d);
        assert_eq!(d.result, r);
        r
    };
    let r = tiled(&mut uv, nv - 1, &mut idx, nt, mat.as_mut_ptr(), &mut d);
    assert_eq!(
        (r, d.needed, d.capacity, what(&d).as_str()),
        (WeftResult::TiledMeshCapacity, nv, nv - 1, "uv_capacity")
    );
    let r = tiled(&mut uv, nv, &mut idx, nt - 1, mat.as_mut_ptr(), &mut d);
    assert_eq!(
        (r, d.needed, d.capacity, what(&d).as_str()),
        (
            WeftResult::TiledMeshCapacity,
            nt,
            nt - 1,
            "triangle_capacity"
        )
    );
    let odd = unsafe { mat.as_mut_ptr().cast::<u8>().add(1).cast() };
    assert_eq!(
        tiled(&mut uv, nv, &mut idx, nt, odd, &mut d),
        WeftResult::Misaligned
    );
    assert!(uv.iter().all(|p| p.x == -1.0) && idx.iter().all(|&i| i == u32::MAX));
    assert!(mat.iter().all(|&m| m == u32::MAX));
    // Success writes exactly the counts, materials optional.
    assert_eq!(
        tiled(&mut uv, nv + 1, &mut idx, nt + 1, ptr::null_mut(), &mut d),
        WeftResult::Ok
    );
    assert_eq!(uv[nv as usize].x, -1.0);
    assert_eq!(idx[3 * nt as usize], u32::MAX);
    assert_eq!(
        (uv[0], uv[nv as usize - 1]),
        (WeftVec2 { x: 0.0, y: 0.0 }, WeftVec2 { x: 0.02, y: 0.02 })
    );
    assert!(idx[..3 * nt as usize].iter().all(|&i| i < nv));

    // A tiny cell over a huge cloth: more vertices than 32 bits count.
    let mut huge = Mesh::grid(2, 1000.0, 0.0);
    huge.positions[3].z = 0.5;
    let mut block = Block::for_capacity(&small_capacity());
    let mut def = huge.def();
    def.capacity = small_capacity();
    let (r, hw, _) = create(&def, &mut block);
    assert_eq!(r, WeftResult::Ok);
    let r = unsafe { weft_tiled_mesh_counts(hw, 0, &mut v2, &mut t2, &mut d) };
    assert_eq!((r, d.cell), (WeftResult::TiledMeshTooLarge, 0));
}
