//! Consistency checks of deserialised models and trackers: a model or tracker read back with
//! serde is validated as a whole (layouts, sizes against its [`Space`](crate::Space),
//! finiteness, non-negativity) before it can be used, so a corrupted or hand-edited file gives
//! [`TrackError::Corrupt`] instead of a panic or a silent wrong answer in the filter.

use crate::TrackError;

/// A [`TrackError::Corrupt`] naming what is wrong.
pub(crate) fn corrupt(what: impl Into<String>) -> TrackError {
    TrackError::Corrupt(what.into())
}

/// Checks that `what` has `want` entries.
pub(crate) fn len(what: &str, got: usize, want: usize) -> Result<(), TrackError> {
    if got == want {
        Ok(())
    } else {
        Err(corrupt(format!(
            "{what} has {got} entries, expected {want}"
        )))
    }
}

/// Checks that every value is finite and non-negative.
pub(crate) fn nonneg(what: &str, v: &[f64]) -> Result<(), TrackError> {
    match v.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
        None => Ok(()),
        Some(i) => Err(corrupt(format!(
            "{what}[{i}] = {} is not a finite non-negative number",
            v[i]
        ))),
    }
}

/// Checks that one value is finite and non-negative.
pub(crate) fn nonneg1(what: &str, v: f64) -> Result<(), TrackError> {
    nonneg(what, &[v])
}

/// Checks that every value is finite.
pub(crate) fn finite(what: &str, v: &[f64]) -> Result<(), TrackError> {
    match v.iter().position(|x| !x.is_finite()) {
        None => Ok(()),
        Some(i) => Err(corrupt(format!("{what}[{i}] = {} is not finite", v[i]))),
    }
}

/// How far from 1 the sum of a saved distribution may be (rounding: a sum over up to 2^28
/// cells errs by under 10⁻⁷).
pub(crate) const MASS_SLACK: f64 = 1e-6;

/// A saved distribution (non-negative, checked before) sums to 1 within [`MASS_SLACK`], as
/// every step, start and reset leaves it: a scaled one gave scaled certainties, silently.
pub(crate) fn unit_mass(what: &str, v: &[f64]) -> Result<(), TrackError> {
    let sum: f64 = v.iter().sum();
    if (sum - 1.0).abs() <= MASS_SLACK {
        Ok(())
    } else {
        Err(corrupt(format!("{what} sums to {sum}, not 1")))
    }
}

/// Checks sparse `(index, value)` entries: indices below `bound`, values finite and
/// non-negative.
pub(crate) fn sparse(what: &str, v: &[(u32, f64)], bound: usize) -> Result<(), TrackError> {
    for &(i, x) in v {
        if i as usize >= bound {
            return Err(corrupt(format!(
                "{what} has index {i}, beyond its {bound} cells"
            )));
        }
        nonneg1(what, x)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    // JSON cannot carry NaN or ∞, but other serde formats can: the checks reject them.
    #[test]
    fn non_finite_and_negative_values_are_corrupt() {
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -1e-300] {
            assert!(matches!(
                nonneg("v", &[0.0, bad]),
                Err(TrackError::Corrupt(_))
            ));
            assert!(matches!(nonneg1("v", bad), Err(TrackError::Corrupt(_))));
            assert!(matches!(
                sparse("v", &[(0, bad)], 1),
                Err(TrackError::Corrupt(_))
            ));
        }
        for bad in [f64::NAN, f64::INFINITY] {
            assert!(matches!(finite("v", &[bad]), Err(TrackError::Corrupt(_))));
        }
        assert!(finite("v", &[-3.0, 0.0]).is_ok() && nonneg("v", &[0.0, 2.0]).is_ok());
        assert!(matches!(
            sparse("v", &[(3, 1.0)], 3),
            Err(TrackError::Corrupt(_))
        ));
        assert!(len("v", 3, 3).is_ok() && len("v", 2, 3).is_err());
    }
}
