//! 3MF (3D Manufacturing Format, core specification 1.3): a triangle mesh with its
//! length unit, and optionally one display colour, in an OPC package (a ZIP of three
//! parts: content types, the root relationship and the model).

use std::fmt::Write as _;
use std::io::{self, Write};

use crate::mesh::Mesh;

/// A length unit a print file can name.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres (`mm`).
    Millimetre,
    /// Centimetres (`cm`).
    Centimetre,
    /// Inches (`in`).
    Inch,
}

impl LengthUnit {
    /// Every unit, in the order the command line lists them.
    pub const ALL: [LengthUnit; 3] = [Self::Millimetre, Self::Centimetre, Self::Inch];

    /// The unit's length in millimetres.
    pub fn millimetres(self) -> f64 {
        match self {
            Self::Millimetre => 1.0,
            Self::Centimetre => 10.0,
            Self::Inch => 25.4,
        }
    }

    /// Its symbol: `mm`, `cm`, `in`.
    pub fn symbol(self) -> &'static str {
        match self {
            Self::Millimetre => "mm",
            Self::Centimetre => "cm",
            Self::Inch => "in",
        }
    }

    /// The unit of `symbol` (`mm`, `cm`, `in`).
    pub fn from_symbol(symbol: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|u| u.symbol() == symbol)
    }

    /// Its name in a 3MF model's `unit` attribute.
    pub fn three_mf_name(self) -> &'static str {
        match self {
            Self::Millimetre => "millimeter",
            Self::Centimetre => "centimeter",
            Self::Inch => "inch",
        }
    }
}

/// The package's content types: relationships and 3D models by extension.
const CONTENT_TYPES: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Types xmlns="http://schemas.openxmlformats.org/package/2006/content-types">
 <Default Extension="rels" ContentType="application/vnd.openxmlformats-package.relationships+xml"/>
 <Default Extension="model" ContentType="application/vnd.ms-package.3dmanufacturing-3dmodel+xml"/>
</Types>
"#;

/// The root relationship: the package's 3D model part.
const RELS: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<Relationships xmlns="http://schemas.openxmlformats.org/package/2006/relationships">
 <Relationship Target="/3D/3dmodel.model" Id="rel0" Type="http://schemas.microsoft.com/3dmanufacturing/2013/01/3dmodel"/>
</Relationships>
"#;

/// `s` with XML's special characters escaped, for attribute values and text.
fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The 3MF model part of `mesh`: one object named `name` of the mesh's vertices and
/// triangles (coordinates as 32-bit floats in decimal, as the spec's `ST_Number`
/// takes them), built once; with `colour` (linear RGB in [0, 1], written as sRGB) a
/// base material the object takes.
pub fn three_mf_model(
    mesh: &Mesh,
    unit: LengthUnit,
    name: &str,
    colour: Option<[f64; 3]>,
) -> String {
    let mut x = String::with_capacity(64 * mesh.positions.len() + 48 * mesh.triangles.len());
    let _ = write!(
        x,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<model unit=\"{}\" xml:lang=\"en-US\" \
         xmlns=\"http://schemas.microsoft.com/3dmanufacturing/core/2015/02\">\n \
         <metadata name=\"Application\">caoen</metadata>\n <resources>\n",
        unit.three_mf_name()
    );
    let mut material = String::new();
    if let Some(c) = colour {
        let srgb = c.map(|v| {
            let v = v.clamp(0.0, 1.0);
            let s = if v <= 0.003_130_8 {
                12.92 * v
            } else {
                1.055 * v.powf(1.0 / 2.4) - 0.055
            };
            (s * 255.0).round() as u8
        });
        let _ = writeln!(
            x,
            "  <basematerials id=\"2\">\n   <base name=\"{}\" displaycolor=\"#{:02X}{:02X}{:02X}\"/>\n  </basematerials>",
            xml_escape(name),
            srgb[0],
            srgb[1],
            srgb[2]
        );
        material = " pid=\"2\" pindex=\"0\"".into();
    }
    let _ = write!(
        x,
        "  <object id=\"1\" type=\"model\" name=\"{}\"{material}>\n   <mesh>\n    <vertices>\n",
        xml_escape(name)
    );
    for p in &mesh.positions {
        let [a, b, c] = p.map(|v| v as f32);
        let _ = writeln!(x, "     <vertex x=\"{a}\" y=\"{b}\" z=\"{c}\"/>");
    }
    x.push_str("    </vertices>\n    <triangles>\n");
    for [a, b, c] in &mesh.triangles {
        let _ = writeln!(x, "     <triangle v1=\"{a}\" v2=\"{b}\" v3=\"{c}\"/>");
    }
    x.push_str(
        "    </triangles>\n   </mesh>\n  </object>\n </resources>\n <build>\n  <item objectid=\"1\"/>\n </build>\n</model>\n",
    );
    x
}

/// Writes `mesh` as a 3MF package (see [`three_mf_model`] for the model part).
pub fn write_3mf(
    mesh: &Mesh,
    unit: LengthUnit,
    name: &str,
    colour: Option<[f64; 3]>,
    out: &mut impl Write,
) -> io::Result<()> {
    let model = three_mf_model(mesh, unit, name, colour);
    let bytes = super::zip::zip(&[
        ("[Content_Types].xml", CONTENT_TYPES.as_bytes()),
        ("_rels/.rels", RELS.as_bytes()),
        ("3D/3dmodel.model", model.as_bytes()),
    ])?;
    out.write_all(&bytes)
}
