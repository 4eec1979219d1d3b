//! Warnings for a nominal that is valid but clips its own noise: the marker's ink at the tone
//! curve's black level, or its paper at the white level. The renderer adds the sensor's noise to
//! the signal and then clips it to [0, 1] (black to white): a level at an end loses half its
//! noise there (the footage shows a pile at the end and a one-sided spread), a level within a
//! few σ of it a tail. A real camera's ink and paper usually sit inside its range, and
//! `geneva calibrate` writes them so (the black level 5σ + 1 DN below the ink, the white level as
//! far above the paper, unless the footage itself shows the pile). `geneva scenario check`
//! prints these warnings with the statement that keeps the levels and frees the noise, and warns
//! when the light's gain over time (`effects.lighting` drift, steps, flicker) drives the paper
//! past the white level.

use super::Scenario;
use crate::render::effects::lighting::LightingConfig;

/// A level closer than this many σ of its noise to an end of the tone curve is warned about
/// (2.3 % of its noise clipped; at the end itself, half).
pub const MIN_CLEARANCE_SIGMA: f64 = 2.0;

/// σ of noise that the statement leaves between a level and the end beyond it, plus 1 DN: what
/// `geneva calibrate` writes.
pub const STATED_CLEARANCE_SIGMA: f64 = 5.0;

/// One warning: the field it is about and what to do.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    pub field: &'static str,
    pub message: String,
}

/// The tone curve as DN(signal) = black + span·s^(1/γ) for s in [0, 1].
#[derive(Debug, Clone, Copy)]
pub(crate) struct Tone {
    black: f64,
    white: f64,
    gamma: f64,
}

impl Tone {
    pub(crate) fn of(l: &LightingConfig) -> Tone {
        if l.enabled {
            Tone {
                black: l.black_level_dn,
                white: l.white_level_dn,
                gamma: l.gamma,
            }
        } else {
            Tone {
                black: 0.0,
                white: 255.0,
                gamma: 1.0,
            }
        }
    }

    pub(crate) fn dn(&self, s: f64) -> f64 {
        self.black + (self.white - self.black) * s.clamp(0.0, 1.0).powf(1.0 / self.gamma)
    }

    /// The signal whose DN is `dn`.
    fn signal(&self, dn: f64) -> f64 {
        ((dn - self.black) / (self.white - self.black))
            .clamp(0.0, 1.0)
            .powf(self.gamma)
    }
}

/// Share of a normal's mass beyond `z` σ: Φ(−z).
fn beyond(z: f64) -> f64 {
    crate::numeric::dist::normal_cdf(-z)
}

/// The warnings of `s`: levels that clip their noise (none when its pixel noise is off) and a
/// light over time that drives the paper past the white level.
pub fn warnings(s: &Scenario) -> Vec<Warning> {
    let mut out = noise_warnings(s);
    out.extend(light_warning(s));
    out
}

/// The lowest and highest gain of the light over the scenario's duration (exposures taken as
/// instants, which bounds every exposure's mean): at the ends, at every step and on a grid of
/// 4,000 instants (the flicker's extremes to within its amplitude × (π/4,000 per period)²/2).
pub fn light_range(s: &Scenario) -> (f64, f64) {
    let l = &s.effects.lighting;
    if !l.varies_in_time() {
        return (1.0, 1.0);
    }
    let d = s.duration_s.max(0.0);
    let steps = l
        .gain_steps
        .iter()
        .map(|g| g.at_s)
        .filter(|&t| (0.0..=d).contains(&t));
    let grid = (0..=4000).map(|i| d * i as f64 / 4000.0);
    let flicker_peaks = if l.flicker_frac > 0.0 {
        // The sinusoid's crests and troughs inside the span.
        let period = 1.0 / l.flicker_hz;
        let first = -l.flicker_phase_rad / std::f64::consts::TAU * period + period / 4.0;
        let k0 = ((0.0 - first) / (period / 2.0)).ceil() as i64;
        let k1 = ((d - first) / (period / 2.0)).floor() as i64;
        let n = (k1 - k0 + 1).clamp(0, 200_000);
        (0..n)
            .map(|k| first + (k0 + k) as f64 * period / 2.0)
            .collect::<Vec<_>>()
    } else {
        Vec::new()
    };
    grid.chain(steps)
        .chain(flicker_peaks)
        .map(|t| l.temporal_gain(t, 0.0))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), g| {
            (lo.min(g), hi.max(g))
        })
}

/// The paper driven past the white level by the light's gain over time.
fn light_warning(s: &Scenario) -> Option<Warning> {
    let (_, g_hi) = light_range(s);
    let paper = s.scene.paper_radiance * g_hi;
    (g_hi > 1.0 && paper > 1.0).then(|| Warning {
        field: "effects.lighting",
        message: format!(
            "the light's gain over time reaches {g_hi:.3} (its drift, steps or flicker): the \
             paper (scene.paper_radiance = {:.4}) then lies past the white level ({:.3} of it), \
             and rendered frames clip it flat; state a paper radiance at most {:.4} or a white \
             level with room for the brightest light",
            s.scene.paper_radiance,
            paper,
            1.0 / g_hi
        ),
    })
}

