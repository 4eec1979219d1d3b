//! The time a long command has left, from the work done so far and the work still planned: the
//! estimate the diagnosis and its self-check print beside their progress.

/// "about 3 min 20 s left": the time `done` units took (`elapsed_s`) scaled to the
/// `planned − done` still to run; "estimating" before the first unit is done.
pub fn left(elapsed_s: f64, done: usize, planned: usize) -> String {
    if done == 0 || !elapsed_s.is_finite() {
        return "estimating the time left".into();
    }
    let left_s = elapsed_s / done as f64 * planned.saturating_sub(done) as f64;
    format!("about {} left", duration(left_s))
}

/// A duration for people: "45 s", "3 min 20 s", "2 h 05 min".
pub fn duration(seconds: f64) -> String {
    let s = seconds.max(0.0).round() as u64;
    match s {
        0..=59 => format!("{s} s"),
        60..=3599 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, (s % 3600) / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_time_left_scales_the_time_per_unit_to_the_units_left() {
        assert_eq!(left(30.0, 10, 40), "about 1 min 30 s left");
        assert_eq!(left(30.0, 0, 40), "estimating the time left");
        assert_eq!(left(30.0, 50, 40), "about 0 s left");
        assert_eq!(duration(7325.0), "2 h 02 min");
        assert_eq!(duration(59.4), "59 s");
    }
}
