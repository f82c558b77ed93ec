//! Validating value types for the scene file. Each rejects bad numbers while
//! the file is parsed, so the error carries the exact line and column.

use std::fmt;

use glam::{DVec3, Vec3};
use serde::de::{self, Deserializer, SeqAccess, Visitor};
use serde::Deserialize;

/// Reads a number or a `[x, y, z]` array (a number means all three equal),
/// each checked by `check`, which returns what is wrong. The values are kept
/// in `f64`; each must also fit in an `f32`.
fn number_or_triple<'de, D: Deserializer<'de>>(
    d: D,
    allow_single: bool,
    check: fn(f64) -> Option<&'static str>,
) -> Result<DVec3, D::Error> {
    struct V {
        allow_single: bool,
        check: fn(f64) -> Option<&'static str>,
    }
    impl V {
        fn checked<E: de::Error>(&self, x: f64) -> Result<f64, E> {
            let x = if x.is_finite() && !(x as f32).is_finite() { f64::INFINITY } else { x };
            match (self.check)(x) {
                None => Ok(x),
                Some(what) => Err(E::custom(format!("{what}, found {x}"))),
            }
        }
    }
    impl<'de> Visitor<'de> for V {
        type Value = DVec3;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            if self.allow_single {
                f.write_str("a number or an array of 3 numbers")
            } else {
                f.write_str("an array of 3 numbers [x, y, z]")
            }
        }
        fn visit_f64<E: de::Error>(self, x: f64) -> Result<DVec3, E> {
            if !self.allow_single {
                return Err(E::invalid_type(de::Unexpected::Float(x), &self));
            }
            Ok(DVec3::splat(self.checked(x)?))
        }
        fn visit_i64<E: de::Error>(self, x: i64) -> Result<DVec3, E> {
            if !self.allow_single {
                return Err(E::invalid_type(de::Unexpected::Signed(x), &self));
            }
            Ok(DVec3::splat(self.checked(x as f64)?))
        }
        fn visit_u64<E: de::Error>(self, x: u64) -> Result<DVec3, E> {
            self.visit_i64(x.min(i64::MAX as u64) as i64)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<DVec3, A::Error> {
            let mut out = [0.0f64; 3];
            for (i, slot) in out.iter_mut().enumerate() {
                let x: f64 = seq.next_element()?.ok_or_else(|| de::Error::invalid_length(i, &self))?;
                *slot = self.checked(x)?;
            }
            if seq.next_element::<de::IgnoredAny>()?.is_some() {
                return Err(de::Error::invalid_length(4, &self));
            }
            Ok(DVec3::from_array(out))
        }
    }
    d.deserialize_any(V { allow_single, check })
}

fn finite(x: f64) -> Option<&'static str> {
    (!x.is_finite()).then_some("expected a finite number")
}

fn non_negative(x: f64) -> Option<&'static str> {
    finite(x).or((x < 0.0).then_some("expected a number that is not negative"))
}

/// The largest light power (and ambient radiance) per channel: beyond it,
/// spreading and summing light overflows 32-bit floats.
pub const MAX_POWER: f64 = 1e30;

fn power(x: f64) -> Option<&'static str> {
    non_negative(x).or((x > MAX_POWER).then_some(
        "expected at most 1e30 per channel (beyond, the light's arithmetic overflows 32-bit floats)",
    ))
}

fn positive(x: f64) -> Option<&'static str> {
    finite(x).or((x <= 0.0).then_some("expected a number greater than 0"))
}

fn fraction(x: f64) -> Option<&'static str> {
    finite(x).or((!(0.0..=1.0).contains(&x)).then_some("expected a reflectance between 0 and 1"))
}

fn non_zero(x: f64) -> Option<&'static str> {
    finite(x).or((x == 0.0).then_some("expected a non-zero scale (zero flattens the object)"))
}

macro_rules! vector_type {
    ($(#[$doc:meta])* $name:ident, single: $single:expr, $check:ident) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq)]
        pub struct $name(pub Vec3);
        impl<'de> Deserialize<'de> for $name {
            fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
                number_or_triple(d, $single, $check).map(|v| $name(v.as_vec3()))
            }
        }
    };
}

vector_type!(
    /// A direction or an edge `[x, y, z]` of finite numbers.
    Point, single: false, finite
);

/// A place `[x, y, z]` of finite numbers, kept in `f64` until the scene is
/// re-centred at the camera (far from the origin, `f32` would lose detail).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position(pub DVec3);
impl<'de> Deserialize<'de> for Position {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        number_or_triple(d, false, finite).map(Position)
    }
}
vector_type!(
    /// A reflectance: one number or `[r, g, b]`, each in `[0, 1]`.
    Reflectance, single: true, fraction
);
vector_type!(
    /// A power in watts: one number or `[r, g, b]`, none negative, at most [`MAX_POWER`].
    Power, single: true, power
);
vector_type!(
    /// A scale: one number (uniform) or `[x, y, z]`, none zero.
    Scale, single: true, non_zero
);
vector_type!(
    /// A size: one number or `[x, y, z]`, each greater than 0.
    Size, single: true, positive
);

/// A single number checked by one of the rules above.
fn scalar<'de, D: Deserializer<'de>>(d: D, check: fn(f64) -> Option<&'static str>) -> Result<f32, D::Error> {
    let x = f64::deserialize(d)?;
    match check(x) {
        None if (x as f32).is_finite() => Ok(x as f32),
        None => Err(de::Error::custom(format!("{x} is too large"))),
        Some(what) => Err(de::Error::custom(format!("{what}, found {x}"))),
    }
}

/// A finite number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Finite(pub f32);
impl<'de> Deserialize<'de> for Finite {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        scalar(d, finite).map(Finite)
    }
}

/// A finite number greater than zero.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Positive(pub f32);
impl<'de> Deserialize<'de> for Positive {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        scalar(d, positive).map(Positive)
    }
}

/// A whole number in `min..=max`, with the range named in the error.
pub fn whole_number<'de, D: Deserializer<'de>>(d: D, min: u32, max: u32) -> Result<u32, D::Error> {
    let n = i64::deserialize(d)?;
    if n < min as i64 || n > max as i64 {
        return Err(de::Error::custom(format!("expected a whole number from {min} to {max}, found {n}")));
    }
    Ok(n as u32)
}
