//! `caoen transfer`: texture transfer between surfaces through their shared
//! domain.

mod common;
use common::{assert_ok, caoen, caoen_ok, s};

use std::path::{Path, PathBuf};

use caoen::render::framebuffer::RgbImage;
use caoen::render::texture::{domain_uv, Texture, Wrap};
use caoen::surface::gallery;
use caoen::texture::transfer::{transfer, uv_domain};
// The 16^3 test volume is the one `caoen examples` writes.
use caoen_cli::commands::examples::volume_slices;

fn tmpdir(name: &str) -> PathBuf {
    common::fresh_dir(&format!("transfer-{name}"))
}

/// The surface model `examples/{name}`.
fn example(name: &str) -> caoen::surface::SurfaceModel {
    let path = common::repo_path("examples").join(name);
    caoen::surface::SurfaceModel::load(&path, &caoen::Limits::default()).unwrap()
}

fn checker() -> Texture {
    Texture::checker(
        256,
        128,
        16,
        8,
        [0.9, 0.85, 0.7],
        [0.05, 0.1, 0.3],
        &caoen::Limits::default(),
    )
    .unwrap()
}

#[test]
fn uv_domain_inverts_domain_uv() {
    for domain in [
        caoen::surface::Domain::SPHERE,
        caoen::surface::Domain::Torus,
    ] {
        for uv in [[0.1, 0.2], [0.7, 0.9], [0.5, 0.5]] {
            let x = uv_domain(&domain, uv).unwrap();
            let back = domain_uv(&domain, &x).unwrap();
            assert!((back[0] - uv[0]).abs() < 1e-12 && (back[1] - uv[1]).abs() < 1e-12);
        }
    }
}

#[test]
fn checkerboard_round_trip_a_b_a() {
    let a = gallery::by_name("octahedron").unwrap().unwrap();
    let b = gallery::by_name("blob").unwrap().unwrap();
    let tex = checker();
    // A to B on a `w x h` texture grid, and back to A's 256x128.
    let round_trip = |(w, h): (u32, u32)| {
        let on_b = transfer(&a, &b, &tex, w, h).unwrap();
        let on_b = Texture::new(on_b, &caoen::Limits::default()).unwrap();
        let back = transfer(&b, &a, &on_b, 256, 128).unwrap();
        common::psnr_render(tex.image(), &back)
    };
    let p = round_trip((256, 128));
    println!("A -> B -> A checkerboard (same texture size): PSNR {p} dB");
    assert!(p > 35.0, "{p}");
    // Through a finer texture grid on B: resampled twice.
    let p2 = round_trip((512, 256));
    println!("A -> B (512x256) -> A checkerboard: PSNR {p2:.2} dB");
    assert!(p2 > 20.0, "{p2}");
}

#[test]
fn colours_stay_at_the_key_points_images() {
    // A texture on the sphere carried to a deformed sphere (the blob): the colour B
    // shows at each key point's image B(w_i) is the colour A shows at A(w_i).
    let a = gallery::by_name("six-point").unwrap().unwrap();
    let b = gallery::by_name("blob").unwrap().unwrap();
    let tex = checker();
    let on_b = Texture::new(
        transfer(&a, &b, &tex, 256, 128).unwrap(),
        &caoen::Limits::default(),
    )
    .unwrap();
    let mut worst: f32 = 0.0;
    for kp in b.network.key_points() {
        let uv = domain_uv(&b.domain, &kp.source).unwrap();
        let (ca, cb) = (tex.sample(uv, Wrap::Sphere), on_b.sample(uv, Wrap::Sphere));
        for k in 0..3 {
            worst = worst.max((ca[k] - cb[k]).abs());
        }
    }
    println!("colour difference at B's key points: max {worst:.2e}");
    assert!(worst < 1e-3, "{worst}");
}

#[test]
fn different_domains_are_refused() {
    let a = gallery::by_name("blob").unwrap().unwrap();
    let b = gallery::by_name("ring").unwrap().unwrap();
    assert!(transfer(&a, &b, &checker(), 64, 32).is_err());
}

/// Runs `caoen transfer` of the picture `texture` from the surface `from` to `to` into
/// `out`, with the arguments `more`, and asserts that it succeeded.
fn transfer_cli(texture: &Path, from: &str, to: &str, out: &Path, more: &[&str]) {
    let args = [
        "transfer",
        "--texture",
        s(texture),
        "--from",
        from,
        "--to",
        to,
    ];
    caoen_ok(&[&args[..], &["-o", s(out)], more].concat());
}

