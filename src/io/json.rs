//! JSON values the outputs share.

use serde_json::Value;

/// A JSON number, or null where `x` is not finite (JSON has neither NaN nor ∞): a 1-σ
/// uncertainty the data do not determine, a failed simulation's objective, a statistic of no
/// samples.
pub fn finite_or_null(x: f64) -> Value {
    serde_json::Number::from_f64(x)
        .map(Value::Number)
        .unwrap_or(Value::Null)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_finite_number_is_written_as_serde_writes_it_and_nan_or_infinity_as_null() {
        for x in [0.0, -0.0, 1.5e-9, -3.25, 1e300] {
            assert_eq!(finite_or_null(x), serde_json::json!(x), "{x}");
        }
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            assert_eq!(finite_or_null(x), Value::Null, "{x}");
        }
    }
}
