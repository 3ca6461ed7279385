//! Strict CI: with `CI=true` (as `.ci/run` and most CI services set it), a check that cannot run
//! — missing benchmark data, a peer that does not build — is a failure with a message; locally
//! the same check is skipped with a printed note.

/// Whether the environment asks for strict checks: `CI` set to `true` or `1` (any case).
pub fn is_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| ci_value_is_true(&v))
}

fn ci_value_is_true(v: &str) -> bool {
    let v = v.trim();
    v.eq_ignore_ascii_case("true") || v == "1"
}

/// Prints `note` and returns `Ok` locally; an error carrying `note` under CI.
pub fn skip_or_fail(note: &str) -> crate::Result<()> {
    if is_ci() {
        return Err(format!("{note} (CI=true: a check that cannot run is a failure)").into());
    }
    eprintln!("note: {note}");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_true_or_one_is_ci() {
        for v in ["true", "TRUE", " 1", "True"] {
            assert!(ci_value_is_true(v), "{v}");
        }
        for v in ["", "false", "0", "no", "yes"] {
            assert!(!ci_value_is_true(v), "{v}");
        }
    }
}
