//! The F-rep model file's nodes as written: each body a typed struct read by serde, and
//! the node object itself (its kind's key, with an operation's parameters beside it)
//! read key by key, since no serde enum representation puts fields beside a tag.

use std::fmt;

use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

use super::values::{
    by_name, present, present_object, ByName, Int, Num, Numbers, Object, Projection, Scale,
};
use crate::convex_solid::FileSolid;
use crate::height_map::Interp;
use crate::node::MAX_DEPTH;
use crate::rfunction::SetOp;

/// The leaves' kinds.
const PRIMITIVES: [&str; 11] = [
    "cao_en_solid",
    "caoen_surface",
    "height_map",
    "sphere",
    "box",
    "cylinder",
    "cone",
    "torus",
    "half_space",
    "quadric",
    "superellipsoid",
];

/// The other kinds (`pattern`, a leaf with a picture, among them).
const OPERATIONS: [&str; 17] = [
    "negate",
    "shell",
    "blend_difference",
    "twist",
    "taper",
    "bend",
    "noise",
    "pattern",
    "relief",
    "perturb",
    "union",
    "intersection",
    "difference",
    "blend_union",
    "blend_intersection",
    "offset",
    "transform",
];

/// A node as written.
pub(crate) struct FileNode {
    /// What it is, with the body under its key.
    pub kind: FileKind,
    /// The parameters beside the kind's key.
    pub params: Params,
}

/// A node's kind and the body under its key.
pub(crate) enum FileKind {
    CaoEnSolid(FileSolid),
    CaoenSurface(FileSurface),
    HeightMap(FileHeightMap),
    Sphere(FileSphere),
    Box(FileBox),
    Cylinder(FileRound),
    Cone(FileRound),
    Torus(FileTorus),
    HalfSpace(FileHalfSpace),
    Quadric(Numbers<10>),
    Superellipsoid(FileSuperellipsoid),
    Pattern(FilePattern),
    /// `union`, `intersection`, `difference`.
    SetOp(SetOp, Vec<FileNode>),
    /// `blend_union`, `blend_intersection`, `blend_difference`.
    Blend(SetOp, Vec<FileNode>),
    /// An operation on one operand.
    Unary(Unary, Box<FileNode>),
}

/// The operations on one operand.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Unary {
    Negate,
    Shell,
    Twist,
    Taper,
    Bend,
    Noise,
    Relief,
    Perturb,
    Offset,
    Transform,
}

impl FileKind {
    /// The kind's key.
    pub fn name(&self) -> &'static str {
        let set_op = |op: &SetOp, prefix: &'static str| match (op, prefix.is_empty()) {
            (SetOp::Union, true) => "union",
            (SetOp::Intersection, true) => "intersection",
            (SetOp::Difference, true) => "difference",
            (SetOp::Union, false) => "blend_union",
            (SetOp::Intersection, false) => "blend_intersection",
            (SetOp::Difference, false) => "blend_difference",
        };
        match self {
            FileKind::CaoEnSolid(_) => "cao_en_solid",
            FileKind::CaoenSurface(_) => "caoen_surface",
            FileKind::HeightMap(_) => "height_map",
            FileKind::Sphere(_) => "sphere",
            FileKind::Box(_) => "box",
            FileKind::Cylinder(_) => "cylinder",
            FileKind::Cone(_) => "cone",
            FileKind::Torus(_) => "torus",
            FileKind::HalfSpace(_) => "half_space",
            FileKind::Quadric(_) => "quadric",
            FileKind::Superellipsoid(_) => "superellipsoid",
            FileKind::Pattern(_) => "pattern",
            FileKind::SetOp(op, _) => set_op(op, ""),
            FileKind::Blend(op, _) => set_op(op, "blend_"),
            FileKind::Unary(u, _) => match u {
                Unary::Negate => "negate",
                Unary::Shell => "shell",
                Unary::Twist => "twist",
                Unary::Taper => "taper",
                Unary::Bend => "bend",
                Unary::Noise => "noise",
                Unary::Relief => "relief",
                Unary::Perturb => "perturb",
                Unary::Offset => "offset",
                Unary::Transform => "transform",
            },
        }
    }

    /// The parameters the kind takes beside its key; None for the leaves, which take
    /// none.
    fn fields(&self) -> Option<&'static [&'static str]> {
        Some(match self {
            FileKind::SetOp(..) => &["a"],
            FileKind::Blend(..) => &["a", "a0", "a1", "a2"],
            FileKind::Unary(u, _) => match u {
                Unary::Negate => &[],
                Unary::Twist => &["deg_per_unit"],
                Unary::Taper => &["z", "scale"],
                Unary::Bend => &["radius"],
                Unary::Noise => &["amplitude", "scale", "seed"],
                Unary::Offset => &["by"],
                Unary::Shell => &["thickness"],
                Unary::Perturb => &["patches", "power"],
                Unary::Relief => &["image", "projection", "rect", "depth", "interp"],
                Unary::Transform => &["scale", "rotate_deg", "translate"],
            },
            _ => return None,
        })
    }
}

