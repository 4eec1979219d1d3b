//! `geneva decompose`: which effect costs how much. Runs the scenario with no optional effect
//! (`none`: corner quantisation), with all of the base scenario's effects, with each source alone
//! and with each left out, every configuration with the same seeds (common random numbers), adds
//! seeds until every share's 95 % CI is narrow enough or a cap is hit, and splits the fused ω2
//! and α2 mean square error into rows that add up to the whole ([`crate::budget::decompose`]).
//! Writes `decomposition.csv`, `per_seed.csv`, `decomposition.md` and bar charts.
//!
//! Mechanism effects (drive speed, clearance dynamics, disc vibration, axis runout) are the
//! motion being measured, not sources of measurement error: they stay as in the base scenario in
//! every configuration, and the errors are measured against the resolvable truth, the budget's
//! headline ([`error_variances`]), so the part of the rattle no camera can follow is not charged
//! to a detection source.

use super::run::{run, CornerSource, RunError, RunOptions};
use crate::budget::decompose::{
    decompose, next_seeds, DecomposeError, Decomposition, PairedRuns, SeedRule, StopReason,
    ESTIMATOR, INTERACTION, QUANTISATION,
};
use crate::budget::report::Budget;
use crate::budget::MeanCi;
use crate::errors::FileError;
use crate::plot::bars_png;
use crate::scenario::effects::{Effect, EffectKind};
use crate::scenario::{Scenario, ScenarioError};
use rayon::prelude::*;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum DecompositionError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("run `{run}`, seed {seed}")]
    Run {
        run: String,
        seed: u64,
        source: Box<RunError>,
    },
    #[error(transparent)]
    Decompose(#[from] DecomposeError),
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error(
        "seed rule: needs 2 ≤ initial seeds ({initial}) ≤ cap ({cap}) and a target half-width \
         (got {target_half_width})"
    )]
    Rule {
        initial: usize,
        cap: usize,
        target_half_width: f64,
    },
}

/// What the errors of a decomposition are measured against: the budget's headline truth.
pub const ERRORS_AGAINST: &str = "the resolvable truth (the actual motion averaged over each \
     frame's exposure of the marker and band-limited to the footage's Nyquist rate: \
     ARCHITECTURE.md, \"Resolvable truth\"), so the rattle no camera at this frame rate can \
     follow is not charged to a source";

/// The per-seed numbers a decomposition splits: the fused ω2 and α2 mean square errors,
/// (rad/s)² and (rad/s²)², against the resolvable truth (the budget's headline). The one place that chooses
/// the error metric.
pub fn error_variances(b: &Budget) -> [f64; 2] {
    [b.omega.rms * b.omega.rms, b.alpha.rms * b.alpha.rms]
}

/// One configuration: a name (`none`, `all`, `X alone`, `X left out`, `exact corners`), its
/// scenario and where its corners come from.
#[derive(Debug, Clone)]
pub struct Configuration {
    pub name: String,
    pub scenario: Scenario,
    pub corners: CornerSource,
}

/// Name of the configuration that runs the estimator on the `none` scenario's exact corners.
pub const EXACT_CORNERS: &str = "exact corners";

/// The configurations of a decomposition of `base`.
#[derive(Debug, Clone)]
pub struct Plan {
    /// Sources decomposed: effects on in `base`, grouped by shared switch, not mechanism.
    pub sources: Vec<Vec<Effect>>,
    /// Mechanism effects on in `base`: kept as the motion in every configuration.
    pub motion: Vec<Effect>,
    /// Effects off in `base`.
    pub off: Vec<Effect>,
    /// `none`, `all`, then per source `alone` and `left out`, then `exact corners` (the
    /// `none` scenario with the detector replaced by the scene's exact corners: what is left is
    /// the estimator's own error, and V(none) − V(exact corners) is the corners' quantisation).
    pub configurations: Vec<Configuration>,
    /// For each configuration, the first configuration with the same scenario (run once).
    pub same_as: Vec<usize>,
}

