//! Meshes to print: the printable mesh of an F-rep solid scaled into the file's unit and
//! written as binary or ASCII STL, 3MF (which names the unit), OBJ or PLY; and
//! `caoen lithophane`.

use std::path::{Path, PathBuf};

use caoen::geometry::mesh::Mesh;
use caoen::render::mesh_io::{
    write_3mf, write_obj, write_ply, write_stl, write_stl_ascii, LengthUnit,
};

use crate::cli::{CurveArg, GlobalArgs, Length, LithophaneArgs, MeshFileArgs};
use crate::commands::note;
use crate::failure::{CliError, CliResult};
use crate::output::{extension_lowercase, format_extension, shown, Outputs};

/// How a model's coordinates become the file's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scaling {
    /// Multiplied by this factor.
    Factor(f64),
    /// Scaled so the mesh's largest extent is this many millimetres.
    LargestMm(f64),
}

/// How a printable mesh file is written.
#[derive(Debug, Clone)]
pub struct MeshFile {
    /// The unit of the file's coordinates.
    pub unit: LengthUnit,
    /// From the model's coordinates to the file's.
    pub scaling: Scaling,
    /// STL as text.
    pub ascii: bool,
    /// The object's name (3MF).
    pub name: String,
    /// The object's colour, linear RGB (3MF).
    pub colour: Option<[f64; 3]>,
    /// Decimated by quadric error (`frep::polygonise::solid_mesh_with`).
    pub adaptive: bool,
}

impl MeshFile {
    /// The file of `--units`, `--ascii` and `--size` or `--scale` (neither: factor 1).
    pub fn from_args(a: &MeshFileArgs, size: Option<Length>, scale: Option<f64>) -> Self {
        let unit = a.unit();
        MeshFile {
            unit,
            scaling: match (size, scale) {
                (Some(l), _) => Scaling::LargestMm(l.millimetres(unit)),
                (None, s) => Scaling::Factor(s.unwrap_or(1.0)),
            },
            ascii: a.ascii,
            name: "model".into(),
            colour: None,
            adaptive: !a.no_decimate,
        }
    }
}

/// Whether `path` names a mesh file (.stl, .3mf, .obj, .ply).
pub fn is_mesh_path(path: &Path) -> bool {
    let ext = extension_lowercase(path);
    matches!(ext.as_deref(), Some("stl" | "3mf" | "obj" | "ply"))
}

/// The format of the mesh output `path` (`-` is STL), or a usage error naming the
/// formats; `--ascii` is for STL only.
pub fn mesh_format(path: &Path, file: &MeshFile) -> CliResult<String> {
    let ext = format_extension(path, "stl");
    match ext.as_deref() {
        Some("stl") => Ok("stl".into()),
        Some(e @ ("3mf" | "obj" | "ply")) if !file.ascii => Ok(e.into()),
        Some("3mf" | "obj" | "ply") => Err(CliError::Usage(format!(
            "{}: --ascii is for STL output (.stl or `-`)",
            path.display()
        ))),
        _ => Err(CliError::Usage(format!(
            "{}: mesh output must end in .stl, .3mf, .obj or .ply (`-`: binary STL on standard \
             output, ASCII with --ascii)",
            path.display()
        ))),
    }
}

/// The factor from the model's coordinates to the file's for a mesh whose largest
/// extent is `largest` model units.
pub fn factor(file: &MeshFile, largest: f64) -> f64 {
    match file.scaling {
        Scaling::Factor(k) => k,
        Scaling::LargestMm(mm) => mm / file.unit.millimetres() / largest,
    }
}

/// The mesh's extent along x, y and z.
pub fn extents(m: &Mesh) -> [f64; 3] {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &m.positions {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    [0, 1, 2].map(|k| (hi[k] - lo[k]).max(0.0))
}

/// The bytes of `m` as a file of `format` (see [`mesh_format`]).
pub fn encode(m: &Mesh, format: &str, file: &MeshFile) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::new();
    match format {
        "obj" => write_obj(m, &mut bytes, None),
        "ply" => write_ply(m, &mut bytes),
        "3mf" => write_3mf(m, file.unit, &file.name, file.colour, &mut bytes),
        _ if file.ascii => write_stl_ascii(m, &mut bytes),
        _ => write_stl(m, &mut bytes),
    }?;
    Ok(bytes)
}

/// Upper bound of the memory writing `m` as `format` takes: the mesh, and the file's
/// bytes built in memory (a number printed takes at most 25 characters; a 3MF holds
/// its XML, the deflated part and the archive at once).
fn file_memory(m: &Mesh, format: &str, file: &MeshFile) -> u64 {
    let (v, t) = (m.positions.len() as u64, m.triangles.len() as u64);
    let bytes = match format {
        "obj" => 160 * v + 80 * t,
        "ply" => 80 * v + 40 * t,
        "3mf" => 3 * (100 * v + 50 * t + 4096),
        _ if file.ascii => 400 * t,
        _ => 50 * t,
    };
    (48 * v + 12 * t + bytes + 4096).saturating_add(24 << 20)
}

