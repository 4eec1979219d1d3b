//! `Timestamps`: a validated, strictly increasing list of frame times in seconds.

use super::error::TimingError;

/// Frame times in seconds, finite and strictly increasing (guaranteed by construction).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Timestamps {
    times_s: Vec<f64>,
}

impl Timestamps {
    /// Validates `times_s`: every value finite, each strictly greater than the one before.
    pub fn new(times_s: Vec<f64>) -> Result<Self, TimingError> {
        for (frame, &value_s) in times_s.iter().enumerate() {
            let previous_s = frame.checked_sub(1).map(|p| times_s[p]);
            check_next(frame, previous_s, value_s)?;
        }
        Ok(Self { times_s })
    }

    pub fn as_slice(&self) -> &[f64] {
        &self.times_s
    }

    pub fn into_vec(self) -> Vec<f64> {
        self.times_s
    }

    pub fn len(&self) -> usize {
        self.times_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.times_s.is_empty()
    }

    /// Frame-to-frame intervals in seconds (`len() - 1` values, all > 0).
    pub fn intervals_s(&self) -> Vec<f64> {
        self.times_s.windows(2).map(|w| w[1] - w[0]).collect()
    }

    /// The same frames with `offset_s` added to every time (ordering is unchanged).
    pub fn shifted(&self, offset_s: f64) -> Result<Self, TimingError> {
        // Re-validated: adding a huge offset can merge neighbours through rounding.
        Self::new(self.times_s.iter().map(|t| t + offset_s).collect())
    }

    /// The frames with `t < end_s`.
    pub fn truncated_before(&self, end_s: f64) -> Self {
        let n = self.times_s.partition_point(|&t| t < end_s);
        Self {
            times_s: self.times_s[..n].to_vec(),
        }
    }
}

/// The check of one frame time against the one before it (None for frame 0): finite and
/// strictly later.
pub(super) fn check_next(
    frame: usize,
    previous_s: Option<f64>,
    value_s: f64,
) -> Result<(), TimingError> {
    if !value_s.is_finite() {
        return Err(TimingError::NotFinite { frame, value_s });
    }
    match previous_s {
        Some(previous_s) if value_s == previous_s => Err(TimingError::Repeated {
            frame,
            previous_s,
            value_s,
        }),
        Some(previous_s) if value_s < previous_s => Err(TimingError::Backwards {
            frame,
            previous_s,
            value_s,
        }),
        _ => Ok(()),
    }
}

/// The analysis timebase: `n` frames at exactly `k / fps` seconds, as an analysis that assumes a
/// constant frame rate would use. `fps` must be finite and > 0.
pub fn timebase(n: usize, fps: f64) -> Result<Timestamps, TimingError> {
    if !fps.is_finite() || fps <= 0.0 {
        return Err(TimingError::InvalidConfig(format!(
            "timebase fps must be > 0, got {fps}"
        )));
    }
    Timestamps::new((0..n).map(|k| k as f64 / fps).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_timestamp_names_frame_and_values() {
        let err = Timestamps::new(vec![0.0, 0.033, 0.033]).unwrap_err();
        assert_eq!(
            err,
            TimingError::Repeated {
                frame: 2,
                previous_s: 0.033,
                value_s: 0.033
            }
        );
        let msg = err.to_string();
        assert!(
            msg.contains("frame 2") && msg.contains("frame 1") && msg.contains("0.033"),
            "{msg}"
        );
    }

    #[test]
    fn backwards_timestamp_names_frame_and_values() {
        let err = Timestamps::new(vec![0.0, 0.05, 0.04, 0.1]).unwrap_err();
        assert_eq!(
            err,
            TimingError::Backwards {
                frame: 2,
                previous_s: 0.05,
                value_s: 0.04
            }
        );
        assert!(err.to_string().contains("goes backwards"));
    }

    #[test]
    fn nan_and_infinity_rejected() {
        assert!(matches!(
            Timestamps::new(vec![0.0, f64::NAN]),
            Err(TimingError::NotFinite { frame: 1, .. })
        ));
        assert!(matches!(
            Timestamps::new(vec![f64::INFINITY]),
            Err(TimingError::NotFinite { frame: 0, .. })
        ));
    }

    #[test]
    fn timebase_is_k_over_fps() {
        let tb = timebase(31, 30.0).unwrap();
        assert_eq!(tb.len(), 31);
        assert_eq!(tb.as_slice()[30], 1.0);
        assert!(tb
            .intervals_s()
            .iter()
            .all(|d| (d - 1.0 / 30.0).abs() < 1e-12));
        assert!(timebase(3, 0.0).is_err());
    }

    #[test]
    fn truncation_is_half_open() {
        let tb = timebase(10, 10.0).unwrap();
        assert_eq!(tb.truncated_before(0.5).len(), 5);
        assert_eq!(tb.truncated_before(0.0).len(), 0);
    }
}
