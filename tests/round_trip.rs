//! Every file a caoen writer makes, caoen's own reader reads: each writer (convert,
//! distort, relief, carve, heightfield, frep mesh, transfer, morph) driven in process
//! with random valid options and extreme-but-legal inputs, its output read back by the
//! matching reader. A writer may refuse its input (a typed error), never write a file
//! the reader refuses. `CAOEN_PROPTEST_CASES` sets the cases per writer (default 1000).

mod common;
use common::repo_path;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use caoen::conversion::mesh_file::{check_convertible, MAX_CONVERT_COORDINATE, MIN_CONVERT_EXTENT};
use caoen::conversion::{openings, Bump, ImplicitModel, PolygonMesh};
use caoen::surface::{gallery, SurfaceModel};
use caoen_cli::cli::Cli;
use clap::Parser as _;
use proptest::prelude::*;

/// Cases per writer: `CAOEN_PROPTEST_CASES`, else 1000.
fn cases() -> u32 {
    std::env::var("CAOEN_PROPTEST_CASES")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1000)
}

/// A scratch folder for this process's files.
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("caoen-round-trip-{}", std::process::id()));
        std::fs::create_dir_all(&d).expect("scratch dir");
        d
    })
}

/// A file name unique to this case (tests run in parallel).
fn file(stem: &str, ext: &str) -> PathBuf {
    use std::sync::atomic::{AtomicU64, Ordering};
    static N: AtomicU64 = AtomicU64::new(0);
    scratch().join(format!(
        "{stem}-{}.{ext}",
        N.fetch_add(1, Ordering::Relaxed)
    ))
}

/// Runs a `caoen` command line in process (quiet, replacing outputs).
fn caoen(args: &[String]) -> Result<(), caoen_cli::failure::CliError> {
    let mut all = vec!["caoen".to_string(), "--quiet".into(), "-f".into()];
    all.extend_from_slice(args);
    let cli = Cli::try_parse_from(&all).unwrap_or_else(|e| panic!("{all:?}: {e}"));
    caoen_cli::commands::run(cli)
}

/// Reads an F-rep model file back the way `caoen frep render` does.
fn reads_back_as_model(path: &Path) {
    if let Err(e) = caoen_cli::commands::frep::load(path, &caoen::Limits::default()) {
        let text = std::fs::read_to_string(path).unwrap_or_default();
        panic!(
            "{}: written but not read back: {e}\n{}",
            path.display(),
            &text[..text.len().min(2000)]
        );
    }
}

