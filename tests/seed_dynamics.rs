//! The simulated seed rig (`seed-internal-4k`, 10 s, two complete engagements) against what the
//! seed report observed, and the contact model's energy and rattle on the whole rig.

use geneva_vision::mechanism::engagements::{engagement_summaries, seed_checks};
use geneva_vision::mechanism::{
    ContactModel, CrankModel, DynamicsConfig, Mechanism, MechanismError,
};
use geneva_vision::scenario::load_builtin;

fn seed_rig_for(
    duration_s: f64,
    change: impl FnOnce(&mut DynamicsConfig),
) -> Result<Mechanism, MechanismError> {
    let mut s = load_builtin("seed-internal-4k").unwrap();
    change(&mut s.dynamics);
    Mechanism::new(&s.mechanism, &s.drive_speed, &s.dynamics, duration_s)
}

fn seed_rig(change: impl FnOnce(&mut DynamicsConfig)) -> Mechanism {
    seed_rig_for(10.0, change).unwrap()
}

/// One complete engagement (entry 0.2 s, exit 3.46 s) and the dwell after it.
const ONE_ENGAGEMENT_S: f64 = 4.4;

fn mid_drive_impacts(m: &Mechanism) -> usize {
    engagement_summaries(m)
        .iter()
        .map(|e| e.mid_drive_impacts)
        .sum()
}

#[test]
fn calibrated_seed_rig_shows_what_the_seed_observed() {
    let m = seed_rig(|_| {});
    let engagements = engagement_summaries(&m);
    assert_eq!(engagements.len(), 2, "10 s hold two complete engagements");
    let checks = seed_checks(&m, &engagements);
    assert_eq!(checks.len(), 6);
    for c in &checks {
        eprintln!(
            "{} {}: {} ({})",
            if c.pass { "ok  " } else { "FAIL" },
            c.name,
            c.measured,
            c.criterion
        );
    }
    assert!(checks.iter().all(|c| c.pass), "{checks:#?}");
}

/// The model before restitution (linear penalty, e ≈ 0.95) fails the seed's observations:
/// it rattles through mid-drive with many entry spikes.
#[test]
fn the_old_penalty_default_fails_the_seed_checks() {
    let m = seed_rig(|d| d.contact_model = ContactModel::Penalty);
    let engagements = engagement_summaries(&m);
    let checks = seed_checks(&m, &engagements);
    let failed: Vec<&str> = checks.iter().filter(|c| !c.pass).map(|c| c.name).collect();
    for name in ["entry spikes", "mid-drive ω2", "no rattle"] {
        assert!(failed.contains(&name), "{name} passed: {checks:#?}");
    }
    assert!(mid_drive_impacts(&m) >= 10);
}

/// The energy the discrete contacts create (the ledger's residual) is negligible against what
/// friction and contact damping dissipate, for the calibrated model, the old penalty model, an
/// undamped contact (e = 1, one engagement) and a servo-driven crank: the old rattle was not
/// numerical. What keeps a rattle going is the prescribed crank's work.
#[test]
fn contacts_create_no_energy() {
    type Change = Box<dyn Fn(&mut DynamicsConfig)>;
    let cases: [(&str, f64, Change); 4] = [
        ("calibrated", 10.0, Box::new(|_| {})),
        (
            "penalty",
            10.0,
            Box::new(|d| d.contact_model = ContactModel::Penalty),
        ),
        (
            "e = 1",
            ONE_ENGAGEMENT_S,
            Box::new(|d| d.contact_restitution = 1.0),
        ),
        (
            "servo",
            10.0,
            Box::new(|d| d.crank.model = CrankModel::Servo),
        ),
    ];
    for (name, duration_s, change) in cases {
        let m = seed_rig_for(duration_s, change).unwrap();
        let ledger = m.dynamics().unwrap().energy;
        let dissipated = ledger.friction_loss_j + ledger.damping_loss_j;
        assert!(ledger.friction_loss_j > 0.0 && ledger.damping_loss_j >= 0.0);
        assert!(
            ledger.residual_j().abs() <= 1e-4 * dissipated,
            "{name}: {ledger:?}"
        );
    }
    // Undamped, the crank's work piles up in the rattle until the wheel breaks through a slot
    // wall in the second engagement; the run is refused, naming the parameter to change.
    let err = seed_rig_for(10.0, |d| d.contact_restitution = 1.0).unwrap_err();
    assert!(
        matches!(err, MechanismError::WallBreakthrough { .. })
            && err.to_string().contains("dynamics.contact_restitution"),
        "{err}"
    );
}

/// Only a restitution near 1 keeps the wheel rattling: with e ≤ 0.5 the entry bounces die out
/// before mid-drive; above, visible mid-drive impacts grow with e, and an undamped contact
/// (e = 1) rattles through the whole engagement.
#[test]
fn only_restitution_near_one_keeps_the_wheel_rattling() {
    for e in [0.2, 0.35, 0.5] {
        let m = seed_rig(|d| d.contact_restitution = e);
        assert_eq!(mid_drive_impacts(&m), 0, "e = {e}");
    }
    let mut previous = 0;
    for e in [0.8, 0.9, 0.95, 1.0] {
        let m = seed_rig_for(ONE_ENGAGEMENT_S, |d| d.contact_restitution = e).unwrap();
        let n = mid_drive_impacts(&m);
        assert!(
            n > previous,
            "e = {e}: {n} mid-drive impacts after {previous}"
        );
        previous = n;
    }
    assert!(previous >= 15, "undamped: {previous}");
}

/// A servo holding the crank: the stiffer and heavier it is, the closer the wheel moves to the
/// prescribed-crank run; with the default hobby-servo figures the crank leaves its prescribed
/// motion by little and the seed checks still hold.
#[test]
fn servo_crank_tends_to_the_prescribed_crank() {
    let prescribed = seed_rig(|_| {});
    let largest = |f: &dyn Fn(f64) -> f64| {
        (0..10_000)
            .map(|i| f(i as f64 * 1e-3).abs())
            .fold(0.0, f64::max)
    };
    let distance =
        |m: &Mechanism| largest(&|t| m.actual(t).omega2_rad_s - prescribed.actual(t).omega2_rad_s);
    let crank_lag = |m: &Mechanism| largest(&|t| m.actual(t).theta1_rad - m.ideal(t).theta1_rad);
    let mut previous = f64::INFINITY;
    // Critically damped servos of growing inertia and stiffness.
    for (inertia, stiffness) in [(1e-4, 2.0), (1e-2, 200.0), (1.0, 2e4)] {
        let m = seed_rig(|d| {
            d.crank.model = CrankModel::Servo;
            d.crank.reflected_inertia_kg_m2 = inertia;
            d.crank.stiffness_n_m_rad = stiffness;
            d.crank.damping_n_m_s_rad = 2.0 * (stiffness * d.crank.inertia_kg_m2()).sqrt();
        });
        let dist = distance(&m);
        assert!(dist < previous, "J {inertia}: {dist} after {previous}");
        previous = dist;
    }
    assert!(previous < 0.01, "{previous}");
    let default_servo = seed_rig(|d| d.crank.model = CrankModel::Servo);
    let lag = crank_lag(&default_servo);
    assert!(lag > 0.0 && lag < 0.01, "crank lag {lag} rad");
    let engagements = engagement_summaries(&default_servo);
    let checks = seed_checks(&default_servo, &engagements);
    assert!(checks.iter().all(|c| c.pass), "{checks:#?}");
}
