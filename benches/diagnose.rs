//! Wall time of one diagnosis (issue #11's speed figure): 300 frames of 1280×720 footage with a
//! withheld rolling shutter (30 ms readout), all candidates, from the frames and from the
//! tracks CSV the frame run wrote. Targets on the 2-core reference machine: ≤ 5 min from frames,
//! ≤ 2 min from tracks.
//! Run: `cargo bench --bench diagnose` (or `cargo xtask bench`).

use geneva_vision::diagnose::scoring::Expectation;
use geneva_vision::pipeline::analyze::Source;
use geneva_vision::pipeline::diagnose::selfcheck::{render_case, suite_base, Case, PostProcess};
use geneva_vision::pipeline::diagnose::{diagnose, DiagnoseOptions};
use geneva_vision::scenario::effects::Effect;
use std::time::Instant;

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let tmp = tempfile::tempdir().expect("temporary folder");
    let nominal = suite_base(10.0).expect("built-in rig");
    let mut data = nominal.clone();
    Effect::RollingShutter.apply(&mut data, &[0.03]);
    data.seed = nominal.seed + 17;
    let case = Case {
        name: "bench".into(),
        expectation: Expectation::Withheld {
            effect: "rolling_shutter".into(),
            also: vec![],
            strong: true,
        },
        data,
        nominal: nominal.clone(),
        post: PostProcess::None,
        effects: None,
        truth: None,
    };
    let frames = tmp.path().join("frames");
    render_case(&case, &frames).expect("render");
    let options = DiagnoseOptions::default();
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let started = Instant::now();
    let (d, _) = diagnose(
        &nominal,
        &source,
        &tmp.path().join("from-frames"),
        &options,
        &|_, _, _| {},
    )
    .expect("diagnosis from frames");
    let frames_s = started.elapsed().as_secs_f64();
    println!(
        "diagnose: 300 frames 1280x720, all candidates: {frames_s:.1} s wall ({} simulations; verdict {}; target <= 300 s)",
        d.simulations,
        d.verdict.as_str()
    );
    let tracks = Source::Tracks(tmp.path().join("from-frames/real/tracks.csv"));
    let started = Instant::now();
    let (d, _) = diagnose(
        &nominal,
        &tracks,
        &tmp.path().join("from-tracks"),
        &options,
        &|_, _, _| {},
    )
    .expect("diagnosis from tracks");
    let tracks_s = started.elapsed().as_secs_f64();
    println!(
        "diagnose: the same from tracks.csv: {tracks_s:.1} s wall ({} simulations; verdict {}; target <= 120 s)",
        d.simulations,
        d.verdict.as_str()
    );
}