/// A base model file for relief, carve and frep mesh: one primitive with extreme but
/// legal numbers.
fn base_model() -> impl Strategy<Value = PathBuf> {
    let centre = prop::array::uniform3(-1e3f64..1e3);
    let size = prop_oneof![1e-3f64..1e-2, 0.1f64..10.0, 10.0f64..1e3];
    (0u8..4, centre, size.clone(), size).prop_map(|(kind, c, s, t)| {
        let model = match kind {
            0 => format!(r#"{{"sphere": {{"centre": {c:?}, "radius": {s}}}}}"#),
            1 => format!(r#"{{"box": {{"centre": {c:?}, "size": [{s}, {t}, {s}]}}}}"#),
            2 => format!(
                r#"{{"torus": {{"centre": {c:?}, "major": {}, "minor": {}}}}}"#,
                s + t,
                t.min(s)
            ),
            _ => format!(r#"{{"cylinder": {{"centre": {c:?}, "radius": {s}, "length": {t}}}}}"#),
        };
        let path = file("base", "frep.json");
        std::fs::write(
            &path,
            format!(r#"{{"format": "caoen-frep/1", "model": {model}}}"#),
        )
        .expect("base model");
        path
    })
}

fn s(p: &Path) -> String {
    p.display().to_string()
}

proptest! {
    #![proptest_config(common::proptest_config(cases()))]

    /// convert: any mesh box the conversion accepts, any fitted numbers it can reach.
    #[test]
    fn converted_models_read_back(
        lo in prop::array::uniform3(-MAX_CONVERT_COORDINATE..MAX_CONVERT_COORDINATE),
        extent in prop_oneof![
            MIN_CONVERT_EXTENT..1e-3,
            1e-3f64..10.0,
            10.0f64..2.0 * MAX_CONVERT_COORDINATE
        ],
        stretch in prop::array::uniform3(1e-3f64..=1.0),
        base in prop::array::uniform10(-1e3f64..1e3),
        bumps in prop::collection::vec(
            (prop::array::uniform3(-0.6f64..0.6), 0.004f64..0.5, -1e3f64..1e3),
            0..6
        ),
        hole in (
            prop::array::uniform3(-0.5f64..0.5),
            prop::array::uniform3(-1.0f64..1.0),
            1e-4f64..0.3,
            3usize..9,
        ),
    ) {
        let hi = [0, 1, 2].map(|k| (lo[k] + extent * stretch[k]).min(MAX_CONVERT_COORDINATE));
        let mesh = PolygonMesh {
            positions: vec![lo, [hi[0], lo[1], lo[2]], [lo[0], hi[1], lo[2]], hi],
            triangles: vec![[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]],
        };
        if check_convertible(&mesh, "m.obj").is_err() {
            return Ok(());
        }
        let bumps = bumps
            .into_iter()
            .map(|(centre, radius, factor)| Bump { centre, radius, factor })
            .collect();
        let model = ImplicitModel::new(mesh.unit_frame(), base, bumps);
        let path = file("convert", "json");
        let json = model.to_frep_json("m (converted)", mesh.bounds());
        std::fs::write(&path, serde_json::to_string(&json).expect("json")).expect("write");
        reads_back_as_model(&path);
        // The same model as a shell with an opening over a regular polygon (a fan of
        // triangles) anywhere, of any size the loops of a mesh give.
        let (centre, axis, radius, corners) = hole;
        let len = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
        if len > 1e-3 {
            let normal = axis.map(|v| v / len);
            let u = {
                let t = if normal[0].abs() < 0.9 { [1.0, 0.0, 0.0] } else { [0.0, 1.0, 0.0] };
                let c = [
                    normal[1] * t[2] - normal[2] * t[1],
                    normal[2] * t[0] - normal[0] * t[2],
                    normal[0] * t[1] - normal[1] * t[0],
                ];
                let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                c.map(|v| v / l)
            };
            let w = [
                normal[1] * u[2] - normal[2] * u[1],
                normal[2] * u[0] - normal[0] * u[2],
                normal[0] * u[1] - normal[1] * u[0],
            ];
            let opening = openings::Opening {
                centre,
                normal,
                slab: [-0.02, 0.03],
                corners: (0..corners)
                    .map(|k| {
                        let a = std::f64::consts::TAU * k as f64 / corners as f64;
                        [0, 1, 2].map(|i| centre[i] + radius * (a.cos() * u[i] + a.sin() * w[i]))
                    })
                    .collect(),
                triangles: (1..corners - 1).map(|k| [0, k, k + 1]).collect(),
                loop_edges: corners,
            };
            let unit_model = openings::shell_with_openings(
                model.fitted_json(),
                &[opening],
                openings::SHELL_THICKNESS,
            );
            let json = model.to_frep_json_of(unit_model, "m (converted)", mesh.bounds());
            std::fs::write(&path, serde_json::to_string(&json).expect("json")).expect("write");
            reads_back_as_model(&path);
        }
        std::fs::remove_file(&path).ok();
    }

    /// distort: moves anywhere a surface may hold coordinates.
    #[test]
    fn distorted_surfaces_read_back(
        moves in prop::collection::vec(
            (
                prop::array::uniform3(-1.5f64..1.5),
                prop::array::uniform3(prop_oneof![-1.5f64..1.5, -1e6f64..=1e6]),
            ),
            1..4
        ),
    ) {
        use caoen::texture::warp3d::{Move3, Warp3};
        let blob = gallery::blob().expect("blob");
        let moves: Vec<Move3> = moves.into_iter().map(|(from, to)| Move3 { from, to }).collect();
        let Ok(warp) = Warp3::new([-1.0; 3], [1.0; 3], &moves) else {
            return Ok(());
        };
        let Ok(out) = warp.apply_to_model(&blob) else {
            return Ok(());
        };
        let text = out.to_json();
        if let Err(e) = SurfaceModel::from_json(&text) {
            panic!("distorted surface written but not read back: {e}");
        }
    }

    /// morph: any frame between a surface and a rescaled copy of it (the same domain
    /// and normalisation), shapes up to a tenth of the largest a surface holds.
    #[test]
    fn morphed_surfaces_read_back(
        pick in 0usize..2,
        scale in prop_oneof![-1e5f64..-1e-3, 1e-3f64..1e5],
        u in prop_oneof![Just(0.0), Just(1.0), 0.0f64..=1.0],
    ) {
        let a = gallery::by_name(["blob", "ring"][pick]).expect("known").expect("builds");
        let p = a.network.output_dim();
        let shapes: Vec<f64> = a.network.shapes().iter().map(|v| v * scale).collect();
        let b = a.network.with_shapes(p, shapes).expect("rescaled");
        let net = caoen::surface::morph::morph(&a.network, &b, u).expect("morph");
        let out = SurfaceModel { network: net, ..a };
        if let Err(e) = SurfaceModel::from_json(&out.to_json()) {
            panic!("morph at u = {u} written but not read back: {e}");
        }
    }

    /// transfer: the baked texture (any grid size) is a PNG the image reader takes, and
    /// the default grid is bounded.
    #[test]
    fn transferred_textures_read_back(
        tw in 1u32..48,
        th in 1u32..48,
        picture in (1u32..10_000, 1u32..10_000),
        output in (1u32..20_000, 1u32..20_000),
    ) {
        let (bw, bh) = caoen_cli::commands::texture::default_bake(picture.0, picture.1, output);
        let cap = caoen_cli::commands::texture::MAX_DEFAULT_BAKE;
        prop_assert!(bw >= 1 && bh >= 1 && bw <= cap && bh <= cap);
        prop_assert!(bw <= picture.0 && bh <= picture.1);
        let tex = texture();
        let from = gallery::by_name("octahedron").expect("known").expect("builds");
        let to = gallery::blob().expect("blob");
        let Ok(img) = caoen::texture::transfer::transfer(&from, &to, tex, tw, th) else {
            return Ok(());
        };
        let png = img.encode_png().expect("png");
        let back = caoen::image_io::load_from_memory(&png, &Default::default()).expect("reads back");
        prop_assert_eq!((back.width(), back.height()), (tw, th));
    }
}

/// A small texture for the transfers.
fn texture() -> &'static caoen::render::texture::Texture {
    static T: OnceLock<caoen::render::texture::Texture> = OnceLock::new();
    T.get_or_init(|| {
        caoen::render::texture::Texture::load(
            &repo_path("tests/bad/hostile/small.png"),
            &caoen::Limits::default(),
        )
        .expect("small.png")
    })
}

// The writers behind the command line: each case is a whole command in process.
proptest! {
    #![proptest_config(common::proptest_config(cases()))]

    /// relief and carve: any legal depth, level, shell and projection on any base.
    #[test]
    fn relief_and_carve_models_read_back(
        base in base_model(),
        carve in any::<bool>(),
        depth in prop_oneof![-1e3f64..=1e3, -1.0f64..1.0],
        level in 0.0f64..=1.0,
        shell in prop::option::of(prop_oneof![1e-6f64..1e-3, 1e-3f64..=1e3]),
        projection in prop_oneof![Just("planar"), Just("cylindrical"), Just("spherical")],
    ) {
        let out = file(if carve { "carve" } else { "relief" }, "json");
        let mut args = vec![
            if carve { "carve" } else { "relief" }.to_string(),
            s(&repo_path("tests/bad/hostile/small.png")),
            "--on".into(),
            s(&base),
            "-o".into(),
            s(&out),
            "--projection".into(),
            projection.into(),
            format!("--depth={depth}"),
            format!("--level={level}"),
        ];
        if let (true, Some(t)) = (carve, shell) {
            args.push(format!("--shell={t}"));
        }
        if caoen(&args).is_ok() {
            reads_back_as_model(&out);
        }
        std::fs::remove_file(&out).ok();
    }

    /// heightfield: any legal height and threshold on every base.
    #[test]
    fn heightfield_models_read_back(
        height in prop_oneof![-1e3f64..=1e3, -1e-3f64..1e-3],
        threshold in prop::option::of(-1e3f64..=1e3),
        base in prop_oneof![Just("plane"), Just("ellipsoid"), Just("cylinder")],
        bicubic in any::<bool>(),
    ) {
        let out = file("heightfield", "json");
        let mut args = vec![
            "heightfield".to_string(),
            s(&repo_path("tests/bad/hostile/small.png")),
            "-o".into(),
            s(&out),
            "--base".into(),
            base.into(),
            format!("--height={height}"),
            "--interp".into(),
            if bicubic { "bicubic" } else { "bilinear" }.into(),
        ];
        if let Some(t) = threshold {
            args.push(format!("--threshold={t}"));
        }
        if caoen(&args).is_ok() {
            reads_back_as_model(&out);
        }
        std::fs::remove_file(&out).ok();
    }

    /// frep mesh: the OBJ or PLY written is a mesh the conversion reads.
    #[test]
    fn frep_meshes_read_back(base in base_model(), cells in 4u32..12, ply in any::<bool>()) {
        let out = file("mesh", if ply { "ply" } else { "obj" });
        let args = [
            "frep".to_string(),
            "mesh".into(),
            s(&base),
            "-o".into(),
            s(&out),
            format!("--cells={cells}"),
        ];
        if caoen(&args).is_ok() {
            if let Err(e) = caoen::conversion::read(&out, &caoen::Limits::default()) {
                panic!("{}: written but not read back: {e}", out.display());
            }
        }
        std::fs::remove_file(&out).ok();
    }
}
