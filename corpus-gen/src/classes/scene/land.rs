//! The outdoor scenes inland: countryside and a mountain lake at sunset.

use super::*;

pub(super) fn countryside(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let horizon = hf * rng.range(0.48, 0.6);
    let sun = (wf * rng.range(0.15, 0.85), horizon * rng.range(0.2, 0.55));
    let sun_r = s * 0.028;
    let zen = Col::hex_linear(0x2a62b0).mix(Col::hex_linear(0x4a80c8), rng.f64());
    let hor = Col::hex_linear(0xc4d8ea);
    let sun_col = Col(1.0, 0.92, 0.78);
    let cover = rng.range(0.0, 0.25);
    let f0 = rng.range(2.0, 3.5) / s;
    let light = normalize3(((sun.0 - wf * 0.5) / wf, (sun.1 - hf * 0.5) / hf - 0.3, 0.7));
    let sky_at = move |x: f64, y: f64| {
        let t = clamp01(y / horizon);
        let mut col = zen.mix(hor, pow(t, 1.6));
        let d = sqrt(sq(x - sun.0) + sq(y - sun.1)) / s;
        col = col + sun_col * (0.9 * exp(-d * 18.0) + 0.2 * exp(-d * 4.0));
        col
    };
    // Sky, sun, clouds.
    c.shade(|x, y| {
        let mut col = sky_at(x, y);
        let ds = sqrt(sq(x - sun.0) + sq(y - sun.1));
        col = col.mix(Col(4.0, 3.8, 3.4), clamp01(sun_r + 0.5 - ds));
        if y < horizon {
            let fade = 1.0 - smoothstep(0.55, 1.0, y / horizon);
            let d = cloud_density(&n0, &n1, x, y, f0, cover, 2.2) * fade;
            if d > 0.0 {
                let toward = cloud_density(
                    &n0,
                    &n1,
                    x + (sun.0 - x) * 0.02,
                    y + (sun.1 - y) * 0.02 - s * 0.004,
                    f0,
                    cover,
                    2.2,
                );
                let lit = clamp01(1.0 - 1.8 * (toward - d).max(0.0) - 0.3 * d);
                let cloud = Col(0.45, 0.5, 0.6).mix(Col(1.05, 1.02, 0.98), lit);
                col = col.mix(cloud, d);
            }
        }
        col
    });
    // Far mountains, hazy.
    let mtop = horizon - s * rng.range(0.08, 0.16);
    let mh = s * rng.range(0.06, 0.12);
    let mf = rng.range(3.0, 6.0) / s;
    let haze = hor.mix(zen, 0.15);
    c.draw(
        &below(
            |x| mtop + mh * (1.0 - n2.ridged(x * mf, 0.5, 6)),
            [0.0, mtop - 2.0, wf, hf],
        ),
        1.0,
        |x, y| {
            let shade = 0.5 + 0.5 * n2.fbm(x * mf * 4.0, y * mf * 4.0, 5, 2.0, 0.5);
            let rock = Col(0.12, 0.14, 0.18) * (0.7 + 0.6 * shade);
            rock.mix(haze, 0.62)
        },
    );
    // Rolling hills with a farmland patchwork.
    let h1 = horizon - s * 0.02;
    let hf1 = 2.0 / s;
    let hill1 = move |x: f64| h1 + s * 0.03 * n3.fbm1(x * hf1, 3);
    let field_seed = rng.next_u64();
    let cw = s * rng.range(0.08, 0.14);
    let skew = rng.range(-0.8, 0.8);
    let greens = [
        Col::hex_linear(0x5f8a2c),
        Col::hex_linear(0x7a9a38),
        Col::hex_linear(0xa8a050),
        Col::hex_linear(0x4d7a2a),
        Col::hex_linear(0x8aa040),
        Col::hex_linear(0xc0b060),
    ];
    c.draw(&below(hill1, [0.0, h1 - s * 0.06, wf, hf]), 1.0, |x, y| {
        let depth = clamp01((y - h1) / (hf - h1)); // 0 far .. 1 near
        let z = 0.08 + depth;
        let u = (x - wf * 0.5) / z / cw * 0.12 + skew * (y - h1) / cw;
        let v = 1.0 / z * 1.6;
        let (ci, cj) = (u.floor(), v.floor());
        let base = greens[(hash2(field_seed, ci as i64, cj as i64) % 6) as usize];
        // Hedgerows along field borders: width ~1.5 px in screen space.
        let du = (fract(u) - 0.5).abs();
        let dv = (fract(v) - 0.5).abs();
        let px_u = 0.12 / z / cw;
        let px_v = 1.6 / sq(z) / (hf - h1);
        let hedge = clamp01((du - 0.5) / px_u + 1.6).max(clamp01((dv - 0.5) / px_v + 1.6));
        let tex = 0.85 + 0.3 * (0.5 + 0.5 * n4.fbm(x * 0.08, y * 0.25, 4, 2.0, 0.5));
        let col = base.mix(Col::hex_linear(0x2a4418), hedge) * tex;
        col.mix(haze, 0.35 * (1.0 - depth))
    });
    // A row of distant trees on the hill crest.
    let ntrees_far = rng.int(4, 12);
    for _ in 0..ntrees_far {
        let tx = rng.range(0.0, wf);
        let ty = hill1(tx) + s * 0.003;
        let r = s * rng.range(0.008, 0.016);
        let blob = Blob::new(
            vec![
                (tx, ty - r, r),
                (tx - r * 0.7, ty - r * 0.6, r * 0.7),
                (tx + r * 0.7, ty - r * 0.6, r * 0.7),
            ],
            n5,
            r * 0.25,
            0.5 / r.max(1.0),
        );
        let base = Col::hex_linear(0x2c4a22).mix(haze, 0.3);
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, tx, ty - r, r * 1.4, light);
            base * (0.5 + 0.7 * lit)
        });
    }
    // Near meadow.
    let h2 = hf * rng.range(0.72, 0.82);
    let meadow = move |x: f64| h2 - s * 0.06 * (0.5 + 0.5 * n3.fbm1(x * 1.2 / s + 3.3, 4));
    let grass_a = Col::hex_linear(0x4e7d22);
    let grass_b = Col::hex_linear(0x8fae3c);
    c.draw(&below(meadow, [0.0, h2 - s * 0.07, wf, hf]), 1.0, |x, y| {
        let depth = clamp01((y - h2 + s * 0.06) / (hf - h2 + s * 0.06));
        let blades = 0.5 + 0.5 * n4.fbm(x * 0.35, y * 0.06, 4, 2.0, 0.6);
        let clumps = 0.5 + 0.5 * n5.fbm(x * 6.0 / s, y * 12.0 / s, 4, 2.0, 0.5);
        let col = grass_a.mix(grass_b, clumps * 0.8) * (0.55 + 0.6 * blades);
        col * (1.1 - 0.45 * depth)
    });
    // House on the meadow ridge: hard edges over soft background.
    let hx = wf * rng.range(0.15, 0.55);
    let hs = s * rng.range(0.09, 0.14);
    let gy = meadow(hx) + hs * 0.15;
    let wall = Col::hex_linear(0xe8e0d0);
    let roof = Col::hex_linear(0x8a3a28).mix(Col::hex_linear(0x4a4a50), rng.f64());
    let side_w = hs * 1.6;
    let depth_dy = hs * 0.18;
    let front = Polygon::new(vec![
        (hx, gy),
        (hx + hs, gy),
        (hx + hs, gy - hs * 0.7),
        (hx + hs * 0.5, gy - hs * 1.15),
        (hx, gy - hs * 0.7),
    ]);
    let side = Polygon::new(vec![
        (hx + hs, gy),
        (hx + hs + side_w, gy - depth_dy),
        (hx + hs + side_w, gy - hs * 0.7 - depth_dy),
        (hx + hs, gy - hs * 0.7),
    ]);
    let roof_side = Polygon::new(vec![
        (hx + hs * 0.5, gy - hs * 1.15),
        (hx + hs * 0.5 + side_w, gy - hs * 1.15 - depth_dy),
        (hx + hs + side_w + hs * 0.08, gy - hs * 0.66 - depth_dy),
        (hx + hs + hs * 0.08, gy - hs * 0.66),
    ]);
    let lit_front = 0.4 + 0.8 * (-light.0).max(0.0) + 0.3 * light.2;
    let lit_side = 0.4 + 0.8 * light.0.max(0.0) + 0.3 * light.2;
    c.fill(
        &soft_poly(
            Polygon::new(vec![
                (hx - hs * 0.1, gy + 1.0),
                (hx + hs + side_w + hs * 0.3, gy - depth_dy + 1.0),
                (hx + hs + side_w + hs * 0.6, gy + hs * 0.1),
                (hx, gy + hs * 0.12),
            ]),
            hs * 0.08,
        ),
        Col(0.05, 0.07, 0.03),
    );
    c.fill(&front, wall * lit_front);
    c.fill(&side, wall * lit_side * 0.85);
    c.draw(&roof_side, 1.0, |x, y| {
        // Tile rows parallel to the ridge.
        let t = (y - (gy - hs * 1.15) + (x - hx - hs * 0.5) * depth_dy / side_w) / (hs * 0.09);
        let line = clamp01(1.0 - (fract(t) - 0.05).abs() * hs * 0.09 / 0.8);
        roof * (0.75 + 0.3 * light.2) * (1.0 - 0.35 * line)
    });
    // Windows with frames on the side wall, door on the gable end.
    let nw = 3;
    for k in 0..nw {
        let wx = hx + hs + side_w * (0.15 + 0.3 * k as f64);
        let wy = gy - hs * 0.5 - depth_dy * (0.15 + 0.3 * k as f64);
        let ww = hs * 0.18;
        let wh = hs * 0.22;
        c.fill(
            &Polygon::new(vec![
                (wx, wy),
                (wx + ww, wy - ww * depth_dy / side_w),
                (wx + ww, wy + wh - ww * depth_dy / side_w),
                (wx, wy + wh),
            ]),
            Col(0.9, 0.9, 0.88),
        );
        let fr = (hs * 0.02).max(0.8);
        c.fill(
            &Polygon::new(vec![
                (wx + fr, wy + fr),
                (wx + ww - fr, wy + fr - ww * depth_dy / side_w),
                (wx + ww - fr, wy + wh - fr - ww * depth_dy / side_w),
                (wx + fr, wy + wh - fr),
            ]),
            Col(0.03, 0.04, 0.06),
        );
        c.fill(
            &Stroke::line(
                (wx + ww * 0.5, wy),
                (wx + ww * 0.5, wy + wh - ww * 0.5 * depth_dy / side_w),
                fr,
            ),
            Col(0.9, 0.9, 0.88),
        );
    }
    c.fill(
        &Polygon::rect(hx + hs * 0.38, gy - hs * 0.4, hx + hs * 0.62, gy),
        Col::hex_linear(0x3a2418),
    );
    c.fill(
        &Disc::new(hx + hs * 0.5, gy - hs * 0.85, hs * 0.07),
        Col(0.03, 0.03, 0.04),
    );
    // Trees in front of the meadow ridge.
    let ntrees = rng.int(2, 5);
    for _ in 0..ntrees {
        let mut tx = rng.range(0.0, wf);
        if (tx - hx - hs).abs() < hs * 1.5 {
            tx = (tx + wf * 0.5) % wf;
        }
        let ty = meadow(tx) + s * rng.range(0.0, 0.02);
        let th = s * rng.range(0.12, 0.25);
        let tw = th * 0.05;
        let cr = th * rng.range(0.3, 0.42);
        // Ground shadow away from the sun.
        let sd = if light.0 > 0.0 { -1.0 } else { 1.0 };
        flat_shadow(
            c,
            (tx + sd * cr * 0.8, ty + cr * 0.08),
            (cr * 1.3, cr * 0.18),
            cr * 0.15,
            0.55,
            Col(0.02, 0.04, 0.01),
        );
        c.fill(
            &Polygon::new(vec![
                (tx - tw, ty),
                (tx + tw, ty),
                (tx + tw * 0.5, ty - th * 0.7),
                (tx - tw * 0.5, ty - th * 0.7),
            ]),
            Col::hex_linear(0x3a2a1c),
        );
        let ccy = ty - th + cr;
        let mut discs = vec![(tx, ccy, cr)];
        for _ in 0..rng.int(4, 8) {
            let a = rng.range(0.0, TAU);
            let rr = cr * rng.range(0.35, 0.8);
            discs.push((tx + cos(a) * cr * 0.75, ccy + sin(a) * cr * 0.6, rr));
        }
        let blob = Blob::new(discs, n5, cr * 0.18, 2.5 / cr);
        let base = Col::hex_linear(0x2f5a1c).mix(Col::hex_linear(0x47702a), rng.f64());
        let leaf_f = 1.0 / (s * 0.006).max(1.0);
        c.draw(&blob, 1.0, |x, y| {
            let (lit, _) = sphere_light(x, y, tx, ccy, cr * 1.2, light);
            let leaves = 0.5 + 0.5 * n4.fbm(x * leaf_f, y * leaf_f, 3, 2.0, 0.6);
            base * (0.2 + 1.1 * lit * (0.45 + 0.7 * leaves)) + Col(0.01, 0.015, 0.02)
        });
    }
    // Fence along the foreground.
    let fy = hf * rng.range(0.86, 0.93);
    let post_gap = s * rng.range(0.06, 0.1);
    let post_h = s * 0.06;
    let wood = Col::hex_linear(0x6a5a48);
    let mut px = rng.range(0.0, post_gap);
    let rail = |x: f64| fy - post_h * 0.8 + x * 0.02;
    while px < wf {
        let pw = (s * 0.006).max(1.2);
        c.fill(
            &Polygon::rect(px - pw, rail(px) - post_h * 0.3, px + pw, fy + px * 0.02),
            wood * 0.8,
        );
        px += post_gap;
    }
    for k in 0..2 {
        let off = post_h * 0.45 * k as f64;
        c.fill(
            &Stroke::line(
                (0.0, rail(0.0) + off),
                (wf, rail(wf) + off),
                (s * 0.005).max(1.0),
            ),
            wood,
        );
    }
    // Power line sagging across the sky, and birds.
    let py0 = horizon * rng.range(0.15, 0.5);
    let py1 = horizon * rng.range(0.15, 0.5);
    let sag = s * rng.range(0.03, 0.08);
    let pts: Vec<(f64, f64)> = (0..=64)
        .map(|k| {
            let t = k as f64 / 64.0;
            (t * wf, py0 + (py1 - py0) * t + sag * 4.0 * t * (1.0 - t))
        })
        .collect();
    c.fill(&Stroke::new(pts, 0.8), Col(0.03, 0.03, 0.035));
    birds(
        c,
        rng,
        (0.0, wf),
        (horizon * 0.1, horizon * 0.6),
        s * 0.01,
        Col(0.02, 0.02, 0.025),
    );
}

