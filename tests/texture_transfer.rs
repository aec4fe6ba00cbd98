//! `caoen transfer` (issue 7): texture transfer between surfaces through their shared
//! domain.

mod common;
use common::caoen;

use std::path::{Path, PathBuf};

use caoen::render::framebuffer::RgbImage;
use caoen::render::texture::{domain_uv, Texture, Wrap};
use caoen::surface::gallery;
use caoen::texture::transfer::{transfer, uv_domain};

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caoen-transfer-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn checker() -> Texture {
    Texture::checker(256, 128, 16, 8, [0.9, 0.85, 0.7], [0.05, 0.1, 0.3]).unwrap()
}

fn psnr(a: &RgbImage, b: &RgbImage) -> f64 {
    let mse: f64 = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] as f64 - q[k] as f64).powi(2)))
        .sum::<f64>()
        / (3 * a.pixels.len()) as f64;
    10.0 * (1.0 / mse).log10()
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
    let on_b = transfer(&a, &b, &tex, 256, 128).unwrap();
    let back = transfer(&b, &a, &Texture::new(on_b).unwrap(), 256, 128).unwrap();
    let p = psnr(tex.image(), &back);
    println!("A -> B -> A checkerboard (same texture size): PSNR {p} dB");
    assert!(p > 35.0, "{p}");
    // Through a finer texture grid on B: resampled twice.
    let on_b = transfer(&a, &b, &tex, 512, 256).unwrap();
    let back = transfer(&b, &a, &Texture::new(on_b).unwrap(), 256, 128).unwrap();
    let p2 = psnr(tex.image(), &back);
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
    let on_b = Texture::new(transfer(&a, &b, &tex, 256, 128).unwrap()).unwrap();
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

#[test]
fn cli_transfer_png_obj_and_errors() {
    let dir = tmpdir("cli");
    let tex = dir.join("checker.png");
    std::fs::write(&tex, checker().image().encode_png().unwrap()).unwrap();
    let png = dir.join("b.png");
    let o = caoen(&[
        "transfer",
        "--texture",
        s(&tex),
        "--from",
        "builtin:octahedron",
        "--to",
        "builtin:blob",
        "-o",
        s(&png),
        "--size",
        "160x120",
        "--detail",
        "4",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(png.exists());
    let obj = dir.join("b.obj");
    let o = caoen(&[
        "transfer",
        "--texture",
        s(&tex),
        "--from",
        "builtin:octahedron",
        "--to",
        "builtin:blob",
        "-o",
        s(&obj),
        "--detail",
        "3",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&obj).unwrap();
    assert!(text.contains("mtllib") && text.contains("vt "));
    assert!(dir.join("b.mtl").exists() && dir.join("b-texture.png").exists());
    // A .cae texture.
    let cae = dir.join("t.cae");
    assert!(caoen(&["encode", s(&tex), "-o", s(&cae), "--quiet"])
        .status
        .success());
    let o = caoen(&[
        "transfer",
        "--texture",
        s(&cae),
        "--from",
        "builtin:six-point",
        "--to",
        "builtin:blob",
        "-o",
        s(&dir.join("c.png")),
        "--size",
        "64x48",
        "--detail",
        "3",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let code = |args: &[&str]| {
        let o = caoen(args);
        assert!(!String::from_utf8_lossy(&o.stderr).contains("panicked"));
        o.status.code()
    };
    let base = ["transfer", "--texture", s(&tex), "--from", "builtin:blob"];
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
    // texture coordinates of its domain point, whatever the shape does. With
    // CAOEN_WRITE_EXAMPLES=1 the frames are written as textured surface files to
    // examples/morph-textured/ (render them with `caoen surface render`).
    use caoen::render::mesh::{tessellate, NormalMode};
    use caoen::surface::{morph::morph, SurfaceModel};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let a = SurfaceModel::load(&root.join("examples/morph-a.json")).unwrap();
    let b = SurfaceModel::load(&root.join("examples/morph-b.json")).unwrap();
    let write = std::env::var_os("CAOEN_WRITE_EXAMPLES").is_some();
    for k in 0..5 {
        let u = k as f64 / 4.0;
        let net = morph(&a.network, &b.network, u).unwrap();
        let model = SurfaceModel::new(format!("morph-{k}"), a.domain, net)
            .unwrap()
            .with_texture("../checker.png");
        let mesh = tessellate(&model, 3, NormalMode::Exact).unwrap();
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
        if write {
            let dir = root.join("examples/morph-textured");
            std::fs::create_dir_all(&dir).unwrap();
            model.save(&dir.join(format!("frame-{k}.json"))).unwrap();
        }
    }
}

#[test]
fn texture_space_carries_a_solid_texture() {
    use caoen::texture::transfer::{bake_texture_space, solid_checker};
    let b = gallery::by_name("blob").unwrap().unwrap();
    // Texture space = the shape itself: the object looks carved from the solid.
    let solid = |p: [f64; 3]| solid_checker(p, 0.3);
    let img = bake_texture_space(&b, &b, &solid, 64, 32).unwrap();
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
    assert!(bake_texture_space(&ring, &b, &solid, 8, 8).is_err());
    let dir = tmpdir("space");
    let out = dir.join("s.png");
    let o = caoen(&[
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
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
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