/// The parameters an operation may have beside its kind's key, each typed as every
/// kind that takes it reads it (`scale` is a number or a list: taper, noise and
/// transform read it differently).
#[derive(Default)]
pub(crate) struct Params {
    pub a: Option<Num>,
    pub a0: Option<Num>,
    pub a1: Option<Num>,
    pub a2: Option<Num>,
    pub deg_per_unit: Option<Num>,
    pub z: Option<Numbers<2>>,
    pub scale: Option<Scale>,
    pub radius: Option<Num>,
    pub amplitude: Option<Num>,
    pub seed: Option<Int>,
    pub by: Option<Num>,
    pub thickness: Option<Num>,
    pub patches: Option<Vec<FilePatch>>,
    pub power: Option<Int>,
    pub image: Option<String>,
    pub projection: Option<Projection>,
    pub rect: Option<Numbers<4>>,
    pub depth: Option<Num>,
    pub interp: Option<Interp>,
    pub rotate_deg: Option<Numbers<3>>,
    pub translate: Option<Numbers<3>>,
}

impl Params {
    /// Reads the value of `key` if it names a parameter; false (the value unread) if it
    /// does not.
    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<bool, A::Error> {
        match key {
            "a" => self.a = Some(map.next_value()?),
            "a0" => self.a0 = Some(map.next_value()?),
            "a1" => self.a1 = Some(map.next_value()?),
            "a2" => self.a2 = Some(map.next_value()?),
            "deg_per_unit" => self.deg_per_unit = Some(map.next_value()?),
            "z" => self.z = Some(map.next_value()?),
            "scale" => self.scale = Some(map.next_value()?),
            "radius" => self.radius = Some(map.next_value()?),
            "amplitude" => self.amplitude = Some(map.next_value()?),
            "seed" => self.seed = Some(map.next_value()?),
            "by" => self.by = Some(map.next_value()?),
            "thickness" => self.thickness = Some(map.next_value()?),
            "patches" => {
                let list: Vec<Object<FilePatch>> = map.next_value()?;
                self.patches = Some(list.into_iter().map(|p| p.0).collect());
            }
            "power" => self.power = Some(map.next_value()?),
            "image" => self.image = Some(map.next_value()?),
            "projection" => self.projection = Some(map.next_value()?),
            "rect" => self.rect = Some(map.next_value()?),
            "depth" => self.depth = Some(map.next_value()?),
            "interp" => self.interp = Some(map.next_value::<ByName<_>>()?.0),
            "rotate_deg" => self.rotate_deg = Some(map.next_value()?),
            "translate" => self.translate = Some(map.next_value()?),
            _ => return Ok(false),
        }
        Ok(true)
    }
}

fn one() -> Num {
    Num(1.0)
}

fn half() -> Num {
    Num(0.5)
}

fn detail() -> Num {
    Num(5.0)
}

