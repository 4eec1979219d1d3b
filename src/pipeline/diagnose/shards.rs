//! One diagnosis as shards: the work unit is one candidate effect's single-effect fit and
//! judgement ([`Fitter::fit_single`]), the units are the signature-significant candidates in
//! their screening order.
//!
//! Every shard, and the merge, recomputes the deterministic prefix (the real measurement, the
//! nuisance alignment, the nominal simulations): it costs about as much as the nominal
//! simulation, once per shard. A shard fits every candidate it owns (`unit % N == I`) without
//! the best-score bound and without a deadline, since neither is known before all candidates
//! are in; the merge then runs the one candidate loop of [`super::diagnose`] with the stored
//! results in place of fits, so pruning, ranking, grouping, the pair stage (run at merge time)
//! and the report are those of a one-machine run, byte for byte.
//!
//! A record keeps every f64 as its bit pattern (a JSON integer): exact, infinities and NaN
//! included, whatever the JSON float parser does.

use super::{DiagnoseError, DiagnoseOptions};
use crate::diagnose::cells::{channel, CellKey, PHASES};
use crate::diagnose::fit::{Evaluated, FitKind, Fitted, FittedRunoutForm, Fitter};
use crate::diagnose::gap::{CellGap, GapMap, GapOptions};
use crate::diagnose::verdict::Outcome;
use crate::pipeline::analyze::Source;
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use crate::shard::{Manifest, Shard, Study, UnitDirs};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;

/// How a diagnosis runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    /// Everything on this machine.
    Whole,
    /// Shard `I/N` of the candidate fits into `DIR/shards/I/`; no report.
    Shard { shard: Shard, restart: bool },
    /// The report from the complete shards of `DIR/shards/`.
    Merge,
}

/// Study kind in the shard manifests.
pub const KIND: &str = "diagnose";

/// The candidate fits of one diagnosis as a [`Study`].
pub struct CandidateStudy<'a> {
    /// Locked only to fork: the fits run on forks, so units never wait on each other.
    fitter: Mutex<Fitter<'a>>,
    units: Vec<Effect>,
    manifest: Manifest,
}

impl<'a> CandidateStudy<'a> {
    pub fn new(fitter: Fitter<'a>, units: Vec<Effect>, manifest: Manifest) -> Self {
        Self {
            fitter: Mutex::new(fitter),
            units,
            manifest,
        }
    }
}

impl Study for CandidateStudy<'_> {
    type Error = DiagnoseError;

    fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn run_unit(&self, unit: usize, _work_dir: &Path) -> Result<String, DiagnoseError> {
        let e = *self.units.get(unit).ok_or(DiagnoseError::NoUnit {
            unit,
            units: self.units.len(),
        })?;
        let fork = self.fitter.lock().unwrap_or_else(|p| p.into_inner()).fork();
        let (evaluated, simulations) = fork.fit_single(e)?;
        encode(&evaluated, simulations)
    }

    fn finalize(&self, _: &[String], _: UnitDirs, out_dir: &Path) -> Result<(), DiagnoseError> {
        Err(DiagnoseError::Output {
            file: out_dir.to_path_buf(),
            message: "diagnosis shards are merged by `geneva diagnose … --merge`, which \
                      recomputes the prefix and runs the pair stage"
                .into(),
        })
    }

    fn unit_name(&self, unit: usize) -> String {
        self.units
            .get(unit)
            .map_or_else(|| format!("candidate {unit}"), |e| e.name().to_string())
    }
}

