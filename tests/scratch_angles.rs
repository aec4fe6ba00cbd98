use caoen::conversion::*;
use std::path::Path;
#[test]
fn angles() {
    let mesh_path = std::env::var("MESH").unwrap();
    let model_path = std::env::var("MODEL").unwrap();
    let mesh = read(Path::new(&mesh_path)).unwrap();
    let frame = mesh.unit_frame();
    let unit = mesh.transformed(&frame);
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&model_path).unwrap()).unwrap();
    let node = caoen::frep::Node::from_json(&v["model"], "model", Path::new(".")).unwrap();
    let f = InUnitCube { field: &node, frame };
    let n = unit.outward_normals();
    let mut a: Vec<(f64, usize)> = unit.positions.iter().enumerate().map(|(i, p)| {
        let (x, _) = caoen::conversion::deviation::project(&f, *p);
        let (_, g) = f.value_gradient(x);
        let l = (g[0]*g[0]+g[1]*g[1]+g[2]*g[2]).sqrt();
        (((-(g[0]*n[i][0]+g[1]*n[i][1]+g[2]*n[i][2]))/l).clamp(-1.0,1.0).acos().to_degrees(), i)
    }).collect();
    a.sort_by(|x, y| y.0.total_cmp(&x.0));
    let total: f64 = a.iter().map(|x| x.0).sum();
    println!("mean {}", total / a.len() as f64);
    for q in [0.001, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5] {
        let k = (q * a.len() as f64) as usize;
        let top: f64 = a[..k].iter().map(|x| x.0).sum();
        println!("top {q}: angle {:.1}, share of sum {:.2}", a[k].0, top / total);
    }
    for x in &a[..15] { println!("{:.1} at {:?}", x.0, unit.positions[x.1]); }
}
