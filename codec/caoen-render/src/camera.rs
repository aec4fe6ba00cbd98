//! Cameras: where a world point lands on the image, and the ray through a pixel.
//!
//! Image coordinates are continuous pixels, x to the right and y down, with pixel
//! `(i, j)` covering `[i, i+1) x [j, j+1)` (its centre at `(i + 0.5, j + 0.5)`).
//! Depth is the distance along the viewing direction, for both projections, so every
//! method (depth buffer, mesh rasteriser, ray tracer) writes comparable depths.

use super::error::{RenderError, Result};
pub use caoen_geometry::ray::Ray;
use caoen_geometry::vector::{add, cross, dot, norm, scale, sub, unit};

/// How the camera projects.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// A pinhole camera with the given vertical field of view (degrees).
    Perspective {
        /// Vertical field of view in degrees, in (0, 180).
        fov_y_deg: f64,
    },
    /// A parallel projection showing `height` world units vertically.
    Orthographic {
        /// World units spanned by the image height.
        height: f64,
    },
}

/// Nearest depth a perspective camera accepts (points closer are not drawn).
pub const NEAR: f64 = 1e-6;

/// A camera with an image size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    /// Eye position (for orthographic cameras, the centre of the image plane).
    pub eye: [f64; 3],
    /// Unit viewing direction.
    pub forward: [f64; 3],
    /// Unit image x axis.
    pub right: [f64; 3],
    /// Unit image up axis (image y points the other way).
    pub up: [f64; 3],
    /// Projection kind and its parameter.
    pub projection: Projection,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

impl Camera {
    /// A camera at `eye` looking at `target` with `up` roughly up.
    pub fn look_at(
        eye: [f64; 3],
        target: [f64; 3],
        up: [f64; 3],
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let finite = eye.iter().chain(&target).chain(&up).all(|v| v.is_finite());
        let f = sub(target, eye);
        let r = cross(f, up);
        if !finite || norm(f) == 0.0 || norm(r) < 1e-12 * norm(f) * norm(up).max(1e-300) {
            return Err(RenderError::parameter(
                "camera",
                "eye must differ from target and up must not be parallel to the view",
            ));
        }
        match projection {
            Projection::Perspective { fov_y_deg } if !(fov_y_deg > 0.0 && fov_y_deg < 179.0) => {
                return Err(RenderError::parameter(
                    "camera.fov_deg",
                    format!("{fov_y_deg} is not in (0, 179)"),
                ))
            }
            Projection::Orthographic { height } if !(height > 0.0 && height.is_finite()) => {
                return Err(RenderError::parameter(
                    "camera.height",
                    format!("{height} must be finite and > 0"),
                ))
            }
            _ => {}
        }
        if width == 0 || height == 0 || (width as u64) * (height as u64) > 1 << 28 {
            return Err(RenderError::parameter(
                "image size",
                format!("{width}x{height}: must be non-empty and at most 2^28 pixels"),
            ));
        }
        let forward = unit(f);
        let right = unit(r);
        Ok(Camera {
            eye,
            forward,
            right,
            up: cross(right, forward),
            projection,
            width,
            height,
        })
    }

    /// The same view at another image size (for supersampling).
    pub fn with_size(&self, width: u32, height: u32) -> Self {
        Camera {
            width,
            height,
            ..*self
        }
    }

    /// Pixels per world unit at unit depth (perspective) or everywhere (orthographic).
    pub fn pixel_scale(&self) -> f64 {
        let h = self.height as f64;
        match self.projection {
            Projection::Perspective { fov_y_deg } => 0.5 * h / (0.5 * fov_y_deg.to_radians()).tan(),
            Projection::Orthographic { height } => h / height,
        }
    }

    /// Image position `(x, y)` and depth of a world point; None if behind a
    /// perspective camera.
    #[inline]
    pub fn project(&self, p: [f64; 3]) -> Option<[f64; 3]> {
        let r = sub(p, self.eye);
        let z = dot(r, self.forward);
        let s = match self.projection {
            Projection::Perspective { .. } => {
                if !(z > NEAR) {
                    return None;
                }
                self.pixel_scale() / z
            }
            Projection::Orthographic { .. } => self.pixel_scale(),
        };
        Some([
            0.5 * self.width as f64 + s * dot(r, self.right),
            0.5 * self.height as f64 - s * dot(r, self.up),
            z,
        ])
    }