/// The effects of the registry that are on in `base`, grouped by shared switch (a group is
/// decomposed as one source, named `a+b`), in registry order.
pub fn active_effects(base: &Scenario) -> Vec<Vec<Effect>> {
    let mut groups: Vec<Vec<Effect>> = Vec::new();
    for e in Effect::ALL {
        if !e.is_on(base) || groups.iter().flatten().any(|g| *g == e) {
            continue;
        }
        let mut group = vec![e];
        group.extend(
            e.shares_switch_with()
                .iter()
                .copied()
                .filter(|o| o.is_on(base)),
        );
        groups.push(group);
    }
    groups
}

pub fn group_name(group: &[Effect]) -> String {
    group.iter().map(|e| e.name()).collect::<Vec<_>>().join("+")
}

impl Plan {
    pub fn new(base: &Scenario) -> Plan {
        let (motion, sources): (Vec<Vec<Effect>>, Vec<Vec<Effect>>) = active_effects(base)
            .into_iter()
            .partition(|g| g.iter().any(|e| e.kind() == EffectKind::Mechanism));
        let off: Vec<Effect> = Effect::ALL
            .iter()
            .copied()
            .filter(|e| !sources.iter().chain(&motion).flatten().any(|a| a == e))
            .collect();
        let mut none = base.clone();
        for e in sources.iter().flatten() {
            e.switch_off(&mut none);
        }
        let mut configurations = vec![
            Configuration {
                name: "none".into(),
                scenario: none.clone(),
                corners: CornerSource::Detected,
            },
            Configuration {
                name: "all".into(),
                scenario: base.clone(),
                corners: CornerSource::Detected,
            },
        ];
        for group in &sources {
            let name = group_name(group);
            let mut alone = none.clone();
            group[0].copy_section(base, &mut alone);
            let mut out = base.clone();
            group[0].switch_off(&mut out);
            configurations.push(Configuration {
                name: format!("{name} alone"),
                scenario: alone,
                corners: CornerSource::Detected,
            });
            configurations.push(Configuration {
                name: format!("{name} left out"),
                scenario: out,
                corners: CornerSource::Detected,
            });
        }
        configurations.push(Configuration {
            name: EXACT_CORNERS.into(),
            scenario: none,
            corners: CornerSource::Exact,
        });
        let text: Vec<String> = configurations
            .iter()
            .map(|c| {
                let scenario = serde_json::to_string(&c.scenario).unwrap_or_default();
                format!("{:?} {scenario}", c.corners)
            })
            .collect();
        let same_as = (0..text.len())
            .map(|i| text.iter().position(|t| *t == text[i]).unwrap_or(i))
            .collect();
        Plan {
            sources,
            motion: motion.into_iter().flatten().collect(),
            off,
            configurations,
            same_as,
        }
    }

    /// Configurations actually run (the others repeat one of them).
    pub fn distinct(&self) -> Vec<usize> {
        (0..self.configurations.len())
            .filter(|&i| self.same_as[i] == i)
            .collect()
    }
}

/// How to run a decomposition.
#[derive(Debug, Clone)]
pub struct DecomposeOptions {
    pub rule: SeedRule,
    pub roi: bool,
}

impl Default for DecomposeOptions {
    fn default() -> Self {
        Self {
            rule: SeedRule::default(),
            roi: true,
        }
    }
}

/// Everything a decomposition computed.
#[derive(Debug, Clone)]
pub struct DecompositionOutput {
    pub name: String,
    /// Sources decomposed, mechanism effects kept as motion, effects off in the base scenario.
    pub sources: Vec<String>,
    pub motion: Vec<String>,
    pub effects_off: Vec<String>,
    /// Configuration names, and per configuration and seed the [`error_variances`].
    pub configurations: Vec<String>,
    pub per_seed: Vec<Vec<[f64; 2]>>,
    pub seed_values: Vec<u64>,
    pub omega_runs: PairedRuns,
    pub alpha_runs: PairedRuns,
    pub omega: Decomposition,
    pub alpha: Decomposition,
    pub seeds: usize,
    /// Seed count after each round.
    pub rounds: Vec<usize>,
    pub stop: StopReason,
    pub rule: SeedRule,
    /// Runs of the pipeline done (distinct configurations × seeds).
    pub runs: usize,
    /// Wall time of the runs (printed by the command, kept out of the files: they must not
    /// depend on the machine).
    pub elapsed_s: f64,
    pub files: Vec<PathBuf>,
}

