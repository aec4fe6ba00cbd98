//! The checker pigment as POV-Ray's `checker` pattern (3.7, `pattern.cpp`): unit
//! cubes in two colours, the first where `floor(x + t) + floor(y + t) + floor(z + t)`
//! is even, `t` = 0.001 POV-Ray's tolerance (so a face on a cube's boundary takes the
//! colour of the cube it faces into), after the texture transform. The sum does not
//! depend on the order of the axes, so caoen's point needs no swap; the transform is
//! written in POV-Ray's axes, as for image maps.

use caoen_geometry::transform::Affine;

/// POV-Ray's `SMALL_TOLERANCE`, added before each `floor`.
const TOLERANCE: f64 = 0.001;

/// A checker of two colours in world space, with its texture transform.
#[derive(Debug, Clone)]
pub struct Checker {
    /// The colours (linear light): the first on the cube at the origin.
    pub colours: [[f32; 3]; 2],
    /// The texture transform (scale, then rotate, then translate) from pattern space
    /// to the world; must be invertible.
    pub transform: Affine,
    /// World to pattern space.
    to_pattern: Affine,
}

impl Checker {
    /// A checker; None if `transform` is singular.
    pub fn new(colours: [[f32; 3]; 2], transform: Affine) -> Option<Checker> {
        if !(transform.det().abs() > 1e-300) {
            return None;
        }
        Some(Checker {
            colours,
            to_pattern: transform.inverse()?,
            transform,
        })
    }

    /// The colour at world point `p`.
    pub fn colour(&self, p: [f64; 3]) -> [f32; 3] {
        let q = self.to_pattern.point(p);
        let sum: f64 = q.iter().map(|v| (v + TOLERANCE).floor()).sum();
        // POV-Ray truncates the sum to an int; a point that far out is the first colour.
        if !(sum.abs() < 1e15) {
            return self.colours[0];
        }
        self.colours[((sum as i64) & 1) as usize]
    }

    /// POV-Ray's pigment: `checker` of the two colours with `transmit`, the texture
    /// transform as a matrix in POV-Ray's axes.
    pub fn pov_pigment(&self, transmit: f32) -> String {
        let [a, b] = self.colours;
        format!(
            "pigment {{ checker rgbt <{}, {}, {}, {transmit}>, rgbt <{}, {}, {}, {transmit}>{} }}",
            a[0],
            a[1],
            a[2],
            b[0],
            b[1],
            b[2],
            super::image_map::pov_matrix(&self.transform)
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: [f32; 3] = [1.0, 0.0, 0.0];
    const B: [f32; 3] = [0.0, 0.0, 1.0];

    #[test]
    fn cubes_alternate_as_in_pov_ray() {
        let c = Checker::new([A, B], Affine::IDENTITY).unwrap();
        assert_eq!(c.colour([0.5, 0.5, 0.5]), A);
        assert_eq!(c.colour([1.5, 0.5, 0.5]), B);
        assert_eq!(c.colour([1.5, 1.5, 0.5]), A);
        // Negative cells: floor(-0.5) = -1, odd.
        assert_eq!(c.colour([-0.5, 0.5, 0.5]), B);
        assert_eq!(c.colour([-0.5, -0.5, -0.5]), B);
        // A boundary a little below 1 already counts as the next cube.
        assert_eq!(c.colour([0.9995, 0.5, 0.5]), B);
        assert_eq!(c.colour([0.998, 0.5, 0.5]), A);
        // The texture transform scales the cubes.
        let s = Checker::new([A, B], Affine::from_parts([0.25; 3], [0.0; 3], [0.0; 3])).unwrap();
        assert_eq!(s.colour([0.3, 0.1, 0.1]), B);
        assert!(Checker::new([A, B], Affine::from_parts([0.0; 3], [0.0; 3], [0.0; 3])).is_none());
    }

    #[test]
    fn pov_pigment_lists_both_colours() {
        let c = Checker::new([A, B], Affine::from_parts([0.5; 3], [0.0; 3], [0.0; 3])).unwrap();
        assert_eq!(
            c.pov_pigment(0.0),
            "pigment { checker rgbt <1, 0, 0, 0>, rgbt <0, 0, 1, 0> matrix <0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0> }"
        );
    }
}
