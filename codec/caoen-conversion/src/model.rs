//! The converted model: a base quadric plus local cubic perturbations,
//! `F = Q0 + sum_i f_i max(Q_i, 0)^3`, each `Q_i = 1 - |p - c_i|^2 / r_i^2` (a quadric
//! positive in a ball), kept in the unit cube of the mesh it was fitted to.

use serde_json::{json, Value};

use super::polygon_mesh::UnitFrame;
use super::quadric;
use super::support::Supports;
use caoen_frep::patch_index::PatchIndex;
use caoen_frep::Aabb;

/// A real function of 3-D space with its gradient, `>= 0` inside.
pub trait ImplicitField: Sync {
    /// The value at `p`.
    fn value(&self, p: [f64; 3]) -> f64 {
        self.value_gradient(p).0
    }
    /// The value and the gradient at `p`.
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]);
}

impl ImplicitField for caoen_frep::Node {
    fn value(&self, p: [f64; 3]) -> f64 {
        caoen_frep::Node::value(self, p)
    }
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        caoen_frep::Node::value_gradient(self, p)
    }
}

/// A field given in a mesh's own coordinates, seen in the mesh's unit cube.
pub struct InUnitCube<'a, F: ImplicitField> {
    /// The field.
    pub field: &'a F,
    /// The mesh's unit-cube frame.
    pub frame: UnitFrame,
}

impl<F: ImplicitField> ImplicitField for InUnitCube<'_, F> {
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let q = [0, 1, 2].map(|k| p[k] / self.frame.scale + self.frame.centre[k]);
        let (v, g) = self.field.value_gradient(q);
        (v, g.map(|x| x / self.frame.scale))
    }
}

/// One perturbation: `factor * max(1 - |p - centre|^2 / radius^2, 0)^3`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bump {
    /// The centre of its ball.
    pub centre: [f64; 3],
    /// The radius of its ball.
    pub radius: f64,
    /// The form factor.
    pub factor: f64,
}

impl Bump {
    /// `max(Q, 0)^3` (without the factor) and its gradient.
    #[inline]
    pub fn kernel(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let d = [0, 1, 2].map(|k| p[k] - self.centre[k]);
        let inv = 1.0 / (self.radius * self.radius);
        let q = 1.0 - (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]) * inv;
        if q <= 0.0 {
            return (0.0, [0.0; 3]);
        }
        let s = -6.0 * q * q * inv;
        (q * q * q, d.map(|v| s * v))
    }

    /// The box of its ball.
    pub fn support(&self) -> Aabb {
        Aabb::new(
            self.centre.map(|v| v - self.radius),
            self.centre.map(|v| v + self.radius),
        )
    }

    /// `Q` as the ten coefficients of the paper's eq. 4.
    pub fn quadric(&self) -> [f64; 10] {
        caoen_frep::node::bump_quadric(self.centre, self.radius, 1.0)
    }
}

/// The converted model.
#[derive(Debug, Clone)]
pub struct ImplicitModel {
    /// The mesh's unit-cube frame; the model lives in the unit cube.
    pub frame: UnitFrame,
    /// The base quadric `Q0` (unit-cube coordinates).
    pub base: [f64; 10],
    /// The perturbations, in the order they were added.
    pub bumps: Vec<Bump>,
    /// The planes the model is cut to ([`ImplicitModel::with_supports`]); `None` while
    /// it is fitted.
    pub supports: Option<Supports>,
    index: PatchIndex,
}

thread_local! {
    static NEAR: std::cell::RefCell<Vec<u32>> = const { std::cell::RefCell::new(Vec::new()) };
}

impl ImplicitModel {
    /// A model from its parts.
    pub fn new(frame: UnitFrame, base: [f64; 10], bumps: Vec<Bump>) -> ImplicitModel {
        let supports: Vec<Option<Aabb>> = bumps.iter().map(|b| Some(b.support())).collect();
        ImplicitModel {
            frame,
            base,
            index: PatchIndex::new(&supports),
            bumps,
            supports: None,
        }
    }

    /// The model cut to `supports` (unit cube): as a field and as a model file.
    pub fn with_supports(self, supports: Supports) -> ImplicitModel {
        ImplicitModel {
            supports: Some(supports),
            ..self
        }
    }

