//! Arguments of printable mesh output: units, scale, ASCII STL, and `caoen lithophane`.

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use caoen::render::mesh_io::LengthUnit;

/// A length as given: a number and its unit, if it names one (a bare number is in
/// `--units`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Length {
    /// The number.
    pub value: f64,
    /// Its unit, when written after it.
    pub unit: Option<LengthUnit>,
}

impl Length {
    /// The length in millimetres, a bare number read in `default`.
    pub fn millimetres(self, default: LengthUnit) -> f64 {
        self.value * self.unit.unwrap_or(default).millimetres()
    }
}

/// Parses a positive length: `150mm`, `15cm`, `6in`, or a bare number.
pub fn length(s: &str) -> Result<Length, String> {
    let t = s.trim();
    let (num, unit) = match LengthUnit::ALL
        .into_iter()
        .find(|u| t.ends_with(u.symbol()))
    {
        Some(u) => (t[..t.len() - 2].trim(), Some(u)),
        None => (t, None),
    };
    match num.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e6 => Ok(Length { value: v, unit }),
        Ok(_) => Err(format!("`{s}`: a length must be above 0 and at most 1e6")),
        Err(_) => Err(format!(
            "`{s}`: expected a length such as 150mm, 15cm or 6in (a bare number is in --units)"
        )),
    }
}

/// Parses a positive, finite number (a scale factor, an absorption coefficient).
pub fn scale_factor(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v <= 1e6 => Ok(v),
        _ => Err(format!("`{s}`: expected a number above 0 and at most 1e6")),
    }
}

/// How a mesh file is written: the unit of its coordinates and STL as text or binary.
#[derive(Debug, Args)]
pub struct MeshFileArgs {
    /// The unit of the mesh file's coordinates: 3MF names it, STL, OBJ and PLY carry
    /// none (slicers read them as millimetres); a bare number in --size is in it.
    #[arg(long, value_parser = ["mm", "cm", "in"], default_value = "mm")]
    pub units: String,
    /// STL as text (ASCII STL) rather than binary; for .stl outputs and `-`.
    #[arg(long)]
    pub ascii: bool,
    /// Keep every grid cell's triangles: no quadric-error decimation of flat and
    /// gently curved parts (the mesh is then as fine everywhere as the grid).
    #[arg(long)]
    pub no_decimate: bool,
}

impl MeshFileArgs {
    /// The unit `--units` names.
    pub fn unit(&self) -> LengthUnit {
        LengthUnit::from_symbol(&self.units).expect("clap takes only mm, cm or in")
    }
}

/// How `caoen lithophane` turns a grey level into a thickness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum CurveArg {
    /// Thickness linear in grey: black the thickest, white the thinnest.
    Linear,
    /// The light let through, `exp(-mu t)`, linear in grey: `t = -ln(T) / mu`.
    BeerLambert,
}

/// `caoen lithophane`.
#[derive(Debug, Args)]
pub struct LithophaneArgs {
    /// The picture (any image caoen reads; the mean of its colour channels is its grey).
    pub image: PathBuf,
    /// Mesh files to write (.3mf, .stl, .obj, .ply), one mesh for all: repeat `-o` for
    /// several; `-`: binary STL (or ASCII with --ascii) on standard output.
    #[arg(short, long, required = true)]
    pub output: Vec<PathBuf>,
    /// The plate's width (along x, the picture's rows), frame included: 150mm, 15cm,
    /// 6in.
    #[arg(long, default_value = "100mm", value_parser = length, allow_hyphen_values = true)]
    pub width: Length,
    /// The thickness where the picture is white (the most light through).
    #[arg(long, default_value = "0.8mm", value_parser = length, allow_hyphen_values = true)]
    pub thinnest: Length,
    /// The thickness where the picture is black, and of the frame.
    #[arg(long, default_value = "3mm", value_parser = length, allow_hyphen_values = true)]
    pub thickest: Length,
    /// How grey becomes thickness.
    #[arg(long, value_enum, default_value_t = CurveArg::Linear)]
    pub curve: CurveArg,
    /// Beer-Lambert: the material's absorption coefficient mu per millimetre (white
    /// PLA is about 1 to 2).
    #[arg(long, default_value_t = 1.5, value_parser = scale_factor, allow_hyphen_values = true)]
    pub absorption: f64,
    /// A frame this wide around the picture at the thickest thickness (rounded to
    /// whole pixels of the picture).
    #[arg(long, value_parser = length, allow_hyphen_values = true)]
    pub frame: Option<Length>,
    /// Grid cells along the width (the mesh's resolution).
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u32).range(4..=1024))]
    pub cells: u32,
    /// Unit and STL form of the files.
    #[command(flatten)]
    pub file: MeshFileArgs,
}
