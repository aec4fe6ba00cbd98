//! The coast with a lighthouse.

use super::*;

pub(super) fn coast(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let horizon = hf * rng.range(0.4, 0.5);
    let zen = Col::hex_linear(0x3068b8);
    let hor = Col::hex_linear(0xd0e0ee);
    let sun = (wf * rng.range(0.6, 1.1), -s * rng.range(0.0, 0.2));
    let f0 = rng.range(2.5, 4.0) / s;
    let cover = rng.range(0.05, 0.3);
    let sea_far = Col::hex_linear(0x3a7090);
    let sea_near = Col::hex_linear(0x0e3a48);
    c.shade(|x, y| {
        if y < horizon {
            let t = clamp01(y / horizon);
            let mut col = zen.mix(hor, pow(t, 2.0));
            let d = sqrt(sq(x - sun.0) + sq(y - sun.1)) / s;
            col = col + Col(0.8, 0.7, 0.5) * 0.6 * exp(-d * 3.0);
            let dn =
                cloud_density(&n0, &n1, x, y, f0, cover, 2.5) * (1.0 - smoothstep(0.6, 1.0, t));
            if dn > 0.0 {
                let tw = cloud_density(&n0, &n1, x + s * 0.006, y - s * 0.006, f0, cover, 2.5);
                let lit = clamp01(1.0 - 1.8 * (tw - dn).max(0.0) - 0.25 * dn);
                col = col.mix(Col(0.5, 0.55, 0.65).mix(Col(1.05, 1.03, 1.0), lit), dn);
            }
            col
        } else {
            let z = (y - horizon) / (hf - horizon); // 0 at horizon, 1 at bottom
            let zz = 0.02 + z;
            let waves = n2.fbm(x * 0.02 / zz, 3.0 / zz, 5, 2.0, 0.55);
            let fine = n3.fbm(x * 0.1 / zz, 12.0 / zz, 3, 2.0, 0.5);
            let fres = 0.5 * (1.0 - smoothstep(0.0, 0.5, z));
            let base = sea_far.mix(sea_near, smoothstep(0.0, 0.8, z));
            let skyref = hor * 0.8;
            let mut col = base.mix(skyref, fres) * (0.8 + 0.3 * waves + 0.1 * fine);
            let glint =
                smoothstep(0.55, 0.8, fine * 0.5 + waves * 0.7) * exp(-sq((x - sun.0) / (s * 0.5)));
            col = col + Col::gray(glint * 0.8);
            col
        }
    });
    // Headland with a cliff face and a grassy top.
    let hl_end = wf * rng.range(0.3, 0.45);
    let hl_top = horizon - s * rng.range(0.08, 0.14);
    let cliff_top = move |x: f64| {
        let t = clamp01(x / hl_end);
        hl_top
            + (horizon + s * 0.01 - hl_top) * smoothstep(0.55, 1.0, t)
            + s * 0.012 * n4.fbm1(x * 0.02, 4)
    };
    let grass = Col::hex_linear(0x5a7a2a);
    let rock = Col::hex_linear(0x7a6e62);
    let waterline = horizon + s * 0.018;
    let headland = SdfShape {
        bb: [0.0, hl_top - s * 0.05, hl_end + s * 0.05, waterline + 1.0],
        f: move |x: f64, y: f64| {
            let c = cliff_top(x);
            let d = cliff_top(x + 0.5) - cliff_top(x - 0.5);
            ((c - y) / sqrt(1.0 + d * d)).max(y - waterline)
        },
    };
    c.draw(&headland, 1.0, |x, y| {
        let top = cliff_top(x);
        let band = s * (0.02 + 0.01 * n5.perlin(x * 0.05, 0.3));
        let strata = n4.ridged(x * 0.03, y * 0.006, 5);
        let face = rock * (0.45 + 0.7 * strata) * (0.6 + 0.5 * (1.0 - x / hl_end));
        let g = grass * (0.7 + 0.5 * (0.5 + 0.5 * n5.fbm(x * 0.2, y * 0.2, 3, 2.0, 0.5)));
        if y - top < band {
            g
        } else {
            face
        }
    });
    // Foam where the cliff meets the sea.
    let foam_band = SdfShape {
        bb: [
            0.0,
            waterline - s * 0.01,
            hl_end + s * 0.1,
            waterline + s * 0.03,
        ],
        f: move |x: f64, y: f64| {
            let end = cliff_top(x) > waterline - s * 0.002;
            let t =
                (y - waterline - s * 0.006 * (1.0 + n3.perlin(x * 0.05, 1.0))).abs() - s * 0.006;
            if end {
                t.max(x - hl_end - s * 0.02)
            } else {
                t
            }
        },
    };
    c.draw(&foam_band, 0.9, |x, y| {
        let f = smoothstep(0.0, 0.7, 0.5 + 0.5 * n2.fbm(x * 0.08, y * 0.3, 4, 2.0, 0.5));
        sea_far.mix(Col(0.85, 0.88, 0.9), 0.3 + 0.7 * f)
    });
    // Lighthouse with red and white bands, gallery railing, lantern.
    let lx = hl_end * rng.range(0.3, 0.55);
    let base_y = cliff_top(lx) + s * 0.01;
    let th = s * rng.range(0.16, 0.22);
    let rb = th * 0.11;
    let rt = th * 0.075;
    let red = Col::hex_linear(0xb8202a);
    let white = Col::hex_linear(0xf0eee8);
    let bands = 4.0;
    let tower = Polygon::new(vec![
        (lx - rb, base_y),
        (lx + rb, base_y),
        (lx + rt, base_y - th),
        (lx - rt, base_y - th),
    ]);
    c.draw(&tower, 1.0, |x, y| {
        let t = (base_y - y) / th;
        let r = rb + (rt - rb) * t;
        let nx = ((x - lx) / r).clamp(-1.0, 1.0);
        let lit = 0.25 + 0.85 * (0.5 + 0.5 * nx).max(0.0);
        let band = (t * bands * 2.0).floor() as i64 % 2 == 0;
        (if band { white } else { red }) * lit
    });
    let gy = base_y - th;
    c.fill(
        &Polygon::rect(
            lx - rt * 1.5,
            gy - th * 0.02,
            lx + rt * 1.5,
            gy + th * 0.015,
        ),
        Col(0.05, 0.05, 0.05),
    );
    let lh = th * 0.14;
    c.draw(
        &Polygon::rect(
            lx - rt * 0.8,
            gy - th * 0.02 - lh,
            lx + rt * 0.8,
            gy - th * 0.02,
        ),
        1.0,
        |x, _| Col(0.9, 0.85, 0.55) * (0.6 + 0.4 * (x - lx + rt) / (2.0 * rt)),
    );
    let post_w = (s * 0.0025).max(0.6);
    let nposts = 7;
    for k in 0..=nposts {
        let px = lx - rt * 1.4 + rt * 2.8 * k as f64 / nposts as f64;
        c.fill(
            &Stroke::line(
                (px, gy - th * 0.02),
                (px, gy - th * 0.02 - th * 0.05),
                post_w,
            ),
            Col(0.04, 0.04, 0.04),
        );
    }
    c.fill(
        &Stroke::line(
            (lx - rt * 1.45, gy - th * 0.07),
            (lx + rt * 1.45, gy - th * 0.07),
            post_w,
        ),
        Col(0.04, 0.04, 0.04),
    );
    for k in 0..3 {
        let px = lx - rt * 0.8 + rt * 1.6 * (k as f64 + 0.5) / 3.0;
        c.fill(
            &Stroke::line((px, gy - th * 0.02), (px, gy - th * 0.02 - lh), post_w),
            Col(0.05, 0.05, 0.05),
        );
    }
    let cap = Polygon::new(closed_spline(
        &[
            (lx - rt * 0.95, gy - th * 0.02 - lh),
            (lx, gy - th * 0.02 - lh - rt * 0.9),
            (lx + rt * 0.95, gy - th * 0.02 - lh),
        ],
        8,
    ));
    c.fill(&cap, Col::hex_linear(0x301010));
    // Keeper's cottage.
    let kx = lx + rb * 1.6;
    let kw = th * 0.4;
    let kh = th * 0.2;
    let ky = cliff_top(kx + kw * 0.5) + s * 0.012;
    c.fill(&Polygon::rect(kx, ky - kh, kx + kw, ky), white * 0.8);
    c.fill(
        &Polygon::new(vec![
            (kx - kw * 0.05, ky - kh),
            (kx + kw * 1.05, ky - kh),
            (kx + kw * 0.85, ky - kh * 1.6),
            (kx + kw * 0.15, ky - kh * 1.6),
        ]),
        Col::hex_linear(0x3a3a40),
    );
    for k in 0..2 {
        let wx = kx + kw * (0.2 + 0.45 * k as f64);
        c.fill(
            &rounded_rect(wx, ky - kh * 0.75, wx + kw * 0.18, ky - kh * 0.35, 0.5),
            Col(0.05, 0.07, 0.1),
        );
    }
    // Beach in the lower right with wet sand and a foam line.
    let shore = {
        let a = hf * rng.range(0.7, 0.8);
        move |x: f64| a + (hf - a) * 0.8 * (1.0 - x / wf) + s * 0.015 * n4.fbm1(x * 0.01, 4)
    };
    let sand = Col::hex_linear(0xd8c098);
    c.draw(&below(shore, [0.0, hf * 0.6, wf, hf]), 1.0, |x, y| {
        let d = (y - shore(x)) / s;
        let fine = unit_f64(hash2(77, x as i64, y as i64));
        let ripples = 0.5
            + 0.5 * sin((x * 0.3 + y * 0.9) / (s * 0.004) + 3.0 * n5.perlin(x * 0.02, y * 0.02));
        let wet = 1.0 - smoothstep(0.0, 0.05, d);
        let col = sand * (0.82 + 0.1 * fine + 0.08 * ripples) * (1.0 - 0.45 * wet);
        let foam = smoothstep(
            0.45,
            0.8,
            0.5 + 0.5 * n2.fbm(x * 0.05, y * 0.2, 4, 2.0, 0.5),
        ) * (1.0 - smoothstep(0.0, 0.012, d));
        col.mix(Col(0.9, 0.92, 0.95), foam)
    });
    // Rocks in the surf.
    let nrocks = rng.int(2, 4);
    for _ in 0..nrocks {
        let rx = wf * rng.range(0.4, 0.95);
        let ry = shore(rx) - s * rng.range(0.0, 0.08);
        let rr = s * rng.range(0.025, 0.05);
        let blob = Blob::new(
            vec![(rx, ry, rr), (rx + rr * 0.6, ry + rr * 0.2, rr * 0.7)],
            n1,
            rr * 0.25,
            1.5 / rr,
        );
        let (bcx, bcy, brad) = blob.centre();
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, bcx, bcy, brad, normalize3((0.5, -0.6, 0.6)));
            let tex = 0.6 + 0.6 * n3.ridged(x * 0.08, y * 0.08, 4);
            Col(0.09, 0.08, 0.075) * tex * (0.35 + 1.1 * lit)
        });
        let foam = Blob::new(
            (0..6)
                .map(|k| {
                    (
                        rx - rr * 0.9 + rr * 0.45 * k as f64,
                        ry + rr * 0.85,
                        rr * 0.18,
                    )
                })
                .collect(),
            n2,
            rr * 0.12,
            4.0 / rr,
        );
        c.draw(&foam, 0.6, |x, y| {
            Col(0.8, 0.84, 0.88) * (0.8 + 0.2 * n4.perlin(x * 0.3, y * 0.3))
        });
    }
    birds(
        c,
        rng,
        (wf * 0.3, wf),
        (horizon * 0.15, horizon * 0.7),
        s * 0.008,
        Col(0.03, 0.03, 0.035),
    );
    let _ = n0;
}
