//! Tests of the models: config (serde, validation), schedules (determinism, ordering,
//! log handling) and the statistics of synthetic schedules.

use proptest::prelude::*;

use super::*;
use crate::proptest_utils::vfr_model;
use crate::validation::Problems;

fn vfr(fps: f64, v: VfrModel) -> FrameTimingConfig {
    FrameTimingConfig {
        fps,
        model: TimingModel::Vfr(v),
        ..FrameTimingConfig::default()
    }
}

fn problems_of(c: &FrameTimingConfig) -> Vec<String> {
    let mut p = Problems::new();
    c.validate("frame_timing", &mut p);
    p.iter().map(|x| x.to_string()).collect()
}

#[test]
fn toml_sections_parse_with_kind_and_defaults() {
    let c: FrameTimingConfig =
        toml::from_str("fps = 60.0\n[model]\nkind = \"vfr\"\njitter_s = 1e-5\n").unwrap();
    assert_eq!(c.fps, 60.0);
    assert_eq!(
        c.model,
        TimingModel::Vfr(VfrModel {
            jitter_s: 1e-5,
            ..VfrModel::default()
        })
    );
    let c: FrameTimingConfig =
        toml::from_str("[model]\nkind = \"log\"\nfile = \"a.csv\"\nformat = \"frames_csv\"\n")
            .unwrap();
    assert_eq!(c.fps, 30.0);
    assert!(
        matches!(&c.model, TimingModel::Log(l) if l.file == "a.csv" && l.format == LogFormat::FramesCsv && l.rebase_to_zero)
    );
    assert_eq!(
        toml::from_str::<FrameTimingConfig>("").unwrap(),
        FrameTimingConfig::default()
    );
    assert!(toml::from_str::<FrameTimingConfig>("fsp = 3.0").is_err());
    assert!(
        toml::from_str::<FrameTimingConfig>("[model]\nkind = \"vfr\"\njiter_s = 1.0\n").is_err()
    );
    let round = toml::to_string(&vfr(25.0, VfrModel::default())).unwrap();
    assert_eq!(
        toml::from_str::<FrameTimingConfig>(&round).unwrap(),
        vfr(25.0, VfrModel::default())
    );
}

#[test]
fn validation_names_fields_and_ranges() {
    assert!(problems_of(&FrameTimingConfig::default()).is_empty());
    assert!(problems_of(&vfr(30.0, VfrModel::default())).is_empty());
    let bad = vfr(
        0.0,
        VfrModel {
            drop_probability: 0.9,
            jitter_s: -1.0,
            ..VfrModel::default()
        },
    );
    let msgs = problems_of(&bad);
    assert!(
        msgs.iter()
            .any(|m| m.starts_with("frame_timing.fps: must be in [0.1, 10000]")),
        "{msgs:?}"
    );
    assert!(msgs
        .iter()
        .any(|m| m.starts_with("frame_timing.model.drop_probability: must be in [0, 0.5]")));
    assert!(msgs
        .iter()
        .any(|m| m.starts_with("frame_timing.model.jitter_s: must be in [0, 1]")));
    let too_jittery = vfr(
        30.0,
        VfrModel {
            jitter_s: 0.003,
            ..VfrModel::default()
        },
    );
    let msgs = problems_of(&too_jittery);
    assert!(
        msgs.len() == 1
            && msgs[0].contains("frame_timing.model.jitter_s")
            && msgs[0].contains("half the frame interval"),
        "{msgs:?}"
    );
    let short_first = vfr(
        30.0,
        VfrModel {
            first_interval_s: 0.001,
            ..VfrModel::default()
        },
    );
    assert!(problems_of(&short_first)[0]
        .starts_with("frame_timing.model.first_interval_s: must be in ["));
    let no_file = FrameTimingConfig {
        fps: 30.0,
        model: TimingModel::Log(LogModel::default()),
        ..FrameTimingConfig::default()
    };
    assert!(problems_of(&no_file)[0].starts_with("frame_timing.model.file"));
    let err = too_jittery.schedule(1.0, 1, None).unwrap_err();
    assert!(
        matches!(&err, TimingError::InvalidConfig(m) if m.contains("jitter_s")),
        "{err}"
    );
    assert!(FrameTimingConfig::default()
        .schedule(-1.0, 1, None)
        .is_err());
}

#[test]
fn constant_schedule_is_k_over_fps_in_half_open_duration() {
    let c = FrameTimingConfig {
        fps: 30.0,
        model: TimingModel::Constant,
        ..FrameTimingConfig::default()
    };
    let ts = c.schedule(2.0, 0, None).unwrap();
    assert_eq!(ts.len(), 60);
    assert_eq!(ts, timebase(60, 30.0).unwrap());
    assert_eq!(c.schedule(2.01, 0, None).unwrap().len(), 61);
    // The analysis timebase ignores the model: the same k / fps for a VFR camera.
    let v = vfr(30.0, VfrModel::default());
    assert_eq!(v.timebase(60).unwrap(), ts);
    assert_ne!(v.schedule(2.0, 0, None).unwrap(), ts);
}

#[test]
fn vfr_schedule_is_deterministic_per_seed_and_extends_with_duration() {
    let c = vfr(
        30.0,
        VfrModel {
            drop_probability: 0.05,
            pair_alternation_s: 1e-4,
            ..VfrModel::default()
        },
    );
    let a = c.schedule(5.0, 42, None).unwrap();
    assert_eq!(a, c.schedule(5.0, 42, None).unwrap());
    assert_ne!(a, c.schedule(5.0, 43, None).unwrap());
    let longer = c.schedule(9.0, 42, None).unwrap();
    assert_eq!(&longer.as_slice()[..a.len()], a.as_slice());
    assert!(longer.len() > a.len());
    assert_eq!(a.as_slice()[0], 0.0);
    assert!(*a.as_slice().last().unwrap() < 5.0);
}