    /// The number of functions: the base quadric and the perturbations.
    pub fn functions(&self) -> usize {
        1 + self.bumps.len()
    }

    /// The model as an F-rep model file (`caoen-frep/1`) in the mesh's own
    /// coordinates: the unit-cube model, cut to its supports (without them, to the
    /// mesh's box: the fit says nothing beyond it), scaled back.
    pub fn to_frep_json(&self, name: &str, mesh_box: ([f64; 3], [f64; 3])) -> Value {
        self.to_frep_json_of(self.fitted_json(), name, mesh_box)
    }

    /// The fitted function as an F-rep node in the unit cube.
    pub fn fitted_json(&self) -> Value {
        let patches: Vec<Value> = self
            .bumps
            .iter()
            .map(|b| {
                json!({"bump": {"centre": b.centre, "radius": b.radius, "height": 1.0},
                       "factor": b.factor})
            })
            .collect();
        // The base alone when nothing perturbs it: the model file's `perturb` needs at
        // least one patch.
        // A model file's node holds at most MAX_NODES patches: more nest as a
        // perturbation of a perturbation (the sum is the same).
        let mut fitted = json!({"quadric": self.base});
        for chunk in patches.chunks(caoen_frep::node::MAX_NODES / 2) {
            fitted = json!({"perturb": fitted, "patches": chunk, "power": 3});
        }
        fitted
    }

    /// The nodes [`ImplicitModel::fitted_json`] holds, as a model file counts them.
    pub fn fitted_nodes(&self) -> usize {
        1 + self.bumps.len() + self.bumps.len().div_ceil(caoen_frep::node::MAX_NODES / 2)
    }

    /// `unit_model`, a node in this model's unit cube (the fitted function or one made
    /// from it), as an F-rep model file in the mesh's own coordinates, as
    /// [`ImplicitModel::to_frep_json`] writes the fitted function.
    pub fn to_frep_json_of(
        &self,
        unit_model: Value,
        name: &str,
        mesh_box: ([f64; 3], [f64; 3]),
    ) -> Value {
        let nodes = match &self.supports {
            Some(s) => s.json_nodes(),
            None => Supports::of_box(
                self.frame.to_unit(mesh_box.0),
                self.frame.to_unit(mesh_box.1),
            )
            .json_nodes(),
        };
        let model = json!({
            "transform": {
                "intersection": std::iter::once(unit_model).chain(nodes).collect::<Vec<_>>(),
                "a": 1
            },
            "scale": 1.0 / self.frame.scale,
            "translate": self.frame.centre,
        });
        json!({
            "format": "caoen-frep/1",
            "name": name,
            "model": model,
            "material": {"colour": [0.85, 0.8, 0.72]},
        })
    }
}

impl ImplicitField for ImplicitModel {
    fn value_gradient(&self, p: [f64; 3]) -> (f64, [f64; 3]) {
        let mut v = quadric::value(&self.base, p);
        let mut g = quadric::gradient(&self.base, p);
        NEAR.with(|near| {
            let mut near = near.borrow_mut();
            self.index.at_point(p, &mut near);
            for &i in near.iter() {
                let b = &self.bumps[i as usize];
                let (r, gr) = b.kernel(p);
                v += b.factor * r;
                for k in 0..3 {
                    g[k] += b.factor * gr[k];
                }
            }
        });
        match &self.supports {
            Some(s) => s.cut(p, (v, g)),
            None => (v, g),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use caoen_geometry::vector::central_difference;

    #[test]
    fn the_kernel_gradient_is_its_derivative_and_the_quadric_matches() {
        let b = Bump {
            centre: [0.1, -0.2, 0.05],
            radius: 0.3,
            factor: -0.7,
        };
        for p in [[0.2, -0.1, 0.0], [0.0, -0.3, 0.2], [0.3, -0.2, 0.1]] {
            let (r, g) = b.kernel(p);
            let q = quadric::value(&b.quadric(), p);
            assert!((r - q.max(0.0).powi(3)).abs() < 1e-12);
            let fd = central_difference(|q| b.kernel(q).0, p, 1e-6);
            for k in 0..3 {
                assert!((fd[k] - g[k]).abs() < 1e-7, "{} {}", fd[k], g[k]);
            }
        }
    }
}