#[test]
fn cli_transfer_png_obj_and_errors() {
    let dir = tmpdir("cli");
    let tex = dir.join("checker.png");
    std::fs::write(&tex, checker().image().encode_png().unwrap()).unwrap();
    let png = dir.join("b.png");
    let (octahedron, blob) = ("builtin:octahedron", "builtin:blob");
    transfer_cli(
        &tex,
        octahedron,
        blob,
        &png,
        &["--size", "160x120", "--detail", "4"],
    );
    assert!(png.exists());
    let obj = dir.join("b.obj");
    transfer_cli(&tex, octahedron, blob, &obj, &["--detail", "3"]);
    // What a viewer needs: the OBJ names its MTL and material, the MTL names the PNG,
    // every face corner indexes an existing position, texture coordinate and normal.
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.contains("mtllib b.mtl") && text.contains("usemtl "));
    let mtl = std::fs::read_to_string(dir.join("b.mtl")).unwrap();
    assert!(mtl.contains("map_Kd b-texture.png"), "{mtl}");
    assert!(image::open(dir.join("b-texture.png")).is_ok());
    let count = |tag: &str| text.lines().filter(|l| l.starts_with(tag)).count();
    let (nv, nvt, nvn) = (count("v "), count("vt "), count("vn "));
    assert!(nvt > 0 && count("f ") > 0);
    for l in text.lines().filter(|l| l.starts_with("f ")) {
        for corner in l.split_whitespace().skip(1) {
            let idx: Vec<usize> = corner.split('/').map(|v| v.parse().unwrap()).collect();
            assert_eq!(idx.len(), 3, "{l}");
            assert!((1..=nv).contains(&idx[0]) && (1..=nvt).contains(&idx[1]));
            assert!((1..=nvn).contains(&idx[2]), "{l}");
        }
    }
    for l in text.lines().filter(|l| l.starts_with("vt ")) {
        let uv: Vec<f64> = l
            .split_whitespace()
            .skip(1)
            .map(|v| v.parse().unwrap())
            .collect();
        assert!(uv.iter().all(|v| v.is_finite()), "{l}");
    }
    // A .cae texture.
    let cae = dir.join("t.cae");
    caoen_ok(&["encode", s(&tex), "-o", s(&cae), "--quiet"]);
    let more = ["--size", "64x48", "--detail", "3"];
    transfer_cli(&cae, "builtin:six-point", blob, &dir.join("c.png"), &more);
    let code = |args: &[&str]| {
        let o = caoen(args);
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
        o.status.code()
    };
    // --force: these cases are about the surfaces and the texture, and `png` exists.
    let base = [
        "transfer",
        "--force",
        "--texture",
        s(&tex),
        "--from",
        "builtin:blob",
    ];
    fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [base, extra].concat()
    }
    assert_eq!(
        code(&with(
            &base,
            &["--to", "builtin:blob", "-o", s(&dir.join("x.txt"))]
        )),
        Some(2)
    );
    assert_eq!(
        code(&with(&base, &["--to", "builtin:nope", "-o", s(&png)])),
        Some(2)
    );
    assert_eq!(
        code(&with(&base, &["--to", "builtin:ring", "-o", s(&png)])),
        Some(1)
    );
    assert_eq!(
        code(&with(
            &base,
            &["--to", s(&dir.join("missing.json")), "-o", s(&png)]
        )),
        Some(1)
    );
    assert_eq!(
        code(&[
            "transfer",
            "--force",
            "--texture",
            s(&dir.join("none.png")),
            "--from",
            "builtin:blob",
            "--to",
            "builtin:blob",
            "-o",
            s(&png)
        ]),
        Some(1)
    );
}