/// The levels that clip their noise (none when the pixel noise is off).
fn noise_warnings(s: &Scenario) -> Vec<Warning> {
    let noise = &s.effects.pixel_noise;
    if !noise.enabled {
        return Vec::new();
    }
    let tone = Tone::of(&s.effects.lighting);
    // σ of the normalised signal at s (shot + read, as `PixelNoiseConfig::apply`).
    let sigma_s = |sig: f64| {
        (sig.max(0.0) * noise.full_well_e + noise.read_noise_e.powi(2)).sqrt() / noise.full_well_e
    };
    let (ink, paper) = (s.scene.ink_radiance, s.scene.paper_radiance);
    let (si, sp) = (sigma_s(ink), sigma_s(paper));
    // Clearance to the end in σ, in signal space (where the clip is).
    let z_ink = ink / si;
    let z_paper = (1.0 - paper) / sp;
    let low = z_ink < MIN_CLEARANCE_SIGMA;
    let high = z_paper < MIN_CLEARANCE_SIGMA;
    if !(low || high) {
        return Vec::new();
    }
    // The levels in DN and their noise there (one σ of signal through the curve).
    let (li, lp) = (tone.dn(ink), tone.dn(paper));
    // The larger one-sided step: at an end the curve has only one side.
    let sigma_dn = |sig: f64, sd: f64| {
        (tone.dn(sig + sd) - tone.dn(sig))
            .max(tone.dn(sig) - tone.dn(sig - sd))
            .max(1e-9)
    };
    let (di, dp) = (sigma_dn(ink, si), sigma_dn(paper, sp));
    // The statement: the clipped end moved clear of its level, both levels kept in DN.
    let black = if low {
        (li - STATED_CLEARANCE_SIGMA * di - 1.0).max(0.0)
    } else {
        tone.black
    };
    let white = if high {
        (lp + STATED_CLEARANCE_SIGMA * dp + 1.0).min(255.0)
    } else {
        tone.white
    };
    let stated = Tone {
        black,
        white,
        gamma: tone.gamma,
    };
    let statement = format!(
        "state {}scene.ink_radiance = {:.4} and scene.paper_radiance = {:.4}, which keep the ink \
         at {li:.1} DN and the paper at {lp:.1} DN (as `geneva calibrate` writes a footage's \
         levels: the black level {STATED_CLEARANCE_SIGMA}σ + 1 DN below the ink, the white level \
         as far above the paper; the pixel noise's electrons count over the span, so its σ in DN \
         grows by {:.3} with it)",
        [
            (low, "effects.lighting.black_level_dn", black),
            (high, "effects.lighting.white_level_dn", white),
        ]
        .iter()
        .filter(|t| t.0)
        .map(|t| format!("{} = {:.1}, ", t.1, t.2))
        .collect::<String>(),
        stated.signal(li),
        stated.signal(lp),
        (white - black) / (tone.white - tone.black)
    );
    let warn = |field, what: &str, level: f64, end: &str, end_dn: f64, z: f64, sd: f64| Warning {
        field,
        message: format!(
            "the {what} ({field} → {level:.1} DN) sits {z:.1}σ from the tone curve's {end} level \
             ({end_dn:.1} DN): the curve clips {:.0} % of its pixel noise (σ {sd:.2} DN), so \
             rendered frames show less noise there than the sensor makes and a pile at \
             {end_dn:.0} DN; unless footage of the rig shows that pile (a camera that clips \
             there, as `geneva calibrate` then writes it), {statement}",
            100.0 * beyond(z)
        ),
    };
    let mut out = Vec::new();
    if low {
        out.push(warn(
            "scene.ink_radiance",
            "ink",
            li,
            "black",
            tone.black,
            z_ink,
            di,
        ));
    }
    if high {
        out.push(warn(
            "scene.paper_radiance",
            "paper",
            lp,
            "white",
            tone.white,
            z_paper,
            dp,
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scenario(ink: f64, paper: f64, black: f64, white: f64) -> Scenario {
        let mut s = Scenario::default();
        s.scene.ink_radiance = ink;
        s.scene.paper_radiance = paper;
        s.effects.lighting.black_level_dn = black;
        s.effects.lighting.white_level_dn = white;
        s
    }

    /// The value a warning's statement gives `field`.
    fn stated(message: &str, field: &str) -> f64 {
        let at = message.find(&format!("{field} = ")).expect(field) + field.len() + 3;
        message[at..]
            .split([',', ' '])
            .next()
            .and_then(|v| v.parse().ok())
            .expect("a number")
    }

    #[test]
    fn paper_at_the_white_level_is_warned_about_with_half_its_noise_clipped() {
        // The built-in default: paper radiance 1 at 206 DN, ink at 0.04.
        let w = warnings(&Scenario::default());
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!(w[0].field, "scene.paper_radiance");
        assert!(w[0].message.contains("clips 50 %"), "{}", w[0].message);
        assert!(w[0].message.contains("effects.lighting.white_level_dn = "));
        assert!(!w[0].message.contains("black_level_dn = "));
    }

    #[test]
    fn ink_at_the_black_level_is_warned_about_and_a_clear_nominal_is_not() {
        let w = warnings(&scenario(0.0, 0.9, 40.0, 220.0));
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!(w[0].field, "scene.ink_radiance");
        assert!(w[0].message.contains("clips 50 %"), "{}", w[0].message);
        // A tail within 2σ is clipped too: ink 1.5σ above black.
        let mut s = scenario(0.0, 0.9, 40.0, 220.0);
        let sigma = (s.effects.pixel_noise.read_noise_e) / s.effects.pixel_noise.full_well_e;
        s.scene.ink_radiance = 1.5 * sigma;
        let w = warnings(&s);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].message.contains("clips 7 %"), "{}", w[0].message);
        // Clear of both ends, or without noise: nothing to say.
        assert!(warnings(&scenario(0.1, 0.9, 40.0, 220.0)).is_empty());
        let mut off = scenario(0.0, 1.0, 40.0, 220.0);
        off.effects.pixel_noise.enabled = false;
        assert!(warnings(&off).is_empty());
    }

    #[test]
    fn the_stated_nominal_keeps_the_levels_and_is_clear_of_both_ends() {
        for gamma in [1.0, 2.2] {
            let mut s = scenario(0.0, 1.0, 51.0, 206.0);
            s.effects.lighting.gamma = gamma;
            let w = warnings(&s);
            assert_eq!(w.len(), 2, "{w:?}");
            let before = (
                Tone::of(&s.effects.lighting).dn(0.0),
                Tone::of(&s.effects.lighting).dn(1.0),
            );
            let m = &w[0].message;
            s.effects.lighting.black_level_dn = stated(m, "effects.lighting.black_level_dn");
            s.effects.lighting.white_level_dn = stated(m, "effects.lighting.white_level_dn");
            s.scene.ink_radiance = stated(m, "scene.ink_radiance");
            s.scene.paper_radiance = stated(m, "scene.paper_radiance");
            assert!(s.validate().is_empty(), "{:?}", s.validate());
            let t = Tone::of(&s.effects.lighting);
            let after = (t.dn(s.scene.ink_radiance), t.dn(s.scene.paper_radiance));
            assert!(
                (after.0 - before.0).abs() < 0.2,
                "γ {gamma}: {before:?} → {after:?}"
            );
            assert!(
                (after.1 - before.1).abs() < 0.2,
                "γ {gamma}: {before:?} → {after:?}"
            );
            assert!(warnings(&s).is_empty(), "γ {gamma}: {:?}", warnings(&s));
        }
    }

    #[test]
    fn a_light_that_rises_past_the_paper_s_room_is_warned_about_and_a_steady_one_not() {
        let mut s = scenario(0.05, 0.9, 30.0, 220.0);
        s.effects.pixel_noise.enabled = false;
        s.duration_s = 4.0;
        assert!(warnings(&s).is_empty());
        assert_eq!(light_range(&s), (1.0, 1.0));
        // 1 + 0.05·4 = 1.2 at the end: the paper at 0.9·1.2 = 1.08 of the white level.
        s.effects.lighting.gain_drift_per_s = 0.05;
        let (lo, hi) = light_range(&s);
        assert!(
            (lo - 1.0).abs() < 1e-12 && (hi - 1.2).abs() < 1e-12,
            "{lo} {hi}"
        );
        let w = warnings(&s);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].message.contains("reaches 1.200"), "{}", w[0].message);
        assert!(w[0].message.contains("at most 0.8333"), "{}", w[0].message);
        // A flicker's crest is found between grid instants; a fading light is no warning.
        s.effects.lighting.gain_drift_per_s = -0.05;
        assert!(warnings(&s).is_empty());
        s.effects.lighting.gain_drift_per_s = 0.0;
        s.effects.lighting.flicker_frac = 0.1;
        s.effects.lighting.flicker_hz = 100.0;
        s.effects.lighting.flicker_phase_rad = 0.3;
        let (lo, hi) = light_range(&s);
        assert!(
            (hi - 1.1).abs() < 1e-12 && (lo - 0.9).abs() < 1e-12,
            "{lo} {hi}"
        );
        // 0.9 · 1.1 stays inside; 0.95 · 1.1 does not.
        assert!(warnings(&s).is_empty());
        s.scene.paper_radiance = 0.95;
        assert_eq!(warnings(&s).len(), 1);
    }
}