fn paired(plan: &Plan, per_seed: &[Vec<[f64; 2]>], q: usize) -> PairedRuns {
    let series = |i: usize| per_seed[i].iter().map(|v| v[q]).collect::<Vec<f64>>();
    let mut runs = PairedRuns {
        none: series(0),
        all: series(1),
        exact: plan
            .configurations
            .iter()
            .position(|c| c.corners == CornerSource::Exact)
            .map(series),
        alone: vec![],
        left_out: vec![],
    };
    for (k, group) in plan.sources.iter().enumerate() {
        let name = group_name(group);
        runs.alone.push((name.clone(), series(2 + 2 * k)));
        runs.left_out.push((name, series(3 + 2 * k)));
    }
    runs
}

/// Runs the decomposition of `base`: seeds `base.seed + k`, added in rounds by `options.rule`.
/// `progress` gets a line after each round.
pub fn decompose_effects(
    base: &Scenario,
    options: &DecomposeOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<DecompositionOutput, DecompositionError> {
    let rule = options.rule;
    if rule.initial < 2 || rule.cap < rule.initial || rule.target_half_width.is_nan() {
        return Err(DecompositionError::Rule {
            initial: rule.initial,
            cap: rule.cap,
            target_half_width: rule.target_half_width,
        });
    }
    let started = std::time::Instant::now();
    let plan = Plan::new(base);
    let distinct = plan.distinct();
    let mut per_seed: Vec<Vec<[f64; 2]>> = vec![Vec::new(); plan.configurations.len()];
    let mut rounds = Vec::new();
    let mut wanted = rule.initial;
    let mut runs = 0;
    loop {
        let have = per_seed[0].len();
        let jobs: Vec<(usize, usize)> = (have..wanted)
            .flat_map(|k| distinct.iter().map(move |&c| (c, k)))
            .collect();
        let values = jobs
            .par_iter()
            .map(|&(c, k)| run_one(&plan.configurations[c], k, options.roi))
            .collect::<Result<Vec<[f64; 2]>, DecompositionError>>()?;
        runs += jobs.len();
        for (&(c, _), v) in jobs.iter().zip(values) {
            per_seed[c].push(v);
        }
        for i in 0..per_seed.len() {
            if plan.same_as[i] != i {
                per_seed[i] = per_seed[plan.same_as[i]].clone();
            }
        }
        rounds.push(wanted);
        let omega = decompose(&paired(&plan, &per_seed, 0))?;
        let alpha = decompose(&paired(&plan, &per_seed, 1))?;
        let widest = omega
            .widest_share_half_width()
            .max(alpha.widest_share_half_width());
        progress(&format!(
            "{wanted} seeds: widest share 95 % half-width {:.1} percentage points (target {:.1})",
            100.0 * widest,
            100.0 * rule.target_half_width
        ));
        match next_seeds(&rule, wanted, widest) {
            Ok(stop) => {
                let names = |v: &[Effect]| v.iter().map(|e| e.name().to_string()).collect();
                return Ok(DecompositionOutput {
                    name: base.name.clone(),
                    sources: plan.sources.iter().map(|g| group_name(g)).collect(),
                    motion: names(&plan.motion),
                    effects_off: names(&plan.off),
                    configurations: plan.configurations.iter().map(|c| c.name.clone()).collect(),
                    seed_values: (0..wanted as u64)
                        .map(|k| base.seed.wrapping_add(k))
                        .collect(),
                    omega_runs: paired(&plan, &per_seed, 0),
                    alpha_runs: paired(&plan, &per_seed, 1),
                    per_seed,
                    omega,
                    alpha,
                    seeds: wanted,
                    rounds,
                    stop,
                    rule,
                    runs,
                    elapsed_s: started.elapsed().as_secs_f64(),
                    files: vec![],
                });
            }
            Err(next) => wanted = next,
        }
    }
}

/// Seed `base.seed + k` of one configuration: its [`error_variances`].
/// Moves the rotation centre of `s` by a sub-pixel offset drawn from its seed alone (up to ±½ px
/// in x and y), the same in every configuration of that seed. Corner quantisation, most of the
/// error, depends on where the marker falls on the pixel grid: with one placement for every seed
/// it was one draw reported as certain (a zero-width interval on the quantisation row), and the
/// comparison of two rigs rested on that draw.
pub fn place_for_seed(s: &mut Scenario, purpose: crate::rng::Stream) {
    use rand::Rng;
    let mut r = crate::rng::stream(s.seed, purpose, 0);
    let (dx, dy): (f64, f64) = (r.gen::<f64>() - 0.5, r.gen::<f64>() - 0.5);
    let c = s
        .camera
        .rotation_centre_px
        .unwrap_or_else(|| s.camera.image_centre_px());
    s.camera.rotation_centre_px = Some([c[0] + dx, c[1] + dy]);
}

fn run_one(c: &Configuration, k: usize, roi: bool) -> Result<[f64; 2], DecompositionError> {
    let mut s = c.scenario.clone();
    s.seed = s.seed.wrapping_add(k as u64);
    place_for_seed(&mut s, crate::rng::Stream::DecomposePlacement);
    let options = RunOptions {
        roi,
        plots: false,
        write_files: false,
        corners: c.corners,
        ..RunOptions::default()
    };
    let out =
        run(&s, Path::new(""), &options, &|_, _| {}).map_err(|e| DecompositionError::Run {
            run: c.name.clone(),
            seed: s.seed,
            source: Box::new(e),
        })?;
    Ok(error_variances(&out.budget))
}

fn pct(m: &MeanCi) -> String {
    format!(
        "{:.1} % [{:.1}, {:.1}]",
        100.0 * m.mean,
        100.0 * m.ci95_low,
        100.0 * m.ci95_high
    )
}

fn sci(m: &MeanCi) -> String {
    format!("{:.3e} [{:.2e}, {:.2e}]", m.mean, m.ci95_low, m.ci95_high)
}

fn table(d: &Decomposition, symbol: &str, unit: &str) -> String {
    let mut s = format!(
        "| {symbol} | part of the MSE {unit} [95 % CI] | share of the whole [95 % CI] | \
         left out: V(all) − V(all without it) [95 % CI] | |\n|---|---|---|---|---|\n"
    );
    for r in &d.rows {
        let mut note = Vec::new();
        if r.share_indistinguishable_from_zero() {
            note.push("not distinguishable from 0".to_string());
        }
        if ![QUANTISATION, ESTIMATOR, INTERACTION].contains(&r.name.as_str())
            && r.variance.ci95_high < 0.0
        {
            note.push(
                "lowers the error (it smooths or dithers the corners' pixel quantisation)".into(),
            );
        }
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} |\n",
            r.name,
            sci(&r.variance),
            pct(&r.share),
            r.left_out.as_ref().map_or(String::new(), sci),
            note.join("; ")
        ));
    }
    s.push_str(&format!(
        "| **whole**: V(all) | {} | 100 % | | |\n",
        sci(&d.all)
    ));
    s
}

