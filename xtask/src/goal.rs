//! Goal verdicts in the evaluation summaries: one wording for every study.

/// `met` when `value ≤ limit`, else `MISSED by (value − limit) unit` (`MISSED` when `value` is
/// NaN).
pub fn verdict(value: f64, limit: f64, unit: &str) -> String {
    if value <= limit {
        "met".into()
    } else if value > limit {
        format!("MISSED by {:.2} {unit}", value - limit)
    } else {
        "MISSED".into()
    }
}

/// `met` or `MISSED`, for a goal that is not a margin (a count, a comparison).
pub fn met(ok: bool) -> &'static str {
    if ok { "met" } else { "MISSED" }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdicts_name_the_margin() {
        assert_eq!(verdict(0.5, 0.5, "px"), "met");
        assert_eq!(verdict(0.79, 0.7, "px"), "MISSED by 0.09 px");
        assert_eq!(verdict(f64::NAN, 0.7, "px"), "MISSED");
        assert_eq!(met(true), "met");
        assert_eq!(met(false), "MISSED");
    }
}