/// The inputs that determine a diagnosis' candidate fits: the scenario as resolved, the
/// source, the options, and what the prefix made of them (the units, the nominal gap), so a
/// change of the footage's content is caught even under the same file name.
pub fn manifest(
    nominal: &Scenario,
    source: &Source,
    options: &DiagnoseOptions,
    fitter: &Fitter<'_>,
    units: &[Effect],
) -> Manifest {
    let names = |v: &[Effect]| v.iter().map(|e| e.name()).collect::<Vec<_>>();
    let mut inputs = BTreeMap::new();
    inputs.insert(
        "scenario".to_string(),
        serde_json::to_value(nominal).unwrap_or(Value::Null),
    );
    inputs.insert("source".to_string(), json!(format!("{source:?}")));
    inputs.insert(
        "options".to_string(),
        json!({
            "seeds": options.seeds,
            "fit_seeds": options.fit_seeds,
            "escalate_seeds": options.escalate_seeds,
            "eval_seeds": fitter.eval_seeds.len(),
            "effects": options.effects.as_deref().map(names),
            "fdr_q": options.gap.fdr_q,
            "dead_zone_z": options.gap.dead_zone_z,
            "min_sims": options.gap.min_sims,
        }),
    );
    let g = &fitter.nominal_gap;
    inputs.insert(
        "prefix".to_string(),
        json!({
            "candidates": names(units),
            "frames": fitter.real.t_s.len(),
            "nominal gap D0": g.total,
            "nominal gap D0 bits": format!("{:016x}", g.total.to_bits()),
            "significant cells": g.n_significant(),
            "cells": g.cells.len(),
        }),
    );
    Manifest::new(KIND, units.len(), inputs)
}

/// A candidate's fit and judgement, and the simulations it cost.
pub type StoredFit = (Evaluated, usize);

/// The stored result of every unit, from the complete shards of `dir` (an error naming the
/// missing candidates and unfinished shards when one is missing).
pub fn stored(
    dir: &Path,
    manifest: &Manifest,
    units: &[Effect],
) -> Result<Vec<(Effect, StoredFit)>, DiagnoseError> {
    let name = |u: usize| {
        units
            .get(u)
            .map_or_else(|| format!("candidate {u}"), |e| e.name().to_string())
    };
    let (records, _) = crate::shard::shard_records(dir, manifest, &name)?;
    let place = dir.join(crate::shard::SHARDS);
    units
        .iter()
        .zip(&records)
        .map(|(e, text)| Ok((*e, decode(text, &place)?)))
        .collect()
}

#[derive(Serialize, Deserialize)]
struct Record {
    candidate: String,
    simulations: usize,
    effects: Vec<FittedRecord>,
    cells: Vec<CellRecord>,
    total: u64,
    fdr_q: u64,
    dead_zone_z: u64,
    min_sims: usize,
    remaining: u64,
    params: usize,
    significant_left: usize,
}

#[derive(Serialize, Deserialize)]
struct FittedRecord {
    effect: String,
    values: Vec<u64>,
    stds: Vec<u64>,
    method: String,
    simulations: usize,
    /// An axis runout's form as bits: cycles per wheel revolution, phase, phase's σ.
    #[serde(default)]
    runout_form: Option<[u64; 3]>,
    /// [`FitKind::name`]. Absent from records written by builds before fits carried it:
    /// such a record is refused (its shard is run again), never read off the method's words.
    #[serde(default)]
    kind: Option<String>,
}

