//! Rays: the half-lines cameras cast and tracers cross solids with.

use super::vector::{add, scale};

/// A ray `origin + t dir`, `dir` of unit length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Start point.
    pub origin: [f64; 3],
    /// Unit direction.
    pub dir: [f64; 3],
}

impl Ray {
    /// The point at parameter `t`.
    pub fn at(&self, t: f64) -> [f64; 3] {
        add(self.origin, scale(self.dir, t))
    }
}
