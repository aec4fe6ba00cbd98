//! The values of a model file that serde's own types read too loosely or name in its
//! own terms: numbers and lists of them ("expected a number", not `f64`), whole
//! numbers, names, objects that must be objects, fields that must not be `null`.

use std::fmt;

use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

/// A number (serde's own name for it is `f64`).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Num(pub f64);

impl From<Num> for f64 {
    fn from(n: Num) -> f64 {
        n.0
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Num;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Num, E> {
                Ok(Num(x))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Num, E> {
                Ok(Num(x as f64))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Num, E> {
                Ok(Num(x as f64))
            }
        }
        d.deserialize_f64(V)
    }
}

/// `N` numbers as a list.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Numbers<const N: usize>(pub [f64; N]);

impl<const N: usize> Default for Numbers<N> {
    fn default() -> Self {
        Numbers([0.0; N])
    }
}

impl<const N: usize> From<Numbers<N>> for [f64; N] {
    fn from(n: Numbers<N>) -> [f64; N] {
        n.0
    }
}

impl<'de, const N: usize> Deserialize<'de> for Numbers<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<'de, const N: usize> Visitor<'de> for V<N> {
            type Value = Numbers<N>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str(match N {
                    2 => "two numbers",
                    3 => "three numbers [x, y, z]",
                    4 => "four numbers [u0, v0, u1, v1]",
                    10 => "ten coefficients [a, b, c, d, e, f, g, h, i, j]",
                    _ => "a list of numbers",
                })
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Numbers<N>, A::Error> {
                let mut out = [0.0; N];
                let mut len = 0;
                while let Some(Num(x)) = seq.next_element()? {
                    if len < N {
                        out[len] = x;
                    }
                    len += 1;
                }
                if len != N {
                    return Err(de::Error::invalid_length(len, &self));
                }
                Ok(Numbers(out))
            }
        }
        d.deserialize_seq(V::<N>)
    }
}

/// A whole number, kept wide enough that any the file holds reaches the range check.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Int(pub i128);

impl<'de> Deserialize<'de> for Int {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl Visitor<'_> for V {
            type Value = Int;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a whole number")
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Int, E> {
                Ok(Int(x.into()))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Int, E> {
                Ok(Int(x.into()))
            }
            // JSON writers print whole numbers as `7.0` too; the range check that
            // follows bounds them, so only the fraction is refused here.
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Int, E> {
                if x.is_finite() && x.fract() == 0.0 && x.abs() < 1e30 {
                    Ok(Int(x as i128))
                } else {
                    Err(E::invalid_type(de::Unexpected::Float(x), &self))
                }
            }
        }
        d.deserialize_i64(V)
    }
}

/// A `scale` beside an operation: one number or a list of them.
pub(crate) enum Scale {
    One(f64),
    List(Vec<f64>),
}

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or a list of numbers")
            }
            fn visit_f64<E: de::Error>(self, x: f64) -> Result<Scale, E> {
                Ok(Scale::One(x))
            }
            fn visit_u64<E: de::Error>(self, x: u64) -> Result<Scale, E> {
                Ok(Scale::One(x as f64))
            }
            fn visit_i64<E: de::Error>(self, x: i64) -> Result<Scale, E> {
                Ok(Scale::One(x as f64))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Scale, A::Error> {
                let mut list = Vec::new();
                while let Some(Num(x)) = seq.next_element()? {
                    list.push(x);
                }
                Ok(Scale::List(list))
            }
        }
        d.deserialize_any(V)
    }
}

/// How a picture lies on space: by name; a value that is not a string is the
/// default, planar.
#[derive(Debug, Clone, Copy, Default, Deserialize)]
#[serde(rename_all = "lowercase", remote = "Self")]
pub(crate) enum Projection {
    /// Along z.
    #[default]
    Planar,
    /// Around the z axis.
    Cylindrical,
    /// Around the origin.
    Spherical,
}

impl<'de> Deserialize<'de> for Projection {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        match serde_json::Value::deserialize(d)? {
            serde_json::Value::String(name) => {
                Projection::deserialize(de::IntoDeserializer::<D::Error>::into_deserializer(name))
            }
            _ => Ok(Projection::Planar),
        }
    }
}

/// A body that must be a JSON object: serde's derived structs also take a list of
/// their fields in order.
pub(crate) struct Object<T>(pub T);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for Object<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<T>(std::marker::PhantomData<T>);
        impl<'de, T: Deserialize<'de>> Visitor<'de> for V<T> {
            type Value = T;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an object")
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<T, A::Error> {
                T::deserialize(de::value::MapAccessDeserializer::new(map))
            }
        }
        d.deserialize_map(V(std::marker::PhantomData)).map(Object)
    }
}

/// An optional object field that, when present, must be an object.
pub(super) fn present_object<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    Object::deserialize(d).map(|o| Some(o.0))
}

/// A name-only enum (`"bicubic"`): serde alone would also take `{"bicubic": null}`.
pub(super) struct ByName<T>(pub T);

impl<'de, T: Deserialize<'de>> Deserialize<'de> for ByName<T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        by_name(d).map(ByName)
    }
}

pub(super) fn by_name<'de, D: Deserializer<'de>, T: Deserialize<'de>>(d: D) -> Result<T, D::Error> {
    let name = String::deserialize(d)?;
    T::deserialize(de::IntoDeserializer::<D::Error>::into_deserializer(name))
}

/// An optional field that, when present, must be a `T` (serde alone reads `null` as
/// absent).
pub(super) fn present<'de, D: Deserializer<'de>, T: Deserialize<'de>>(
    d: D,
) -> Result<Option<T>, D::Error> {
    T::deserialize(d).map(Some)
}