#[test]
fn textured_morph_keeps_the_texture_attached() {
    // Five frames of examples/morph-a.json -> morph-b.json: every mesh vertex keeps the
    // texture coordinates of its domain point, whatever the shape does.
    use caoen::render::mesh::{tessellate, NormalMode};
    use caoen::surface::{morph::morph, SurfaceModel};
    let (a, b) = (example("morph-a.json"), example("morph-b.json"));
    for k in 0..5 {
        let u = k as f64 / 4.0;
        let net = morph(&a.network, &b.network, u).unwrap();
        let model = SurfaceModel::new(format!("morph-{k}"), a.domain, net)
            .unwrap()
            .with_texture("../checker.png");
        let mesh = tessellate(&model, 3, NormalMode::Exact, &caoen::Limits::default()).unwrap();
        for (t, uvs) in mesh.triangles.iter().zip(&mesh.corner_uvs) {
            for c in 0..3 {
                let x = &mesh.domain_points[t[c] as usize];
                if x[0].hypot(x[1]) < 1e-9 {
                    continue; // poles: u is a convention there
                }
                let want = domain_uv(&model.domain, x).unwrap();
                let du = (uvs[c][0] - want[0]).rem_euclid(1.0);
                assert!(du.min(1.0 - du) < 1e-9 && (uvs[c][1] - want[1]).abs() < 1e-9);
            }
        }
    }
}

#[test]
fn texture_space_carries_a_solid_texture() {
    use caoen::texture::transfer::{bake_texture_space, solid_checker};
    let b = gallery::by_name("blob").unwrap().unwrap();
    // Texture space = the shape itself: the object looks carved from the solid.
    let solid = |p: [f64; 3]| solid_checker(p, 0.3);
    let img = bake_texture_space(&b, &b, &solid, 64, 32, 1).unwrap();
    for (k, px) in img.pixels.iter().enumerate().step_by(37) {
        let uv = [
            ((k % 64) as f64 + 0.5) / 64.0,
            ((k / 64) as f64 + 0.5) / 32.0,
        ];
        let x = uv_domain(&b.domain, uv).unwrap();
        let y = b.network.eval(&x).unwrap();
        assert_eq!(*px, solid([y[0], y[1], y[2]]));
    }
    let ring = gallery::by_name("ring").unwrap().unwrap();
    assert!(bake_texture_space(&ring, &b, &solid, 8, 8, 1).is_err());
    let dir = tmpdir("space");
    let out = dir.join("s.png");
    caoen_ok(&[
        "transfer",
        "--texture-space",
        "builtin:six-point",
        "--to",
        "builtin:blob",
        "-o",
        s(&out),
        "--size",
        "96x72",
        "--detail",
        "3",
    ]);
    assert_eq!(
        caoen(&["transfer", "--to", "builtin:blob", "-o", s(&out)])
            .status
            .code(),
        Some(2)
    );
    assert_eq!(
        caoen(&[
            "transfer",
            "--texture-space",
            "builtin:ring",
            "--to",
            "builtin:blob",
            "-o",
            s(&out)
        ])
        .status
        .code(),
        Some(1)
    );
}

#[test]
fn procedural_solid_textures_golden_and_properties() {
    use caoen::texture::solid::{perlin, turbulence, Solid, DEFAULT_COLOURS, PROCEDURAL};
    // Golden values: the textures are plain IEEE arithmetic, so these are exact on
    // every platform.
    let golden: [(&str, [f64; 3], [f32; 3]); 6] = [
        ("checker", [0.1, 0.2, 0.3], [0.06, 0.12, 0.35]),
        ("checker", [-0.71, 0.45, 1.3], [0.85, 0.8, 0.65]),
        (
            "stripes",
            [0.1, 0.2, 0.3],
            [0.26481485, 0.2962963, 0.42777777],
        ),
        (
            "rings",
            [-0.71, 0.45, 1.3],
            [0.8381016, 0.7897584, 0.6454816],
        ),
        (
            "marble",
            [-0.71, 0.45, 1.3],
            [0.6806402, 0.65422195, 0.58568615],
        ),
        (
            "marble",
            [1.234, -0.9, -0.05],
            [0.8499223, 0.79993314, 0.6499705],
        ),
    ];
    for (kind, p, want) in golden {
        let s = Solid::procedural(kind, 0.3, DEFAULT_COLOURS).unwrap();
        assert_eq!(s.sample(p), want, "{kind} at {p:?}");
    }
    assert_eq!(perlin([0.3, 1.7, -2.2]), -0.1851828844799999);
    assert_eq!(turbulence([0.3, 1.7, -2.2], 5), 0.5383035766515709);
    // Perlin noise vanishes on the integer lattice and stays within -1..1.
    assert_eq!(perlin([3.0, -2.0, 7.0]), 0.0);
    for i in 0..2000 {
        let t = i as f64 * 0.0137;
        let v = perlin([t, 0.7 * t + 0.3, 0.1 - 1.3 * t]);
        assert!(v.abs() <= 1.0, "{v}");
    }
    // Every kind stays between its two colours; stripes repeat with their period.
    let c = [[0.0, 0.5, 1.0], [1.0, 0.25, 0.0]];
    for kind in PROCEDURAL {
        let s = Solid::procedural(kind, 0.5, c).unwrap();
        for i in 0..500 {
            let p = [i as f64 * 0.031 - 7.0, (i as f64 * 0.017).fract(), 0.3];
            let v = s.sample(p);
            for k in 0..3 {
                let (lo, hi) = (c[0][k].min(c[1][k]), c[0][k].max(c[1][k]));
                assert!(v[k] >= lo && v[k] <= hi, "{kind} {p:?} {v:?}");
            }
        }
    }
    let stripes = Solid::procedural("stripes", 0.5, c).unwrap();
    assert_eq!(
        stripes.sample([0.125, 0.3, 0.2]),
        stripes.sample([0.625, -4.0, 9.0])
    );
    // Huge and non-finite coordinates are defined.
    for kind in PROCEDURAL {
        let s = Solid::procedural(kind, 0.5, c).unwrap();
        let _ = s.sample([1e300, -1e300, f64::NAN]);
    }
    assert!(Solid::procedural("wood", 0.5, c).is_err());
    assert!(Solid::procedural("checker", 0.0, c).is_err());
    assert!(Solid::procedural("checker", f64::NAN, c).is_err());
}

