"""Renders one case: a scenario's rig as 3D geometry path-traced by Blender's Cycles, through
this tool's own phone (isp.py), with the case's effects — vocabulary effects in this tool's own
way, and novel ones the vocabulary has no word for (novel.py).

Only the mechanism's motion is the project's: `geneva kinematics --times` gives the wheel's
angle and centre at every instant the renderer samples (exposure, rolling-shutter rows), and
`geneva scenario show` resolves the scenario (with `--with` for a withheld mechanism effect,
through the project's effect registry).
"""

import csv
import json
import math
import os
import resource
import shutil
import subprocess
import time
import tomllib

import cv2
import numpy as np

import isp
import novel
import rig
import schedule

HERE = os.path.dirname(os.path.abspath(__file__))

# The look of the rig: materials, lights, the room. Chosen to resemble the seed's rig (an orange
# printed disc with print lines, a taped paper marker, a wooden base plate, red fabric behind).
LOOK = {
    "disc": {"colour": (0.80, 0.26, 0.06), "line_spacing_m": 0.0004, "line_angle_deg": 45.0,
             "line_banding": 0.06, "mottle": 0.08, "bump_strength": 0.25,
             "bump_distance_m": 0.00008, "roughness": 0.45, "specular": 0.4},
    "paper": {"ink_albedo": 0.035, "paper_albedo": 0.82, "ink_roughness": 0.45,
              "paper_roughness": 0.9, "specular": 0.3, "fibre_bump": 0.05},
    "tape": {"colour": (0.74, 0.72, 0.64), "roughness": 0.3},
    "plate": {"colour": (0.42, 0.28, 0.16)},
    "fabric": {"colour": (0.38, 0.035, 0.045), "thread_m": 0.0012},
    "room": {"colour": (0.9, 0.92, 1.0), "strength": 0.0},
}

# The phone when a case says nothing else: a short exposure in good light (its blur a small
# fraction of a pixel), focus a little off the disc (the disc's circle of confusion 4 σ of the
# scenario's optical blur), a Bayer sensor with the scenario's full well and read noise, mild
# sharpening, and H.264 with B-frames at a phone's bits per pixel (a 1080p30 video at 17 Mbit/s
# spends 0.27 bit per pixel and frame; a crop of it gets its share).
PHONE = {
    "exposure_s": 0.00025,
    "aperture_m": 0.004,
    "headroom": 1.6,
    "sharpen_amount": 0.35,
    "sharpen_sigma_px": 1.0,
    "codec": "h264",
    "bits_per_pixel": 0.27,
    "gop": 30,
    "bframes": 2,
    "preset": "medium",
    "jpeg_quality": None,
}

MECHANISM_EFFECTS = ("drive_speed", "backlash", "overrotation", "disc_vibration", "axis_runout")


class Tools:
    def __init__(self, geneva, blender, threads):
        self.geneva = geneva
        self.blender = blender
        self.threads = threads

    def run(self, args):
        proc = subprocess.run(args, capture_output=True, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"{' '.join(map(str, args))}: {proc.stderr.strip()}")
        return proc

    def scenario_show(self, spec, with_=(), without=()):
        args = [self.geneva, "scenario", "show", spec]
        for w in with_:
            args += ["--with", w]
        if without:
            args += ["--without", ",".join(without)]
        return self.run(args).stdout

    def motion(self, scenario_file, times, work):
        """The mechanism's motion at `times` (`geneva kinematics --times`): rows of
        (θ2 actual, centre offset x, y, phase)."""
        times_file = os.path.join(work, "times.csv")
        with open(times_file, "w") as f:
            f.write("t_s\n")
            for t in times:
                f.write(f"{t!r}\n")
        out = os.path.join(work, "motion")
        shutil.rmtree(out, ignore_errors=True)
        self.run([self.geneva, "kinematics", scenario_file, "--times", times_file, "--out", out])
        with open(os.path.join(out, "truth.csv")) as f:
            rows = list(csv.DictReader(f))
        return rows, os.path.join(out, "truth.csv")


def load_toml(text):
    return tomllib.loads(text)


