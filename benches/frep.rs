//! F-rep rendering beside POV-Ray, measured in the same run: each exported example
//! model rendered by caoen's interval ray caster and by POV-Ray's isosurface (from
//! `caoen frep export-pov`) at the same size, one sample per pixel for both (no
//! antialiasing), both on all cores. A summary with the ratios prints first (medians of
//! five runs; one POV-Ray run for the picture models, which POV-Ray renders at 128x128
//! in tens of seconds); criterion's report of caoen's renders follows. POV-Ray's time
//! includes its start-up and parse, which the ratio states; without `povray` on the
//! PATH only caoen is measured. `CAOEN_FREP_BENCH=NAME` limits the run to the models
//! whose name contains NAME.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use caoen::render::renderer::{render, Method, RenderOptions};
use caoen::render::Scene;
use criterion::{criterion_group, Criterion};

const SIDE: u32 = 384;
/// The side of the picture models' renders.
const PICTURE_SIDE: u32 = 128;

/// The example models that export to POV-Ray, with the side they render at.
fn models() -> Vec<(String, PathBuf, u32)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("caoen-bench-frep-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bumps = dir.join("bumps.json");
    std::fs::write(
        &bumps,
        serde_json::json!({
            "format": "caoen-frep/1", "name": "patches",
            "model": {"perturb": {"sphere": {"radius": 0.8}}, "patches": [
                {"bump": {"centre": [0.7, 0.0, 0.3], "radius": 0.45, "height": 0.5}},
                {"bump": {"centre": [-0.3, -0.6, 0.4], "radius": 0.4, "height": 0.4}}
            ]}
        })
        .to_string(),
    )
    .unwrap();
    let solid = dir.join("solid.json");
    std::fs::write(
        &solid,
        serde_json::json!({
            "format": "caoen-frep/1", "name": "Cao En solid and torus",
            "model": {"blend_union": [
                {"cao_en_solid": {"polyhedron": "dodecahedron", "radius": 0.8, "q": 12.0, "level": 2.0}},
                {"torus": {"major": 0.9, "minor": 0.15}}], "a0": 0.5, "a1": 0.5, "a2": 0.3}
        })
        .to_string(),
    )
    .unwrap();
    let example = |m: &str| root.join(format!("examples/frep/{m}.json"));
    let filter = std::env::var("CAOEN_FREP_BENCH").ok();
    let all: Vec<(String, PathBuf, u32)> = vec![
        ("blend".into(), example("blend"), SIDE),
        ("patches".into(), bumps, SIDE),
        ("cao-en-solid".into(), solid, SIDE),
        ("lattice".into(), example("lattice"), PICTURE_SIDE),
        ("relief".into(), example("relief"), PICTURE_SIDE),
        (
            "heightfield-ellipsoid".into(),
            example("heightfield-ellipsoid"),
            PICTURE_SIDE,
        ),
    ];
    all.into_iter()
        .filter(|(name, _, _)| filter.as_ref().is_none_or(|f| name.contains(f.as_str())))
        .collect()
}

fn scene(path: &Path) -> Scene {
    let text = std::fs::read_to_string(path).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let mut object = serde_json::json!({"frep": v["model"]});
    if !v["material"].is_null() {
        object["material"] = v["material"].clone();
    }
    let mut s = serde_json::json!({"format": "caoen-scene/1", "objects": [object]});
    if !v["camera"].is_null() {
        s["camera"] = v["camera"].clone();
    }
    Scene::from_json(
        &s.to_string(),
        path.parent().unwrap(),
        &caoen::Limits::default(),
    )
    .unwrap()
}

fn opts(side: u32) -> RenderOptions {
    RenderOptions {
        width: side,
        height: side,
        samples: 1,
        method: Method::Ray,
        ..RenderOptions::default()
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn summary() {
    let has_povray = Command::new("povray").arg("--version").output().is_ok();
    println!("F-rep rendering, 1 sample per pixel, medians of 5 runs:");
    for (name, path, side) in models() {
        let s = scene(&path);
        let ours = median(
            (0..5)
                .map(|_| {
                    let t = Instant::now();
                    render(&s, &opts(side), &|_, _| {}).unwrap();
                    t.elapsed().as_secs_f64()
                })
                .collect(),
        );
        if !has_povray {
            println!(
                "  {name} ({side}x{side}): caoen {:.1} ms (POV-Ray not installed)",
                1e3 * ours
            );
            continue;
        }
        let camera = s.camera(side, side).unwrap();
        let pov = caoen::render::pov::export(&s, &camera).unwrap();
        let dir = std::env::temp_dir().join(format!("caoen-bench-frep-{}", std::process::id()));
        let (pov_path, out) = (
            dir.join(format!("{name}.pov")),
            dir.join(format!("{name}.png")),
        );
        std::fs::write(&pov_path, pov).unwrap();
        let runs = if side == SIDE { 5 } else { 1 };
        let theirs = median(
            (0..runs)
                .map(|_| {
                    let t = Instant::now();
                    let o = Command::new("povray")
                        .args([
                            format!("+I{}", pov_path.display()),
                            format!("+O{}", out.display()),
                            format!("+W{side}"),
                            format!("+H{side}"),
                            "-A".into(),
                            "-D".into(),
                            "-V".into(),
                            "-GA".into(),
                        ])
                        .output()
                        .unwrap();
                    assert!(o.status.success(), "povray failed on {name}");
                    t.elapsed().as_secs_f64()
                })
                .collect(),
        );
        println!(
            "  {name} ({side}x{side}): caoen {:.1} ms, POV-Ray {:.1} ms (with start-up): caoen takes {:.3}x POV-Ray's time",
            1e3 * ours,
            1e3 * theirs,
            ours / theirs
        );
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("frep_render");
    g.sample_size(10);
    for (name, path, side) in models() {
        let s = scene(&path);
        g.bench_function(&name, |b| {
            b.iter(|| render(&s, &opts(side), &|_, _| {}).unwrap())
        });
    }
    g.finish();
}

criterion_group!(benches, bench);

fn main() {
    common::main(summary, benches);
}