#[test]
fn volume_texture_trilinear_and_errors() {
    use caoen::texture::solid::{Volume, VolumeWrap};
    // 2 x 2 x 2 voxels over [0, 2]^3: voxel centres at 0.5 and 1.5.
    let vox: Vec<[f32; 3]> = (0..8).map(|i| [i as f32, 0.0, 1.0]).collect();
    let cube = |wrap| Volume::new([2, 2, 2], vox.clone(), [0.0; 3], [2.0; 3], wrap);
    let v = cube(VolumeWrap::Clamp).unwrap();
    assert_eq!(v.sample([0.5, 0.5, 0.5]), [0.0, 0.0, 1.0]);
    assert_eq!(v.sample([1.5, 0.5, 1.5]), [5.0, 0.0, 1.0]);
    // The centre: the mean of all eight.
    assert_eq!(v.sample([1.0, 1.0, 1.0]), [3.5, 0.0, 1.0]);
    // Along x between two centres: linear; beyond the box: the edge voxel (clamp).
    assert_eq!(v.sample([0.75, 0.5, 0.5]), [0.25, 0.0, 1.0]);
    assert_eq!(v.sample([-5.0, 9.0, 0.5]), [2.0, 0.0, 1.0]);
    // Repeat: one box further along every axis is the same point.
    let r = cube(VolumeWrap::Repeat).unwrap();
    assert_eq!(r.sample([0.8, 1.3, 0.6]), r.sample([2.8, -0.7, 4.6]));
    // Between the last and the first voxel it wraps: x = 0 is halfway between them.
    assert_eq!(r.sample([0.0, 0.5, 0.5]), [0.5, 0.0, 1.0]);
    assert!(Volume::new(
        [2, 2, 2],
        vox.clone(),
        [0.0; 3],
        [0.0, 2.0, 2.0],
        VolumeWrap::Clamp
    )
    .is_err());
    assert!(Volume::new([2, 2, 3], vox, [0.0; 3], [2.0; 3], VolumeWrap::Clamp).is_err());
    assert!(Volume::new([0, 2, 2], vec![], [0.0; 3], [2.0; 3], VolumeWrap::Clamp).is_err());
    // From slices: slice k is layer z = k.
    let slices = volume_slices();
    let v = Volume::from_slices(&slices, [-1.0; 3], [1.0; 3], VolumeWrap::Clamp).unwrap();
    assert_eq!(v.size(), [16, 16, 16]);
    let c = |i: usize| -1.0 + (i as f64 + 0.5) / 8.0;
    assert_eq!(v.sample([c(3), c(7), c(11)]), slices[11].pixels[7 * 16 + 3]);
    assert!(Volume::from_slices(&[], [-1.0; 3], [1.0; 3], VolumeWrap::Clamp).is_err());
}

