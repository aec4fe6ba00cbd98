//! The image domain on the sphere: pixel positions embedded on S^2 by inverse
//! stereographic projection, and the sharpness that gives a key point a chosen
//! footprint in pixels.
//!
//! Pixel `(x, y)` (continuous, pixel centres at `i + 0.5`) maps to the plane point
//! `(u, v) = ((x - W/2) / S, (y - H/2) / S)`, `S = max(W, H)`, and then to
//! `P = (2u, 2v, 1 - r^2) / (1 + r^2)`, `r^2 = u^2 + v^2`. The map is conformal, with
//! chord distance `|P - P'| = 2 d / sqrt((1 + r^2)(1 + r'^2))` for plane distance `d`, so a
//! key point at plane radius `r_c` with `q = ((1 + r_c^2) S / (2 sigma))^2` has, near its
//! centre, the compact kernel `(1 - d_px^2 / (6 sigma^2))^3`: an isotropic footprint of
//! `sigma` pixels whose support radius is `sqrt(6) sigma`.

/// The embedding of one image's pixel grid, or of a window of it (a tile, in its own
/// pixel coordinates, embedded where it lies in the whole image).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    inv_scale: f64,
    /// The whole image's centre in this frame's pixel coordinates.
    centre: (f64, f64),
}

/// Support radius of the compact kernel in units of sigma: `sqrt(6)`.
pub const SUPPORT_SIGMAS: f64 = 2.449_489_742_783_178;

impl Frame {
    /// The frame of a `width x height` image.
    pub fn new(width: u32, height: u32) -> Self {
        Frame {
            width,
            height,
            inv_scale: 1.0 / width.max(height).max(1) as f64,
            centre: (0.5 * width as f64, 0.5 * height as f64),
        }
    }

    /// The `width x height` window at `(x0, y0)` of a `full_width x full_height`
    /// image: pixel `(x, y)` of the window embeds as pixel `(x0 + x, y0 + y)` of the
    /// image, so key points fitted in a tile are the image's own.
    pub fn window(
        full_width: u32,
        full_height: u32,
        (x0, y0): (u32, u32),
        width: u32,
        height: u32,
    ) -> Self {
        let full = Frame::new(full_width, full_height);
        Frame {
            width,
            height,
            inv_scale: full.inv_scale,
            centre: (full.centre.0 - x0 as f64, full.centre.1 - y0 as f64),
        }
    }

    /// One over the plane scale `S` (the whole image's larger side).
    #[inline]
    pub fn inv_scale(&self) -> f64 {
        self.inv_scale
    }

    /// The whole image's centre in this frame's pixel coordinates.
    #[inline]
    pub fn centre(&self) -> (f64, f64) {
        self.centre
    }

    /// Plane coordinates of pixel position `(x, y)`.
    #[inline]
    pub fn plane(&self, x: f64, y: f64) -> (f64, f64) {
        (
            (x - self.centre.0) * self.inv_scale,
            (y - self.centre.1) * self.inv_scale,
        )
    }

    /// The unit-sphere point of pixel position `(x, y)`.
    #[inline]
    pub fn embed(&self, x: f64, y: f64) -> [f64; 3] {
        let (u, v) = self.plane(x, y);
        let r2 = u * u + v * v;
        let d = 1.0 / (1.0 + r2);
        [2.0 * u * d, 2.0 * v * d, (1.0 - r2) * d]
    }

    /// The pixel position of a sphere point (inverse of [`Frame::embed`]).
    #[inline]
    pub fn unembed(&self, p: &[f64]) -> (f64, f64) {
        let d = 1.0 + p[2];
        let (u, v) = if d > 1e-300 {
            (p[0] / d, p[1] / d)
        } else {
            (f64::INFINITY, f64::INFINITY)
        };
        (
            u / self.inv_scale + self.centre.0,
            v / self.inv_scale + self.centre.1,
        )
    }

