//! The model file's reader: what serde alone would let through is refused, messages
//! name the field and what it must be, and the limits hold before anything is built.

use serde_json::{json, Value};

use crate::node::{Node, MAX_DEPTH, MAX_NODES};

fn error(v: Value) -> String {
    Node::from_json(
        &v,
        "model",
        std::path::Path::new("."),
        &caoen_base::budget::Limits::default(),
    )
    .unwrap_err()
    .to_string()
}

#[test]
fn bodies_are_objects_and_present_fields_are_not_null() {
    for (v, want) in [
        (
            json!({"half_space": [[0, 0, 1], [1, 0, 1]]}),
            "model.half_space: invalid type: sequence, expected an object",
        ),
        (
            json!({"sphere": {"centre": null, "radius": 1}}),
            "model.sphere.centre: invalid type: null, expected three numbers [x, y, z]",
        ),
        (
            json!({"perturb": {"sphere": {"radius": 1}}, "patches": [{"bump": null}]}),
            "model.patches[0].bump: invalid type: null, expected an object",
        ),
        (
            json!({"pattern": {"image": "p.png", "interp": {"bicubic": null}}}),
            "model.pattern.interp: invalid type: map, expected a string",
        ),
        (
            json!({"height_map": {"image": "p.png", "base": {"plane": null}, "rect": [0, 0, 1, 1]}}),
            "model.height_map.base: invalid value: map, expected \"plane\"",
        ),
    ] {
        let e = error(v);
        assert!(e.starts_with(want), "`{e}` should start with `{want}`");
    }
}

#[test]
fn messages_name_the_field_and_what_it_must_be() {
    for (v, want) in [
        (
            json!({"sphere": {"centre": [0, 0], "radius": 1}}),
            "model.sphere.centre: invalid length 2, expected three numbers [x, y, z]",
        ),
        (
            json!({"sphere": {"radius": "big"}}),
            "model.sphere.radius: invalid type: string \"big\", expected a number",
        ),
        (
            json!({"noise": {"sphere": {"radius": 1}}, "amplitude": 0.1, "scale": 0.2, "seed": 1.5}),
            "model.seed: invalid type: floating point `1.5`, expected a whole number",
        ),
        (
            json!({"noise": {"sphere": {"radius": 1}}, "amplitude": 0.1, "scale": [0.2]}),
            "model.scale: [0.2], expected a number",
        ),
        (
            json!({"union": [{"sphere": {"radius": 1}}, {"sphere": {"radius": 1}}], "by": 1}),
            "model: unknown field `by` beside `union` (expected: a)",
        ),
        (
            json!({"sphere": {"radius": 1}, "a": 1}),
            "model: a `sphere` node takes no fields beside `sphere`",
        ),
    ] {
        assert_eq!(error(v), want);
    }
}

#[test]
fn limits_hold_before_anything_is_built() {
    // Far deeper than the limit: refused at the first node past it, not read below.
    let mut v = json!({"sphere": {"radius": 1}});
    for _ in 0..4 * MAX_DEPTH {
        v = json!({"negate": v});
    }
    let e = error(v);
    assert!(
        e.ends_with(&format!("nested deeper than {MAX_DEPTH} levels")),
        "{e}"
    );
    assert_eq!(e.matches(".negate").count(), MAX_DEPTH + 1, "{e}");
    // A missing image in the last operand: the node count is refused first.
    let mut spheres = vec![json!({"sphere": {"radius": 1}}); MAX_NODES];
    spheres.push(json!({"pattern": {"image": "missing.png", "rect": [0, 0, 1, 1]}}));
    let e = error(json!({"union": spheres}));
    assert_eq!(
        e,
        format!(
            "model.union: has {} operands; expected 2 to {MAX_NODES}",
            MAX_NODES + 1
        )
    );
}

#[test]
fn whole_numbers_written_as_floats_are_whole_numbers() {
    let read = |seed: Value| {
        let v = json!({"noise": {"sphere": {"radius": 1}}, "amplitude": 0.1, "scale": 0.2, "seed": seed});
        Node::from_json(
            &v,
            "model",
            std::path::Path::new("."),
            &caoen_base::budget::Limits::default(),
        )
    };
    // `7.0` and `7` are the same model; a fraction or a value out of range is not one.
    assert_eq!(read(json!(7.0)).unwrap(), read(json!(7)).unwrap());
    assert!(read(json!(7.5)).is_err());
    let e = read(json!(1e20)).unwrap_err().to_string();
    assert!(
        e.ends_with("expected a whole number in [0, 1000000]"),
        "{e}"
    );
}