#[test]
fn cli_solid_textures_and_volume_specs() {
    let dir = tmpdir("solid");
    let vdir = dir.join("volume");
    std::fs::create_dir_all(&vdir).unwrap();
    let mut names = Vec::new();
    for (k, s) in volume_slices().iter().enumerate() {
        let name = format!("z{k:02}.png");
        std::fs::write(vdir.join(&name), s.encode_png().unwrap()).unwrap();
        names.push(name);
    }
    let spec = vdir.join("volume.json");
    let spec_json = |slices: &[String]| {
        format!(
            "{{\"slices\": {}, \"min\": [-1.5, -1.5, -1.5], \"max\": [1.5, 1.5, 1.5], \"wrap\": \"clamp\"}}",
            serde_json::to_string(slices).unwrap()
        )
    };
    std::fs::write(&spec, spec_json(&names)).unwrap();
    let run = |extra: &[&str], out: &Path| {
        let mut args = vec![
            "transfer",
            "--texture-space",
            "builtin:blob",
            "--to",
            "builtin:blob",
            "-o",
            s(out),
            "--size",
            "96x72",
            "--detail",
            "3",
            "--texture-size",
            "64x32",
        ];
        args.extend_from_slice(extra);
        let o = caoen(&args);
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(!err.contains("panicked"), "{err}");
        (o.status.code(), err)
    };
    // Every procedural kind, with colours, and the volume: images that differ.
    let mut outputs = Vec::new();
    for kind in ["checker", "stripes", "rings", "marble"] {
        let out = dir.join(format!("{kind}.png"));
        let (code, err) = run(
            &[
                "--solid",
                kind,
                "--scale",
                "0.4",
                "--colours",
                "#f0e0c0,402010",
            ],
            &out,
        );
        assert_eq!(code, Some(0), "{err}");
        outputs.push(std::fs::read(&out).unwrap());
    }
    let out = dir.join("volume.png");
    let (code, err) = run(&["--solid", s(&spec)], &out);
    assert_eq!(code, Some(0), "{err}");
    outputs.push(std::fs::read(&out).unwrap());
    for i in 0..outputs.len() {
        for j in 0..i {
            assert_ne!(outputs[i], outputs[j], "outputs {i} and {j} are the same");
        }
    }
    // The OBJ path with a volume: its texture is the volume sampled at B(x).
    let obj = dir.join("v.obj");
    let (code, err) = run(&["--solid", s(&spec)], &obj);
    assert_eq!(code, Some(0), "{err}");
    assert!(dir.join("v-texture.png").exists());
    // Bad parameters: usage errors.
    let bad = dir.join("bad.png");
    for extra in [
        &["--solid", "wood"][..],
        &["--solid", "marble", "--scale", "0"],
        &["--solid", "marble", "--scale", "-1"],
        &["--solid", "marble", "--colours", "ff0000"],
        &["--solid", "marble", "--colours", "ff0000,zz0000"],
        &["--solid", s(&spec), "--colours", "ff0000,00ff00"],
    ] {
        assert_eq!(run(extra, &bad).0, Some(2), "{extra:?}");
    }
    // Bad volumes: failures with a message naming the problem.
    let bad_spec = |name: &str, text: String| {
        let p = vdir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let mut missing = names.clone();
    missing[1] = "nope.png".into();
    let p = bad_spec("missing.json", spec_json(&missing));
    let (code, err) = run(&["--solid", s(&p)], &bad);
    assert_eq!(code, Some(1));
    assert!(err.contains("slice 1") && err.contains("nope.png"), "{err}");
    std::fs::write(
        dir.join("small.png"),
        RgbImage {
            width: 8,
            height: 16,
            pixels: vec![[0.5; 3]; 128],
        }
        .encode_png()
        .unwrap(),
    )
    .unwrap();
    let mut mismatched = names.clone();
    mismatched[2] = s(&dir.join("small.png")).to_string();
    let p = bad_spec("mismatched.json", spec_json(&mismatched));
    let (code, err) = run(&["--solid", s(&p)], &bad);
    assert_eq!(code, Some(1));
    assert!(
        err.contains("slice 2 is 8x16") && err.contains("one size"),
        "{err}"
    );
    let p = bad_spec("empty.json", spec_json(&[]));
    let (code, err) = run(&["--solid", s(&p)], &bad);
    assert_eq!(code, Some(1));
    assert!(err.contains("empty"), "{err}");
    let p = bad_spec(
        "box.json",
        r#"{"slices": ["z00.png"], "min": [1, 0, 0], "max": [0, 1, 1]}"#.into(),
    );
    let (code, err) = run(&["--solid", s(&p)], &bad);
    assert_eq!(code, Some(1));
    assert!(err.contains("min < max"), "{err}");
    let p = bad_spec("junk.json", "{\"slices\": 3}".into());
    assert_eq!(run(&["--solid", s(&p)], &bad).0, Some(1));
    assert_eq!(
        run(&["--solid", s(&dir.join("none.json"))], &bad).0,
        Some(1)
    );
    for name in [
        "missing.json",
        "mismatched.json",
        "empty.json",
        "box.json",
        "junk.json",
    ] {
        let _ = std::fs::remove_file(vdir.join(name));
    }
}

#[test]
fn texture_control_example_steers_the_texture() {
    // examples/texture-control.json: key points with different sources and one shape
    // vector (the paper's texture control). More of the domain, so more of the texture,
    // lands on the +x tip than on the plain blob.
    use caoen::surface::SurfaceModel;
    let model = example("texture-control.json");
    assert!(model.texture.is_some());
    let kps = model.network.key_points();
    let tip: Vec<_> = kps.iter().filter(|k| k.shape == [1.3, 0.0, 0.0]).collect();
    assert!(
        tip.len() >= 2,
        "{} key points share the tip's shape",
        tip.len()
    );
    for (i, a) in tip.iter().enumerate() {
        for b in &tip[..i] {
            assert_ne!(a.source, b.source);
        }
    }
    let blob = gallery::by_name("blob").unwrap().unwrap();
    let on_tip = |m: &SurfaceModel| {
        let mut n = 0;
        for j in 0..64 {
            for i in 0..128 {
                let uv = [(i as f64 + 0.5) / 128.0, (j as f64 + 0.5) / 64.0];
                let y = m.network.eval(&uv_domain(&m.domain, uv).unwrap()).unwrap();
                n += usize::from(y[0] > 0.9);
            }
        }
        n
    };
    let (steered, plain) = (on_tip(&model), on_tip(&blob));
    println!("texels on the +x tip: texture control {steered}, plain blob {plain}");
    assert!(steered as f64 > 1.3 * plain as f64, "{steered} vs {plain}");
}

/// A colour ramp in sRGB: red rises with the column, green with the row.
fn ramp_png(path: &Path, w: u32, h: u32) {
    let img = image::RgbImage::from_fn(w, h, |i, j| {
        image::Rgb([(i * 255 / (w - 1)) as u8, (j * 255 / (h - 1)) as u8, 96])
    });
    img.save(path).unwrap();
}

fn load_rgb(path: &Path) -> RgbImage {
    RgbImage::load(path, &caoen::Limits::default()).unwrap()
}

#[test]
fn cli_the_source_surface_shapes_a_projected_picture() {
    // A picture laid on A in A's own space: carried to the same B, it looks different
    // from different A (and from A's domain texture), while `--project domain` carries
    // the same domain texture whatever A is.
    let dir = tmpdir("from");
    let pic = dir.join("ramp.png");
    ramp_png(&pic, 128, 64);
    let run = |from: &str, project: &str, out: &str| {
        let out = dir.join(out);
        let more = ["--project", project, "--size", "96x72", "--detail", "4"];
        transfer_cli(&pic, from, "builtin:blob", &out, &more);
        std::fs::read(out).unwrap()
    };
    for project in ["planar", "cylindrical", "spherical"] {
        let a = run("builtin:octahedron", project, &format!("o-{project}.png"));
        let c = run("builtin:six-point", project, &format!("s-{project}.png"));
        assert!(
            a != c,
            "{project}: octahedron and six-point give the same result"
        );
    }
    // The ring lives on the torus: a different domain is refused, not ignored.
    let o = caoen(&[
        "transfer",
        "--texture",
        s(&pic),
        "--from",
        "builtin:ring",
        "--to",
        "builtin:blob",
        "-o",
        s(&dir.join("ring.png")),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&o.stderr).contains("domain"));
    let a = run("builtin:octahedron", "domain", "o-domain.png");
    let c = run("builtin:six-point", "domain", "s-domain.png");
    assert_eq!(
        a, c,
        "a domain texture does not depend on the source surface"
    );
    assert!(a != run("builtin:octahedron", "spherical", "o-spherical2.png"));
}

#[test]
fn cli_projected_picture_round_trip_a_b_a() {
    // A picture on A carried to B (written as an OBJ with B's texture) and back to A
    // (B's texture is a domain texture) renders as A with the picture directly, and
    // within 35 dB of a reference baked at 4x the texture size.
    let dir = tmpdir("roundtrip");
    let pic = dir.join("ramp.png");
    ramp_png(&pic, 128, 64);
    let sized = ["--size", "128x96", "--detail", "4"];
    let (obj, back, direct, reference) = (
        dir.join("b.obj"),
        dir.join("back.png"),
        dir.join("direct.png"),
        dir.join("reference.png"),
    );
    let (blob, octahedron) = ("builtin:blob", "builtin:octahedron");
    transfer_cli(&pic, blob, octahedron, &obj, &["--detail", "3"]);
    let b_texture = dir.join("b-texture.png");
    let domain = [&["--project", "domain"][..], &sized].concat();
    transfer_cli(&b_texture, octahedron, blob, &back, &domain);
    transfer_cli(&pic, blob, blob, &direct, &sized);
    let bake = [&["--bake-size", "512x256"][..], &sized].concat();
    transfer_cli(&pic, blob, blob, &reference, &bake);
    let (back, direct, reference) = (load_rgb(&back), load_rgb(&direct), load_rgb(&reference));
    let (to_direct, to_reference) = (
        common::psnr_render(&direct, &back),
        common::psnr_render(&reference, &back),
    );
    println!("A -> B -> A: {to_direct:.1} dB against A directly, {to_reference:.1} dB against the 4x bake");
    assert!(to_direct >= 35.0 && to_reference >= 35.0);
}

#[test]
fn baked_checker_has_no_stair_steps() {
    // The blob carved from a solid checker, baked at 256x256 and rendered at 128x128
    // (2x2 samples), against a 4x reference: bake at 1024x1024, 8x8 samples. Texels
    // averaged over their area (--bake-samples) and pyramid lookups keep the edges
    // smooth; point-sampled texels draw stair steps the reference does not have.
    use caoen::render::renderer::{render, RenderOptions};
    use caoen::render::Scene;
    use caoen::texture::transfer::bake_texture_space;
    let blob = gallery::by_name("blob").unwrap().unwrap();
    let solid = |p: [f64; 3]| caoen::texture::transfer::solid_checker(p, 0.3);
    let shot = |tex: RgbImage, samples: u32| {
        let dir = tmpdir("stairs");
        std::fs::write(dir.join("t.png"), tex.encode_png().unwrap()).unwrap();
        let model = blob.clone().with_texture("t.png");
        let scene = Scene::from_model(
            model,
            Some(&dir.join("blob.json")),
            &caoen::Limits::default(),
        )
        .unwrap();
        let opts = RenderOptions {
            width: 128,
            height: 128,
            samples,
            mesh_detail: 5,
            ..Default::default()
        };
        render(&scene, &opts, &|_, _| {}).unwrap().image
    };
    let reference = shot(
        bake_texture_space(&blob, &blob, &solid, 1024, 1024, 3).unwrap(),
        8,
    );
    let filtered = shot(
        bake_texture_space(&blob, &blob, &solid, 256, 256, 3).unwrap(),
        2,
    );
    let point = shot(
        bake_texture_space(&blob, &blob, &solid, 256, 256, 1).unwrap(),
        2,
    );
    let (f, p) = (
        common::psnr_render(&reference, &filtered),
        common::psnr_render(&reference, &point),
    );
    println!("against the 4x reference: filtered bake {f:.2} dB, point-sampled bake {p:.2} dB");
    assert!(f >= 35.0, "{f:.2} dB");
    assert!(f > p + 0.3, "filtering gains {:.2} dB", f - p);
}

#[test]
fn texture_pyramid_averages_and_selects_levels() {
    let tex = checker();
    assert_eq!(tex.levels(), 9); // 256x128 .. 1x1
    let mean = |img: &RgbImage| {
        let n = img.pixels.len() as f64;
        [0, 1, 2].map(|k| img.pixels.iter().map(|p| p[k] as f64).sum::<f64>() / n)
    };
    let m = mean(tex.image());
    // The top level is the mean of the image; a footprint beyond the image reads it.
    let top = tex.sample_filtered([0.3, 0.6], 1e9, Wrap::Sphere);
    for k in 0..3 {
        assert!((top[k] as f64 - m[k]).abs() < 1e-5, "{top:?} vs {m:?}");
    }
    // A footprint of one texel or less is the plain bilinear lookup.
    for uv in [[0.1, 0.2], [0.77, 0.31], [0.999, 0.001]] {
        assert_eq!(
            tex.sample_filtered(uv, 0.5, Wrap::Sphere),
            tex.sample(uv, Wrap::Sphere)
        );
    }
    // Across a 16-texel checker cell a footprint of 2 texels blends into level 1, and
    // moves the value towards the mean; far from any edge it changes nothing.
    let inside = [(8.0 + 0.5) / 256.0, (8.0 + 0.5) / 128.0];
    let c = tex.sample(inside, Wrap::Sphere);
    let f = tex.sample_filtered(inside, 2.0, Wrap::Sphere);
    assert!((0..3).all(|k| (c[k] - f[k]).abs() < 1e-6));
    // Odd sizes keep every texel's area: a 3x1 image's level 1 has 2 texels.
    let odd = Texture::new(
        RgbImage {
            width: 3,
            height: 1,
            pixels: vec![[0.0; 3], [1.0; 3], [0.5; 3]],
        },
        &caoen::Limits::default(),
    )
    .unwrap();
    assert_eq!(odd.levels(), 3);
    let l1 = odd.sample_filtered([0.25, 0.5], 2.0, Wrap::Clamp);
    assert!((l1[0] - 0.5).abs() < 1e-6, "{l1:?}");
    // Huge finite coordinates neither panic nor leave the image.
    let far = tex.sample_filtered([1e300, -1e300], 3.0, Wrap::Torus);
    assert!(far.iter().all(|v| v.is_finite()));
}

#[test]
fn obj_with_texture_loads_in_trimesh() {
    // An independent reader (Python's trimesh) loads the OBJ + MTL + texture, and the
    // colour it looks up at each vertex's texture coordinates is the one caoen meant:
    // with a domain ramp texture, red follows u and green follows v measured downwards
    // (the OBJ's vt runs upwards).
    let probe = std::process::Command::new("python3")
        .args(["-c", "import trimesh, PIL"])
        .output();
    if !common::tool_present(
        probe.is_ok_and(|o| o.status.success()),
        "python3 with trimesh and pillow",
    ) {
        return;
    }
    let dir = tmpdir("trimesh");
    let pic = dir.join("ramp.png");
    ramp_png(&pic, 256, 128);
    let obj = dir.join("blob.obj");
    caoen_ok(&[
        "transfer",
        "--texture",
        s(&pic),
        "--project",
        "domain",
        "--from",
        "builtin:blob",
        "--to",
        "builtin:blob",
        "-o",
        s(&obj),
        "--detail",
        "3",
    ]);
    let script = r#"
import sys, trimesh, numpy as np
m = trimesh.load(sys.argv[1], force='mesh')
assert m.visual.kind == 'texture', m.visual.kind
img = m.visual.material.image
c = m.visual.to_color().vertex_colors[:, :3].astype(float)
uv = m.visual.uv
# Away from the u seam and the poles, where a vertex's colour is a blend across a jump.
keep = (uv[:, 0] > 0.03) & (uv[:, 0] < 0.97) & (uv[:, 1] > 0.03) & (uv[:, 1] < 0.97)
er = np.abs(c[keep, 0] - 255 * uv[keep, 0]).mean()
eg = np.abs(c[keep, 1] - 255 * (1 - uv[keep, 1])).mean()
eg_flipped = np.abs(c[keep, 1] - 255 * uv[keep, 1]).mean()
print(len(m.vertices), len(m.faces), img.size[0], img.size[1], keep.sum(), er, eg, eg_flipped)
"#;
    let o = std::process::Command::new("python3")
        .args(["-c", script, s(&obj)])
        .output()
        .unwrap();
    assert_ok(&o);
    let out = String::from_utf8_lossy(&o.stdout);
    println!("trimesh: {out}");
    let v: Vec<f64> = out.split_whitespace().map(|t| t.parse().unwrap()).collect();
    assert_eq!(v[1], 1280.0, "triangles of a level-3 sphere mesh");
    assert_eq!((v[2], v[3]), (256.0, 128.0), "the texture's size");
    assert!(v[4] > 300.0, "vertices checked: {}", v[4]);
    assert!(
        v[5] < 4.0 && v[6] < 4.0,
        "mean colour error {} / {} levels",
        v[5],
        v[6]
    );
    assert!(v[7] > 40.0, "v upside down would fit too: {}", v[7]);
}