pub(super) fn lake(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, n4, n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let water = hf * rng.range(0.55, 0.65);
    let sun = (
        wf * rng.range(0.25, 0.75),
        water - s * rng.range(0.12, 0.25),
    );
    let sun_r = s * 0.035;
    let top = Col::hex_linear(0x121a3a);
    let mid = Col::hex_linear(0x8a4a5a).mix(Col::hex_linear(0x6a4a7a), rng.f64());
    let low = Col::hex_linear(0xffb060).mix(Col::hex_linear(0xff9050), rng.f64());
    let f0 = rng.range(1.5, 2.5) / s;
    let cover = rng.range(0.0, 0.2);
    c.shade(|x, y| {
        let t = clamp01(y / water);
        let mut col = if t < 0.55 {
            top.mix(mid, smoothstep(0.0, 0.55, t))
        } else {
            mid.mix(low, smoothstep(0.55, 1.0, t))
        };
        let d = sqrt(sq(x - sun.0) + sq((y - sun.1) * 1.3)) / s;
        col = col + Col(1.0, 0.6, 0.25) * (1.2 * exp(-d * 10.0) + 0.3 * exp(-d * 3.0));
        let ds = sqrt(sq(x - sun.0) + sq(y - sun.1));
        col = col.mix(Col(5.0, 3.8, 2.2), clamp01(sun_r + 0.5 - ds));
        // Long streaky clouds lit from below.
        let dn = cloud_density(&n0, &n1, x, y, f0, cover, 5.0) * (1.0 - smoothstep(0.6, 1.0, t));
        if dn > 0.0 {
            let below = cloud_density(&n0, &n1, x, y + s * 0.01, f0, cover, 5.0);
            let lit = clamp01(0.3 + 1.5 * (dn - below) + 0.8 * t) * (0.6 + 0.8 * exp(-d * 2.5));
            let cl = Col(0.12, 0.07, 0.14).mix(Col(1.1, 0.55, 0.35), clamp01(lit));
            col = col.mix(cl, dn * 0.9);
        }
        col
    });
    // Two mountain ranges, with rim light and snow on the sunny side.
    for (k, (hgt, dark, haze)) in [(0.3, 0.1, 0.55), (0.18, 0.04, 0.25)]
        .into_iter()
        .enumerate()
    {
        let nn = if k == 0 { n2 } else { n3 };
        let base_y = water - s * 0.01;
        let mf = rng.range(2.5, 4.5) / s;
        let amp = s * hgt * rng.range(0.7, 1.1);
        let ridge = move |x: f64| base_y - amp * nn.ridged(x * mf + k as f64 * 10.0, 0.3, 5);
        let col_m = Col(0.09, 0.07, 0.12) * (dark * 10.0);
        let to_sun = if k == 0 { 1.0 } else { 0.7 };
        c.draw(
            &below(ridge, [0.0, base_y - amp - 2.0, wf, hf]),
            1.0,
            |x, y| {
                let r = ridge(x);
                let below_crest = (y - r) / amp;
                // Facets: lighting from the gradient of a 2-D height field.
                let hf2 = |x: f64, y: f64| nn.fbm(x * mf * 3.0, y * mf * 3.0, 6, 2.0, 0.5);
                let e = 2.0;
                let gx = (hf2(x + e, y) - hf2(x - e, y)) / (2.0 * e) * s * 0.05;
                let dir = if x < sun.0 { 1.0 } else { -1.0 };
                let lit = clamp01(0.45 + 2.0 * gx * dir * to_sun - 0.6 * below_crest);
                let tex = 0.5 + 0.5 * hf2(x * 3.0, y * 3.0);
                let snow =
                    smoothstep(0.6, 0.75, tex + 0.5 - below_crest * 3.0) * (k == 0) as u8 as f64;
                let rock = col_m * (0.7 + 0.5 * tex) * (0.5 + 0.9 * lit);
                let snowc = Col(0.85, 0.5, 0.42) * (0.3 + 0.8 * lit);
                let rim = Col(0.8, 0.4, 0.2) * exp(-below_crest * 40.0) * lit * 0.6;
                let col = rock.mix(snowc, snow) + rim;
                col.mix(low * 0.5, haze * (1.0 - below_crest).max(0.0) * 0.5)
            },
        );
    }
    // Pine forest along the shore.
    let pine_seed = rng.next_u64();
    let pine_w = s * 0.025;
    let pines = move |x: f64| {
        let i = (x / pine_w).floor() as i64;
        let mut best = water + 1.0;
        for k in i - 1..=i + 1 {
            let hsh = hash2(pine_seed, k, 0);
            let cx = (k as f64 + 0.3 + 0.4 * unit_f64(hsh)) * pine_w;
            let th = s * (0.03 + 0.06 * unit_f64(hsh >> 16));
            let slope = 3.2;
            let jag = 0.15 * th * (0.5 + 0.5 * sin((x - cx) * 2.4 / pine_w * TAU));
            let y = water - th + (x - cx).abs() * slope + jag;
            best = best.min(y);
        }
        best.min(water - s * 0.006 + s * 0.004 * n4.perlin(x * 0.02, 0.5))
    };
    c.draw(
        &below(pines, [0.0, water - s * 0.1, wf, water + 1.0]),
        1.0,
        |x, y| Col(0.012, 0.016, 0.018) * (0.8 + 0.4 * n5.perlin(x * 0.3, y * 0.3)),
    );
    // Water: rippled reflection of everything above the waterline, sun glitter.
    let snap = c.clone();
    let (w, h) = (c.w, c.h);
    let wi = water.floor() as usize;
    c.shade_rows_from(wi.min(h), |x, y| {
        let depth = (y - water) / (hf - water + 1.0);
        let rip = n4.fbm(x * 0.01, y * 0.3 / (0.05 + depth), 4, 2.0, 0.5);
        let dx = rip * s * 0.02 * (0.2 + depth);
        let ry = (2.0 * water - y + rip * s * 0.01 * depth).max(0.5);
        let sx = (x + dx).clamp(0.5, wf - 0.5);
        let ix = (sx as usize).min(w - 1);
        let iy = (ry as usize).min(h - 1);
        let refl = snap.get(ix, iy);
        let fresnel = 0.55 + 0.35 * (1.0 - depth);
        let mut col = refl * fresnel + Col(0.005, 0.01, 0.015);
        let band = exp(-sq((x - sun.0) / (s * (0.02 + 0.12 * depth))));
        let spark = smoothstep(
            0.25,
            0.6,
            n5.fbm(x * 0.08, y * 0.8 / (0.05 + depth), 3, 2.0, 0.5),
        );
        col = col + Col(3.0, 1.8, 0.8) * band * spark * 0.8;
        col
    });
    // A small boat.
    let bx = wf * rng.range(0.1, 0.8);
    let by = water + (hf - water) * rng.range(0.3, 0.6);
    let bl = s * rng.range(0.05, 0.08);
    c.fill(
        &Polygon::new(vec![
            (bx - bl, by - bl * 0.12),
            (bx + bl, by - bl * 0.12),
            (bx + bl * 0.75, by + bl * 0.05),
            (bx - bl * 0.8, by + bl * 0.05),
        ]),
        Col(0.01, 0.008, 0.008),
    );
    c.fill(
        &Stroke::line(
            (bx, by - bl * 0.12),
            (bx, by - bl * 1.2),
            (s * 0.003).max(0.8),
        ),
        Col(0.01, 0.008, 0.008),
    );
    c.fill(
        &Polygon::new(vec![
            (bx + bl * 0.05, by - bl * 1.15),
            (bx + bl * 0.7, by - bl * 0.2),
            (bx + bl * 0.05, by - bl * 0.2),
        ]),
        Col(0.5, 0.32, 0.22),
    );
    flat_shadow(
        c,
        (bx, by + bl * 0.3),
        (bl * 0.9, bl * 0.15),
        bl * 0.1,
        0.6,
        Col(0.005, 0.005, 0.008),
    );
    birds(
        c,
        rng,
        (0.0, wf),
        (water * 0.2, water * 0.6),
        s * 0.009,
        Col(0.01, 0.008, 0.01),
    );
}