    /// The ray through image position `(x, y)` (continuous pixels).
    #[inline]
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        let dx = x - 0.5 * self.width as f64;
        let dy = 0.5 * self.height as f64 - y;
        let s = self.pixel_scale();
        match self.projection {
            Projection::Perspective { .. } => Ray {
                origin: self.eye,
                dir: unit(add(
                    scale(self.forward, s),
                    add(scale(self.right, dx), scale(self.up, dy)),
                )),
            },
            Projection::Orthographic { .. } => Ray {
                origin: add(
                    self.eye,
                    add(scale(self.right, dx / s), scale(self.up, dy / s)),
                ),
                dir: self.forward,
            },
        }
    }

    /// Derivatives of the image position `(x, y)` with respect to the world point `p`
    /// (two rows of three), where `p` is in front of the camera.
    pub fn screen_jacobian(&self, p: [f64; 3]) -> [[f64; 3]; 2] {
        let s = self.pixel_scale();
        match self.projection {
            Projection::Orthographic { .. } => [scale(self.right, s), scale(self.up, -s)],
            Projection::Perspective { .. } => {
                let r = sub(p, self.eye);
                let z = dot(r, self.forward);
                let k = s / (z * z);
                let row = |axis: [f64; 3], sign: f64| {
                    scale(
                        sub(scale(axis, z), scale(self.forward, dot(r, axis))),
                        sign * k,
                    )
                };
                [row(self.right, 1.0), row(self.up, -1.0)]
            }
        }
    }

    /// Depth of a world point (distance along the viewing direction from the eye).
    #[inline]
    pub fn depth(&self, p: [f64; 3]) -> f64 {
        dot(sub(p, self.eye), self.forward)
    }

    /// A camera that frames the sphere `(centre, radius)` from direction `from`
    /// (pointing from the centre towards the eye), z up unless the view is vertical.
    pub fn framing(
        centre: [f64; 3],
        radius: f64,
        from: [f64; 3],
        projection: Projection,
        width: u32,
        height: u32,
    ) -> Result<Self> {
        let from = unit(from);
        let radius = if radius > 0.0 && radius.is_finite() {
            radius
        } else {
            1.0
        };
        let aspect = (width as f64 / height.max(1) as f64).min(1.0);
        let (eye, projection) = match projection {
            Projection::Perspective { fov_y_deg } => {
                // The sphere fits the narrower image side with a 10% margin.
                let half = (0.5 * fov_y_deg.to_radians()).tan() * aspect;
                let dist = 1.1 * radius * (1.0 + half * half).sqrt() / half;
                (add(centre, scale(from, dist)), projection)
            }
            Projection::Orthographic { .. } => (
                add(centre, scale(from, 4.0 * radius)),
                Projection::Orthographic {
                    height: 2.2 * radius / aspect,
                },
            ),
        };
        let up = if cross(from, [0.0, 0.0, 1.0]).iter().all(|v| v.abs() < 1e-6) {
            [0.0, 1.0, 0.0]
        } else {
            [0.0, 0.0, 1.0]
        };
        Camera::look_at(eye, centre, up, projection, width, height)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_through_projection_hits_the_point() {
        for projection in [
            Projection::Perspective { fov_y_deg: 40.0 },
            Projection::Orthographic { height: 3.0 },
        ] {
            let cam = Camera::look_at(
                [3., -4., 2.],
                [0., 0., 0.],
                [0., 0., 1.],
                projection,
                64,
                48,
            )
            .unwrap();
            let p = [0.3, -0.2, 0.5];
            let [x, y, z] = cam.project(p).unwrap();
            let ray = cam.ray(x, y);
            let t = dot(sub(p, ray.origin), ray.dir);
            let q = ray.at(t);
            assert!(norm(sub(p, q)) < 1e-9, "{projection:?}: {q:?}");
            assert!((cam.depth(p) - z).abs() < 1e-12);
        }
    }
}
