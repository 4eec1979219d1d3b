//! `geneva slurm script SWEEP.toml --out DIR --shards N [...]`: writes an `sbatch` array script
//! (task I runs shard I/N of the sweep), a merge script for a job that depends on the whole
//! array (`afterok`), and `submit.sh`, which submits both; prints the submit command. The same
//! for a Monte Carlo study (`--montecarlo S --seeds K`) and for the candidate fits of one
//! diagnosis (`--diagnose S --video F …`, merged by `geneva diagnose … --merge`).

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use geneva_vision::io::output_dir::write_file_atomic;
use geneva_vision::shard::slurm::{self, Job, ScriptSpec};
use geneva_vision::sweep::SweepSpec;
use std::path::{Path, PathBuf};

#[derive(Subcommand, Debug)]
pub enum SlurmCmd {
    /// Write sbatch scripts that run a sweep (or, with --montecarlo, a Monte Carlo study) as a
    /// Slurm array job plus a dependent merge job.
    Script(ScriptArgs),
}

#[derive(Args, Debug, Clone)]
pub struct ScriptArgs {
    /// Sweep file.
    #[arg(required_unless_present_any = ["montecarlo", "diagnose"], conflicts_with_all = ["montecarlo", "diagnose"])]
    pub sweep: Option<PathBuf>,
    /// A Monte Carlo study of this scenario (file or built-in name) instead of a sweep.
    #[arg(long, requires = "seeds", conflicts_with = "diagnose")]
    pub montecarlo: Option<String>,
    /// Seeds of the Monte Carlo study (or of the diagnosis: `geneva diagnose --seeds`).
    #[arg(long)]
    pub seeds: Option<usize>,
    /// The candidate fits of `geneva diagnose --scenario S` on the footage given by --video,
    /// --frames/--timestamps or --tracks, instead of a sweep.
    #[arg(long)]
    pub diagnose: Option<String>,
    #[command(flatten)]
    pub source: super::source_args::SourceArgs,
    /// Candidate effects of the diagnosis (`geneva diagnose --effects`).
    #[arg(long, value_delimiter = ',', requires = "diagnose")]
    pub effects: Option<Vec<String>>,
    /// Fit seeds of the diagnosis (`geneva diagnose --fit-seeds`; the shards and the merge
    /// must fit on the same ones).
    #[arg(long, requires = "diagnose", value_parser = super::diagnose_cmd::parse_fit_seeds)]
    pub fit_seeds: Option<usize>,
    /// Refits of the best candidate at merge time (`geneva diagnose --refits`).
    #[arg(long, requires = "diagnose", conflicts_with = "no_refit", value_parser = super::diagnose_cmd::parse_count)]
    pub refits: Option<usize>,
    /// Skip the merge's refits of the best candidate (`geneva diagnose --no-refit`).
    #[arg(long, requires = "diagnose")]
    pub no_refit: bool,
    /// Footages simulated at the best candidate's values, fitted at merge time to measure the
    /// footage's own noise (`geneva diagnose --bootstrap`).
    #[arg(long, requires = "diagnose", value_parser = super::diagnose_cmd::parse_bootstrap)]
    pub bootstrap: Option<usize>,
    /// Output folder of the sweep (shared by all nodes).
    #[arg(long)]
    pub out: PathBuf,
    /// Number of array tasks (shards).
    #[arg(long)]
    pub shards: usize,
    #[arg(long)]
    pub partition: Option<String>,
    /// Time limit per task (`HH:MM:SS` or any sbatch --time form).
    #[arg(long)]
    pub time: Option<String>,
    #[arg(long)]
    pub cpus_per_task: Option<usize>,
    /// Memory per task (sbatch --mem form, e.g. 8G).
    #[arg(long)]
    pub mem: Option<String>,
    /// Folder for the scripts and Slurm logs (default: DIR-slurm beside DIR).
    #[arg(long)]
    pub scripts: Option<PathBuf>,
    /// The geneva binary the nodes run (default: this one).
    #[arg(long)]
    pub geneva: Option<PathBuf>,
    /// Write the scripts (and let the tasks run) even when one shard's work is estimated above
    /// the time or memory limits.
    #[arg(long)]
    pub yes: bool,
}

pub fn run(cmd: SlurmCmd) -> Result<()> {
    match cmd {
        SlurmCmd::Script(a) => script(a),
    }
}

/// A path for the nodes: absolute, and one a script line can hold (a refusal names `what`).
fn node_path(what: &str, p: &Path) -> Result<PathBuf> {
    let abs = std::path::absolute(p).with_context(|| format!("{what} {}", p.display()))?;
    slurm::check_path(what, &abs)?;
    Ok(abs)
}