/// The markdown of a decomposition (numbers formatted from the results).
pub fn markdown_table(d: &DecompositionOutput) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "Mean square error (MSE) of the fused ω2 and α2 signals against {}, split into rows that \
         add up to the whole: the estimator on exact corners (every optional effect off and the \
         detector replaced by the scene's exact corners: the estimator's and differentiator's own \
         error, no pixels), corner quantisation (every optional effect off, detected on the \
         rendered pixels, minus the row before: what the pixel grid adds), each source's \
         contribution alone (V(alone) − V(none), paired by seed), and the interaction (what the \
         alone contributions leave over). Every configuration ran the same {} seed(s) ({}), with \
         common random numbers and a sub-pixel placement of the scene drawn per seed (corner \
         quantisation depends on it); seeds were added in rounds ({}) until every share's 95 % CI \
         half-width was below {:.1} percentage points, or {} seeds: stopped because {}. {} runs \
         of the pipeline.\n\n",
        ERRORS_AGAINST,
        d.seeds,
        seed_range(&d.seed_values),
        d.rounds
            .iter()
            .map(|n| n.to_string())
            .collect::<Vec<_>>()
            .join(" → "),
        100.0 * d.rule.target_half_width,
        d.rule.cap,
        d.stop.describe(),
        d.runs,
    ));
    s.push_str(&format!(
        "### ω2\n\n{}\n### α2\n\n{}\n",
        table(&d.omega, "ω2", "(rad/s)²"),
        table(&d.alpha, "α2", "(rad/s²)²")
    ));
    if !d.motion.is_empty() {
        s.push_str(&format!(
            "Motion, kept as in the base scenario in every configuration (what is measured, not a \
             source of error): {}.\n",
            d.motion.join(", ")
        ));
    }
    if !d.effects_off.is_empty() {
        s.push_str(&format!(
            "\nEffects off in the base scenario (not decomposed): {}.\n",
            d.effects_off.join(", ")
        ));
    }
    s
}

