//! The C API from C and C++: the examples in `c_examples/` are compiled against the committed
//! `include/weft.h` and the shipped static library (built once per run by
//! `scripts/build-staticlib.sh`: no_std, panic = "abort", LTO) with every warning an error, then
//! run and their output checked — plainly, under AddressSanitizer + UndefinedBehaviorSanitizer,
//! and under valgrind where it is installed. Also: the library links with no system library
//! beyond libc, the header compiles as C99, C11 and C++, and the C compiler agrees with Rust on
//! every struct's size and field offsets.

use std::mem::{offset_of, size_of};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use weft::ffi::*;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn work_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .join("c-examples")
        .join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(o: &Output) -> String {
    format!(
        "status: {}\n--- stdout\n{}--- stderr\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn run(cmd: &mut Command) -> Output {
    cmd.output()
        .unwrap_or_else(|e| panic!("cannot run {cmd:?}: {e}"))
}

/// The shipped static library, built once per test run (the LTO build takes a while).
fn staticlib() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let out = run(Command::new("bash")
            .arg(root().join("scripts").join("build-staticlib.sh"))
            .env("CARGO", cargo));
        assert!(
            out.status.success(),
            "building libweft.a failed\n{}",
            text(&out)
        );
        let stdout = String::from_utf8(out.stdout).unwrap();
        let path = PathBuf::from(stdout.lines().last().unwrap_or("").trim());
        assert!(path.is_file(), "the build script printed {path:?}");
        path
    })
}

/// The examples' cell blob: `cells/stripes.toml` homogenized at refine 1.
fn blob_path() -> &'static Path {
    static BLOB: OnceLock<PathBuf> = OnceLock::new();
    BLOB.get_or_init(|| {
        let cells = [root().join("cells").join("stripes.toml")];
        let bytes = weft::homogenize::build_blob(&cells, 1, &mut |_, _| {}).unwrap();
        let path = work_dir("blob").join("stripes.weft");
        std::fs::write(&path, bytes).unwrap();
        path
    })
}

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    Plain,
    Sanitized,
}

/// Compiles one example with the strict flags (C11 or C++17) and links the static library
/// with nothing else.
fn compile(source: &str, mode: Mode) -> PathBuf {
    let cpp = source.ends_with(".cpp");
    let dir = work_dir(match mode {
        Mode::Plain => "plain",
        Mode::Sanitized => "sanitized",
    });
    let exe = dir.join(source.split('.').next().unwrap());
    let mut cmd = Command::new(if cpp { "c++" } else { "cc" });
    cmd.arg(if cpp { "-std=c++17" } else { "-std=c11" })
        .args(["-Wall", "-Wextra", "-Werror", "-pedantic", "-O1", "-g"])
        .arg("-I")
        .arg(root().join("include"));
    if mode == Mode::Sanitized {
        cmd.args([
            "-fsanitize=address,undefined",
            "-fno-sanitize-recover=all",
            "-fno-omit-frame-pointer",
        ]);
    }
    cmd.arg(root().join("c_examples").join(source))
        .arg(staticlib())
        .arg("-o")
        .arg(&exe);
    let out = run(&mut cmd);
    assert!(out.status.success(), "{cmd:?}\n{}", text(&out));
    exe
}