/// The job the tasks will run, checked as the command itself checks it before any work
/// (inputs, options, the work of one shard against the limits): a job that would refuse to run
/// gets no script.
fn job(a: &ScriptArgs, out: &Path) -> Result<Job> {
    let shards = a.shards.max(1) as f64;
    let out_s = out.to_string_lossy().into_owned();
    let job = match (&a.sweep, &a.montecarlo, a.seeds) {
        _ if a.diagnose.is_some() => diagnose_job(a, out)?,
        (Some(sweep), None, _) => {
            let spec = SweepSpec::load(sweep)?;
            if spec.adaptive.is_some() {
                bail!(
                    "{}: [adaptive] seeds are picked round by round from the results, so the \
                     sweep runs on one machine (`geneva sweep`); drop [adaptive] to shard it",
                    sweep.display()
                );
            }
            super::refuse_inputs_inside(out, &super::sweep_cmd::sweep_inputs(sweep))?;
            // Its base and every point's settings, as the sweep itself checks them.
            geneva_vision::sweep::check(&spec, sweep)?;
            let base = geneva_vision::sweep::grid::load_base(&spec, sweep)?;
            let mut work = super::work::sweep_workload(&spec, &base, sweep);
            work.runs = (work.runs / shards).ceil();
            super::work::confirm(
                &format!("each shard of sweep {}", sweep.display()),
                &work,
                a.yes,
            )?;
            let sweep = node_path("the sweep file", sweep)?;
            let sweep_s = sweep.to_string_lossy().into_owned();
            Job {
                study: vec!["sweep".into(), sweep_s.clone()],
                merge: vec![
                    "sweep".into(),
                    "merge".into(),
                    out_s,
                    "--sweep".into(),
                    sweep_s,
                ],
                what: format!("Sweep {}", sweep.display()),
            }
        }
        (None, Some(scenario), Some(seeds)) => {
            if seeds == 0 {
                bail!("--seeds 0: a Monte Carlo study needs at least one seed");
            }
            super::refuse_inputs_inside(out, &super::scenario_inputs("--montecarlo", scenario))?;
            let (spec, s) = scenario_spec(scenario)?;
            let seeds_here = seeds.div_ceil(a.shards.max(1));
            let work =
                geneva_vision::pipeline::workload::Workload::of(&s, true).times(seeds_here as f64);
            super::work::confirm(
                &format!("each shard's {seeds_here} seeds of {}", s.name),
                &work,
                a.yes,
            )?;
            Job {
                study: vec![
                    "montecarlo".into(),
                    spec,
                    "--seeds".into(),
                    seeds.to_string(),
                ],
                merge: vec!["montecarlo".into(), "merge".into(), out_s],
                what: format!("Monte Carlo of {scenario} over {seeds} seeds"),
            }
        }
        _ => bail!("give a sweep file, --montecarlo SCENARIO --seeds K, or --diagnose SCENARIO"),
    };
    Ok(job)
}

type DirectiveCheck = fn(&str) -> Result<(), slurm::SlurmError>;

fn script(a: ScriptArgs) -> Result<()> {
    let out = node_path("--out", &a.out)?;
    // Every value of a directive, before the job is looked at.
    let directives: [(DirectiveCheck, &Option<String>); 3] = [
        (slurm::check_partition, &a.partition),
        (slurm::check_time, &a.time),
        (slurm::check_mem, &a.mem),
    ];
    for (check, value) in directives {
        if let Some(v) = value {
            check(v)?;
        }
    }
    let mut job = job(&a, &out)?;
    if a.yes {
        // The tasks run what was confirmed here.
        job.study.push("--yes".into());
    }
    let geneva = match &a.geneva {
        Some(g) => node_path("--geneva", g)?,
        None => std::env::current_exe().context("path of this geneva binary")?,
    };
    let dir = match &a.scripts {
        Some(d) => node_path("--scripts", d)?,
        None => {
            let name = out
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .context("--out needs a folder name")?;
            out.with_file_name(format!("{name}-slurm"))
        }
    };
    let spec = ScriptSpec {
        job,
        out,
        scripts: dir.clone(),
        geneva,
        shards: a.shards,
        cpus_per_task: a.cpus_per_task.unwrap_or(1),
        partition: a.partition.clone(),
        time: a.time.clone(),
        mem: a.mem.clone(),
    };
    let scripts = slurm::scripts(&spec)?;
    std::fs::create_dir_all(dir.join("logs"))
        .with_context(|| format!("{}: cannot create", dir.join("logs").display()))?;
    for (file, text) in scripts {
        let path = dir.join(file);
        write_file_atomic(&path, text.as_bytes())?;
        println!("wrote {}", path.display());
    }
    let q = |f: &str| slurm::shell_quote(&dir.join(f).to_string_lossy());
    println!(
        "submit with:\n  bash {}\n(= sbatch {}, then sbatch --dependency=afterok:<array job> {})",
        q("submit.sh"),
        q("shards.sbatch"),
        q("merge.sbatch")
    );
    Ok(())
}