#[test]
fn vfr_statistics_follow_the_parameters() {
    let v = VfrModel {
        jitter_s: 0.0,
        pair_alternation_s: 2e-4,
        first_interval_s: 0.06,
        drop_probability: 0.0,
        rate_error_ppm: -4500.0,
    };
    let ts = vfr(30.0, v.clone()).schedule(20.0, 7, None).unwrap();
    let s = TimingStats::of(&ts).unwrap();
    let interval = 1.0 / v.actual_fps(30.0);
    // First interval: slot 1 is displaced by −a/2.
    assert!((s.first_interval_s - (0.06 - 1e-4)).abs() < 1e-12);
    assert!(
        (s.coherent_alternation_s - 2e-4).abs() < 1e-6,
        "{}",
        s.coherent_alternation_s
    );
    assert!((s.mean_abs_alternation_s - 2e-4).abs() < 1e-9);
    // Steady rate: an odd number of alternating intervals biases the mean by at most a / n.
    assert!((s.steady_fps - 1.0 / interval).abs() < 0.01);
    assert_eq!(s.dropped_frames, 0);
    assert!(s.to_string().contains("dropped frames       0"));
}

#[test]
fn dropped_frames_are_counted() {
    let v = VfrModel {
        jitter_s: 1e-5,
        drop_probability: 0.1,
        ..VfrModel::default()
    };
    let c = vfr(30.0, v.clone());
    let ts = c.schedule(30.0, 3, None).unwrap();
    let interval = 1.0 / v.actual_fps(30.0);
    let last = *ts.as_slice().last().unwrap();
    // Slots spanned, from the construction formula; every slot not present was dropped.
    let slots = ((last - v.first_interval_s) / interval).round() as usize + 1;
    let s = TimingStats::of(&ts).unwrap();
    assert_eq!(s.dropped_frames, slots + 1 - ts.len());
    let rate = s.dropped_frames as f64 / slots as f64;
    assert!((rate - 0.1).abs() < 0.03, "{rate}");
}

#[test]
fn log_schedule_rebases_offsets_and_truncates() {
    let log = Timestamps::new(vec![10.0, 10.05, 10.1, 10.2, 10.3]).unwrap();
    let mut l = LogModel {
        file: "x.log".into(),
        ..LogModel::default()
    };
    let c = |l: &LogModel| FrameTimingConfig {
        fps: 30.0,
        model: TimingModel::Log(l.clone()),
        ..FrameTimingConfig::default()
    };
    let ts = c(&l).schedule(0.15, 0, Some(&log)).unwrap();
    let expect = [0.0, 0.05, 0.1];
    assert_eq!(ts.len(), 3);
    assert!(ts
        .as_slice()
        .iter()
        .zip(expect)
        .all(|(a, b)| (a - b).abs() < 1e-12));
    l.offset_s = 1.0;
    assert_eq!(c(&l).schedule(1.15, 0, Some(&log)).unwrap().len(), 3);
    l.rebase_to_zero = false;
    l.offset_s = 0.0;
    assert_eq!(c(&l).schedule(100.0, 0, Some(&log)).unwrap(), log);
    assert_eq!(
        c(&l).schedule(1.0, 0, None).unwrap_err(),
        TimingError::MissingLog
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn any_valid_vfr_schedule_strictly_increases((fps, v) in vfr_model(), seed in any::<u64>()) {
        let c = vfr(fps, v);
        prop_assert!(problems_of(&c).is_empty(), "{:?}", problems_of(&c));
        let ts = c.schedule(3.0, seed, None).unwrap();
        prop_assert!(ts.intervals_s().iter().all(|&d| d > 0.0));
        prop_assert!(ts.as_slice().iter().all(|&t| (0.0..3.0).contains(&t)));
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// A schedule valid at one rate, moved to any rate a candidate search tries (the
    /// timebase's 1–1000 fps), validates there and still orders its frames.
    #[test]
    fn a_valid_schedule_moved_to_any_rate_stays_valid(
        (fps, v) in vfr_model(),
        log_rate in (1.0f64).ln()..(1000.0f64).ln(),
        seed in any::<u64>(),
    ) {
        let rate = log_rate.exp();
        let moved = v.valid_at(rate);
        let c = vfr(rate, moved.clone());
        prop_assert!(problems_of(&c).is_empty(), "{:?} at {rate} fps (from {fps}): {:?}", moved, problems_of(&c));
        let ts = c.schedule(3.0, seed, None).unwrap();
        prop_assert!(ts.intervals_s().iter().all(|&d| d > 0.0));
        // Where it was already valid, nothing moves.
        let c0 = vfr(fps, v.clone());
        prop_assert_eq!(v.valid_at(fps), v.clone(), "{:?}", problems_of(&c0));
    }
}

#[test]
fn the_phone_schedule_at_three_fps_gets_a_regular_first_interval() {
    let moved = VfrModel::default().valid_at(2.8);
    assert_eq!(moved.first_interval_s, 0.0);
    assert_eq!(moved.jitter_s, VfrModel::default().jitter_s);
    assert!(problems_of(&vfr(2.8, VfrModel::default()))
        .iter()
        .any(|p| p.contains("first_interval_s")));
    assert!(problems_of(&vfr(2.8, moved)).is_empty());
}