fn valgrind_available() -> bool {
    Command::new("valgrind")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

/// Runs an example plainly, sanitized and under valgrind; `args` come after the blob path.
/// Returns the plain run's stdout after checking that every run succeeded and printed `expect`.
fn run_everywhere(source: &str, args: &[&str], expect: &[&str]) -> String {
    let check = |label: &str, out: &Output| {
        assert!(
            out.status.success(),
            "{source} ({label}) failed\n{}",
            text(out)
        );
        let stdout = String::from_utf8_lossy(&out.stdout);
        for line in expect {
            assert!(
                stdout.contains(line),
                "{source} ({label}) did not print {line:?}\n{}",
                text(out)
            );
        }
    };
    let plain = compile(source, Mode::Plain);
    let out = run(Command::new(&plain).arg(blob_path()).args(args));
    check("plain", &out);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();

    let sanitized = compile(source, Mode::Sanitized);
    let out = run(Command::new(&sanitized)
        .arg(blob_path())
        .args(args)
        .env("ASAN_OPTIONS", "detect_leaks=1:halt_on_error=1")
        .env("UBSAN_OPTIONS", "halt_on_error=1:print_stacktrace=1"));
    check("ASan+UBSan", &out);

    if valgrind_available() {
        let out = run(Command::new("valgrind")
            .args([
                "--error-exitcode=99",
                "--leak-check=full",
                "--errors-for-leak-kinds=definite",
                "-q",
            ])
            .arg(&plain)
            .arg(blob_path())
            .args(args));
        check("valgrind", &out);
    } else {
        println!("note: valgrind is not installed; {source} ran plain and sanitized only");
    }
    stdout
}

/// The numbers after `label` on the line that starts with it (`[`, `]`, `,`, `%` and words are
/// skipped).
fn numbers_after(out: &str, label: &str) -> Vec<f64> {
    let line = out
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no line starting with {label:?} in\n{out}"));
    line[label.len()..]
        .split(|c: char| c.is_whitespace() || "[],:%=()".contains(c))
        .filter_map(|w| w.parse::<f64>().ok())
        .collect()
}

#[test]
fn hello_c() {
    let out = run_everywhere(
        "hello.c",
        &[],
        &[
            "cell 0: stripes",
            "world: 256 vertices, 450 triangles",
            "fine mesh: 160801 vertices, 320000 triangles (cell 0 tiled at 1.25 mm)",
            "hello: ok",
        ],
    );
    print!("{out}");
    // The localized fine mesh spans the hanging coarse cloth to within the micro displacement.
    let coarse = numbers_after(&out, "coarse extent:");
    let fine = numbers_after(&out, "fine   extent:");
    assert_eq!((coarse.len(), fine.len()), (6, 6), "{out}");
    for (c, f) in coarse.iter().zip(&fine) {
        assert!((c - f).abs() < 5e-4, "extents differ: {coarse:?} {fine:?}");
    }
    assert!(coarse[5] - coarse[4] > 0.2, "the cloth hangs: {coarse:?}");
    // The stripes split the stretch across them like a laminate: the soft layers (material 1,
    // '.', 10 × softer) take far more than the hard ones, and the two average (they are
    // equally thick) to the coarse cloth's strain.
    let s = numbers_after(&out, "strain along v (Green, mean over edges along v):");
    let (coarse, fine, m0, m1) = (s[0], s[1], s[3], s[5]);
    assert_eq!((s[2], s[4]), (0.0, 1.0), "material indices: {s:?}");
    assert!(coarse > 0.01, "the cloth is stretched along v: {s:?}");
    assert!((fine - coarse).abs() < 0.1 * coarse, "{s:?}");
    assert!((0.5 * (m0 + m1) - coarse).abs() < 0.1 * coarse, "{s:?}");
    assert!(m1 > 5.0 * m0 && m0 > 0.0, "{s:?}");
}

/// The engine calls beyond create and step (`c_examples/engine_api.c`): each is checked in C
/// against what it must do and prints "ok" or "WRONG".
#[test]
fn engine_api_c() {
    let out = run_everywhere(
        "engine_api.c",
        &[],
        &[
            "a force changes the momentum by F dt: ok",
            "forces last one step: ok",
            "an impulse changes the momentum by J: ok",
            "a heavier hem: ok",
            "the curtain slides along its rail at g sin(theta): ok",
            "a rail without a direction is refused: ok",
            "a range of positions round-trips: ok",
            "a teleport keeps the shape: ok",
            "a teleport turns the velocities: ok",
            "the other colliders keep their ids: ok",
            "a removed collider's id is refused: ok",
            "the world carries the engine's pointer: ok",
            "a 10 % stretch along u reads back as E11 = 0.105: ok",
            "strains past the last triangle are refused: ok",
            "a cloth that could never step is refused: ok",
            "engine_api: ok",
        ],
    );
    print!("{out}");
    assert!(!out.contains("WRONG") && !out.contains("FAILED"), "{out}");
}

/// The README's hanging cloth: at most 40 lines of C, the same text in the README as in
/// `c_examples/hanging.c`, compiled and run like every example; the cloth hangs below its
/// pinned top edge.
#[test]
fn readme_hanging_c() {
    let source = std::fs::read_to_string(root().join("c_examples").join("hanging.c")).unwrap();
    assert!(
        source.lines().count() <= 40,
        "{} lines",
        source.lines().count()
    );
    let readme = std::fs::read_to_string(root().join("README.md")).unwrap();
    assert!(
        readme.contains(&format!("```c\n{source}```")),
        "the README's hanging cloth differs from c_examples/hanging.c"
    );
    let out = run_everywhere(
        "hanging.c",
        &[],
        &["hanging: the bottom corners are at z = "],
    );
    print!("{out}");
    let z = numbers_after(&out, "hanging: the bottom corners are at z = ");
    assert_eq!(z.len(), 2, "{out}");
    assert!(z.iter().all(|&z| z < -0.2), "the cloth hangs: {z:?}");
    assert!(
        (z[0] - z[1]).abs() < 0.01,
        "nearly symmetric (the diagonals are not): {z:?}"
    );
}

#[test]
fn engine_loop_c() {
    let obj = work_dir("engine_loop").join("last_frame.obj");
    let obj_s = obj.to_str().unwrap();
    let out = run_everywhere(
        "engine_loop.c",
        &[obj_s],
        &[
            "corrupt blob: blob checksum mismatch",
            "truncated blob: blob size does not match its header",
            "foreign file: not a weft cell blob",
            "bad mesh: triangle vertex index out of range [triangle 7]",
            "small capacity: more vertices than capacity.max_vertices [needed 144] [capacity 143]",
            "bad setting: setting out of range [substeps]",
            "uninitialized def: def or blob not initialized",
            ": asleep",
            "asleep step: skipped",
            "after moving a pin: awake",
            "destroyed handle: not a live world handle",
            "render mesh: 1156 vertices, 2178 triangles, 41632 bytes of bindings, 11552 bytes \
             of frames",
            "unprepared frames: frames not prepared by weft_localize_prepare",
            "outside the cloth: fine vertex outside the coarse cloth's (u, v) [vertex 4]",
            "small bindings: bindings block smaller than weft_bind_memory_size [needed 1156] \
             [capacity 6]",
            "not bindings: not a bindings block written by weft_bind",
            "range: first + count beyond the bindings [needed 1157] [capacity 1156]",
            "overlapping normals: normals overlap the positions or leave their record",
            "strain measure: argument out of range [strain_measure]",
            "wrote ",
            "engine_loop: ok",
        ],
    );
    print!("{out}");
    // Render vertices on cloth vertices land on them, up to the micro displacement.
    let gap = numbers_after(&out, "render vertices on cloth vertices:");
    assert!(gap[0] < 1.0, "{gap:?} mm");
    assert!(gap[1] < 1e-5, "normals not unit: {gap:?}");

    // The OBJ is the localized render mesh: 34 × 34 vertices with normals, above the floor,
    // each normal on the side its faces face (counter-clockwise in (u, v)).
    let obj = std::fs::read_to_string(&obj).unwrap();
    let rows = |p: &str| -> Vec<[f32; 3]> {
        obj.lines()
            .filter(|l| l.starts_with(p))
            .map(|l| {
                let v: Vec<f32> = l.split(' ').skip(1).map(|w| w.parse().unwrap()).collect();
                [v[0], v[1], v[2]]
            })
            .collect()
    };
    let (v, vn) = (rows("v "), rows("vn "));
    let faces: Vec<[usize; 3]> = obj
        .lines()
        .filter(|l| l.starts_with("f "))
        .map(|l| {
            let i: Vec<usize> = l
                .split(' ')
                .skip(1)
                .map(|w| w.split("//").next().unwrap().parse::<usize>().unwrap() - 1)
                .collect();
            [i[0], i[1], i[2]]
        })
        .collect();
    assert_eq!((v.len(), vn.len(), faces.len()), (1156, 1156, 2178));
    for p in &v {
        assert!(p.iter().all(|c| c.is_finite()) && p[2] > -0.41, "{p:?}");
    }
    let sub = |a: [f32; 3], b: [f32; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let mut agree = 0;
    for f in &faces {
        let (e1, e2) = (sub(v[f[1]], v[f[0]]), sub(v[f[2]], v[f[0]]));
        let n = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let m = vn[f[0]];
        agree += usize::from(n[0] * m[0] + n[1] * m[1] + n[2] * m[2] > 0.0);
    }
    assert!(
        agree * 100 >= faces.len() * 99,
        "{agree} of {} faces",
        faces.len()
    );
    // The render mesh spans the cloth: 0.6 m across in (u, v), hanging from z 0.55.
    let (lo, hi) = v
        .iter()
        .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), p| {
            (
                std::array::from_fn(|k| lo[k].min(p[k])),
                std::array::from_fn(|k| hi[k].max(p[k])),
            )
        });
    assert!(
        (0.55 - hi[2]).abs() < 0.01 && hi[2] - lo[2] > 0.3,
        "{lo:?} {hi:?}"
    );
}

