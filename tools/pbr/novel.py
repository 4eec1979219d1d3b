"""Effects outside the diagnosis' vocabulary, as a real rig has them, and the camera shake of the
vocabulary's `camera_vibration` in this tool's own form.

Each novel effect is a class with hooks the renderer calls: the camera's motion (`camera`), the
disc's tilt on its shaft (`wobble`), the marker's slip on the disc (`creep`), the lens's circle
of confusion per frame (`coc`), extra objects in the scene (`extras`), frames the phone repeats
(`duplicates`), a change of the sensor's signal (`signal`), and a laminate on the marker's print
(`laminate`). A case lists them as `{"kind": name, ...parameters}` under `novel`.
"""

import math
from dataclasses import dataclass

import numpy as np

import rig

# Where the soft box is (render.lights): a shadow is cast across its beam.
KEY_LIGHT_M = (-0.30, -0.35, -0.55)

# The diameter about which a wobbling disc is tilted, in the wheel's frame.
WOBBLE_AXIS_RAD = 0.7


@dataclass
class Context:
    spec: dict
    scenario: dict
    camera: rig.Camera
    rng: np.random.Generator
    key_times: np.ndarray
    theta: np.ndarray
    phases: list
    duration_s: float
    frame_times: np.ndarray


def random_shake(rng, times, rms_px, band_hz=(1.0, 20.0), components=16):
    """A band-limited random shake: per axis a sum of sinusoids at frequencies drawn uniformly
    in the band with random phases, each axis with `rms_px` root-mean-square."""
    out = np.zeros((len(times), 2))
    for axis in range(2):
        freqs = rng.uniform(band_hz[0], band_hz[1], components)
        phases = rng.uniform(0.0, 2 * math.pi, components)
        amp = rms_px / math.sqrt(components / 2.0)
        out[:, axis] = (amp * np.sin(2 * math.pi * np.outer(times, freqs) + phases)).sum(axis=1)
    return out


def smooth_step(t, t0, rise_s):
    """0 before t0, 1 after t0 + rise, a cosine ramp between."""
    x = np.clip((np.asarray(t) - t0) / rise_s, 0.0, 1.0)
    return 0.5 - 0.5 * np.cos(math.pi * x)


class Novel:
    kind = ""
    laminate = 0.0
    doc = ""

    def __init__(self, params):
        self.params = params

    def p(self, name, default):
        return float(self.params.get(name, default))

    def camera(self, ctx):
        return np.zeros((len(ctx.key_times), 2)), np.zeros(len(ctx.key_times))

    def wobble(self, ctx):
        return np.zeros(len(ctx.key_times))

    def creep(self, ctx):
        return np.zeros(len(ctx.key_times))

    def coc(self, ctx, coc):
        return coc

    def extras(self, ctx, key_frames, marker, sheet_png):
        return []

    def duplicates(self, ctx):
        return {}

    def signal(self, ctx, k, signal):
        return signal


class Creep(Novel):
    kind = "creep"
    doc = ("the marker slips on the wheel during each dwell (tape creeping under a stiff "
           "sheet), `rate_deg_s` while the wheel rests, none while it turns")

    def creep(self, ctx):
        rate = math.radians(self.p("rate_deg_s", 3.0))
        order = np.argsort(ctx.key_times)
        t = ctx.key_times[order]
        dwell = np.array([ctx.phases[i] == "dwell" for i in order], dtype=float)
        dt = np.diff(t, prepend=t[0])
        # The slip accumulates over the time spent in dwell (mid-point rule on the samples).
        mid = 0.5 * (dwell + np.concatenate([[dwell[0]], dwell[:-1]]))
        acc = np.cumsum(rate * dt * mid)
        out = np.empty_like(acc)
        out[order] = acc
        return out


