//! Field validators for deserialization (scenes; and numbers a run summary
//! may have written as `null`). Used with
//! `#[serde(deserialize_with = ...)]`, they fail while the value is being
//! parsed, so RON reports the exact line and column of the bad value.

use serde::de::Error;
use serde::{Deserialize, Deserializer};

fn number<'de, D: Deserializer<'de>>(
    d: D,
    ok: impl Fn(f64) -> bool,
    what: &str,
) -> Result<f64, D::Error> {
    let v = f64::deserialize(d)?;
    if v.is_finite() && ok(v) {
        Ok(v)
    } else {
        Err(D::Error::custom(format!("must be {what} (got {v})")))
    }
}

/// A finite number > 0.
pub fn positive<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    number(d, |v| v > 0.0, "a finite number > 0")
}

/// A finite number ≥ 0.
pub fn non_negative<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    number(d, |v| v >= 0.0, "a finite number ≥ 0")
}

/// Any finite number.
pub fn finite<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    number(d, |_| true, "a finite number")
}

/// A name of letters, digits and `_` (it names a term, its timing and its
/// series columns).
pub fn name<'de, D: Deserializer<'de>>(d: D) -> Result<String, D::Error> {
    let name = String::deserialize(d)?;
    let ok = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
    match ok {
        true => Ok(name),
        false => Err(D::Error::custom(format!(
            "`{name}` is not a name: use letters, digits and `_`"
        ))),
    }
}

/// A 3-vector of finite numbers.
pub fn finite_vec3<'de, D: Deserializer<'de>>(d: D) -> Result<(f64, f64, f64), D::Error> {
    let v = <(f64, f64, f64)>::deserialize(d)?;
    if v.0.is_finite() && v.1.is_finite() && v.2.is_finite() {
        Ok(v)
    } else {
        Err(D::Error::custom(format!(
            "must have finite coordinates (got {v:?})"
        )))
    }
}

/// An optional direction: a 3-vector of finite numbers, not zero.
pub fn optional_direction<'de, D: Deserializer<'de>>(
    d: D,
) -> Result<Option<(f64, f64, f64)>, D::Error> {
    let v = Option::<(f64, f64, f64)>::deserialize(d)?;
    match v {
        Some((x, y, z))
            if !(x.is_finite() && y.is_finite() && z.is_finite())
                || x * x + y * y + z * z == 0.0 =>
        {
            Err(D::Error::custom(format!(
                "must be a direction: finite coordinates, not all zero (got {:?})",
                (x, y, z)
            )))
        }
        _ => Ok(v),
    }
}

/// An optional finite number > 0.
pub fn optional_positive<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
    let v = Option::<f64>::deserialize(d)?;
    match v {
        Some(x) if !(x.is_finite() && x > 0.0) => Err(D::Error::custom(format!(
            "must be a finite number > 0 (got {x})"
        ))),
        _ => Ok(v),
    }
}

/// Why a parsed value is invalid: a field out of its range, or a
/// combination of fields that does not fit (the reason names the field).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ValidationError {
    /// A field's value is out of its range.
    #[error("`{field}` {reason}")]
    Field {
        /// The field.
        field: &'static str,
        /// What is wrong with its value.
        reason: String,
    },
    /// The value is inconsistent (the reason names the field).
    #[error("{0}")]
    Invalid(String),
}

impl From<&str> for ValidationError {
    fn from(reason: &str) -> Self {
        ValidationError::Invalid(reason.to_string())
    }
}

impl From<String> for ValidationError {
    fn from(reason: String) -> Self {
        ValidationError::Invalid(reason)
    }
}

/// A value with cross-field constraints checked after it is parsed.
pub trait Validate {
    /// `Err(why)` if the value is inconsistent.
    fn validate(&self) -> Result<(), ValidationError>;
}

/// Deserializes a `T` and validates it, so a bad combination is reported at
/// the position of the value.
pub fn checked<'de, D: Deserializer<'de>, T: Deserialize<'de> + Validate>(
    d: D,
) -> Result<T, D::Error> {
    let v = T::deserialize(d)?;
    v.validate().map_err(D::Error::custom)?;
    Ok(v)
}

/// A number that may have been written as `null`: JSON has no NaN or
/// infinity, so serde_json writes a non-finite f64 as `null` (a run that
/// blew up reports its last energies, area and mesh quality so). Read back,
/// `null` is NaN, so such a file reads whole instead of failing.
pub fn number_or_nan<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}