def with_arg(effect, values):
    return f"{effect}=" + ",".join(repr(float(v)) for v in values)


def write_data_scenario(tools, spec, work, rng):
    """The data's scenario: the base with the withheld mechanism effects applied through the
    registry (`--with`), filmed for the case's duration, and its crank nuisance moved by a seeded
    draw (phase ±0.2 rad, speed ±1.5 %), as a self-check case moves it."""
    mech = [with_arg(v["effect"], v["values"]) for v in spec.get("vocabulary", [])
            if v["effect"] in MECHANISM_EFFECTS]
    resolved = os.path.join(work, "data_resolved.toml")
    with open(resolved, "w") as f:
        # A case records its base relative to the repository.
        base = os.path.join(os.path.dirname(os.path.dirname(HERE)), spec["base"])
        f.write(tools.scenario_show(base, with_=mech))
    first = os.path.join(work, "data_first.toml")
    duration = float(spec["duration_s"])
    with open(first, "w") as f:
        f.write(f'extend = "{resolved}"\nduration_s = {duration!r}\nseed = {int(spec["seed"])}\n')
    rows, _ = tools.motion(first, [0.0], work)
    theta1_0 = float(rows[0]["theta1_rad"])
    scenario = load_toml(open(resolved).read())
    drive = scenario["drive_speed"]
    scale = 1.0 + 0.015 * (2 * rng.random() - 1)
    lines = [f'extend = "{resolved}"', f"duration_s = {duration!r}", f"seed = {int(spec['seed'])}",
             "[mechanism]", f"theta1_start_rad = {theta1_0 + 0.2 * (2 * rng.random() - 1)!r}",
             "[drive_speed]"]
    if drive["kind"] == "constant":
        lines.append(f"omega1_rad_s = {drive['omega1_rad_s'] * scale!r}")
    elif drive["kind"] == "polynomial_per_engagement":
        lines.append(f"end_rad_s = {drive['end_rad_s'] * scale!r}")
        lines.append(f"mid_rad_s = {drive['mid_rad_s'] * scale!r}")
    data = os.path.join(work, "data.toml")
    with open(data, "w") as f:
        f.write("\n".join(lines) + "\n")
    return data, load_toml(tools.scenario_show(data)), scale


def marker_image(scenario, path, cell_px=16):
    """The printed sheet as an image: the marker from OpenCV's ArUco module (not this project's
    dictionaries), inside its white margin; 0 = ink, 255 = paper."""
    m = scenario["scene"]["marker"]
    name = m["dictionary"].upper().replace("DICT_", "")
    table = getattr(cv2.aruco, "DICT_" + name, None)
    if table is None:
        raise ValueError(f"scene.marker.dictionary `{m['dictionary']}`: not in OpenCV's ArUco")
    dictionary = cv2.aruco.getPredefinedDictionary(table)
    bits = int(m["border_bits"])
    cells = dictionary.markerSize + 2 * bits
    side = cells * cell_px
    if hasattr(cv2.aruco, "generateImageMarker"):
        img = cv2.aruco.generateImageMarker(dictionary, int(m["id"]), side, borderBits=bits)
    else:
        img = cv2.aruco.drawMarker(dictionary, int(m["id"]), side, borderBits=bits)
    size_mm, margin_mm = float(m["size_mm"]), float(m["white_margin_mm"])
    margin_px = int(round(margin_mm / size_mm * side))
    sheet = np.full((side + 2 * margin_px, side + 2 * margin_px), 255, np.uint8)
    sheet[margin_px:margin_px + side, margin_px:margin_px + side] = img
    cv2.imwrite(path, sheet)
    return cells, margin_px / side * size_mm


def vocabulary_values(spec):
    return {v["effect"]: [float(x) for x in v["values"]] for v in spec.get("vocabulary", [])}


