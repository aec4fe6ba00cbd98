//! The still life: wall, framed picture, table, fruit, vase and books.

use super::*;

pub(super) fn still_life(c: &mut Canvas, rng: &mut Rng, seed: u64) {
    let [n0, n1, n2, n3, _n4, _n5] = noises(seed);
    let (wf, hf, s) = frame(c);
    let table_y = hf * rng.range(0.55, 0.65);
    let front_y = hf * rng.range(0.86, 0.93);
    let lx = wf * rng.range(-0.2, 0.3);
    let ly = hf * rng.range(-0.3, 0.2);
    let light = normalize3((-0.6, -0.5, 0.65));
    let wall = Col::hex_linear(0xb8a890).mix(Col::hex_linear(0x8aa0a8), rng.f64());
    c.shade(|x, y| {
        let d2 = (sq(x - lx) + sq(y - ly)) / sq(s * 1.1);
        let lit = 0.18 + 0.9 * exp(-d2);
        let plaster = 1.0 + 0.04 * n0.fbm(x * 0.05, y * 0.05, 5, 2.0, 0.5);
        wall * lit * plaster
    });
    // Framed picture on the wall, with a soft shadow.
    let fw = s * rng.range(0.25, 0.35);
    let fh = fw * rng.range(0.7, 0.9);
    let fx = wf * rng.range(0.4, 0.6);
    let fy = table_y * 0.45;
    let border = fw * 0.07;
    c.draw(
        &soft_poly(
            Polygon::rect(
                fx - fw * 0.5 + border * 0.6,
                fy - fh * 0.5 + border * 0.9,
                fx + fw * 0.5 + border * 0.6,
                fy + fh * 0.5 + border * 0.9,
            ),
            border * 0.6,
        ),
        0.5,
        |_, _| Col(0.02, 0.015, 0.01),
    );
    c.draw(
        &Polygon::rect(fx - fw * 0.5, fy - fh * 0.5, fx + fw * 0.5, fy + fh * 0.5),
        1.0,
        |x, y| {
            Col::hex_linear(0x5a3a20)
                * (0.7
                    + 0.3 * n1.perlin(x * 0.2, y * 0.01)
                    + 0.2 * (1.0 - (y - fy + fh * 0.5) / fh))
        },
    );
    let (px0, py0, px1, py1) = (
        fx - fw * 0.5 + border,
        fy - fh * 0.5 + border,
        fx + fw * 0.5 - border,
        fy + fh * 0.5 - border,
    );
    c.fill(&Polygon::rect(px0, py0, px1, py1), Col(0.85, 0.83, 0.78));
    let m = border * 0.8;
    let (qx0, qy0, qx1, qy1) = (px0 + m, py0 + m, px1 - m, py1 - m);
    let ph = qy1 - qy0;
    let art_sun = (qx0 + (qx1 - qx0) * rng.range(0.2, 0.8), qy0 + ph * 0.3);
    c.draw(&Polygon::rect(qx0, qy0, qx1, qy1), 1.0, move |x, y| {
        let t = (y - qy0) / ph;
        let hill = qy0 + ph * (0.6 + 0.1 * sin((x - qx0) / (qx1 - qx0) * 5.0));
        if y > hill {
            Col(0.1, 0.25, 0.08) * (1.2 - 0.5 * (y - hill) / ph)
        } else if sq(x - art_sun.0) + sq(y - art_sun.1) < sq(ph * 0.1) {
            Col(0.9, 0.6, 0.2)
        } else {
            Col(0.6, 0.3, 0.2).mix(Col(0.2, 0.35, 0.6), 1.0 - t)
        }
    });
    // Table top (wood in perspective) and front edge.
    let grain_seed = n2;
    c.draw(
        &Polygon::rect(-1.0, table_y, wf + 1.0, hf + 1.0),
        1.0,
        |x, y| {
            let z = (y - table_y) / (front_y - table_y);
            let persp = 0.35 + 0.65 * z;
            let u = (x - wf * 0.5) / persp;
            let v = z * s * 0.6;
            let rings = fract(v * 0.06 + 1.5 * grain_seed.fbm(u * 0.004, v * 0.03, 4, 2.0, 0.5));
            let wood = Col::hex_linear(0x7a4a24)
                .mix(Col::hex_linear(0x4a2812), smoothstep(0.3, 0.9, rings));
            let spec = 0.25 * exp(-sq((x - wf * 0.35) / (s * 0.3)) - sq(z - 0.3) * 6.0);
            if y < front_y {
                wood * (0.45 + 0.55 * z) + Col::gray(spec * 0.5)
            } else {
                wood * 0.22
            }
        },
    );
    c.fill(
        &Stroke::line((0.0, front_y), (wf, front_y), (s * 0.004).max(1.0)),
        Col::hex_linear(0xa0764a),
    );
    // Objects, back to front: books, vase, fruit.
    let shadow = Col(0.015, 0.01, 0.005);
    let bx = wf * rng.range(0.05, 0.2);
    let by = table_y + (front_y - table_y) * 0.35;
    let mut yb = by;
    let nbooks = rng.int(2, 4);
    for k in 0..nbooks {
        let bw = s * rng.range(0.28, 0.36);
        let bh = s * rng.range(0.03, 0.05);
        let x0 = bx + rng.range(-0.02, 0.02) * s;
        let cover = Col::hex_linear(*rng.pick(&[0x7a1e1e, 0x1e3a6a, 0x2a5a3a, 0x6a5a2a, 0x3a2a4a]));
        if k == 0 {
            c.draw(
                &soft_poly(
                    Polygon::rect(
                        x0 + s * 0.02,
                        by - s * 0.01,
                        x0 + bw + s * 0.06,
                        by + s * 0.02,
                    ),
                    s * 0.015,
                ),
                0.7,
                move |_, _| shadow,
            );
        }
        // Top face (pages visible on the top book only as a thin band), spine face.
        c.fill(
            &Polygon::new(vec![
                (x0, yb - bh),
                (x0 + bw, yb - bh),
                (x0 + bw + s * 0.02, yb - bh - s * 0.012),
                (x0 + s * 0.02, yb - bh - s * 0.012),
            ]),
            cover * 0.9,
        );
        c.fill(&Polygon::rect(x0, yb - bh, x0 + bw, yb), cover * 0.55);
        c.draw(
            &Polygon::rect(x0 + bw, yb - bh, x0 + bw + s * 0.02, yb - s * 0.012 * 0.0),
            1.0,
            |_, y| Col(0.75, 0.7, 0.6) * (0.6 + 0.4 * fract(y * 1.3)),
        );
        let style = TextStyle::upright(
            (bh * 0.22).max(1.5),
            (bh * 0.05).max(0.6),
            Col(0.85, 0.75, 0.45),
        );
        draw_line(c, rng, &style, x0 + bw * 0.1, x0 + bw * 0.7, yb - bh * 0.35);
        yb -= bh;
    }
    // Vase: cylinder with a glaze highlight.
    let vx = wf * rng.range(0.45, 0.6);
    let vr = s * rng.range(0.05, 0.08);
    let vh = s * rng.range(0.22, 0.32);
    let vb = table_y + (front_y - table_y) * 0.25;
    let glaze = Col::hex_linear(*rng.pick(&[0x2a4a8a, 0xd8d4cc, 0x3a6a5a, 0x9a3a2a]));
    flat_shadow(
        c,
        (vx + vr * 1.3, vb),
        (vr * 2.2, vr * 0.35),
        vr * 0.3,
        0.8,
        shadow,
    );
    let body = Polygon::new(
        (0..=24)
            .map(|k| {
                let t = k as f64 / 24.0;
                let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
                (vx - r, vb - vh * t)
            })
            .chain((0..=24).rev().map(|k| {
                let t = k as f64 / 24.0;
                let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
                (vx + r, vb - vh * t)
            }))
            .collect(),
    );
    c.draw(&body, 1.0, |x, y| {
        let t = (vb - y) / vh;
        let r = vr * (0.75 + 0.35 * sin(t * PI * 1.2));
        let nx = ((x - vx) / r).clamp(-1.0, 1.0);
        let nz = sqrt(1.0 - nx * nx);
        let diff = (nx * light.0 + nz * light.2).max(0.0) + 0.1;
        let hl = exp(-sq((nx + 0.45) * 9.0)) * 0.8;
        glaze * (0.15 + 0.85 * diff) + Col::gray(hl)
    });
    c.fill(
        &Ellipse {
            cx: vx,
            cy: vb - vh,
            rx: vr * 0.75 * 1.0 + vr * 0.35 * sin(1.2 * PI),
            ry: vr * 0.18,
            rot: (1.0, 0.0),
        },
        glaze * 0.6,
    );
    c.fill(
        &Ellipse {
            cx: vx,
            cy: vb - vh,
            rx: vr * 0.55,
            ry: vr * 0.12,
            rot: (1.0, 0.0),
        },
        Col(0.01, 0.01, 0.01),
    );
    // Fruit: shaded spheres with specular highlights and contact shadows.
    let nf = rng.int(2, 4);
    for k in 0..nf {
        let fr = s * rng.range(0.045, 0.07);
        let fx = wf * (0.6 + 0.12 * k as f64) + rng.range(-0.03, 0.03) * s;
        let fy = table_y + (front_y - table_y) * rng.range(0.45, 0.8) - fr;
        let base = Col::hex_linear(*rng.pick(&[0xe07010, 0xb01818, 0x6a9a20, 0xd0b020]));
        flat_shadow(
            c,
            (fx + fr * 0.5, fy + fr * 0.9),
            (fr * 1.4, fr * 0.3),
            fr * 0.3,
            0.85,
            shadow,
        );
        let spot = n3;
        c.draw(&Disc::new(fx, fy, fr), 1.0, |x, y| {
            let (lit, n) = sphere_light(x, y, fx, fy, fr, light);
            let hv = normalize3((light.0, light.1, light.2 + 1.0));
            let spec = pow((n.0 * hv.0 + n.1 * hv.1 + n.2 * hv.2).max(0.0), 60.0);
            let bounce = clamp01(n.1) * 0.15;
            let pores = 1.0 + 0.06 * spot.perlin(x * 0.6, y * 0.6);
            base * (0.06 + 0.94 * lit) * pores
                + Col(0.25, 0.15, 0.08) * bounce
                + Col::gray(spec * 0.9)
        });
        c.fill(
            &Stroke::new(
                vec![
                    (fx, fy - fr * 0.85),
                    (fx + fr * 0.1, fy - fr * 1.15),
                    (fx + fr * 0.25, fy - fr * 1.25),
                ],
                (fr * 0.08).max(0.8),
            ),
            Col(0.06, 0.04, 0.02),
        );
    }
}