fn seed_range(seeds: &[u64]) -> String {
    match (seeds.first(), seeds.last()) {
        (Some(a), Some(b)) if a != b => format!("{a}..={b}"),
        (Some(a), _) => a.to_string(),
        _ => "none".into(),
    }
}

/// Writes the decomposition's files into `out_dir`; returns their paths.
pub fn write_outputs(
    d: &DecompositionOutput,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, DecompositionError> {
    std::fs::create_dir_all(out_dir).map_err(FileError::io(out_dir))?;
    let csv_path = out_dir.join("decomposition.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(FileError::csv(&csv_path))?;
    let ci = |m: &MeanCi| {
        [m.mean, m.ci95_low, m.ci95_high]
            .iter()
            .map(|v| format!("{v:e}"))
            .collect::<Vec<_>>()
    };
    let mut header = vec!["quantity".to_string(), "row".into()];
    for part in ["mse_part", "share", "left_out"] {
        for stat in ["mean", "ci95_low", "ci95_high"] {
            header.push(format!("{part}_{stat}"));
        }
    }
    header.push("distinguishable_from_0".into());
    header.push("seeds".into());
    w.write_record(&header).map_err(FileError::csv(&csv_path))?;
    for (quantity, dec) in [("omega2_rad2_s2", &d.omega), ("alpha2_rad2_s4", &d.alpha)] {
        for r in &dec.rows {
            let mut rec = vec![quantity.to_string(), r.name.clone()];
            rec.extend(ci(&r.variance));
            rec.extend(ci(&r.share));
            match &r.left_out {
                Some(m) => rec.extend(ci(m)),
                None => rec.extend([String::new(), String::new(), String::new()]),
            }
            rec.push((!r.share_indistinguishable_from_zero()).to_string());
            rec.push(dec.seeds.to_string());
            w.write_record(&rec).map_err(FileError::csv(&csv_path))?;
        }
    }
    w.flush().map_err(FileError::io(&csv_path))?;

    let seeds_path = out_dir.join("per_seed.csv");
    let mut w = csv::Writer::from_path(&seeds_path).map_err(FileError::csv(&seeds_path))?;
    w.write_record([
        "configuration",
        "seed",
        "omega2_mse_rad2_s2",
        "alpha2_mse_rad2_s4",
    ])
    .map_err(FileError::csv(&seeds_path))?;
    for (name, values) in d.configurations.iter().zip(&d.per_seed) {
        for (seed, v) in d.seed_values.iter().zip(values) {
            w.write_record([
                name.clone(),
                seed.to_string(),
                format!("{:e}", v[0]),
                format!("{:e}", v[1]),
            ])
            .map_err(FileError::csv(&seeds_path))?;
        }
    }
    w.flush().map_err(FileError::io(&seeds_path))?;

    let md_path = out_dir.join("decomposition.md");
    let md = format!("# Error decomposition: {}\n\n{}", d.name, markdown_table(d));
    std::fs::write(&md_path, md).map_err(FileError::io(&md_path))?;

    let mut files = vec![csv_path, seeds_path, md_path];
    for (quantity, dec) in [("omega", &d.omega), ("alpha", &d.alpha)] {
        let path = out_dir.join(format!("decomposition_{quantity}.png"));
        let bars: Vec<(String, f64)> = dec
            .rows
            .iter()
            .map(|r| (r.name.clone(), r.share.mean))
            .collect();
        let symbol = if quantity == "omega" { "ω2" } else { "α2" };
        bars_png(
            &path,
            &format!("{}: share of the {symbol} mean square error", d.name),
            "share of V(all)",
            &bars,
        )?;
        files.push(path);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn active_effects_of_fast_are_its_enabled_effects() {
        let s = crate::scenario::load_any("fast").unwrap();
        let names: Vec<String> = active_effects(&s).iter().map(|g| group_name(g)).collect();
        assert!(names.contains(&"pixel_noise".to_string()));
        assert!(
            !names.contains(&"motion_blur".to_string()),
            "fast switches it off"
        );
        assert!(
            !names.contains(&"frame_timing".to_string()),
            "fast has constant timing"
        );
    }

    #[test]
    fn mechanism_effects_are_motion_not_sources() {
        let s = crate::scenario::load_any("seed-internal-4k").unwrap();
        let groups: Vec<String> = active_effects(&s).iter().map(|g| group_name(g)).collect();
        assert!(
            groups.contains(&"backlash+overrotation".to_string()),
            "{groups:?}"
        );
        let plan = Plan::new(&s);
        let sources: Vec<String> = plan.sources.iter().map(|g| group_name(g)).collect();
        assert!(
            !sources.iter().any(|n| n.contains("backlash")),
            "{sources:?}"
        );
        assert!(plan.motion.contains(&Effect::Backlash));
        assert!(sources.contains(&"pixel_noise".to_string()));
        // Every configuration keeps the motion: the dynamics stay on.
        for c in &plan.configurations {
            assert!(Effect::Backlash.is_on(&c.scenario), "{}", c.name);
        }
        assert!(!Effect::PixelNoise.is_on(&plan.configurations[0].scenario));
    }

    #[test]
    fn repeated_configurations_run_once() {
        // Two sources: `a alone` is `b left out` and the reverse.
        let fast = crate::scenario::load_any("fast").unwrap();
        let mut base = fast.clone();
        for g in active_effects(&fast) {
            if !matches!(g[0], Effect::PixelNoise | Effect::OpticalBlur) {
                g[0].switch_off(&mut base);
            }
        }
        let plan = Plan::new(&base);
        assert_eq!(plan.sources.len(), 2);
        assert_eq!(plan.configurations.len(), 7);
        assert_eq!(plan.same_as[5], 2);
        assert_eq!(plan.same_as[4], 3);
        // `exact corners` has the `none` scenario but other corners: it runs on its own.
        assert_eq!(plan.configurations[6].name, EXACT_CORNERS);
        assert_eq!(plan.distinct(), vec![0, 1, 2, 3, 6]);
    }

    #[test]
    fn placement_is_drawn_per_seed_and_shared_by_every_configuration_of_it() {
        let fast = crate::scenario::load_any("fast").unwrap();
        let plan = Plan::new(&fast);
        let centre = fast.camera.image_centre_px();
        let offset = |s: &Scenario, k: u64| {
            let mut s = s.clone();
            s.seed = s.seed.wrapping_add(k);
            place_for_seed(&mut s, crate::rng::Stream::DecomposePlacement);
            let c = s.camera.rotation_centre_px.unwrap();
            [c[0] - centre[0], c[1] - centre[1]]
        };
        let mut offsets = Vec::new();
        for k in 0..8 {
            let first = offset(&plan.configurations[0].scenario, k);
            for c in &plan.configurations {
                assert_eq!(offset(&c.scenario, k), first, "seed {k}, `{}`", c.name);
            }
            assert!(first.iter().all(|d| d.abs() <= 0.5), "{first:?}");
            offsets.push(first);
        }
        // Eight seeds sample the pixel grid: no two share a placement, and they spread over it.
        for a in 0..offsets.len() {
            for b in a + 1..offsets.len() {
                assert_ne!(offsets[a], offsets[b]);
            }
        }
        let spread = |i: usize| {
            let (lo, hi) = offsets
                .iter()
                .fold((1.0f64, -1.0f64), |m, o| (m.0.min(o[i]), m.1.max(o[i])));
            hi - lo
        };
        assert!(spread(0) > 0.3 && spread(1) > 0.3, "{offsets:?}");
    }

    /// Common random numbers: each random draw is keyed by (seed, its own purpose, frame), so
    /// switching one effect on does not shift another effect's draws. Checked on the
    /// decomposition's own configurations of a scenario with three seeded effects.
    #[test]
    fn switching_one_effect_on_does_not_shift_another_effects_draws() {
        use crate::pipeline::rig::Rig;
        use crate::render::effects::camera_vibration::Vibration;
        use crate::render::frame::{render_frame, FrameRequest};
        use crate::render::raster::PixelRect;
        use toml::Value;
        let fast = crate::scenario::load_any("fast").unwrap();
        let mut vfr = toml::map::Map::new();
        vfr.insert("kind".into(), Value::String("vfr".into()));
        vfr.insert("jitter_s".into(), Value::Float(5e-4));
        let base = crate::scenario::with_overrides(
            &fast,
            &[
                ("frame_timing.model".into(), Value::Table(vfr)),
                (
                    "effects.camera_vibration.enabled".into(),
                    Value::Boolean(true),
                ),
                (
                    "effects.camera_vibration.random.x_rms_px".into(),
                    Value::Float(0.5),
                ),
                ("effects.optical_blur.enabled".into(), Value::Boolean(false)),
                ("effects.lighting.enabled".into(), Value::Boolean(false)),
            ],
            Path::new("crn"),
        )
        .unwrap();
        let plan = Plan::new(&base);
        let config = |name: &str| {
            let c = plan.configurations.iter().find(|c| c.name == name);
            c.unwrap_or_else(|| panic!("no `{name}`")).scenario.clone()
        };
        let all = config("all");
        // Frame times: the same draws with or without the image effects.
        let timing_alone = Rig::new(&config("frame_timing alone")).unwrap();
        let timing_all = Rig::new(&all).unwrap();
        assert_eq!(timing_alone.frame_times, timing_all.frame_times);
        let constant = Rig::new(&config("none")).unwrap();
        assert_ne!(
            timing_alone.frame_times, constant.frame_times,
            "jitter is on"
        );
        // Vibration: the same random sinusoids with or without frame timing and noise.
        let (w, h) = (1280, 720);
        let vib = |s: &Scenario| Vibration::new(&s.effects.camera_vibration, s.seed, w, h).unwrap();
        let alone = vib(&config("camera_vibration alone"));
        for t in [0.0, 0.37, 1.9] {
            assert_eq!(alone.at(t), vib(&all).at(t));
        }
        // Pixel noise: a background patch far from the marker renders to the same noisy values
        // with frame timing on or off (the frame is at another time, the noise is the same).
        let noise_alone = config("pixel_noise alone");
        let vib_left_out = config("camera_vibration left out");
        let patch = |s: &Scenario, k: usize| {
            let rig = Rig::new(s).unwrap();
            let t = rig.frame_times.as_slice()[k];
            let frame = render_frame(
                &rig.animated(),
                &rig.settings,
                &FrameRequest {
                    index: k as u64,
                    t_s: rig.render_time_s(t),
                    window: PixelRect::new(0, 0, 24, 24),
                },
            );
            frame.data
        };
        for k in [1, 5] {
            let a = patch(&noise_alone, k);
            assert_eq!(a, patch(&vib_left_out, k), "frame {k}");
            assert!(a.iter().any(|v| *v != a[0]), "the patch is noisy");
        }
    }
}