def defocus_focus_distance(camera, coc_px, aperture_m):
    """The focus distance that blurs the disc plane (at the camera's distance) into a circle of
    confusion `coc_px` across: c = A·f·(d_f − d)/(d·d_f), focused behind the disc."""
    af = aperture_m * camera.focal_px
    d = camera.distance_m
    if coc_px <= 0:
        return d
    if coc_px * d >= af:
        raise ValueError(f"a circle of confusion of {coc_px} px needs a larger aperture")
    return af * d / (af - coc_px * d)


def render_case(spec, out_dir, tools, keep_work=False, log=print):
    """Renders `spec` into `out_dir` (see pbr.py); returns the case as written to case.json."""
    f = Footage(spec, out_dir, tools, log)
    f.resolve()
    f.frame_schedule()
    f.sample_motion()
    shot = f.shot()
    f.path_trace(shot)
    lumas = f.encode(f.develop())
    case = f.write(lumas)
    if not keep_work:
        shutil.rmtree(f.work, ignore_errors=True)
    return case


class Footage:
    """One case being rendered: each stage below adds what the next ones read."""

    def __init__(self, spec, out_dir, tools, log):
        self.started = time.time()
        self.spec, self.tools, self.log = spec, tools, log
        self.out_dir = os.path.abspath(out_dir)
        os.makedirs(self.out_dir, exist_ok=True)
        self.work = os.path.join(self.out_dir, ".work")
        shutil.rmtree(self.work, ignore_errors=True)
        os.makedirs(self.work)
        self.rng = np.random.default_rng(int(spec["seed"]))
        self.vocab = vocabulary_values(spec)
        self.phone = dict(PHONE, **spec.get("phone", {}))
        self.effects = novel.effects_of(spec)
        self.duration = float(spec["duration_s"])

    def resolve(self):
        """The data scenario, and the camera with the nuisance the calibration must find
        (rotation centre ±1.5 px, marker angle ±3°) and the geometric effects."""
        self.data_file, self.scn, self.speed_scale = write_data_scenario(
            self.tools, self.spec, self.work, self.rng)
        scn, vocab = self.scn, self.vocab
        self.fps = float(scn["frame_timing"]["fps"])
        self.width, self.height = int(scn["camera"]["width_px"]), int(scn["camera"]["height_px"])
        camera = rig.Camera(scn)
        camera.rotation_centre_px = camera.rotation_centre_px + 1.5 * (2 * self.rng.random(2) - 1)
        marker = scn["scene"]["marker"]
        marker["angle_on_disc_deg"] = (float(marker["angle_on_disc_deg"])
                                       + 3.0 * (2 * self.rng.random() - 1))
        if "perspective_tilt" in vocab:
            camera.set_tilt(*vocab["perspective_tilt"])
        if "lens_distortion" in vocab:
            camera.distortion = [vocab["lens_distortion"][0], 0.0, 0.0, 0.0, 0.0]
        self.camera = camera

    def frame_schedule(self):
        """When the frames are taken (`times`) and what their stamps say (`stamps`)."""
        vocab, fps, rng = self.vocab, self.fps, self.rng
        model = self.scn["frame_timing"]["model"]
        if "frame_timing" in vocab:
            j, first, ppm, drop, alt = vocab["frame_timing"]
            times = schedule.phone(fps, self.duration, rng, jitter_s=j, first_interval_s=first,
                                   rate_error_ppm=ppm, drop_probability=drop,
                                   pair_alternation_s=alt)
            stamps = times
        elif "timebase" in vocab:
            # Frames taken on a phone's schedule, stamped at a constant rate.
            s = self.spec["timebase_schedule"]
            times = schedule.phone(fps, self.duration, rng, **{
                k: s[k] for k in ("jitter_s", "first_interval_s", "rate_error_ppm",
                                  "drop_probability", "pair_alternation_s")})
            stamps = np.arange(len(times)) / vocab["timebase"][0]
        elif model["kind"] == "constant":
            times = schedule.constant(fps, self.duration)
            stamps = times
        else:
            raise ValueError(f"frame_timing.model.kind `{model['kind']}`: this tool draws "
                             "constant rates and its own phone schedules only")
        self.times, self.stamps, self.n = times, stamps, len(times)

    def sample_motion(self):
        """Instants every 2 ms across each frame's exposure and readout, their Blender frame
        times, and the wheel's motion there (`geneva kinematics --times`)."""
        self.exposure = self.vocab.get("motion_blur", [self.phone["exposure_s"]])[0]
        self.readout = self.vocab.get("rolling_shutter", [0.0])[0]
        marks = self.scn["frame_timing"].get("timestamp_marks", "first_row_exposure_centre")
        starts = schedule.exposure_windows(self.times, self.exposure, self.readout, marks)
        interval = 1.0 / self.fps
        self.window = self.exposure + self.readout
        if self.window >= interval:
            raise ValueError("exposure + readout must fit in one frame interval")
        per_frame = max(2, int(math.ceil(self.window / 0.002)) + 1)
        steps = np.arange(per_frame) / (per_frame - 1)
        self.key_times = (starts[:, None] + self.window * steps[None, :]).reshape(-1)
        self.key_frames = (np.arange(self.n)[:, None]
                           + (self.window / interval) * steps[None, :]).reshape(-1)
        rows, _ = self.tools.motion(self.data_file, self.key_times, self.work)
        self.theta = np.array([float(r.get("theta2_actual_rad") or r["theta2_rad"])
                               for r in rows])
        self.offset = np.array([[float(r.get("centre_offset_x_m") or 0.0),
                                 float(r.get("centre_offset_y_m") or 0.0)] for r in rows])
        self.ctx = novel.Context(spec=self.spec, scenario=self.scn, camera=self.camera,
                                 rng=self.rng, key_times=self.key_times, theta=self.theta,
                                 phases=[r["phase"] for r in rows], duration_s=self.duration,
                                 frame_times=self.times)
        self.creep = sum((e.creep(self.ctx) for e in self.effects),
                         np.zeros(len(self.key_times)))

    def camera_keys(self):
        """The camera's pose at every key: shake (`camera_vibration`) and a loose mount's
        steps (novel) move it in its own image plane and roll it."""
        n_keys = len(self.key_times)
        shake, roll = np.zeros((n_keys, 2)), np.zeros(n_keys)
        if "camera_vibration" in self.vocab:
            shake += novel.random_shake(self.rng, self.key_times, self.vocab["camera_vibration"][0])
        for e in self.effects:
            d_shake, d_roll = e.camera(self.ctx)
            shake, roll = shake + d_shake, roll + d_roll
        cam = self.camera
        base, c2w = cam.position_m(), cam.camera_to_world()
        metres_per_px = cam.distance_m / cam.focal_px
        return [(float(b), rig.rows(cam.blender_rotation(rig.rot_z(roll[i])),
                                    base + c2w @ np.array([-shake[i, 0], -shake[i, 1], 0.0])
                                    * metres_per_px))
                for i, b in enumerate(self.key_frames)]

    def wheel_keys(self):
        wobble = sum((e.wobble(self.ctx) for e in self.effects), np.zeros(len(self.key_times)))
        return [(float(b), rig.wheel_matrix(self.theta[i], self.offset[i], wobble[i],
                                            novel.WOBBLE_AXIS_RAD))
                for i, b in enumerate(self.key_frames)]

    def focus_keys(self):
        """The disc's circle of confusion 4 σ of the optical blur (the scenario's, or the
        withheld effect's); a hunting autofocus moves it (novel)."""
        blur = self.scn["effects"]["optical_blur"]
        sigma = self.vocab.get("optical_blur",
                               [blur["sigma_px"] if blur.get("enabled") else 0.0])[0]
        coc = [4.0 * sigma] * self.n
        for e in self.effects:
            coc = e.coc(self.ctx, coc)
        self.coc = coc
        keys = [(float(k), defocus_focus_distance(self.camera, c, self.phone["aperture_m"]))
                for k, c in enumerate(coc)]
        return keys if len({f for _, f in keys}) > 1 else keys[:1]

    def marker_sheet(self):
        sheet_png = os.path.join(self.work, "marker.png")
        self.cells, _ = marker_image(self.scn, sheet_png)
        laminate = max((e.laminate for e in self.effects), default=0.0)
        marker = rig.marker_sheet(self.scn, sheet_png, LOOK["paper"], laminate)
        marker["pose"] = rig.marker_local(self.scn)
        marker["keys"] = []
        if np.any(self.creep != 0.0):
            marker["keys"] = [(float(b), rig.marker_local(self.scn, self.creep[i]))
                              for i, b in enumerate(self.key_frames)]
        return marker, sheet_png

    def shot(self):
        """What Blender renders (`blender_scene.py` reads it)."""
        cam = self.camera
        # The canvas: the image, or under a lens distortion the undistorted view that holds
        # every pixel's preimage.
        self.canvas_origin, self.canvas = np.array([0.0, 0.0]), (self.width, self.height)
        if cam.distortion is not None:
            self.canvas_origin, self.canvas = isp.canvas_for_distortion(cam, cam.distortion)
        pp = cam.principal_px - self.canvas_origin
        big = max(self.canvas)
        shift = ((pp[0] - (self.canvas[0] - 1) / 2) / big, -(pp[1] - (self.canvas[1] - 1) / 2) / big)
        marker, sheet_png = self.marker_sheet()
        self.duplicates = {}
        for e in self.effects:
            self.duplicates.update(e.duplicates(self.ctx))
        self.rendered = [k for k in range(self.n) if k not in self.duplicates]
        edge = plate_edge_m(cam)
        shot = {
            "samples": int(self.spec.get("samples", 16)),
            "seed": int(self.spec["seed"]) % (2 ** 31),
            "threads": self.tools.threads,
            "render_width": self.canvas[0],
            "render_height": self.canvas[1],
            "frames": self.n,
            "only_frames": self.rendered if self.duplicates else None,
            "shutter_frames": self.window * self.fps,
            # Cycles interpolates each object's transform between 2^(steps − 1) + 1 samples
            # over the shutter: one every 10 ms at most.
            "motion_steps": 1 + max(0, math.ceil(math.log2(max(1.0, self.window / 0.01)))),
            "rolling_duration": (self.exposure / self.window) if self.readout > 0 else None,
            "room": LOOK["room"],
            "camera": {"focal_px": cam.focal_px, "shift": shift, "keys": self.camera_keys(),
                       "dof": {"aperture_m": self.phone["aperture_m"], "blades": 0,
                               "focus_keys": self.focus_keys()}},
            "wheel": {"keys": self.wheel_keys(),
                      "disc_radius_m": float(self.scn["scene"]["disc_radius_mm"]) * 1e-3,
                      "thickness_m": 0.004, "hub_radius_m": 0.006, "hub_height_m": 0.004,
                      "material": LOOK["disc"]},
            "marker": marker,
            "tape": {"strips": rig.tape_strips(self.scn), "material": LOOK["tape"]},
            # The plate ends short of the view's right edge: the fabric shows beyond it.
            "plate": {"corners": [(-0.6, -0.35), (edge, -0.35), (edge, 0.35), (-0.6, 0.35)],
                      "z_m": 0.025, "material": LOOK["plate"]},
            "fabric": {"corners": [(-2.0, -1.5), (2.0, -1.5), (2.0, 1.5), (-2.0, 1.5)],
                       "z_m": 0.25, "material": LOOK["fabric"]},
            "lights": lights(),
            "extras": [x for e in self.effects
                       for x in e.extras(self.ctx, self.key_frames, marker, sheet_png)],
            "out_dir": os.path.join(self.work, "raw"),
        }
        os.makedirs(shot["out_dir"])
        return shot

    def path_trace(self, shot):
        shot_file = os.path.join(self.work, "shot.json")
        with open(shot_file, "w") as f:
            json.dump(shot, f)
        self.raw_dir = shot["out_dir"]
        wall = time.time()
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        proc = subprocess.run([self.tools.blender, "-b", "--factory-startup",
                               "--python-exit-code", "1", "-P",
                               os.path.join(HERE, "blender_scene.py"), "--", shot_file],
                              capture_output=True, text=True)
        with open(os.path.join(self.work, "blender.log"), "w") as f:
            f.write(proc.stdout + proc.stderr)
        if proc.returncode != 0:
            raise RuntimeError(f"Blender failed (see {self.work}/blender.log):\n"
                               f"{proc.stderr[-2000:]}")
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        self.blender_wall = time.time() - wall
        self.blender_cpu = ((after.ru_utime + after.ru_stime)
                            - (before.ru_utime + before.ru_stime))
        self.samples = shot["samples"]
        self.log(f"{self.spec['name']}: {len(self.rendered)} frames path-traced in "
                 f"{self.blender_wall:.0f} s wall, {self.blender_cpu:.0f} s CPU "
                 f"({self.blender_cpu / max(len(self.rendered), 1):.2f} CPU s/frame, "
                 f"{self.canvas[0]}×{self.canvas[1]}, {self.samples} samples)")

    def raw(self, k):
        return isp.read_raw(os.path.join(self.raw_dir, f"raw_{k:06d}.png"))

    def develop(self):
        """The phone from the light to 8-bit RGB: metering on frame 0's marker, the lens
        remap, the sensor, the tone curve, sharpening."""
        levels = self.scn["effects"]["lighting"]
        self.levels = self.vocab.get(
            "lighting", [levels["black_level_dn"], levels["white_level_dn"]])[:2]
        noise = self.scn["effects"]["pixel_noise"]
        self.full_well, self.read_noise = self.vocab.get(
            "pixel_noise", [noise["full_well_e"], noise["read_noise_e"]])
        self.noisy = bool(noise.get("enabled", True)) or "pixel_noise" in self.vocab
        ink, self.paper = meter(self.raw(self.rendered[0]), self.camera, self.scn,
                                self.theta[0], self.offset[0], self.cells, self.canvas_origin,
                                self.creep[0])
        self.ink_over_paper = ink / self.paper
        self.tone_exposure, self.veil = isp.solve_look(self.ink_over_paper, 1.0, *self.levels)
        cam = self.camera
        maps = None
        if cam.distortion is not None:
            maps = isp.distortion_maps(cam, cam.distortion, self.canvas_origin,
                                       (self.width, self.height))
        display = []
        for k in range(self.n):
            if k in self.duplicates:
                display.append(display[self.duplicates[k]].copy())
                continue
            light = self.raw(k)
            if maps is not None:
                light = isp.remap(light, maps)
            signal = isp.expose(light, 1.0 / self.paper, self.full_well, self.read_noise,
                                self.phone["headroom"], self.rng, noise=self.noisy)
            for e in self.effects:
                signal = e.signal(self.ctx, k, signal)
            rgb = isp.tone(np.maximum(signal + self.veil, 0.0), self.tone_exposure)
            rgb = isp.sharpen(rgb, self.phone["sharpen_amount"], self.phone["sharpen_sigma_px"])
            display.append(np.clip(np.round(rgb * 255.0), 0, 255).astype(np.uint8))
        return display

    def encode(self, display):
        """The codec: H.264 and back (luma), or JPEG of the luma for a compression case."""
        self.codec = "jpeg" if "compression" in self.vocab else self.phone["codec"]
        self.bitrate = None
        if self.codec == "h264":
            video = os.path.join(self.work, "footage.mp4")
            self.bitrate = self.phone["bits_per_pixel"] * self.width * self.height * self.fps
            isp.encode_h264(display, self.fps, video, self.bitrate, self.phone["gop"],
                            self.phone["bframes"], self.phone["preset"])
            lumas = isp.decode_luma(video, self.width, self.height)
            if len(lumas) != self.n:
                raise RuntimeError(f"{video}: {len(lumas)} frames decoded, {self.n} encoded")
            return lumas
        lumas = [np.clip(np.round(isp.luma(d.astype(np.float64))), 0, 255).astype(np.uint8)
                 for d in display]
        if self.codec == "jpeg":
            q = self.vocab.get("compression", [self.phone["jpeg_quality"] or 90])[0]
            lumas = [isp.jpeg(y, q) for y in lumas]
        return lumas

    def write(self, lumas):
        """frames/, timestamps.csv, truth.csv, rig_as_rendered.toml, preview.png, case.json."""
        out = self.out_dir
        frames_dir = os.path.join(out, "frames")
        shutil.rmtree(frames_dir, ignore_errors=True)
        os.makedirs(frames_dir)
        for k, y in enumerate(lumas):
            isp.write_png(os.path.join(frames_dir, f"frame_{k:06d}.png"), y)
        with open(os.path.join(frames_dir, "timestamps.csv"), "w") as f:
            f.write("frame,t_s\n")
            for k, t in enumerate(self.stamps):
                f.write(f"{k},{float(t)!r}\n")
        write_rig_as_rendered(self.data_file, os.path.join(out, "rig_as_rendered.toml"),
                              self.scn, self.camera, self.exposure, self.readout, self.tools)
        # The truth at the instants the frames were taken (their stamps may say otherwise).
        _, truth = self.tools.motion(self.data_file, self.times, self.work)
        shutil.copy(truth, os.path.join(out, "truth.csv"))
        preview(lumas, os.path.join(out, "preview.png"))
        case = dict(self.spec)
        case.update(self.stated())
        with open(os.path.join(out, "case.json"), "w") as f:
            json.dump(case, f, indent=1, default=float)
            f.write("\n")
        return case

    def stated(self):
        """What the renderer decided, for case.json."""
        rendered = max(len(self.rendered), 1)
        return {
            "renderer": "tools/pbr (Blender Cycles " + blender_version(self.tools) + ")",
            "frames": self.n,
            "size_px": [self.width, self.height],
            "render_canvas_px": list(self.canvas),
            "samples": self.samples,
            "nuisance": {"crank_speed_scale": self.speed_scale,
                         "rotation_centre_px": [float(v) for v in self.camera.rotation_centre_px],
                         "marker_angle_on_disc_deg":
                             self.scn["scene"]["marker"]["angle_on_disc_deg"],
                         "theta1_start_rad": self.scn["mechanism"]["theta1_start_rad"]},
            "phone": {**self.phone, "exposure_s": self.exposure, "readout_s": self.readout,
                      "circle_of_confusion_px": self.coc[0], "full_well_e": self.full_well,
                      "read_noise_e": self.read_noise, "pixel_noise": self.noisy,
                      "codec": self.codec, "bitrate_bps": self.bitrate,
                      "levels_dn": list(self.levels), "black_point": self.veil,
                      "tone_exposure": self.tone_exposure,
                      "metered_ink_over_paper": self.ink_over_paper},
            "duplicated_frames": {str(k): v for k, v in self.duplicates.items()},
            "seconds": {"blender_wall": round(self.blender_wall, 1),
                        "blender_cpu": round(self.blender_cpu, 1),
                        "cpu_per_frame": round(self.blender_cpu / rendered, 2),
                        "total_wall": round(time.time() - self.started, 1)},
        }


