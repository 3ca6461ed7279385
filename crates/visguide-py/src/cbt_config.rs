//! The CBT configuration in Python: `cbt_tracker::CbtConfig` through its serde form, so the
//! keyword names, their values (enum variants in `snake_case`) and their defaults
//! (`CbtConfig::default()`) are the crate's and are written down nowhere else.
//!
//! A keyword becomes a JSON value (`str`, `int`, `float`, `bool`), replaces the default's field
//! of that name, and the whole object is read back with the crate's `Deserialize` and then
//! checked by `CbtConfig::validate`. Each keyword is also read alone on the defaults first, so
//! a wrong value's `ValueError` names its keyword.

use cbt_tracker::CbtConfig;
use pyo3::exceptions::PyTypeError;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyString};
use serde_json::{Map, Value};

use crate::errors::{from_track, value_error};

/// The fields of `c`, by name, as the crate serialises them, with the options the crate's
/// saved form leaves out while they hold their defaults (so that files written before an
/// option existed still read) filled in: as keywords they are always there. `input` (the
/// periodic known input of the 1-D separable layout, an object) is not a keyword.
fn fields(c: &CbtConfig) -> Map<String, Value> {
    let mut m = match serde_json::to_value(c).expect("a CbtConfig always serialises") {
        Value::Object(m) => m,
        _ => unreachable!("a struct serialises as an object"),
    };
    let value = |v: Result<Value, serde_json::Error>| v.expect("an option always serialises");
    for (name, v) in [
        ("smoothing", value(serde_json::to_value(c.smoothing))),
        ("start", value(serde_json::to_value(c.start))),
        (
            "displacements",
            value(serde_json::to_value(c.displacements)),
        ),
        (
            "observation_smoothing",
            value(serde_json::to_value(c.observation_smoothing)),
        ),
        ("velocity", value(serde_json::to_value(c.velocity))),
    ] {
        m.entry(name).or_insert(v);
    }
    m
}

/// The JSON value of the keyword `name = v`.
fn json_of(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Bool(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    // Python and NumPy integers (anything with `__index__`), but not floats.
    if !v.is_instance_of::<PyFloat>()
        && let Ok(i) = v.extract::<i64>()
    {
        return Ok(i.into());
    }
    if let Ok(f) = v.extract::<f64>() {
        return serde_json::Number::from_f64(f)
            .map(Value::Number)
            .ok_or_else(|| value_error(format!("{name} = {f} is not a finite number")));
    }
    Err(PyTypeError::new_err(format!(
        "{name} must be a str or a number, not {}",
        v.get_type().name()?
    )))
}

/// The configuration: the crate's defaults with the keywords of `kw` replacing fields of the
/// same name. `TypeError` (naming `caller`) for a keyword that is not a field, `ValueError` for
/// a value the crate's `Deserialize` or `validate` rejects.
pub fn config_from(caller: &str, kw: Option<&Bound<'_, PyDict>>) -> PyResult<CbtConfig> {
    let defaults = fields(&CbtConfig::default());
    let mut map = defaults.clone();
    for (k, v) in kw.into_iter().flat_map(|d| d.iter()) {
        let key: String = k.extract()?;
        if !defaults.contains_key(&key) {
            return Err(PyTypeError::new_err(format!(
                "{caller}() got an unexpected keyword argument '{key}'"
            )));
        }
        let value = json_of(&key, &v)?;
        let mut alone = defaults.clone();
        alone.insert(key.clone(), value.clone());
        serde_json::from_value::<CbtConfig>(Value::Object(alone))
            .map_err(|e| value_error(format!("{key}: {e}")))?;
        map.insert(key, value);
    }
    let c: CbtConfig =
        serde_json::from_value(Value::Object(map)).map_err(|e| value_error(e.to_string()))?;
    c.validate().map_err(from_track)?;
    Ok(c)
}

/// `c` as a dict of the keywords [`config_from`] takes, every one of them.
pub fn config_dict<'py>(py: Python<'py>, c: &CbtConfig) -> PyResult<Bound<'py, PyDict>> {
    let text = serde_json::to_string(&fields(c)).map_err(|e| value_error(e.to_string()))?;
    Ok(py
        .import("json")?
        .call_method1("loads", (text,))?
        .cast_into::<PyDict>()?)
}

#[cfg(test)]
mod tests {
    use cbt_tracker::{Displacements, ObservationSmoothing, Smoothing, StartMotion, Velocity};

    use super::*;

    /// Every field the crate serialises, even with every option away from its default, is a
    /// keyword (a new option left out of the saved form at its default must be added to
    /// `fields`), except `input`.
    #[test]
    fn every_option_is_a_keyword() {
        let keywords = fields(&CbtConfig::default());
        let all = CbtConfig {
            smoothing: Smoothing::HeldOut,
            start: StartMotion::Pooled,
            displacements: Displacements::Aligned,
            observation_smoothing: ObservationSmoothing::HeldOut,
            velocity: Velocity::PerPosition,
            ..CbtConfig::stationary()
        };
        let Value::Object(full) = serde_json::to_value(all).unwrap() else {
            panic!("an object")
        };
        for k in full.keys() {
            assert!(keywords.contains_key(k), "{k} is not a keyword");
        }
        assert_eq!(keywords.len(), full.len());
        // The defaults read back as the default configuration.
        let back: CbtConfig = serde_json::from_value(Value::Object(keywords)).unwrap();
        assert_eq!(back, CbtConfig::default());
    }
}