class Glare(Novel):
    kind = "glare"
    laminate = 1.0
    doc = ("the marker's print is laminated and a small bright lamp's reflection sits on the "
           "wheel's path, washing out the marker as it passes (detections lost)")

    def extras(self, ctx, key_frames, marker, sheet_png):
        # The path point where the marker is half way through its travel in the clip.
        mid = float(np.median(ctx.theta))
        m = ctx.scenario["scene"]["marker"]
        r = float(m["radius_mm"]) * 1e-3
        phi = math.radians(float(m["angle_on_disc_deg"])) + mid
        target = np.array([r * math.cos(phi), r * math.sin(phi), 0.0])
        cam = ctx.camera.position_m()
        # The lamp on the camera's side whose mirror image in the disc plane lies on the
        # line from the camera through the target: its reflection reaches the camera there.
        beyond = target + 2.0 * (target - cam)
        lamp = np.array([beyond[0], beyond[1], -beyond[2]])
        # A 10 cm lamp 0.6 m from the marker's path: its reflection in the laminate (4 %) is a
        # disc some 60 px across that saturates the sensor; its light on the rig is about the
        # soft box's (the exposure is metered with it on).
        return [{"kind": "light", "name": "glare_lamp", "size_m": self.p("size_m", 0.1),
                 "power_w": self.p("power_w", 3.0),
                 "pose": rig.rows(rig.look_at(lamp, target), lamp)}]


class MountStep(Novel):
    kind = "mount_step"
    doc = ("a loose camera clamp slips twice: the image jumps by a pixel or two and turns by a "
           "fraction of a degree within 30 ms, then stays")

    def camera(self, ctx):
        d = ctx.duration_s
        t = ctx.key_times
        s1, s2 = smooth_step(t, d / 3, 0.03), smooth_step(t, 2 * d / 3, 0.03)
        shift = np.outer(s1, [1.5, -1.0]) + np.outer(s2, [1.0, 1.5])
        roll = math.radians(0.15) * s1 - math.radians(0.1) * s2
        return shift * self.p("scale", 1.0), roll * self.p("scale", 1.0)


class Wobble(Novel):
    kind = "wobble"
    doc = ("the disc sits skewed on its shaft, `tilt_deg` out of square: its face wobbles out "
           "of plane as it turns (the marker nears and recedes, its image shears)")

    def wobble(self, ctx):
        return np.full(len(ctx.key_times), math.radians(self.p("tilt_deg", 2.5)))


class TwinMarker(Novel):
    kind = "twin_marker"
    doc = ("a second print of the same marker lies on the base plate in view (a spare copy): "
           "the detector may take it for the wheel's")

    def extras(self, ctx, key_frames, marker, sheet_png):
        sheet = dict(marker)
        sheet.pop("keys", None)
        sheet.pop("pose", None)
        # Beyond the disc's rim, up and to the right of the axle: in the suite's crop.
        pos = (self.p("x_m", 0.100), self.p("y_m", -0.132), 0.025 - 0.0002)
        pose = rig.rows(rig.rot_z(math.radians(self.p("angle_deg", 17.0))), pos)
        return [{"kind": "sheet", "name": "twin", "sheet": sheet, "pose": pose}]


def sweep(ctx, key_frames, t0, t1, pose_at):
    """Keys of an object that crosses the scene between t0 and t1: `pose_at(u)` gives its
    matrix rows at progress u (below 0 before the crossing, above 1 after it, where the object
    waits off the view)."""
    keys = []
    for b, t in zip(key_frames, ctx.key_times):
        u = (t - t0) / (t1 - t0)
        keys.append((float(b), pose_at(u)))
    return keys


def marker_world_at(ctx, theta):
    m = ctx.scenario["scene"]["marker"]
    r = float(m["radius_mm"]) * 1e-3
    phi = math.radians(float(m["angle_on_disc_deg"])) + theta
    return np.array([r * math.cos(phi), r * math.sin(phi)])