#[test]
fn wrapper_cpp() {
    let out = run_everywhere(
        "wrapper.cpp",
        &[],
        &[
            "blob: 1 cell(s), cell 0 is 'stripes'",
            "caught: weft_world_set_pin: vertex index out of range, vertex 100000",
            "caught: weft_world_create: triangle material is not a cell of the blob, triangle 0, material 7",
            "render mesh: 1073 vertices (4 x finer), localized on 2 threads every frame",
            "caught: weft_localize: bindings were made for another cloth (bindings)",
            "moved world: 80 vertices",
            "wrapper: ok",
        ],
    );
    print!("{out}");
    let n = numbers_after(&out, "render mesh:");
    assert_eq!(n[..3], [1073.0, 4.0, 2.0], "{n:?}");
    assert!(
        n[3] < 0.5,
        "render corners {} mm from the simulated ones",
        n[3]
    );
    assert!(
        n[4] < 30.0,
        "recomputed normals {} degrees off the blended ones",
        n[4]
    );
}

/// `cc hello.c libweft.a` with no `-lm -lpthread -ldl`, and the archive asks the C runtime for
/// nothing beyond memory functions and `abort` (and the compiler's own runtime helpers).
#[test]
fn staticlib_needs_no_system_libraries() {
    let lib = staticlib();
    let exe = work_dir("nolibs").join("hello");
    let out = run(Command::new("cc")
        .arg("-I")
        .arg(root().join("include"))
        .arg(root().join("c_examples").join("hello.c"))
        .arg(lib)
        .arg("-o")
        .arg(&exe));
    assert!(out.status.success(), "{}", text(&out));
    let out = run(Command::new(&exe).arg(blob_path()));
    assert!(out.status.success(), "{}", text(&out));

    let out = run(Command::new("nm").arg("-g").arg(lib));
    assert!(out.status.success(), "{}", text(&out));
    let listing = String::from_utf8_lossy(&out.stdout);
    let mut defined = std::collections::BTreeSet::new();
    let mut undefined = std::collections::BTreeSet::new();
    for line in listing.lines() {
        let parts: Vec<&str> = line.split_whitespace().collect();
        match parts.as_slice() {
            ["U", name] => {
                undefined.insert(name.to_string());
            }
            [_, kind, name] if *kind != "U" => {
                defined.insert(name.to_string());
            }
            [kind, name] if *kind != "U" => {
                defined.insert(name.to_string());
            }
            _ => {}
        }
    }
    let external: Vec<&String> = undefined.difference(&defined).collect();
    let allowed = [
        "memcpy", "memmove", "memset", "memcmp", "bcmp", "strlen", "abort",
    ];
    // `__udivti3` and the like are the C compiler's own runtime (libgcc / compiler-rt), which
    // every link includes; compiler_builtins' C objects reference them.
    let unexpected: Vec<&&String> = external
        .iter()
        .filter(|s| !allowed.contains(&s.as_str()) && !s.starts_with("__"))
        .collect();
    println!("libweft.a needs from the C runtime: {external:?}");
    assert!(
        unexpected.is_empty(),
        "libweft.a references symbols beyond libc's basics: {unexpected:?}"
    );
    let exported: Vec<&String> = defined.iter().filter(|s| s.starts_with("weft_")).collect();
    assert!(exported.len() >= 40, "{exported:?}");
    for f in [
        "weft_bind",
        "weft_bind_memory_size",
        "weft_localize_prepare",
        "weft_localize",
        "weft_tiled_mesh",
    ] {
        assert!(defined.contains(f), "libweft.a does not export {f}");
    }
}

