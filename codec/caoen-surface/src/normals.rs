//! Surface normals (paper section 4): exact, from the network's Jacobian and the
//! domain's tangents by the chain rule (8–13), and interpolated, from a second
//! network whose shape vectors are the exact normals at the key points.

use super::domain::Domain;
use super::error::{Result, SurfaceError};
use super::network::Network;

use caoen_geometry::vector::{cross, normalise};

fn check_surface(net: &Network, domain: &Domain) -> Result<()> {
    if net.output_dim() != 3 {
        return Err(SurfaceError::Parameter {
            what: "shape dimension p".into(),
            value: net.output_dim() as f64,
            reason: "normals need a surface in 3-D (p = 3)",
        });
    }
    super::error::check_len(
        || "network input vs domain".into(),
        domain.ambient_dim(),
        net.input_dim(),
    )
}

/// The surface point and its (unnormalised) normal `dy/da x dy/db` at domain point `x`.
///
/// `(a, b)` are the domain's tangent directions from [`Domain::tangents`]; the
/// derivatives come from the exact Jacobian (formula 12), so no finite differences.
/// Where the map is singular the normal is the zero vector.
pub fn point_and_normal(net: &Network, domain: &Domain, x: &[f64]) -> Result<([f64; 3], [f64; 3])> {
    check_surface(net, domain)?;
    let (y, jac) = net.eval_with_jacobian(x)?;
    let (ta, tb) = domain.tangents(x)?;
    let m = net.input_dim();
    let push = |t: &[f64; 4]| -> [f64; 3] {
        let mut d = [0.0; 3];
        for (g, dg) in d.iter_mut().enumerate() {
            *dg = (0..m).map(|h| jac[g * m + h] * t[h]).sum();
        }
        d
    };
    Ok(([y[0], y[1], y[2]], cross(push(&ta), push(&tb))))
}

/// The exact unit normal at domain point `x` (zero where the map is singular).
pub fn exact_normal(net: &Network, domain: &Domain, x: &[f64]) -> Result<[f64; 3]> {
    Ok(normalise(point_and_normal(net, domain, x)?.1))
}

/// Normals interpolated over the domain by a second network (the paper's smoothing):
/// same first layer, shape vectors = exact unit normals at the key points.
#[derive(Debug, Clone)]
pub struct NormalNetwork {
    network: Network,
}

impl NormalNetwork {
    /// Computes the exact normal at each key point's source (projected onto the domain).
    pub fn new(net: &Network, domain: &Domain) -> Result<Self> {
        check_surface(net, domain)?;
        let m = net.input_dim();
        let mut shapes = Vec::with_capacity(net.len() * 3);
        for w in net.sources().chunks_exact(m) {
            let x = domain.project(w)?;
            shapes.extend(exact_normal(net, domain, &x)?);
        }
        Ok(NormalNetwork {
            network: net.with_shapes(3, shapes)?,
        })
    }

    /// The interpolated unit normal at domain point `x`.
    pub fn normal(&self, x: &[f64]) -> Result<[f64; 3]> {
        let n = self.network.eval(x)?;
        Ok(normalise([n[0], n[1], n[2]]))
    }

    /// The network that interpolates the normals.
    pub fn network(&self) -> &Network {
        &self.network
    }
}