/// Checks the grid of `--cells` on `bounds` against the memory budget; the mesh is
/// checked once the grid tells its size (`frep::polygonise::solid_mesh_with`).
fn check_grid(bounds: &caoen::frep::Aabb, cells: u32, limits: &caoen::Limits) -> CliResult {
    limits
        .check(
            || format!("sampling the model on {cells} cells along its longest side"),
            caoen::frep::polygonise::solid_mesh_grid_memory(bounds, cells as usize),
        )
        .map_err(|e| CliError::Failed(e.to_string()))
}

/// Writes the printable mesh of `node` (`frep::polygonise::solid_mesh`), scaled as
/// `file` says, to each of `paths` in the format its extension names; fails, writing
/// nothing, when the mesh is empty or not a closed manifold.
pub fn write_solid_mesh(
    global: &GlobalArgs,
    outputs: &Outputs,
    (node, bounds): (&caoen::frep::Node, &caoen::frep::Aabb),
    cells: u32,
    paths: &[&Path],
    file: &MeshFile,
) -> CliResult {
    let formats = paths
        .iter()
        .map(|p| mesh_format(p, file))
        .collect::<CliResult<Vec<_>>>()?;
    check_grid(bounds, cells, &global.limits)?;
    let first = paths.first().map(|p| p.display().to_string());
    let (mut m, rep) = caoen::frep::polygonise::solid_mesh_with(
        node,
        bounds,
        cells as usize,
        file.adaptive,
        &global.limits,
    )
    .map_err(|e| CliError::Failed(format!("{}: {e}", first.unwrap_or_default())))?;
    let k = factor(file, extents(&m).into_iter().fold(0.0, f64::max));
    for p in &mut m.positions {
        *p = p.map(|v| v * k);
    }
    for (path, format) in paths.iter().zip(&formats) {
        global
            .limits
            .check(
                || {
                    format!(
                        "writing {} ({} triangles)",
                        path.display(),
                        m.triangles.len()
                    )
                },
                file_memory(&m, format, file),
            )
            .map_err(|e| CliError::Failed(e.to_string()))?;
        let bytes = encode(&m, format, file).map_err(|e| CliError::io(path, e))?;
        outputs.write_path(path, &bytes)?;
    }
    let mut notes = Vec::new();
    if rep.pieces_dropped > 0 {
        notes.push(format!(
            "dropped {} specks (pieces under {} of the largest's volume)",
            rep.pieces_dropped,
            caoen::frep::polygonise::SPECK_FRACTION
        ));
    }
    if rep.collapsed > 0 {
        notes.push(format!(
            "collapsed {} zero-area triangles' edges",
            rep.collapsed
        ));
    }
    if rep.cells != cells as usize {
        notes.push(format!(
            "meshed on {} cells: the grid of {cells} folded a triangle flat",
            rep.cells
        ));
    }
    if rep.separated > 0 {
        notes.push(format!(
            "{} vertices moved off a touching sheet",
            rep.separated
        ));
    }
    if rep.clamped > 0 {
        notes.push(format!("{} vertices clamped into the bounds", rep.clamped));
    }
    if rep.untangled > 0 {
        notes.push(format!(
            "{} vertices moved back off the surface to undo folds",
            rep.untangled
        ));
    }
    if rep.crossings > 0 {
        notes.push(format!(
            "{} pairs of triangles cross (a slicer may need to repair them)",
            rep.crossings
        ));
    }
    let [x, y, z] = extents(&m);
    let u = file.unit.symbol();
    let names: Vec<String> = paths.iter().map(|p| shown(p)).collect();
    note(
        global,
        format!(
            "wrote {}: {} vertices, {} triangles, closed and manifold, {} piece{}, \
             {x:.4} x {y:.4} x {z:.4} {u} (x {k:.6} of the model), volume {:.6} {u}^3, \
             Euler characteristic {}{}",
            names.join(", "),
            m.positions.len(),
            m.triangles.len(),
            rep.pieces,
            if rep.pieces == 1 { "" } else { "s" },
            rep.volume * k * k * k,
            m.euler_characteristic(),
            notes.iter().map(|n| format!("; {n}")).collect::<String>()
        ),
    );
    Ok(())
}

/// A lithophane's thickness in millimetres at grey level `g` in [0, 1], from
/// `thick` at black to `thin` at white (see [`CurveArg`]).
pub fn thickness(curve: CurveArg, mu: f64, (thin, thick): (f64, f64), g: f64) -> f64 {
    let g = g.clamp(0.0, 1.0);
    match curve {
        CurveArg::Linear => thick - (thick - thin) * g,
        CurveArg::BeerLambert => {
            let (dark, light) = ((-mu * thick).exp(), (-mu * thin).exp());
            (-(dark + (light - dark) * g).ln() / mu).clamp(thin, thick)
        }
    }
}