class Cable(Novel):
    kind = "cable"
    doc = ("a dark cable swings across the marker in front of the disc for part of the clip, "
           "covering part of it (a hand or a cable passing)")

    def extras(self, ctx, key_frames, marker, sheet_png):
        d = ctx.duration_s
        t0, t1 = self.p("start_frac", 0.35) * d, self.p("end_frac", 0.6) * d
        i_mid = int(np.argmin(np.abs(ctx.key_times - 0.5 * (t0 + t1))))
        centre = marker_world_at(ctx, ctx.theta[i_mid])
        rot = rig.rot_x(math.pi / 2) @ rig.rot_y(math.radians(10.0))

        def pose_at(u):
            # In from the left, across the marker, out to the right; parked off the view.
            x = -0.5 if u < 0 else 0.5 if u > 1 else centre[0] - 0.07 + 0.14 * u
            return rig.rows(rot, (x, centre[1], -0.03))

        keys = sweep(ctx, key_frames, t0, t1, pose_at)
        return [{"kind": "cable", "name": "cable", "radius_m": self.p("radius_m", 0.004),
                 "length_m": 0.6, "colour": (0.02, 0.02, 0.025), "keys": keys}]


class FocusHunt(Novel):
    kind = "focus_hunt"
    doc = ("the autofocus hunts twice: the disc's blur grows to a circle of confusion of "
           "`peak_coc_px` and back within about a second")

    def coc(self, ctx, coc):
        d = ctx.duration_s
        peak = self.p("peak_coc_px", 6.5)
        out = list(coc)
        for k, t in enumerate(ctx.frame_times):
            for c, half in ((0.35 * d, 0.08 * d), (0.72 * d, 0.06 * d)):
                x = 1.0 - abs(t - c) / half
                if x > 0:
                    out[k] = max(out[k], coc[k] + (peak - coc[k]) * x)
        return out


class Shadow(Novel):
    kind = "shadow"
    doc = ("someone passes between the lamp and the rig: the light dims by up to half as the "
           "soft box's shadow, its penumbra wider than the view, sweeps across it")

    def extras(self, ctx, key_frames, marker, sheet_png):
        d = ctx.duration_s
        t0, t1 = self.p("start_frac", 0.45) * d, self.p("end_frac", 0.8) * d
        key_light = np.array(KEY_LIGHT_M)
        # A board 70 % of the way from the rig to the lamp (behind the camera, out of its
        # view), swept sideways across the lamp's beam: its shadow on the disc plane moves 3.3
        # times as far, through the axle, past the marker.
        side = np.array([1.0, -0.8, 0.0]) / math.hypot(1.0, 0.8)

        def pose_at(u):
            offset = -0.5 if u < 0 else 0.5 if u > 1 else -0.09 + 0.18 * u
            pos = 0.7 * key_light + offset * side
            return rig.rows(rig.look_at(pos, key_light), pos)

        keys = sweep(ctx, key_frames, t0, t1, pose_at)
        return [{"kind": "card", "name": "card", "size_m": (0.15, 0.6),
                 "colour": (0.2, 0.2, 0.2), "keys": keys}]


class DuplicateFrames(Novel):
    kind = "duplicate_frames"
    doc = ("the phone repeats a frame three times in the clip (an encoder that falls behind "
           "writes the previous picture again under the next frame's timestamp)")

    def duplicates(self, ctx):
        n = len(ctx.frame_times)
        out = {}
        for frac in (0.27, 0.52, 0.77):
            k = int(frac * n)
            if 0 < k < n:
                out[k] = k - 1
        return out


KINDS = {c.kind: c for c in (Creep, Glare, MountStep, Wobble, TwinMarker, Cable, FocusHunt,
                             Shadow, DuplicateFrames)}


def effects_of(spec):
    out = []
    for item in spec.get("novel", []):
        kind = item.get("kind")
        if kind not in KINDS:
            raise ValueError(f"novel effect `{kind}`: not one of {', '.join(sorted(KINDS))}")
        out.append(KINDS[kind]({k: v for k, v in item.items() if k != "kind"}))
    return out
