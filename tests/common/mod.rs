//! Helpers shared by the integration tests that run the `geneva` binary.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

use geneva_vision::diagnose::fit_noise::REPRODUCED_REL;

/// Runs `geneva ARGS…` in `dir`.
pub fn geneva(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geneva"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Runs `geneva ARGS…` in `dir`, which must succeed; its stdout.
pub fn geneva_ok(dir: &Path, args: &[&str]) -> String {
    let out = geneva(dir, args);
    assert!(
        out.status.success(),
        "geneva {}: {}",
        args.join(" "),
        stderr(&out)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Checks a ranked entry of `diagnosis.json` whose refits on fresh seeds were done: each
/// parameter's stated value and ± are the pool of the first fit's and the refits' (the mean of
/// the fits, σ = √(mean σᵢ² + sample variance / n); `diagnose::fit_noise`), recomputed here
/// from the JSON alone. A parameter the first fit left undetermined (± null) must keep its
/// first value. When the bootstrap of the footage's noise ran after the refits, the pool is
/// its value before (`bootstrap.params_before`, `params_std_before`; [`check_bootstrap`] checks
/// what it made of them). Returns the number of refits.
pub fn check_pooled_refit(entry: &serde_json::Value) -> Result<usize, String> {
    let refit = &entry["refit"];
    if refit["status"] != "done" {
        return Err(format!("refit not done: {entry}"));
    }
    let runs = refit["runs"]
        .as_array()
        .ok_or_else(|| format!("no runs: {entry}"))?;
    let params = entry["params"]
        .as_object()
        .ok_or_else(|| format!("no params: {entry}"))?;
    let (pooled, pooled_std) = if entry["bootstrap"]["status"] == "done" {
        (
            &entry["bootstrap"]["params_before"],
            &entry["bootstrap"]["params_std_before"],
        )
    } else {
        (&entry["params"], &entry["params_std"])
    };
    for key in params.keys() {
        let stated = pooled[key]
            .as_f64()
            .ok_or_else(|| format!("{key}: {entry}"))?;
        let first = refit["params_first_fit"][key].as_f64();
        let Some(first_sd) = refit["params_std_first_fit"][key].as_f64() else {
            if first != Some(stated) || !pooled_std[key].is_null() {
                return Err(format!("{key}: undetermined, yet pooled: {entry}"));
            }
            continue;
        };
        let first = first.ok_or_else(|| format!("{key}: no first value: {entry}"))?;
        let mut fits = vec![(first, first_sd)];
        for run in runs {
            if let (Some(v), Some(s)) =
                (run["params"][key].as_f64(), run["params_std"][key].as_f64())
            {
                fits.push((v, s));
            }
        }
        let n = fits.len() as f64;
        let mean = fits.iter().map(|f| f.0).sum::<f64>() / n;
        let sd = if fits.len() < 2 {
            first_sd
        } else {
            let var = fits.iter().map(|f| (f.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (fits.iter().map(|f| f.1 * f.1).sum::<f64>() / n + var / n).sqrt()
        };
        let stated_sd = pooled_std[key]
            .as_f64()
            .ok_or_else(|| format!("{key}: no ±: {entry}"))?;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
        if !close(stated, mean) || !close(stated_sd, sd) {
            return Err(format!(
                "{key}: stated {stated} ± {stated_sd}, pooled {mean} ± {sd}: {entry}"
            ));
        }
    }
    Ok(runs.len())
}

/// Checks a ranked entry of `diagnosis.json` whose fits on footages simulated at its stated
/// values were done, recomputing from the JSON alone (`diagnose::fit_noise::from_footage_fits`):
/// per parameter, `footage_std` is the sample sd s of the footages' fitted values, `bias` their
/// mean less the value before, `bias_std` s/√B; the ± widened is √(± before² + max(0, s² − c²)),
/// c² the mean curvature variance of the fits pooled into the ± before (the first fit's and the
/// refits' ±, or the ± before itself with no refit, which makes it max(± before, s)); when the bias
/// was taken off (only at p < 0.05) the stated value is the value before less the bias and its
/// ± √(widened² + bias_std²), else the value before and the widened ±. Each footage fit lies
/// within 50 % of the value it was simulated at (a footage that is not the effect's would not),
/// and two footages (other data seeds) give other values. A spread or bias within
/// `REPRODUCED_REL` of |value| + ± before is 0, as the library states it. Returns the number of
/// footages.
pub fn check_bootstrap(entry: &serde_json::Value) -> Result<usize, String> {
    let b = &entry["bootstrap"];
    if b["status"] != "done" {
        return Err(format!("bootstrap not done: {entry}"));
    }
    let footages = b["footages"]
        .as_array()
        .ok_or_else(|| format!("no footages: {entry}"))?;
    let params = entry["params"]
        .as_object()
        .ok_or_else(|| format!("no params: {entry}"))?;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
    let num = |v: &serde_json::Value, what: &str, key: &str| {
        v[what][key]
            .as_f64()
            .ok_or_else(|| format!("{key}: no {what}: {entry}"))
    };
    for (key, stated) in params {
        let stated = stated.as_f64().ok_or_else(|| format!("{key}: {entry}"))?;
        let before = num(b, "params_before", key)?;
        let values: Vec<f64> = footages
            .iter()
            .filter_map(|f| f["params"][key].as_f64())
            .collect();
        if values.len() != footages.len() {
            return Err(format!("{key}: a footage without it: {entry}"));
        }
        if values
            .iter()
            .any(|v| (v - before).abs() > 0.5 * before.abs())
        {
            return Err(format!("{key}: a footage fit far from {before}: {entry}"));
        }
        if values.windows(2).any(|w| w[0] == w[1]) {
            return Err(format!("{key}: two footages, one value: {entry}"));
        }
        let Some(before_sd) = b["params_std_before"][key].as_f64() else {
            if stated != before || !b["bias_corrected"][key].is_null() {
                return Err(format!("{key}: undetermined, yet changed: {entry}"));
            }
            continue;
        };
        let n = values.len() as f64;
        let mean = values.iter().sum::<f64>() / n;
        // Footages that give the value back to rounding state a spread and a bias of exactly 0.
        let rounding = REPRODUCED_REL * (before.abs() + before_sd);
        let snap = |x: f64| if x.abs() <= rounding { 0.0 } else { x };
        let sd = snap((values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
        let mean_minus_before = snap(mean - before);
        let curvature: Vec<f64> = if entry["refit"]["status"] == "done" {
            let runs = entry["refit"]["runs"]
                .as_array()
                .cloned()
                .unwrap_or_default();
            std::iter::once(&entry["refit"]["params_std_first_fit"])
                .chain(runs.iter().map(|r| &r["params_std"]))
                .filter_map(|v| v[key].as_f64())
                .collect()
        } else {
            vec![before_sd]
        };
        let c2 = curvature.iter().map(|c| c * c).sum::<f64>() / curvature.len().max(1) as f64;
        let widened = (before_sd * before_sd + (sd * sd - c2).max(0.0)).sqrt();
        let (spread, bias, bias_std) = (
            num(b, "footage_std", key)?,
            num(b, "bias", key)?,
            num(b, "bias_std", key)?,
        );
        let corrected = b["bias_corrected"][key]
            .as_bool()
            .ok_or_else(|| format!("{key}: no bias_corrected: {entry}"))?;
        let stated_sd = num(entry, "params_std", key)?;
        let (want, want_sd) = if corrected {
            (before - bias, widened.hypot(bias_std))
        } else {
            (before, widened)
        };
        let ok = close(spread, sd)
            && close(bias, mean_minus_before)
            && close(bias_std, sd / n.sqrt())
            && (!corrected || num(b, "bias_p", key)? < 0.05)
            && close(stated, want)
            && close(stated_sd, want_sd);
        if !ok {
            return Err(format!(
                "{key}: stated {stated} ± {stated_sd}, recomputed {want} ± {want_sd} (footage \
                 sd {sd}, bias {mean_minus_before}): {entry}"
            ));
        }
    }
    Ok(footages.len())
}

/// Checks a ranked entry's 95 % intervals (`params_ci95`, `params_ci95_dof`) against what its
/// own refits and bootstrap recorded, recomputed from the JSON alone: the refits' spread s²/n on
/// n − 1 degrees of freedom (the first fit and the runs whose value and ± are stated), the
/// footages' spread² where they widened the ± (it then replaced the curvature's part; plus the
/// bias's spread²/B when the bias was taken off) on B − 1, Welch–Satterthwaite's
/// ν = σ⁴ / Σ(uᵢ⁴/νᵢ), k = t₀.₉₇₅ on ⌊ν⌋ (1.96 with nothing estimated): each interval is value ±
/// k·σ (none here lies near a limit of its parameter, so none is clipped), and an undetermined
/// parameter has none. Returns how many parameters took a k above 1.96 (something estimated).
pub fn check_ci95(entry: &serde_json::Value) -> Result<usize, String> {
    let params = entry["params"]
        .as_object()
        .ok_or_else(|| format!("no params: {entry}"))?;
    let close = |a: f64, b: f64, rel: f64| (a - b).abs() <= rel * b.abs().max(1e-300);
    let mut estimated_any = 0;
    for (key, value) in params {
        let value = value.as_f64().ok_or_else(|| format!("{key}: {entry}"))?;
        let ci = &entry["params_ci95"][key];
        let Some(sd) = entry["params_std"][key].as_f64() else {
            if !ci.is_null() || !entry["params_ci95_dof"][key].is_null() {
                return Err(format!("{key}: undetermined, yet an interval: {entry}"));
            }
            continue;
        };
        let mut parts: Vec<(f64, f64)> = Vec::new();
        let refit = &entry["refit"];
        if refit["status"] == "done" {
            let first = (
                refit["params_first_fit"][key].as_f64(),
                refit["params_std_first_fit"][key].as_f64(),
            );
            if let (Some(v1), Some(_)) = first {
                let runs = refit["runs"].as_array().cloned().unwrap_or_default();
                let fits: Vec<f64> = std::iter::once(v1)
                    .chain(runs.iter().filter_map(|r| {
                        r["params_std"][key].as_f64()?;
                        r["params"][key].as_f64()
                    }))
                    .collect();
                if fits.len() >= 2 {
                    let n = fits.len() as f64;
                    let mean = fits.iter().sum::<f64>() / n;
                    let s2 = fits.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
                    parts.push((s2 / n, n - 1.0));
                }
            }
        }
        let b = &entry["bootstrap"];
        if b["status"] == "done" {
            if let Some(before) = b["params_std_before"][key].as_f64() {
                let footages = b["footages"].as_array().cloned().unwrap_or_default();
                let count = footages
                    .iter()
                    .filter(|f| f["params"][key].as_f64().is_some())
                    .count();
                let spread = b["footage_std"][key].as_f64().unwrap_or(0.0);
                let bias_var = if b["bias_corrected"][key] == true {
                    b["bias_std"][key].as_f64().unwrap_or(0.0).powi(2)
                } else {
                    0.0
                };
                let widened = sd * sd - before * before - bias_var > 1e-9 * sd * sd;
                let part = if widened { spread * spread } else { 0.0 } + bias_var;
                if count >= 2 && part > 0.0 {
                    parts.push((part, count as f64 - 1.0));
                }
            }
        }
        let denominator: f64 = parts
            .iter()
            .filter(|(u2, _)| *u2 > 0.0)
            .map(|(u2, dof)| u2 * u2 / dof)
            .sum();
        let dof = if denominator > 0.0 {
            sd.powi(4) / denominator
        } else {
            f64::INFINITY
        };
        let k = if dof.is_finite() {
            geneva_vision::numeric::dist::t975(((dof * (1.0 + 1e-9)).floor() as usize).max(1))
        } else {
            1.959964
        };
        let (low, high) = (ci[0].as_f64(), ci[1].as_f64());
        let stated_dof = entry["params_ci95_dof"][key].as_f64();
        // Beyond a million degrees of freedom k is the normal's to 10⁻⁶: a part of σ² that
        // is rounding here and a last bit there must not tell them apart.
        let dof_ok = match stated_dof {
            Some(d) => close(d, dof, 1e-6) || (d > 1e6 && dof > 1e6),
            None => dof > 1e6,
        };
        let end_ok = |end: Option<f64>, want: f64| {
            end.is_some_and(|e| (e - want).abs() <= 1e-9 * value.abs() + 1e-5 * sd)
        };
        let ends_ok = end_ok(low, value - k * sd) && end_ok(high, value + k * sd);
        if !(dof_ok && ends_ok) {
            return Err(format!(
                "{key}: stated {ci} on ν {stated_dof:?}, recomputed {value} ± {k}·{sd} on ν {dof}: \
                 {entry}"
            ));
        }
        if k > 1.96 {
            estimated_any += 1;
        }
    }
    Ok(estimated_any)
}

/// Renders the `fast` rig with a printed marker into `dir/printed` (frames and timestamps): the
/// marker's paper and ink drawn from a texture (`dir/marker.png`) with a shading across it and
/// a blotch, as a printed marker under a lamp looks; writes `dir/base.toml`, a base that states
/// the mechanism and the marker's side, and `dir/truth.toml` (the rig uniform).
pub fn render_printed_marker(dir: &Path) {
    use geneva_vision::calibrate::appearance::texels_per_cell;
    use geneva_vision::imagestats::Material;
    use geneva_vision::render::texture::value_of;
    std::fs::write(dir.join("truth.toml"), "extend = \"fast\"\n").unwrap();
    std::fs::write(
        dir.join("base.toml"),
        "extend = \"fast\"\n[mechanism]\nkind = \"internal\"\nslots = 4\n[scene.marker]\nsize_mm = 32.0\n",
    )
    .unwrap();
    let truth = geneva_vision::scenario::load(&dir.join("truth.toml")).unwrap();
    let layout = geneva_vision::diagnose::image::marker_layout(&truth).unwrap();
    let cells = layout.side_cells();
    let tpc = texels_per_cell(8.0, layout.margin_cells().unwrap()).unwrap();
    let margin = (layout.margin_cells().unwrap() * tpc as f64).round() as usize;
    let side = cells * tpc as usize + 2 * margin;
    let values: Vec<u16> = (0..side * side)
        .map(|k| {
            let g = |v: usize| (v as f64 + 0.5 - margin as f64) / tpc as f64;
            let (gx, gy) = (g(k % side), g(k / side));
            let shade = (gx - gy) / cells as f64;
            let blotch = (-((gx - 2.0).powi(2) + (gy - 4.0).powi(2)) / 4.5).exp();
            value_of(match layout.material(gx, gy) {
                Material::Ink => 0.12 + 0.04 * shade - 0.04 * blotch,
                _ => 0.7 + 0.12 * shade - 0.1 * blotch,
            })
        })
        .collect();
    geneva_vision::io::texture_png::write_texture(&dir.join("marker.png"), side, side, &values)
        .unwrap();
    std::fs::write(
        dir.join("printed.toml"),
        format!(
            "extend = \"truth.toml\"\n[scene.appearance]\nmarker_file = \"marker.png\"\n\
             marker_texels_per_cell = {tpc}\n"
        ),
    )
    .unwrap();
    let o = geneva(dir, &["render", "printed.toml", "--out", "printed"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Writes `truth.toml` (the `fast` rig), `base.toml` (its mechanism and marker stated) and
/// `taped.toml`: the truth with a disc texture (print lines at 45°, two strips of tape beside
/// the marker's paper, a stain) and a background texture (a gradient with stripes), then
/// renders `taped` into `dir/taped`.
pub fn render_taped_disc(dir: &Path) {
    use geneva_vision::render::texture::value_of;
    std::fs::write(dir.join("truth.toml"), "extend = \"fast\"\n").unwrap();
    std::fs::write(
        dir.join("base.toml"),
        "extend = \"fast\"\n[mechanism]\nkind = \"internal\"\nslots = 4\n[scene.marker]\nsize_mm = 32.0\n",
    )
    .unwrap();
    // The disc (130 mm radius) at 0.5 mm per texel, its centre at texel (260, 260); the
    // marker's paper is centred 100 mm out along the wheel's +x.
    let (side, mm) = (521usize, 0.5);
    let disc: Vec<u16> = (0..side * side)
        .map(|k| {
            let x = (k % side) as f64 * mm - 130.0;
            let y = (k / side) as f64 * mm - 130.0;
            let lines = 0.04 * (std::f64::consts::TAU * (x + y) / 7.0).sin();
            let tape = (85.0..=115.0).contains(&x) && (19.0..=27.0).contains(&y.abs());
            let stain = -0.15 * (-((x - 124.0).powi(2) + (y - 8.0).powi(2)) / 18.0).exp();
            value_of(if tape { 0.8 } else { 0.5 + lines + stain })
        })
        .collect();
    geneva_vision::io::texture_png::write_texture(&dir.join("disc.png"), side, side, &disc)
        .unwrap();
    let (w, h) = (1280usize, 720usize);
    let background: Vec<u16> = (0..w * h)
        .map(|k| {
            let (x, y) = ((k % w) as f64, (k / w) as f64);
            value_of(0.2 + 0.15 * x / w as f64 + 0.05 * (std::f64::consts::TAU * y / 40.0).sin())
        })
        .collect();
    geneva_vision::io::texture_png::write_texture(&dir.join("background.png"), w, h, &background)
        .unwrap();
    std::fs::write(
        dir.join("taped.toml"),
        "extend = \"truth.toml\"\n[scene.appearance]\ndisc_file = \"disc.png\"\n\
         disc_mm_per_texel = 0.5\nbackground_file = \"background.png\"\n",
    )
    .unwrap();
    let o = geneva(dir, &["render", "taped.toml", "--out", "taped"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// `geneva calibrate --frames FRAMES --timestamps TIMES --base base.toml --out cal EXTRA…` in `dir`.
pub fn calibrate_frames(dir: &Path, frames: &str, times: &str, extra: &[&str]) -> Output {
    let mut args = vec![
        "calibrate",
        "--frames",
        frames,
        "--timestamps",
        times,
        "--base",
        "base.toml",
        "--out",
        "cal",
    ];
    args.extend_from_slice(extra);
    geneva(dir, &args)
}

/// Calibrates `dir/frames` (rendered from the `fast` rig) against `fast` with its 32 mm marker
/// stated (`base.toml`, written here) into `dir/cal`; the command must succeed.
pub fn calibrate_fast_frames(dir: &Path) -> Output {
    std::fs::write(
        dir.join("base.toml"),
        "extend = \"fast\"\n[scene.marker]\nsize_mm = 32.0\n",
    )
    .unwrap();
    let o = calibrate_frames(dir, "frames", "frames/timestamps.csv", &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    o
}

/// Renders 4 s of the `fast` rig with `extra` (TOML appended to the truth's scenario) into
/// `dir/frames` and calibrates it with [`calibrate_fast_frames`]: the truth, the calibrated
/// scenario, and what calibrate printed (stdout and stderr).
pub fn render_and_calibrate_fast(
    dir: &Path,
    extra: &str,
) -> (
    geneva_vision::scenario::Scenario,
    geneva_vision::scenario::Scenario,
    String,
) {
    std::fs::write(
        dir.join("truth.toml"),
        format!("extend = \"fast\"\nduration_s = 4.0\n{extra}"),
    )
    .unwrap();
    let o = geneva(dir, &["render", "truth.toml", "--out", "frames"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = calibrate_fast_frames(dir);
    let truth = geneva_vision::scenario::load(&dir.join("truth.toml")).unwrap();
    let cal = geneva_vision::scenario::load(&dir.join("cal/scenario.toml")).unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&o.stdout), stderr(&o));
    (truth, cal, log)
}

/// Render → detect over `frames` of `rig` on a pool of `threads` threads, in chunks of 8 frames.
#[cfg(feature = "opencv-detector")]
pub fn detections(
    rig: &geneva_vision::pipeline::rig::Rig,
    frames: std::ops::Range<usize>,
    roi: bool,
    threads: usize,
) -> Vec<geneva_vision::pipeline::frames::FrameDetection> {
    use geneva_vision::pipeline::frames::{detect_frames, FrameLoopOptions};
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut out = Vec::new();
    pool.install(|| {
        detect_frames(
            rig,
            frames,
            FrameLoopOptions {
                roi,
                chunk_frames: 8,
            },
            |c| {
                out.extend_from_slice(c);
                Ok(())
            },
            &|_| {},
        )
        .unwrap()
    });
    out
}