/// The header alone, in every language mode the README promises, with every warning an error.
#[test]
fn header_compiles_as_c99_c11_and_cpp() {
    let dir = work_dir("header");
    let c = dir.join("include_only.c");
    std::fs::write(
        &c,
        "#include \"weft.h\"\nint main(void) { return weft_version() == WEFT_VERSION ? 0 : 1; }\n",
    )
    .unwrap();
    let modes: [(&str, &[&str]); 5] = [
        ("cc", &["-std=c99"]),
        ("cc", &["-std=c11"]),
        ("cc", &["-std=c17"]),
        ("c++", &["-x", "c++", "-std=c++11"]),
        ("c++", &["-x", "c++", "-std=c++17"]),
    ];
    for (compiler, flags) in modes {
        let out = run(Command::new(compiler)
            .args(flags)
            .args(["-Wall", "-Wextra", "-Werror", "-pedantic", "-fsyntax-only"])
            .arg("-I")
            .arg(root().join("include"))
            .arg(&c));
        assert!(out.status.success(), "{compiler} {flags:?}\n{}", text(&out));
    }
}

/// The C compiler lays out every struct exactly as Rust does.
#[test]
fn c_layout_matches_rust() {
    let mut checks = String::from(
        "#include <stddef.h>\n#include \"weft.h\"\n#ifdef __cplusplus\n#define CHECK static_assert\n\
         #else\n#define CHECK _Static_assert\n#endif\n",
    );
    macro_rules! layout {
        ($t:ident { $($f:ident),* $(,)? }) => {
            checks += &format!(
                "CHECK(sizeof({}) == {}, \"size of {}\");\n",
                stringify!($t), size_of::<$t>(), stringify!($t)
            );
            $(
                checks += &format!(
                    "CHECK(offsetof({t}, {f}) == {o}, \"{t}.{f}\");\n",
                    t = stringify!($t), f = stringify!($f), o = offset_of!($t, $f)
                );
            )*
        };
    }
    layout!(WeftVec3 { x, y, z });
    layout!(WeftVec2 { x, y });
    layout!(WeftQuat { x, y, z, w });
    layout!(WeftCapacity {
        max_vertices,
        max_triangles,
        max_edges,
        max_colliders,
        max_pins
    });
    layout!(WeftSettings {
        effects,
        substeps,
        gravity,
        damping_mass,
        damping_stiffness,
        wind,
        drag,
        tolerance,
        max_iterations,
        rotation_iterations,
        sleep_velocity,
        sleep_frames,
        max_depenetration_speed
    });
    layout!(WeftWorldDef {
        positions,
        position_stride,
        uvs,
        uv_stride,
        vertex_count,
        triangle_count,
        indices,
        materials,
        material,
        capacity,
        settings,
        internal_cookie
    });
    layout!(WeftBlob {
        data,
        size,
        version,
        cell_count,
        internal_cookie,
        reserved
    });
    layout!(WeftCellInfo {
        name,
        width,
        height,
        cols,
        rows,
        refine,
        node_count,
        stiffness,
        density,
        bending
    });
    layout!(WeftShape { kind, p0, p1, size });
    layout!(WeftColliderDef {
        shape,
        friction,
        thickness,
        internal_cookie
    });
    layout!(WeftLocalizeOutput {
        positions,
        position_stride,
        normals,
        normal_stride,
        fine_indices,
        normal_mode,
        fine_triangle_count,
        collider_mode,
        internal_cookie
    });
    layout!(WeftStepStats {
        iterations,
        residual,
        converged,
        substeps,
        asleep,
        contacts,
        redone,
        energy_removed
    });
    layout!(WeftErrorDetail {
        result,
        triangle,
        vertex,
        vertex_b,
        material,
        cell,
        index,
        needed,
        capacity,
        reserved,
        what
    });
    checks += &format!(
        "CHECK(sizeof(WeftResult) == {}, \"WeftResult\");\n",
        size_of::<WeftResult>()
    );
    let dir = work_dir("layout");
    for (compiler, std, file) in [
        ("cc", "-std=c11", "layout.c"),
        ("c++", "-std=c++17", "layout.cpp"),
    ] {
        let path = dir.join(file);
        std::fs::write(&path, &checks).unwrap();
        let out = run(Command::new(compiler)
            .arg(std)
            .args(["-Wall", "-Wextra", "-Werror", "-fsyntax-only"])
            .arg("-I")
            .arg(root().join("include"))
            .arg(&path));
        assert!(
            out.status.success(),
            "{compiler}: layouts differ\n{}",
            text(&out)
        );
    }
}