fn round_exponents() -> Numbers<2> {
    Numbers([1.0, 1.0])
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileSphere {
    #[serde(default)]
    pub centre: Numbers<3>,
    pub radius: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileBox {
    #[serde(default)]
    pub centre: Numbers<3>,
    pub size: Numbers<3>,
}

/// A cylinder's or a cone's body.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileRound {
    #[serde(default)]
    pub centre: Numbers<3>,
    pub radius: Num,
    pub length: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileTorus {
    #[serde(default)]
    pub centre: Numbers<3>,
    pub major: Num,
    pub minor: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileHalfSpace {
    #[serde(default)]
    pub point: Numbers<3>,
    pub normal: Numbers<3>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileSuperellipsoid {
    #[serde(default = "round_exponents")]
    pub exponents: Numbers<2>,
    #[serde(default)]
    pub centre: Numbers<3>,
    pub radii: Numbers<3>,
}

/// `{"caoen_surface": {"file", "detail"}}`; `detail` is read as a number and checked
/// whole, so `5.0` means 5.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileSurface {
    pub file: String,
    #[serde(default = "detail")]
    pub detail: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileHeightMap {
    pub base: FileBase,
    pub rect: Numbers<4>,
    #[serde(default = "one")]
    pub height: Num,
    #[serde(default, deserialize_with = "present")]
    pub threshold: Option<Num>,
    #[serde(default, deserialize_with = "by_name")]
    pub interp: Interp,
    pub image: String,
}

/// A height map's base: `"plane"`, `{"ellipsoid": [a, b, c]}` or `{"cylinder": r}`.
pub(crate) enum FileBase {
    Plane,
    Ellipsoid(Numbers<3>),
    Cylinder(Num),
}

impl<'de> Deserialize<'de> for FileBase {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = FileBase;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(r#""plane", {"ellipsoid": [a, b, c]} or {"cylinder": r}"#)
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<FileBase, E> {
                match s {
                    "plane" => Ok(FileBase::Plane),
                    _ => Err(E::invalid_value(de::Unexpected::Str(s), &self)),
                }
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<FileBase, A::Error> {
                let base = match map.next_key::<String>()?.as_deref() {
                    Some("ellipsoid") => FileBase::Ellipsoid(map.next_value()?),
                    Some("cylinder") => FileBase::Cylinder(map.next_value()?),
                    _ => return Err(de::Error::invalid_value(de::Unexpected::Map, &self)),
                };
                if map.next_key::<IgnoredAny>()?.is_some() {
                    return Err(de::Error::invalid_value(de::Unexpected::Map, &self));
                }
                Ok(base)
            }
        }
        d.deserialize_any(V)
    }
}

/// `{"pattern": {...}}`: a picture swept through space.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FilePattern {
    pub image: String,
    #[serde(default)]
    pub projection: Projection,
    #[serde(default, deserialize_with = "present")]
    pub rect: Option<Numbers<4>>,
    #[serde(default = "half")]
    pub level: Num,
    #[serde(default, deserialize_with = "by_name")]
    pub interp: Interp,
}

/// One patch of a perturbation: one of its four supports and its factor.
#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FilePatch {
    #[serde(default = "one")]
    pub factor: Num,
    #[serde(default, deserialize_with = "present")]
    pub quadric: Option<Numbers<10>>,
    #[serde(default, deserialize_with = "present_object")]
    pub bump: Option<FileBump>,
    #[serde(default, deserialize_with = "present_object")]
    pub polygon: Option<FilePolygon>,
    #[serde(default, deserialize_with = "present_object")]
    pub spherical_polygon: Option<FileSphericalPolygon>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileBump {
    #[serde(default)]
    pub centre: Numbers<3>,
    pub radius: Num,
    pub height: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FilePolygon {
    pub vertices: Vec<Numbers<3>>,
    pub depth: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields, expecting = "an object")]
pub(crate) struct FileSphericalPolygon {
    pub vertices: Vec<Numbers<3>>,
    pub depth: Num,
    #[serde(default)]
    pub centre: Numbers<3>,
    pub radius: Num,
}

impl<'de> Deserialize<'de> for FileNode {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        NodeSeed { depth: 0 }.deserialize(d)
    }
}

/// Reads a node `depth` levels below the root; the nesting limit is checked before
/// descending, so no input nests the reader deeper than the model may.
#[derive(Clone, Copy)]
struct NodeSeed {
    depth: usize,
}

impl NodeSeed {
    fn child(self) -> Self {
        NodeSeed {
            depth: self.depth + 1,
        }
    }

    /// The kind named by `key` with its body, or None (the value unread) if `key`
    /// names no kind.
    fn kind<'de, A: MapAccess<'de>>(
        self,
        key: &str,
        map: &mut A,
    ) -> Result<Option<FileKind>, A::Error> {
        let operands = |map: &mut A| map.next_value_seed(Operands(self.child()));
        let unary = |map: &mut A, u| {
            let operand = map.next_value_seed(self.child())?;
            Ok::<_, A::Error>(FileKind::Unary(u, Box::new(operand)))
        };
        Ok(Some(match key {
            "cao_en_solid" => FileKind::CaoEnSolid(map.next_value()?),
            "caoen_surface" => FileKind::CaoenSurface(map.next_value::<Object<_>>()?.0),
            "height_map" => FileKind::HeightMap(map.next_value::<Object<_>>()?.0),
            "sphere" => FileKind::Sphere(map.next_value::<Object<_>>()?.0),
            "box" => FileKind::Box(map.next_value::<Object<_>>()?.0),
            "cylinder" => FileKind::Cylinder(map.next_value::<Object<_>>()?.0),
            "cone" => FileKind::Cone(map.next_value::<Object<_>>()?.0),
            "torus" => FileKind::Torus(map.next_value::<Object<_>>()?.0),
            "half_space" => FileKind::HalfSpace(map.next_value::<Object<_>>()?.0),
            "quadric" => FileKind::Quadric(map.next_value()?),
            "superellipsoid" => FileKind::Superellipsoid(map.next_value::<Object<_>>()?.0),
            "pattern" => FileKind::Pattern(map.next_value::<Object<_>>()?.0),
            "union" => FileKind::SetOp(SetOp::Union, operands(map)?),
            "intersection" => FileKind::SetOp(SetOp::Intersection, operands(map)?),
            "difference" => FileKind::SetOp(SetOp::Difference, operands(map)?),
            "blend_union" => FileKind::Blend(SetOp::Union, operands(map)?),
            "blend_intersection" => FileKind::Blend(SetOp::Intersection, operands(map)?),
            "blend_difference" => FileKind::Blend(SetOp::Difference, operands(map)?),
            "negate" => unary(map, Unary::Negate)?,
            "shell" => unary(map, Unary::Shell)?,
            "twist" => unary(map, Unary::Twist)?,
            "taper" => unary(map, Unary::Taper)?,
            "bend" => unary(map, Unary::Bend)?,
            "noise" => unary(map, Unary::Noise)?,
            "relief" => unary(map, Unary::Relief)?,
            "perturb" => unary(map, Unary::Perturb)?,
            "offset" => unary(map, Unary::Offset)?,
            "transform" => unary(map, Unary::Transform)?,
            _ => return Ok(None),
        }))
    }
}

impl<'de> DeserializeSeed<'de> for NodeSeed {
    type Value = FileNode;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<FileNode, D::Error> {
        if self.depth > MAX_DEPTH {
            return Err(de::Error::custom(format!(
                "nested deeper than {MAX_DEPTH} levels"
            )));
        }
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for NodeSeed {
    type Value = FileNode;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str(r#"a node object like {"sphere": {...}}"#)
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<FileNode, A::Error> {
        let mut kind = None;
        let mut params = Params::default();
        // Every key but the kind's, in the file's order: the kind decides which it takes.
        let mut beside = Vec::new();
        while let Some(key) = map.next_key::<String>()? {
            if kind.is_none() {
                if let Some(k) = self.kind(&key, &mut map)? {
                    kind = Some(k);
                    continue;
                }
            }
            if !params.read(&key, &mut map)? {
                map.next_value::<IgnoredAny>()?;
            }
            beside.push(key);
        }
        let Some(kind) = kind else {
            return Err(de::Error::custom(format!(
                "no node kind; expected one of: {}, {}",
                PRIMITIVES.join(", "),
                OPERATIONS.join(", ")
            )));
        };
        let name = kind.name();
        match kind.fields() {
            None if !beside.is_empty() => Err(de::Error::custom(format!(
                "a `{name}` node takes no fields beside `{name}`"
            ))),
            Some(fields) => match beside.iter().find(|k| !fields.contains(&k.as_str())) {
                Some(k) => Err(de::Error::custom(format!(
                    "unknown field `{k}` beside `{name}` (expected: {})",
                    fields.join(", ")
                ))),
                None => Ok(FileNode { kind, params }),
            },
            None => Ok(FileNode { kind, params }),
        }
    }
}

/// Reads an operation's list of operands, each a level deeper.
struct Operands(NodeSeed);

impl<'de> DeserializeSeed<'de> for Operands {
    type Value = Vec<FileNode>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Vec<FileNode>, D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for Operands {
    type Value = Vec<FileNode>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a list of operand nodes")
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Vec<FileNode>, A::Error> {
        let mut out = Vec::new();
        while let Some(n) = seq.next_element_seed(self.0)? {
            out.push(n);
        }
        Ok(out)
    }
}