def write_rig_as_rendered(data_file, path, scn, camera, exposure, readout, tools):
    """The rig this footage shows as a scenario states it: the data scenario (mechanism effects
    and crank nuisance included) with the rotation centre, marker angle, exposure and rolling
    shutter the tool drew. The look, the phone's sensor and codec and the novel effects have no
    place in it; `geneva render` of it draws the same rig in the same poses at the same instants
    with the project's renderer (the CI test compares the two)."""
    text = tools.scenario_show(data_file)
    s = load_toml(text)
    s["camera"]["rotation_centre_px"] = [float(v) for v in camera.rotation_centre_px]
    s["scene"]["marker"]["angle_on_disc_deg"] = float(scn["scene"]["marker"]["angle_on_disc_deg"])
    s["effects"]["motion_blur"].update(enabled=exposure > 0.0, exposure_s=float(exposure))
    s["effects"]["rolling_shutter"].update(enabled=readout > 0.0,
                                           readout_s=float(readout) if readout > 0 else 0.02)
    with open(path, "w") as f:
        f.write(toml_text(s))


def toml_text(table):
    """A scenario (nested dicts, arrays of tables, numbers, strings, booleans) as TOML."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, str):
            return json.dumps(v, ensure_ascii=False)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        raise TypeError(f"toml_text: {type(v).__name__} is not a scenario value")

    out = []

    def emit(prefix, t):
        scalars = {k: v for k, v in t.items() if not isinstance(v, dict)
                   and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))}
        if prefix and (scalars or not t):
            out.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            out.append(f"{k} = {value(v)}")
        for k, v in t.items():
            name = f"{prefix}.{k}" if prefix else k
            if isinstance(v, dict):
                emit(name, v)
            elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
                for item in v:
                    out.append(f"\n[[{name}]]")
                    for ik, iv in item.items():
                        out.append(f"{ik} = {value(iv)}")

    emit("", table)
    return "\n".join(out).lstrip("\n") + "\n"


def lights():
    """One soft box up and to the left of the camera. A single light keeps the path tracer's
    own noise on the disc below the sensor's at few samples (two lights and a lit room tripled
    it: each sample picks one light)."""
    pos = novel.KEY_LIGHT_M
    return [{"size_m": (0.45, 0.45), "power_w": 7.0,
             "pose": rig.rows(rig.look_at(pos, (0, 0, 0)), pos)}]


def plate_edge_m(camera):
    """The plate's right edge: a sixth of the view short of the image's right border, at the
    plate's depth."""
    x_right_px = camera.width - 1 - camera.width / 6.0
    centre_x = camera.rotation_centre_px[0]
    return (x_right_px - centre_x) * (camera.distance_m + 0.025) / camera.focal_px