/// A scenario for the nodes: a file by its absolute path, a built-in name as it is (loaded
/// and checked here, not on the cluster), and the scenario.
fn scenario_spec(scenario: &str) -> Result<(String, geneva_vision::scenario::Scenario)> {
    let s = geneva_vision::scenario::load_any(scenario)?;
    let spec = if Path::new(scenario).is_file() {
        node_path("the scenario", Path::new(scenario))?
            .to_string_lossy()
            .into_owned()
    } else {
        slurm::check_path("the scenario", Path::new(scenario))?;
        scenario.to_string()
    };
    Ok((spec, s))
}

/// The candidate fits of one diagnosis: every task recomputes the prefix and fits its share;
/// the merge, with the same arguments, writes the report.
fn diagnose_job(a: &ScriptArgs, out: &Path) -> Result<Job> {
    use geneva_vision::pipeline::analyze::Source;
    let scenario = a.diagnose.as_deref().unwrap_or_default();
    if let Some(seeds) = a.seeds.filter(|s| *s < 2) {
        bail!("--seeds {seeds}: at least 2 seeds are needed for a spread");
    }
    let mut inputs = a.source.inputs();
    inputs.extend(super::scenario_inputs("--diagnose", scenario));
    super::refuse_inputs_inside(out, &inputs)?;
    let (spec, nominal) = scenario_spec(scenario)?;
    let abs = |what: &str, p: &Path| -> Result<String> {
        if !p.exists() {
            bail!("{}: no such file or folder", p.display());
        }
        Ok(node_path(what, p)?.to_string_lossy().into_owned())
    };
    let mut study: Vec<String> = vec!["diagnose".into(), "--scenario".into(), spec];
    match a.source.source()? {
        Source::Video(v) => study.extend(["--video".into(), abs("--video", &v)?]),
        Source::Frames { dir, timestamps } => study.extend([
            "--frames".into(),
            abs("--frames", &dir)?,
            "--timestamps".into(),
            abs("--timestamps", &timestamps)?,
        ]),
        Source::Tracks(t) => study.extend(["--tracks".into(), abs("--tracks", &t)?]),
    }
    let effects = super::effects_arg::parse_effects(a.effects.as_deref())?;
    if let Some(effects) = &effects {
        let names: Vec<&str> = effects.iter().map(|e| e.name()).collect();
        study.extend(["--effects".into(), names.join(",")]);
    }
    for (name, value) in [
        ("--seeds", a.seeds),
        ("--fit-seeds", a.fit_seeds),
        ("--refits", a.refits),
    ] {
        if let Some(v) = value {
            study.extend([name.to_string(), v.to_string()]);
        }
    }
    if a.no_refit {
        study.push("--no-refit".into());
    }
    if let Some(b) = a.bootstrap {
        study.extend(["--bootstrap".to_string(), b.to_string()]);
    }
    // What `geneva diagnose` confirms before its work, on the seeds the tasks will use.
    let seeds = a
        .seeds
        .unwrap_or(geneva_vision::pipeline::diagnose::DiagnoseOptions::default().seeds);
    let work = geneva_vision::pipeline::workload::Workload::of(&nominal, true).times(seeds as f64);
    super::work::confirm(
        &format!(
            "the diagnosis's nominal simulations alone ({seeds} seeds of {})",
            nominal.name
        ),
        &work,
        a.yes,
    )?;
    let mut merge = study.clone();
    merge.extend([
        "--out".into(),
        out.to_string_lossy().into_owned(),
        "--merge".into(),
    ]);
    Ok(Job {
        merge,
        study,
        what: format!("The candidate fits of a diagnosis against {scenario}"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(job: Job) -> ScriptSpec {
        ScriptSpec {
            job,
            out: "/data/it's".into(),
            scripts: "/data/it-slurm".into(),
            geneva: "/opt/geneva".into(),
            shards: 4,
            cpus_per_task: 8,
            partition: Some("gpu".into()),
            time: Some("01:00:00".into()),
            mem: None,
        }
    }

    fn words(w: &[&str]) -> Vec<String> {
        w.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn scripts_run_one_shard_per_array_task_and_merge_after_all_succeeded() {
        let job = Job {
            study: words(&["sweep", "/data/s.toml"]),
            merge: words(&["sweep", "merge", "/data/it's", "--sweep", "/data/s.toml"]),
            what: "Sweep".into(),
        };
        let s = slurm::scripts(&spec(job)).unwrap();
        let (shards, merge, submit) = (&s[0].1, &s[1].1, &s[2].1);
        for want in [
            "#SBATCH --array=0-3\n",
            "#SBATCH --cpus-per-task=8\n",
            "#SBATCH --partition=gpu\n",
            "#SBATCH --time=01:00:00\n",
            "#SBATCH --output=/data/it-slurm/logs/shard-%a.log\n",
            "exec /opt/geneva sweep /data/s.toml --out '/data/it'\\''s' --shard \"${SLURM_ARRAY_TASK_ID}/4\"",
            "RAYON_NUM_THREADS=\"${SLURM_CPUS_PER_TASK:-8}\"",
        ] {
            assert!(shards.contains(want), "`{want}` in\n{shards}");
        }
        assert!(!shards.contains("--mem"));
        assert!(
            merge.contains("sweep merge '/data/it'\\''s' --sweep /data/s.toml"),
            "{merge}"
        );
        assert!(
            submit.contains("--dependency=afterok:\"$array\""),
            "{submit}"
        );
    }

    /// `slurm script` as the command line `args` gives it.
    fn parse(args: &[&str]) -> std::result::Result<ScriptArgs, clap::Error> {
        #[derive(clap::Parser)]
        struct T {
            #[command(subcommand)]
            cmd: SlurmCmd,
        }
        let mut all = vec!["x", "script"];
        all.extend_from_slice(args);
        <T as clap::Parser>::try_parse_from(all).map(|t| {
            let SlurmCmd::Script(a) = t.cmd;
            a
        })
    }

    #[test]
    fn a_diagnosis_runs_its_candidate_fits_as_shards_and_merges_with_the_same_arguments(
    ) -> Result<()> {
        let tmp = tempfile::tempdir().unwrap();
        let tracks = tmp.path().join("t.csv");
        std::fs::write(&tracks, "frame,t_s\n").unwrap();
        let t = tracks.to_str().unwrap();
        let try_parse = |extra: &[&str]| {
            let mut args = vec!["--diagnose", "fast", "--out", "/d", "--shards", "3"];
            args.extend_from_slice(extra);
            parse(&args)
        };
        let a = try_parse(&[
            "--tracks",
            t,
            "--effects",
            "lighting,pixel_noise",
            "--seeds",
            "4",
            "--fit-seeds",
            "5",
            "--no-refit",
        ])?;
        let job = diagnose_job(&a, Path::new("/d"))?;
        let study = words(&[
            "diagnose",
            "--scenario",
            "fast",
            "--tracks",
            t,
            "--effects",
            "lighting,pixel_noise",
            "--seeds",
            "4",
            "--fit-seeds",
            "5",
            "--no-refit",
        ]);
        assert_eq!(job.study, study);
        let mut merge = study.clone();
        merge.extend(words(&["--out", "/d", "--merge"]));
        assert_eq!(job.merge, merge);
        let mut spec = spec(job);
        spec.out = "/d".into();
        let s = slurm::scripts(&spec)?;
        let line = format!("exec /opt/geneva {} --out /d --shard", slurm_words(&study));
        assert!(s[0].1.contains(&line), "{line}\n{}", s[0].1);
        assert!(s[1]
            .1
            .contains(&format!("exec /opt/geneva {}", slurm_words(&merge))));
        // Left out, the diagnosis's own defaults hold, on the shards and the merge alike.
        let base = words(&["diagnose", "--scenario", "fast", "--tracks", t]);
        let job = diagnose_job(&try_parse(&["--tracks", t])?, Path::new("/d"))?;
        assert_eq!(job.study, base);
        // The refits and the bootstrap go to the merge as to the shards.
        for (flag, n) in [("--refits", "4"), ("--bootstrap", "3")] {
            let job = diagnose_job(&try_parse(&["--tracks", t, flag, n])?, Path::new("/d"))?;
            let mut want = base.clone();
            want.extend(words(&[flag, n]));
            assert_eq!(job.study, want);
        }
        assert!(try_parse(&["--tracks", t, "--refits", "4", "--no-refit"]).is_err());
        // One fit seed, or one bootstrap footage, is refused here, as `geneva diagnose`
        // refuses it.
        assert!(try_parse(&["--tracks", t, "--fit-seeds", "1"]).is_err());
        assert!(try_parse(&["--tracks", t, "--bootstrap", "1"]).is_err());
        // Footage that is not there fails here, not on the cluster; so do one seed.
        let a = try_parse(&["--tracks", "/no/such.csv"])?;
        let e = diagnose_job(&a, Path::new("/d")).err().unwrap().to_string();
        assert!(e.contains("/no/such.csv"), "{e}");
        let a = try_parse(&["--tracks", t, "--seeds", "1"])?;
        let e = diagnose_job(&a, Path::new("/d")).err().unwrap().to_string();
        assert!(e.contains("--seeds 1"), "{e}");
        Ok(())
    }

    fn slurm_words(w: &[String]) -> String {
        w.iter()
            .map(|x| slurm::shell_quote(x))
            .collect::<Vec<_>>()
            .join(" ")
    }
}
