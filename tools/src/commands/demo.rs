//! `caoen demo`: the main job on built-in data.

use std::time::Instant;

use caoen::render::mesh::NormalMode;
use caoen::surface::gallery;

use crate::cli::{DemoArgs, GlobalArgs};
use crate::commands::surface::write_mesh;
use crate::failure::CliResult;

/// Meshes the built-in models into `out_dir` and prints what was written.
pub fn run(_global: &GlobalArgs, args: &DemoArgs) -> CliResult {
    let start = Instant::now();
    for name in ["blob", "ring", "octahedron"] {
        let model = gallery::by_name(name).expect("built-in model exists")?;
        let path = args.out_dir.join(format!("{name}.obj"));
        let summary = write_mesh(&model, &path, 5, NormalMode::Exact)?;
        println!("wrote {summary}");
    }
    println!("done in {:.2} s", start.elapsed().as_secs_f64());
    Ok(())
}