    /// Sharpness `q` for a footprint of `sigma` pixels centred at `(x, y)`.
    #[inline]
    pub fn sharpness(&self, x: f64, y: f64, sigma: f64) -> f64 {
        let (u, v) = self.plane(x, y);
        let k = (1.0 + u * u + v * v) / (2.0 * sigma * self.inv_scale);
        k * k
    }

    /// A radius in pixels around `(x, y)` outside which a key point of footprint `sigma`
    /// there has no influence (a safe bound on the conformal distortion included).
    pub fn support_radius(&self, x: f64, y: f64, sigma: f64) -> f64 {
        let (u, v) = self.plane(x, y);
        let rc = (u * u + v * v).sqrt();
        // Within the support, the plane radius of a pixel grows by at most 4 sigma.
        let rp = rc + 4.0 * sigma * self.inv_scale;
        SUPPORT_SIGMAS * sigma * ((1.0 + rp * rp) / (1.0 + rc * rc)).sqrt() * (1.0 + 1e-9) + 1e-9
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn embedding_is_on_the_sphere_and_inverts() {
        let f = Frame::new(768, 512);
        for (x, y) in [(0.5, 0.5), (383.2, 100.0), (767.5, 511.5), (-50.0, 900.0)] {
            let p = f.embed(x, y);
            assert!(((p[0] * p[0] + p[1] * p[1] + p[2] * p[2]) - 1.0).abs() < 1e-15);
            let (bx, by) = f.unembed(&p);
            assert!((bx - x).abs() < 1e-9 && (by - y).abs() < 1e-9);
        }
    }

    #[test]
    fn a_window_embeds_its_pixels_where_they_lie_in_the_image() {
        let full = Frame::new(4032, 3024);
        let tile = Frame::window(4032, 3024, (1536, 512), 512, 512);
        for (x, y) in [(0.5, 0.5), (511.5, 300.25), (-40.0, 600.0)] {
            let a = tile.embed(x, y);
            let b = full.embed(1536.0 + x, 512.0 + y);
            assert!(a.iter().zip(&b).all(|(p, q)| (p - q).abs() < 1e-15));
            assert!(
                (tile.sharpness(x, y, 3.0) - full.sharpness(1536.0 + x, 512.0 + y, 3.0)).abs()
                    < 1e-6
            );
            let (bx, by) = tile.unembed(&a);
            assert!((bx - x).abs() < 1e-9 && (by - y).abs() < 1e-9);
        }
    }

    #[test]
    fn sharpness_gives_the_requested_footprint() {
        // With q from `sharpness`, q (1 - s) at distance d is d^2 / (2 sigma^2) near the centre.
        let f = Frame::new(640, 480);
        let (cx, cy, sigma) = (500.0, 60.0, 3.0);
        let q = f.sharpness(cx, cy, sigma);
        let w = f.embed(cx, cy);
        let p = f.embed(cx + 0.5, cy - 0.5);
        let s: f64 = p.iter().zip(&w).map(|(a, b)| a * b).sum();
        let u = q * (1.0 - s);
        // Exactly d^2 / (2 sigma^2) scaled by the conformal factors' ratio (1+rc^2)/(1+rp^2).
        let r2 = |x: f64, y: f64| {
            let (a, b) = f.plane(x, y);
            a * a + b * b
        };
        let want =
            0.5 / (2.0 * sigma * sigma) * (1.0 + r2(cx, cy)) / (1.0 + r2(cx + 0.5, cy - 0.5));
        assert!((u - want).abs() < 1e-9 * want, "{u} vs {want}");
        // The support bound really bounds: just beyond it the kernel is zero.
        let r = f.support_radius(cx, cy, sigma);
        for k in 0..64 {
            let a = k as f64 * std::f64::consts::TAU / 64.0;
            let p = f.embed(cx + r * a.cos(), cy + r * a.sin());
            let s: f64 = p.iter().zip(&w).map(|(a, b)| a * b).sum();
            assert!(q * (1.0 - s) >= 3.0);
        }
    }
}