def meter(raw, camera, scn, theta2, offset, cells, canvas_origin, creep_rad):
    """The linear luma of the marker's ink and paper in a rendered frame (medians over the
    black border's cells and the white margin), where this tool's geometry puts them: the
    exposure is set on these, and a marker that is not where the geometry says fails here."""
    m = scn["scene"]["marker"]
    size = float(m["size_mm"]) * 1e-3
    margin = float(m["white_margin_mm"]) * 1e-3
    local = np.array(rig.marker_local(scn, creep_rad)).reshape(4, 4)
    wheel = np.array(rig.wheel_matrix(theta2, offset)).reshape(4, 4)
    to_world = wheel @ local
    a = np.linspace(-0.35, 0.35, 15) * size
    ink_pts = [(x, -0.5 * size + 0.5 * size / cells) for x in a]
    ink_pts += [(-0.5 * size + 0.5 * size / cells, y) for y in a]
    paper_pts = [(x, -0.5 * size - 0.5 * margin) for x in a]
    paper_pts += [(-0.5 * size - 0.5 * margin, y) for y in a]
    y = isp.luma(raw)

    def sample(pts):
        world = np.array([(to_world @ np.array([px, py, -0.0001, 1.0]))[:3] for px, py in pts])
        uv = camera.project(world) - canvas_origin
        h, w = y.shape
        vals = [y[int(round(v)), int(round(u))] for u, v in uv if 0 <= u < w and 0 <= v < h]
        if len(vals) < 5:
            raise RuntimeError("metering: the marker is outside the rendered frame")
        return float(np.median(vals))

    ink, paper = sample(ink_pts), sample(paper_pts)
    if not paper > 4 * ink:
        raise RuntimeError(f"metering: ink {ink:.4f} and paper {paper:.4f} where the geometry "
                           "puts the marker: the scene and this tool's projection disagree")
    return ink, paper


def preview(lumas, path):
    """The first, middle and last frames side by side, at half size."""
    picks = [lumas[0], lumas[len(lumas) // 2], lumas[-1]]
    small = [cv2.resize(p, (p.shape[1] // 2, p.shape[0] // 2), interpolation=cv2.INTER_AREA)
             for p in picks]
    cv2.imwrite(path, np.hstack(small))


def blender_version(tools):
    try:
        out = subprocess.run([tools.blender, "--version"], capture_output=True, text=True).stdout
        return out.split("\n")[0].replace("Blender", "").strip()
    except OSError:
        return "?"
