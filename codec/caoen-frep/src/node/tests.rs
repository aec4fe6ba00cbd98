//! The model tree's nodes: the shell's value, gradient and bounds.

use super::*;
use caoen_geometry::vector::central_difference;

fn ball() -> Node {
    Node::Primitive(Primitive::Sphere {
        centre: [0.1, -0.2, 0.05],
        radius: 0.6,
    })
}

#[test]
fn a_frep_shell_is_the_wall_between_the_surface_and_the_inner_level() {
    let t = 0.1;
    let shell = Node::Shell {
        thickness: t,
        operand: Box::new(ball()),
    };
    let f = ball();
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for _ in 0..2000 {
        let p = [next(), next(), next()];
        let (v, g) = shell.value_gradient(p);
        let fv = f.value(p);
        assert_eq!(v, fv.min(t - fv));
        assert_eq!(v, shell.value(p));
        // Inside the wall exactly where the operand is between 0 and the thickness.
        assert_eq!(v >= 0.0, (0.0..=t).contains(&fv), "{p:?}");
        // Away from the crease at f = t / 2 the gradient is the derivative.
        if (fv - 0.5 * t).abs() > 1e-3 {
            let fd = central_difference(|q| shell.value(q), p, 1e-6);
            for k in 0..3 {
                assert!((fd[k] - g[k]).abs() < 1e-6, "{p:?} {k}: {} {}", fd[k], g[k]);
            }
        }
        // The bound over a box around the point holds every value sampled in it.
        let r = 0.2 * (next() + 1.0);
        let b = Aabb::new(p.map(|x| x - r), p.map(|x| x + r));
        let i = shell.interval(&b);
        for _ in 0..20 {
            let q = [0, 1, 2].map(|k| p[k] + r * next());
            let v = shell.value(q);
            assert!(i.lo <= v && v <= i.hi, "{q:?} {v} {i:?}");
        }
    }
    // The peak: half the thickness, reached inside a box holding f = t / 2.
    let i = shell_interval(Interval::new(-1.0, 1.0), t);
    assert_eq!((i.lo, i.hi), (-1.0, 0.5 * t));
    let i = shell_interval(Interval::new(0.02, 0.03), t);
    assert_eq!((i.lo, i.hi), (0.02, 0.03));
    let i = shell_interval(Interval::new(0.07, 0.09), t);
    assert!(
        (i.lo - 0.01).abs() < 1e-12 && (i.hi - 0.03).abs() < 1e-12,
        "{i:?}"
    );
}