/// `caoen lithophane`: a plate `--width` wide on z = 0, each picture sample's
/// thickness by the curve, as a planar relief engraving a box `--thickest` high
/// (bilinear between samples, so no point is thinner or thicker than asked).
pub fn lithophane(global: &GlobalArgs, a: &LithophaneArgs) -> CliResult {
    let unit = a.file.unit();
    let mm = |l: Length| l.millimetres(unit);
    let (width, thin, thick) = (mm(a.width), mm(a.thinnest), mm(a.thickest));
    let frame = a.frame.map_or(0.0, mm);
    if thin >= thick {
        return Err(CliError::Usage(format!(
            "--thinnest {thin} mm: must be below --thickest {thick} mm"
        )));
    }
    if thin < thick * caoen::frep::node::MIN_FLOOR {
        return Err(CliError::Usage(format!(
            "--thinnest {thin} mm: at least {} of --thickest",
            caoen::frep::node::MIN_FLOOR
        )));
    }
    if 2.0 * frame >= width {
        return Err(CliError::Usage(format!(
            "--frame {frame} mm: twice it must be below --width {width} mm"
        )));
    }
    let file = MeshFile {
        unit,
        scaling: Scaling::Factor(1.0 / unit.millimetres()),
        ascii: a.file.ascii,
        name: "lithophane".into(),
        colour: None,
        adaptive: !a.file.no_decimate,
    };
    let paths: Vec<&Path> = a.output.iter().map(PathBuf::as_path).collect();
    for p in &paths {
        mesh_format(p, &file)?;
    }
    let mut outputs = Outputs::new(global.force).input(&a.image);
    for p in &paths {
        outputs.check_path(p)?;
    }
    let (w, h, grey) = caoen::frep::assets::grey_levels(&a.image, "image", 1.0, &global.limits)
        .map_err(|e| CliError::Failed(format!("{}: {e}", a.image.display())))?;
    let (node, height) = lithophane_node(a, (w, h, &grey), (width, frame), (thin, thick), global)?;
    // The plate's own box: the engraving only lowers its top, and a grid on this box
    // has the plate's ends on its planes (the relief's box is padded by the depth).
    let bounds = caoen::frep::Aabb::new([0.0; 3], [width, height, thick]);
    write_solid_mesh(global, &outputs, (&node, &bounds), a.cells, &paths, &file)
}

/// The lithophane's solid in millimetres and the plate's height (along y): a box
/// `thick` high engraved by the samples' depths below its top, framed by `frame` of
/// samples at the full thickness.
fn lithophane_node(
    a: &LithophaneArgs,
    (w, h, grey): (usize, usize, &[f64]),
    (width, frame): (f64, f64),
    (thin, thick): (f64, f64),
    global: &GlobalArgs,
) -> CliResult<(caoen::frep::Node, f64)> {
    use caoen::frep::height_map::{Base, HeightMap, Interp};
    let failed = |e: String| CliError::Failed(format!("{}: {e}", a.image.display()));
    // Samples sit on the plate's corners and edges (HeightMap::sample_uv): a picture
    // of w samples spans w - 1 pitches.
    let inner = (width - 2.0 * frame) / (w.max(2) - 1) as f64;
    let n = (frame / inner).round() as usize;
    let (fw, fh) = (w + 2 * n, h + 2 * n);
    let pitch = width / (fw - 1) as f64;
    let height = pitch * (fh - 1) as f64;
    let span = thick - thin;
    let mut depth = vec![0.0; fw * fh];
    for j in 0..h {
        for i in 0..w {
            let t = thickness(a.curve, a.absorption, (thin, thick), grey[j * w + i]);
            depth[(j + n) * fw + i + n] = (thick - t) / span;
        }
    }
    let map = HeightMap::new(
        Base::Plane,
        [0.0, 0.0, width, height],
        (fw, fh),
        depth,
        f64::NEG_INFINITY,
        Interp::Bilinear,
        &global.limits,
    )
    .map_err(|e| failed(e.to_string()))?;
    let plate = serde_json::json!({"box": {
        "centre": [0.5 * width, 0.5 * height, 0.5 * thick],
        "size": [width, height, thick]
    }});
    let base = caoen::frep::Node::from_json(&plate, "plate", Path::new("."), &global.limits)
        .map_err(|e| failed(e.to_string()))?;
    let node = caoen::frep::Node::Relief(caoen::frep::node::Relief {
        base: Box::new(base),
        map,
        depth: -span,
        ramp: [0.0, thick],
    });
    Ok((node, height))
}
