//! The realised RMS of a case's camera shake at its frame times: copy to `examples/` and run
//! `cut -d, -f2 CASE/diagnosis/real/tracks.csv | tail -n +2 | cargo run --example realised_rms -- SEED`
//! with SEED the case's data seed (`manifest.json`, `inputs.CASE.data.seed`). The configuration is
//! the self-check's strong camera-vibration level, copied by hand from the same manifest
//! (`inputs.CASE.data.effects.camera_vibration`): check it there before reusing this.
use geneva_vision::render::effects::camera_vibration::{CameraVibrationConfig, Vibration};
use std::io::Read;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let seed: u64 = args[1].parse().unwrap();
    let mut cfg = CameraVibrationConfig::default();
    cfg.enabled = true;
    cfg.random.x_rms_px = 1.0;
    cfg.random.y_rms_px = 1.0;
    cfg.random.band_min_hz = 1.0;
    cfg.random.band_max_hz = 20.0;
    cfg.random.components = 16;
    cfg.random.rotation_rms_rad = 0.0;
    let v = Vibration::new(&cfg, seed, 1280, 720).unwrap();
    let mut s = String::new();
    std::io::stdin().read_to_string(&mut s).unwrap();
    let t: Vec<f64> = s.split_whitespace().map(|x| x.parse().unwrap()).collect();
    let xs: Vec<f64> = t.iter().map(|&t| v.at(t).translation_px.x).collect();
    let ys: Vec<f64> = t.iter().map(|&t| v.at(t).translation_px.y).collect();
    let rms = |a: &[f64]| (a.iter().map(|x| x * x).sum::<f64>() / a.len() as f64).sqrt();
    let sd = |a: &[f64]| {
        let m = a.iter().sum::<f64>() / a.len() as f64;
        (a.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / a.len() as f64).sqrt()
    };
    println!(
        "seed {seed}: rms x {:.3} y {:.3} (quadratic mean {:.3}); sd x {:.3} y {:.3}",
        rms(&xs),
        rms(&ys),
        ((rms(&xs).powi(2) + rms(&ys).powi(2)) / 2.0).sqrt(),
        sd(&xs),
        sd(&ys)
    );
}
