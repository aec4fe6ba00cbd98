//! Inputs that once broke caoen (`tests/bad/hostile/`): each must end in a clean error
//! (one `error:` line, the expected exit code, no panic) or a bounded success, inside a
//! 2 GiB address space where `prlimit` exists, and without hanging.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{argv, hostile as bad, s};

/// Far above the 10 s any of these takes alone: a guard against hangs, not a timing.
const HANG_GUARD: Duration = Duration::from_secs(120);
const ADDRESS_SPACE: &str = "--as=2147483648";

fn scratch(test: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("caoen-hostile-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// The scratch directory of `test` and the path of `name` in it, as an argument.
fn scratch_file(test: &str, name: &str) -> (PathBuf, String) {
    let dir = scratch(test);
    let path = dir.join(name).display().to_string();
    (dir, path)
}

/// The path of `name` in the scratch directory of `test`, as an argument.
fn scratch_path(test: &str, name: &str) -> String {
    scratch_file(test, name).1
}

/// Writes the F-rep model file `path` holding the model `model` (JSON text).
fn write_model(path: impl AsRef<Path>, model: &str) {
    let file = format!(r#"{{"format": "caoen-frep/1", "model": {model}}}"#);
    std::fs::write(path, file).expect("model");
}

struct Outcome {
    code: i32,
    stderr: String,
}

/// Runs caoen with `args` under the address-space limit (when `prlimit` is present),
/// killing it if it outlives the hang guard.
fn run(args: &[&str]) -> Outcome {
    let bin = env!("CARGO_BIN_EXE_caoen");
    let limited = Command::new("prlimit")
        .arg("--version")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    let mut cmd = if limited {
        let mut c = Command::new("prlimit");
        c.arg(ADDRESS_SPACE).arg(bin);
        c
    } else {
        Command::new(bin)
    };
    let mut child = cmd
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run caoen");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().expect("wait") {
            break s;
        }
        if start.elapsed() > HANG_GUARD {
            child.kill().ok();
            panic!("caoen {args:?} still running after {HANG_GUARD:?}");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut child.stderr.take().expect("piped"), &mut stderr)
        .expect("stderr");
    Outcome {
        code: status.code().unwrap_or(-1),
        stderr,
    }
}

/// Asserts that the run of `args` did not panic.
fn no_panic(args: &[&str], o: &Outcome) {
    assert!(
        !o.stderr.contains("panicked"),
        "{args:?} panicked:\n{}",
        o.stderr
    );
}

/// Asserts a clean failure with exit code 1 (see [`fails_cleanly_with`]).
fn fails_cleanly(line: &str, paths: &[&str], needle: &str) {
    fails_cleanly_with(line, paths, 1, needle);
}

/// Asserts a clean failure: `code`, one `error:` line containing `needle`, no panic.
fn fails_cleanly_with(line: &str, paths: &[&str], code: i32, needle: &str) {
    let args = argv(line, paths);
    let o = run(&args);
    no_panic(&args, &o);
    assert_eq!(o.code, code, "{args:?}: {}", o.stderr);
    let lines: Vec<&str> = o.stderr.lines().collect();
    assert_eq!(
        lines.len(),
        1,
        "{args:?}: want one line, got:\n{}",
        o.stderr
    );
    assert!(lines[0].starts_with("error: "), "{}", lines[0]);
    assert!(
        lines[0].contains(needle),
        "{args:?}: `{needle}` not in {}",
        lines[0]
    );
    assert!(
        !lines[0].chars().any(|c| c.is_control()),
        "control character in {:?}",
        lines[0]
    );
}

#[test]
fn solids_with_sharpness_where_the_field_overflows_are_refused_with_the_range() {
    let (_, out) = scratch_file("solids", "r.png");
    for method in ["ray", "depth", "mesh"] {
        fails_cleanly(
            "surface render @ -o @ --method @",
            &[&bad("R1-solid-q-1e19.scene.json"), &out, method],
            "q = 1e19 is outside [",
        );
    }
    refused(
        "surface render @ -o @",
        &[&bad("R2-solid-q-1e-300.scene.json"), &out],
        "q = 1e-300 is outside [",
    );
}

#[test]
fn tiny_files_declaring_huge_images_stay_within_the_budget() {
    let dir = scratch("decode");
    let (exr, png) = (dir.join("z.exr"), dir.join("z.png"));
    fails_cleanly(
        "decode @ -o @",
        &[&bad("R3-86-byte-16384x4096-rgba-hdr.cae"), s(&exr)],
        "over the memory budget of 2.0 GiB",
    );
    // The 8-bit file fits the budget: a bounded success.
    let rgba8 = bad("R3b-86-byte-16384x4096-rgba8.cae");
    succeeds("decode @ -o @", &[&rgba8, s(&png)]);
    assert!(png.metadata().expect("written").len() > 0);
    // A tighter budget refuses it before decoding.
    fails_cleanly(
        "decode @ -o @ -f --max-memory 256M",
        &[&rgba8, s(&png)],
        "over the memory budget of 256.0 MiB",
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn supersampling_counts_in_the_pixel_limit_and_the_budget() {
    let (_, out) = scratch_file("supersample", "s.png");
    let file = bad("small_q30.cae");
    fails_cleanly(
        "decode @ --size 8192x8192 --supersample 4 -o @",
        &[&file, &out],
        "memory budget",
    );
    fails_cleanly(
        "decode @ --size 8192x4096 --supersample 4 -o @ --max-memory 64G",
        &[&file, &out],
        "output samples (pixels x S^2) is 536870912, limit 268435456",
    );
}

#[test]
fn encoding_a_huge_image_over_the_budget_is_refused_before_work_starts() {
    // With the default budget it encodes, tile by tile; with 250 MB the decoded input
    // (192 MiB of 8-bit RGB) fits but not the encoder's own share.
    refused(
        "encode @ -o @ --max-memory 250M",
        &[
            &bad("R4-png-8192x8192-flat.png"),
            &scratch_path("encode", "b.cae"),
        ],
        "encoding 8192x8192 at quality 75 (the decoded input included) needs about",
    );
}

/// A texture over the budget or the loader's pixel limit is refused from its header,
/// before anything is decoded.
#[test]
fn textures_are_refused_from_their_headers() {
    let out = scratch_path("textures", "t.png");
    for (line, texture) in [
        ("surface render @ -o @", "R5-texture-bomb.json"),
        (
            "transfer --texture @ --from builtin:octahedron --to builtin:blob -o @",
            "R5-grey-16384x16384.png",
        ),
    ] {
        fails_cleanly(line, &[&bad(texture), &out], "16384x16384");
    }
}

#[test]
fn grid_counts_are_checked_without_overflow() {
    fails_cleanly_with(
        "surface eval builtin:blob --grid 4294967296x4294967296",
        &[],
        2,
        "each side must be in 1..=16000000",
    );
    fails_cleanly_with(
        "surface eval builtin:blob --grid 65536x65536",
        &[],
        2,
        "at most 16000000 points",
    );
}

#[test]
fn container_errors_are_specific_and_printable() {
    fails_cleanly(
        "info @",
        &[&bad("R8-tag-0x1c-control-char.cae")],
        "CRC mismatch in section 0x1c at byte 51: stored",
    );
    let dir = scratch("container");
    fails_cleanly(
        "decode @ -o @",
        &[&bad("R9-E-section-with-payload.cae"), s(&dir.join("e.png"))],
        "the end section at byte 53 carries 4 bytes; it must be empty",
    );
    fails_cleanly(
        "surface info @",
        &[&bad("R10-surface-trailing-garbage.json")],
        "trailing",
    );
}

#[test]
fn memory_budget_sizes_are_validated() {
    for bad_size in ["0", "-1G", "2X", "NaN", "1e400"] {
        let o = run(&["info", &bad("small_q30.cae"), "--max-memory", bad_size]);
        assert_eq!(o.code, 2, "--max-memory {bad_size}: {}", o.stderr);
        assert!(!o.stderr.contains("panicked"));
    }
}

#[test]
fn files_larger_than_the_budget_are_not_read() {
    let (dir, big) = scratch_file("big", "big.cae");
    // Sparse: no disk is spent on the 3 GiB.
    std::fs::File::create(&big)
        .and_then(|f| f.set_len(3 << 30))
        .expect("sparse file");
    fails_cleanly(
        "info @",
        &[&big],
        "reading the file needs about 3.0 GiB, over the memory budget of 2.0 GiB",
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Asserts a clean refusal (exit 1, [`fails_cleanly`]) that wrote nothing at the
/// command's `-o` path.
fn refused(line: &str, paths: &[&str], needle: &str) {
    fails_cleanly(line, paths, needle);
    let args = argv(line, paths);
    let out = args[args.iter().position(|a| *a == "-o").expect("an output") + 1];
    assert!(!Path::new(out).exists(), "{out} written");
}

/// Runs `args`, which must succeed; returns its stderr.
fn succeeds(line: &str, paths: &[&str]) -> String {
    let args = argv(line, paths);
    let o = run(&args);
    no_panic(&args, &o);
    assert_eq!(o.code, 0, "{args:?}: {}", o.stderr);
    o.stderr
}

/// Asserts `args` either succeeds or fails cleanly (exit 1, one printable line
/// naming `needle`): both are within the rules, the hostile part is what happens
/// otherwise (a panic, an abort past the address space, a hang).
fn bounded(line: &str, paths: &[&str], needle: &str) -> bool {
    let o = run(&argv(line, paths));
    if o.code == 0 {
        assert!(!o.stderr.contains("panicked"), "{line}: {}", o.stderr);
        return true;
    }
    fails_cleanly(line, paths, needle);
    false
}

/// Asserts that `caoen convert` refuses each `(file of tests/bad/hostile, needle)` of
/// `cases` cleanly and writes nothing (in the scratch directory of `test`).
fn convert_refuses(test: &str, cases: &[(&str, &str)]) {
    let (dir, out) = scratch_file(test, "m.json");
    for (file, needle) in cases {
        refused("convert @ -o @", &[&bad(file), &out], needle);
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn convert_refuses_meshes_whose_model_it_could_not_read_back() {
    convert_refuses(
        "convert-range",
        &[
            (
                "D1-convert-needle-2e6.obj",
                "a mesh to convert must lie within +-4e5",
            ),
            ("D1b-convert-offset-1e15.obj", "has coordinate 1e15"),
        ],
    );
}

#[test]
fn distort_refuses_moves_past_what_a_surface_holds_and_its_output_reads_back() {
    let (dir, out) = scratch_file("distort", "d.json");
    refused(
        "distort builtin:blob --move 1,0,0:1e300,0,0 -o @",
        &[&out],
        "reaches past 1e6",
    );
    // A long move within the range: written and read back, or refused before writing.
    if bounded(
        "distort builtin:blob --move 1,0,0:9e5,0,0 -o @",
        &[&out],
        "the largest coordinate a surface model holds",
    ) {
        succeeds("surface info @", &[&out]);
    } else {
        assert!(!Path::new(&out).exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_mesh_render_path_checks_the_polygonising_budget_first() {
    refused(
        "frep render @ -o @ --method mesh --cells 1024 --size 64x48",
        &[
            &bad("D3-D5-unnamed-sphere.frep.json"),
            &scratch_path("mesh-render", "m.png"),
        ],
        "polygonising on 1024^3 cells needs about 16.1 GiB",
    );
}

#[test]
fn pov_export_of_a_ten_thousand_node_union_finishes() {
    let dir = scratch("pov");
    let model = dir.join("u.frep.json");
    let spheres: Vec<String> = (0..9999)
        .map(|i| {
            format!(
                r#"{{"sphere": {{"centre": [{}, 0, 0], "radius": 0.5}}}}"#,
                f64::from(i) * 0.001
            )
        })
        .collect();
    write_model(&model, &format!(r#"{{"union": [{}]}}"#, spheres.join(", ")));
    let out = dir.join("u.pov");
    succeeds("frep export-pov @ -o @", &[s(&model), s(&out)]);
    let text = std::fs::read_to_string(&out).expect("written");
    // One function per node (`caoen_f<n>`), beside the shared helpers' declarations.
    let nodes = text
        .match_indices("#declare caoen_f")
        .filter(|(i, _)| {
            text[i + "#declare caoen_f".len()..].starts_with(|c: char| c.is_ascii_digit())
        })
        .count();
    assert_eq!(nodes, 10_000);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn one_budget_counts_every_height_map_a_model_loads() {
    let (dir, o) = scratch_file("height-maps", "d7.png");
    let d7 = bad("D7-heightmap-x3-bomb.json");
    // Within the 2 GiB address space: the three maps of one image share its samples.
    if bounded(
        "frep render @ -o @ --size 32x24 --samples 1",
        &[&d7, &o],
        "over the memory budget of 2.0 GiB",
    ) {
        assert!(Path::new(&o).exists());
    }
    // Twelve maps of twelve copies of one image cannot share: the budget counts them
    // together and refuses the one that does not fit.
    let grey = image::GrayImage::from_fn(2000, 2000, |x, y| image::Luma([((x ^ y) & 255) as u8]));
    let copies: Vec<String> = (0..12)
        .map(|i| {
            let p = dir.join(format!("b{i}.png"));
            grey.save(&p).expect("copy");
            format!(
                r#"{{"height_map": {{"image": "{}", "base": {{"ellipsoid": [1, 1, 1]}}, "rect": [-3.14159, -1.5707, 3.14159, 1.5707]}}}}"#,
                p.display()
            )
        })
        .collect();
    let model = dir.join("d7x12.json");
    write_model(&model, &format!(r#"{{"union": [{}]}}"#, copies.join(", ")));
    fails_cleanly(
        "frep render @ -o @ --size 32x24 --max-memory 512M",
        &[s(&model), s(&dir.join("d12.png"))],
        "MiB already loaded) needs about",
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn carve_and_relief_refuse_to_write_a_model_render_would_refuse() {
    let dir = scratch("nesting");
    let (small, on) = (bad("small.png"), bad("D8-nest64.frep.json"));
    // The shell adds two levels: past the limit, refused before anything is written.
    let out = dir.join("carve.json").display().to_string();
    refused(
        "carve @ --on @ -o @ --shell 0.1",
        &[&small, &on, &out],
        "nested deeper than 64 levels",
    );
    // A relief adds one level, which fits: what is written renders.
    let out = dir.join("relief.json").display().to_string();
    if bounded(
        "relief @ --on @ -o @",
        &[&small, &on, &out],
        "nested deeper than 64 levels",
    ) {
        succeeds(
            "frep render @ -o @ --size 16x12 --samples 1",
            &[&out, s(&dir.join("r.png"))],
        );
    } else {
        assert!(!Path::new(&out).exists());
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn transfer_bakes_a_bounded_grid_by_default() {
    let dir = scratch("transfer");
    let out = dir.join("t.png");
    succeeds(
        "transfer --texture @ --from builtin:octahedron --to builtin:blob -o @ --size 32x24",
        &[&bad("bomb8000.png"), s(&out)],
    );
    let back = caoen::image_io::load(&out).expect("reads back");
    assert_eq!((back.width(), back.height()), (32, 24));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn ply_files_must_hold_exactly_what_their_header_declares() {
    convert_refuses(
        "ply",
        &[
            (
                "M1-ply-declares-fewer-faces.ply",
                "after the 1837 elements the header declares",
            ),
            (
                "M2-ply-ascii-extra-tokens.ply",
                "vertex 0 has 2 more numbers than its properties take",
            ),
        ],
    );
}

/// The rest of the second round (`../shared/hostile/README.md`): an exact sphere
/// converts to a model its readers take; an F-rep model without a name gets a relief
/// and a carving rendered; a perturbation of 9,990 bumps exports to POV-Ray; a mesh
/// without area, a thin box and a stream of zeros are refused.
#[test]
fn second_round_reproducers_end_cleanly_and_what_they_write_reads_back() {
    let dir = scratch("second-round");
    let o = |n: &str| dir.join(n).display().to_string();
    // D2: the base quadric alone, read back by the loader and by deviation.
    let (sphere, model) = (bad("D2-convert-exact-sphere.obj"), o("s.json"));
    succeeds("convert @ -o @", &[&sphere, &model]);
    succeeds("frep render @ -o @ --size 32x24", &[&model, &o("s.png")]);
    succeeds("deviation @ @", &[&sphere, &model]);
    // D3: relief and carve of a model without `name`, as a picture and as a model.
    for cmd in ["relief", "carve"] {
        let on = bad("D3-D5-unnamed-sphere.frep.json");
        let (png, json) = (o(&format!("{cmd}.png")), o(&format!("{cmd}.json")));
        succeeds("@ @ --on @ -o @", &[cmd, &bad("small.png"), &on, &png]);
        succeeds("@ @ --on @ -o @", &[cmd, &bad("small.png"), &on, &json]);
        succeeds(
            "frep render @ -o @ --size 32x24",
            &[&json, &o(&format!("{cmd}-back.png"))],
        );
    }
    // D4b: 9,990 overlapping bumps on one sphere, within the node limit.
    let bumps = vec![r#"{"bump": {"centre": [1, 0, 0], "radius": 0.3, "height": 1}}"#; 9990];
    let patches = bumps.join(", ");
    write_model(
        o("bumps.frep.json"),
        &format!(r#"{{"perturb": {{"sphere": {{"radius": 1.0}}}}, "patches": [{patches}]}}"#),
    );
    succeeds(
        "frep export-pov @ -o @",
        &[&o("bumps.frep.json"), &o("b.pov")],
    );
    // M3: collinear triangles only.
    refused(
        "convert @ -o @",
        &[&bad("M3-all-zero-area-triangles.obj"), &o("m.json")],
        "no area",
    );
    // A box 1e6 x 1e-9 x 1e-9: no grid point inside, so no mesh.
    write_model(
        o("thin.frep.json"),
        r#"{"box": {"size": [1e6, 1e-9, 1e-9]}}"#,
    );
    refused(
        "frep mesh @ -o @",
        &[&o("thin.frep.json"), &o("thin.stl")],
        "the mesh is empty",
    );
    // A wrong magic number is refused after its four bytes, not after reading 2 GiB.
    fails_cleanly("info /dev/zero", &[], "magic");
    fails_cleanly("decode /dev/zero -o @", &[&o("z.png")], "magic");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_whole_number_written_as_a_float_is_read_as_one() {
    let (dir, out) = scratch_file("whole-float", "s.png");
    let model = bad("third-M7-noise-seed-7.0.json");
    succeeds("frep render @ -o @ --size 32x24", &[&model, &out]);
    let png = image::open(&out).expect("the render reads back");
    assert_eq!((png.width(), png.height()), (32, 24));
    std::fs::remove_dir_all(&dir).ok();
}

/// A file coded at 0.7 of its size (third round, M5) decoded stretched 11 times down
/// and as a region at 64 times its size: the post-filters' tasks take rows by their
/// margins and by the worker count, and the output is the same bytes on one thread
/// and on three, within the default budget.
#[test]
fn a_file_coded_at_0_7_decodes_stretched_and_zoomed_the_same_on_any_thread_count() {
    let file = bad("third-M5-resampled-0.7.cae");
    let decoded = |how: &str, threads: &str| {
        let out = scratch_path("m5-replay", &format!("{how}-{threads}.png"));
        let sizes = match how {
            "tall" => "--size 1500x8192",
            _ => "--region 700,500,704,504 --size 256x256",
        };
        let line = format!("decode @ {sizes} -j {threads} -f -o @");
        succeeds(&line, &[&file, &out]);
        std::fs::read(&out).unwrap()
    };
    for how in ["tall", "zoomed"] {
        let one = decoded(how, "1");
        assert!(one.starts_with(b"\x89PNG"), "{how}");
        assert!(one == decoded(how, "3"), "{how}: -j 1 and -j 3 differ");
    }
}
