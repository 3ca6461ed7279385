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

/// The fields of `c`, by name, as the crate serialises them.
fn fields(c: &CbtConfig) -> Map<String, Value> {
    match serde_json::to_value(c).expect("a CbtConfig always serialises") {
        Value::Object(m) => m,
        _ => unreachable!("a struct serialises as an object"),
    }
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

/// `c` as a dict of the keywords [`config_from`] takes (in the struct's field order).
pub fn config_dict<'py>(py: Python<'py>, c: &CbtConfig) -> PyResult<Bound<'py, PyDict>> {
    let text = serde_json::to_string(c).map_err(|e| value_error(e.to_string()))?;
    Ok(py
        .import("json")?
        .call_method1("loads", (text,))?
        .cast_into::<PyDict>()?)
}