#[derive(Serialize, Deserialize)]
struct CellRecord {
    channel: String,
    phase: String,
    band: Option<u8>,
    real: u64,
    sim_mean: u64,
    sim_std: u64,
    sims: usize,
    z: u64,
    p: u64,
    significant: bool,
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn floats(v: &[u64]) -> Vec<f64> {
    v.iter().map(|b| f64::from_bits(*b)).collect()
}

/// One candidate's result and the simulations it cost, as one line of JSON.
pub fn encode(e: &Evaluated, simulations: usize) -> Result<String, DiagnoseError> {
    let g = &e.gap;
    let record = Record {
        candidate: super::candidate_name(e),
        simulations,
        effects: e
            .effects
            .iter()
            .map(|f| FittedRecord {
                effect: f.effect.name().into(),
                values: bits(&f.values),
                stds: bits(&f.stds),
                method: f.method.clone(),
                simulations: f.simulations,
                runout_form: f.runout_form.map(|r| {
                    [
                        r.cycles_per_wheel_rev.to_bits(),
                        r.phase_rad.to_bits(),
                        r.phase_std_rad.to_bits(),
                    ]
                }),
                kind: Some(f.kind.name().into()),
            })
            .collect(),
        cells: g
            .cells
            .iter()
            .map(|c| CellRecord {
                channel: c.key.channel.into(),
                phase: c.key.phase.into(),
                band: c.key.band,
                real: c.real.to_bits(),
                sim_mean: c.sim_mean.to_bits(),
                sim_std: c.sim_std.to_bits(),
                sims: c.sims,
                z: c.z.to_bits(),
                p: c.p.to_bits(),
                significant: c.significant,
            })
            .collect(),
        total: g.total.to_bits(),
        fdr_q: g.options.fdr_q.to_bits(),
        dead_zone_z: g.options.dead_zone_z.to_bits(),
        min_sims: g.options.min_sims,
        remaining: e.outcome.remaining.to_bits(),
        params: e.outcome.params,
        significant_left: e.outcome.significant_left,
    };
    serde_json::to_string(&record).map_err(|source| DiagnoseError::Record {
        place: "candidate record".into(),
        what: "cannot be written".into(),
        source,
    })
}

/// The inverse of [`encode`]; `place` names where the record was read, for errors.
pub fn decode(text: &str, place: &Path) -> Result<(Evaluated, usize), DiagnoseError> {
    let bad = |message: String| DiagnoseError::Output {
        file: place.to_path_buf(),
        message,
    };
    let r: Record = serde_json::from_str(text).map_err(|source| DiagnoseError::Record {
        place: place.to_path_buf(),
        what: "a candidate record does not parse".into(),
        source,
    })?;
    let effects = r
        .effects
        .iter()
        .map(|f| {
            let effect = Effect::from_name(&f.effect)
                .ok_or_else(|| bad(format!("{}: unknown effect `{}`", r.candidate, f.effect)))?;
            let kind = match &f.kind {
                Some(name) => FitKind::from_name(name).ok_or_else(|| {
                    bad(format!(
                        "{}: {}'s fit has an unknown kind `{name}`",
                        r.candidate, f.effect
                    ))
                })?,
                None => {
                    return Err(bad(format!(
                        "{}: {}'s fit states no kind (a record of an older build of geneva): \
                         run its shard again",
                        r.candidate, f.effect
                    )))
                }
            };
            Ok(Fitted {
                effect,
                values: floats(&f.values),
                stds: floats(&f.stds),
                method: f.method.clone(),
                simulations: f.simulations,
                runout_form: f.runout_form.map(|[c, p, s]| FittedRunoutForm {
                    cycles_per_wheel_rev: f64::from_bits(c),
                    phase_rad: f64::from_bits(p),
                    phase_std_rad: f64::from_bits(s),
                }),
                kind,
            })
        })
        .collect::<Result<Vec<_>, DiagnoseError>>()?;
    let cells = r
        .cells
        .iter()
        .map(|c| {
            let ch = channel(&c.channel)
                .ok_or_else(|| bad(format!("{}: unknown channel `{}`", r.candidate, c.channel)))?;
            let phase = PHASES
                .iter()
                .find(|p| **p == c.phase)
                .ok_or_else(|| bad(format!("{}: unknown phase `{}`", r.candidate, c.phase)))?;
            Ok(CellGap {
                key: CellKey {
                    channel: ch.name,
                    phase,
                    band: c.band,
                },
                real: f64::from_bits(c.real),
                sim_mean: f64::from_bits(c.sim_mean),
                sim_std: f64::from_bits(c.sim_std),
                sims: c.sims,
                z: f64::from_bits(c.z),
                p: f64::from_bits(c.p),
                significant: c.significant,
            })
        })
        .collect::<Result<Vec<_>, DiagnoseError>>()?;
    let evaluated = Evaluated {
        effects,
        gap: GapMap {
            cells,
            total: f64::from_bits(r.total),
            options: GapOptions {
                fdr_q: f64::from_bits(r.fdr_q),
                dead_zone_z: f64::from_bits(r.dead_zone_z),
                min_sims: r.min_sims,
            },
        },
        outcome: Outcome {
            remaining: f64::from_bits(r.remaining),
            params: r.params,
            significant_left: r.significant_left,
        },
    };
    Ok((evaluated, r.simulations))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_round_trip_every_bit() {
        let key = CellKey {
            channel: crate::diagnose::cells::CHANNELS[0].name,
            phase: "drive",
            band: Some(2),
        };
        let e = Evaluated {
            effects: vec![Fitted {
                effect: Effect::ALL[0],
                values: vec![0.1 + 0.2, 1e-300, -0.0, f64::MIN_POSITIVE / 3.0],
                stds: vec![f64::INFINITY, f64::NAN, 1.0 / 3.0, 7e22],
                method: "secant".into(),
                kind: FitKind::MomentMatch,
                simulations: 17,
                runout_form: Some(FittedRunoutForm {
                    cycles_per_wheel_rev: -3.0,
                    phase_rad: 0.1 + 0.2,
                    phase_std_rad: f64::INFINITY,
                }),
            }],
            gap: GapMap {
                cells: vec![CellGap {
                    key,
                    real: std::f64::consts::PI,
                    sim_mean: -2.0 / 3.0,
                    sim_std: 5e-324,
                    sims: 4,
                    z: f64::NEG_INFINITY,
                    p: 0.123_456_789_012_345_68,
                    significant: true,
                }],
                total: 123.456_789,
                options: GapOptions::default(),
            },
            outcome: Outcome {
                remaining: 0.1 + 0.7,
                params: 4,
                significant_left: 1,
            },
        };
        let text = encode(&e, 42).unwrap();
        assert!(!text.contains('\n'));
        let (back, sims) = decode(&text, Path::new("x")).unwrap();
        assert_eq!(sims, 42);
        assert_eq!(encode(&back, sims).unwrap(), text);
        assert_eq!(
            back.effects[0].values[0].to_bits(),
            (0.1f64 + 0.2).to_bits()
        );
        assert!(back.effects[0].stds[1].is_nan());
        assert_eq!(back.gap.cells[0].key, key);
        assert_eq!(back.gap, e.gap);
        assert!(decode("{", Path::new("shards/0/units.tsv"))
            .unwrap_err()
            .to_string()
            .contains("shards/0/units.tsv"));
    }

    /// A one-effect candidate fitted with `method` as `kind`, as one record's text.
    fn record_of(method: &str, kind: FitKind) -> String {
        let mut e = Evaluated {
            effects: vec![crate::pipeline::diagnose::tests::fitted(
                Effect::AxisRunout,
                vec![2e-3],
                vec![1e-4],
            )],
            gap: GapMap {
                cells: Vec::new(),
                total: 1.5,
                options: GapOptions::default(),
            },
            outcome: Outcome {
                remaining: 1.5,
                params: 1,
                significant_left: 0,
            },
        };
        e.effects[0].method = method.into();
        e.effects[0].kind = kind;
        encode(&e, 3).unwrap()
    }

    /// `text` with its fits' `kind` field taken out, as a record written before fits carried it reads.
    fn without_kind(text: &str) -> String {
        let mut v: serde_json::Value = serde_json::from_str(text).unwrap();
        for f in v["effects"].as_array_mut().unwrap() {
            assert!(f.as_object_mut().unwrap().remove("kind").is_some());
        }
        v.to_string()
    }

    #[test]
    fn a_fits_kind_round_trips_and_a_record_without_one_is_refused() {
        for kind in FitKind::ALL {
            let text = record_of("any words", kind);
            let (back, _) = decode(&text, Path::new("x")).unwrap();
            assert_eq!(back.effects[0].kind, kind);
        }
        // A record of a build before fits carried their kind: its method's words are not read
        // back as a kind; the record is refused, naming its place and what to do.
        let method = crate::diagnose::fit::search_method(Effect::AxisRunout, 2);
        let old = without_kind(&record_of(&method, FitKind::SumZ2Search));
        let err = decode(&old, Path::new("shards/2/units.tsv"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("shards/2/units.tsv") && err.contains("no kind") && err.contains("again"),
            "{err}"
        );
    }

    #[test]
    fn a_record_with_an_unknown_fit_kind_is_refused_naming_it() {
        let text = record_of("any words", FitKind::Measured).replace("\"measured\"", "\"guessed\"");
        let err = decode(&text, Path::new("shards/1/units.tsv"))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("guessed") && err.contains("shards/1/units.tsv"),
            "{err}"
        );
    }
}
