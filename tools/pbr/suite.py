"""The path-traced suite: footage no renderer of the project drew, through the user's chain
`geneva calibrate` → `geneva diagnose`, scored by `geneva diagnose-score`.

Cases (`plan`):
- `null-K`: the rig as stated, nothing withheld (K = 0 … nulls − 1, one seed each);
- `withheld-EFFECT-strong`: one effect of the vocabulary rendered at the self-check's strong level
  (`geneva scenario effects`), in this tool's own way;
- `novel-KIND`: an effect the vocabulary has no word for (`novel.py`): the answer sought is
  `unexplained`.

Each case: render (`render.py`) → calibrate the footage with the rig as the base → the nominal:
the calibrated scenario, with the withheld effect (if any) switched off through the registry
(`geneva scenario show --without`), as the self-check's nominal lacks what it withholds → diagnose
with every candidate → score. A case's steps leave their outputs in its folder and a step whose
output exists is not redone, so an interrupted suite resumes where it stopped.
"""

import json
import os
import resource
import shutil
import subprocess
import sys
import time

import novel
import render

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
RIG = os.path.join(HERE, "rig.toml")

# The suite's size: 20 null cases (the false-alarm figure is over ≥ 20), every withheld
# effect of the vocabulary at the strong level once, every novel effect once.
NULLS = 20
QUICK = ["null-0", "withheld-motion_blur-strong", "novel-creep"]

# The self-checks whose figures the report shows beside this footage's: the project's renderer
# and the independent one, each drawing the `fast` rig (1280×720, 6 s) for its own nominal.
BESIDE = [("the project's renderer", "diagnosis"),
          ("the independent renderer", "diagnosis-independent")]


def add_arguments(p):
    p.add_argument("--work", default=os.path.join(REPO, "out", "pbr-suite"),
                   help="where the cases are rendered, calibrated and diagnosed (resumable)")
    p.add_argument("--report", default=os.path.join(REPO, "reports", "diagnosis-pbr"),
                   help="the scored report (`geneva diagnose-score`)")
    p.add_argument("--quick", action="store_true", help=f"only {', '.join(QUICK)}")
    p.add_argument("--cases", help="only these cases of the plan (comma-separated names)")
    p.add_argument("--list", action="store_true", help="print the plan's cases and stop")
    p.add_argument("--nulls", type=int, default=NULLS)
    p.add_argument("--samples", type=int, default=10, help="path-tracing samples per pixel")
    p.add_argument("--duration-s", type=float, default=4.0)
    p.add_argument("--seed", type=int, default=20261205)
    p.add_argument("--render-only", action="store_true",
                   help="render the footage and stop (no calibrate, diagnose or score)")
    p.add_argument("--retry-failed", action="store_true",
                   help="run again the cases whose calibration or diagnosis failed before")
    p.add_argument("--keep-frames", action="store_true",
                   help="keep each case's frames after its diagnosis (about 12 MB a case)")
    p.add_argument("--diagnose-arg", action="append", default=[],
                   help="passed to `geneva diagnose` (repeat: --diagnose-arg=--seeds --diagnose-arg=6)")
    p.add_argument("--geneva")
    p.add_argument("--blender")
    p.add_argument("--threads", type=int)
    p.add_argument("--keep-work", action="store_true")


def vocabulary(tools, fps):
    out = subprocess.run([tools.geneva, "scenario", "effects", "--fps", repr(fps)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out)


def plan(tools, args):
    """Every case of the suite, in order, as render specs."""
    import tomllib
    rig = tomllib.loads(tools.scenario_show(RIG))
    fps = float(rig["frame_timing"]["fps"])
    vocab = vocabulary(tools, fps)
    # Recorded relative to the repository, so that a case's record names no machine's folders.
    common = {"base": os.path.relpath(RIG, REPO), "duration_s": args.duration_s,
              "samples": args.samples}
    cases = []
    seed = args.seed
    for k in range(args.nulls):
        seed += 7919
        cases.append(dict(common, name=f"null-{k}", seed=seed, group="null",
                          expectation={"kind": "null"}, truths=[], vocabulary=[], novel=[],
                          withheld=[], description="nothing withheld"))
    shared = set()
    for e in vocab["effects"]:
        # An effect that shares its switch with one already withheld is that case again
        # (overrotation is the backlash's contact dynamics).
        if e["name"] in shared:
            continue
        # The phone codes every case's footage (H.264 at its bitrate, `render.PHONE`), which the
        # nominal `calibrate` writes holds as measured noise and blur with the codec switched
        # off: a withheld codec is every case here, not a case of its own.
        if e["name"] == "video_codec":
            continue
        shared.update(e["shares_switch_with"])
        values = [p["strong"] for p in e["params"]]
        seed += 7919
        spec = dict(common, name=f"withheld-{e['name']}-strong", seed=seed, group="vocabulary",
                    expectation={"kind": "withheld", "effect": e["name"],
                                 "also": e["shares_switch_with"], "strong": True},
                    truths=[{"effect": e["name"], "values": values}],
                    vocabulary=[{"effect": e["name"], "values": values}], novel=[],
                    withheld=[e["name"]],
                    description=f"{e['name']} at " + ", ".join(
                        f"{p['name']} {p['strong']:g} {p['unit']}".strip() for p in e["params"]))
        if e["name"] == "timebase":
            spec["timebase_schedule"] = vocab["timebase_schedule"]["strong"]
            spec["description"] = ("frames taken on a phone's schedule, stamped at a constant "
                                   f"{values[0]:g} fps")
        cases.append(spec)
    for kind, cls in novel.KINDS.items():
        seed += 7919
        cases.append(dict(common, name=f"novel-{kind}", seed=seed, group="novel",
                          expectation={"kind": "out_of_vocabulary"}, truths=[], vocabulary=[],
                          novel=[{"kind": kind}], withheld=[], description=cls.doc))
    return cases


def git_commit():
    try:
        out = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], check=True,
                             capture_output=True, text=True).stdout.strip()
        dirty = subprocess.run(["git", "-C", REPO, "status", "--porcelain", "--", "src"],
                               capture_output=True, text=True).stdout.strip()
        return out + (" (with uncommitted changes under src/)" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def step(name, log):
    log(f"  {name}")
    return time.time()


def run_case(spec, folder, tools, args, log):
    """Render, calibrate, diagnose one case; each step skipped when its output exists. A
    calibration or diagnosis that fails on the footage is recorded in `failed.json` (the
    scoring counts it a miss) and not retried unless asked."""
    frames = os.path.join(folder, "frames")
    case_file = os.path.join(folder, "case.json")
    failed = os.path.join(folder, "failed.json")
    if os.path.exists(failed):
        if not args.retry_failed:
            log("  failed before (failed.json); --retry-failed runs it again")
            return
        os.remove(failed)
    if not os.path.exists(case_file):
        t = step("render", log)
        render.render_case(spec, folder, tools, keep_work=args.keep_work, log=log)
        record_seconds(case_file, {"render_wall": time.time() - t})
    if args.render_only:
        return
    try:
        chain(spec, folder, frames, tools, args, log)
    except ChainFailed as e:
        with open(failed, "w") as f:
            json.dump({"step": e.step, "message": str(e)}, f, indent=1)
            f.write("\n")
        raise


class ChainFailed(RuntimeError):
    def __init__(self, step, message):
        super().__init__(message)
        self.step = step


def record_seconds(case_file, seconds):
    with open(case_file) as f:
        case = json.load(f)
    case.setdefault("seconds", {}).update({k: round(v, 1) for k, v in seconds.items()})
    with open(case_file + ".partial", "w") as f:
        json.dump(case, f, indent=1)
        f.write("\n")
    os.replace(case_file + ".partial", case_file)


def chain(spec, folder, frames, tools, args, log):
    seconds = {}
    case_file = os.path.join(folder, "case.json")
    calibrated = os.path.join(folder, "calibrated")
    if not os.path.exists(os.path.join(calibrated, "scenario.toml")):
        need_frames(frames, spec)
        t = step("calibrate", log)
        # Each step runs in the case's folder with relative paths: the outputs name the
        # footage and files as `frames`, `calibrated/…`, not by this machine's folders.
        cpu = run_logged(tools, ["calibrate", "--frames", "frames", "--timestamps",
                                 "frames/timestamps.csv", "--base",
                                 os.path.relpath(RIG, folder), "--out", "calibrated"],
                         os.path.join(folder, "calibrate.log"), "calibrate", folder)
        seconds["calibrate_wall"] = time.time() - t
        seconds["calibrate_cpu"] = cpu
    # The nominal sits beside the calibrated scenario: the files it names (timestamps,
    # appearance) are relative to that folder.
    nominal = os.path.join(calibrated, "nominal.toml")
    if not os.path.exists(nominal):
        text = tools.scenario_show(os.path.join(calibrated, "scenario.toml"),
                                   without=spec["withheld"])
        with open(nominal + ".partial", "w") as f:
            f.write(text)
        os.replace(nominal + ".partial", nominal)
    diagnosis = os.path.join(folder, "diagnosis")
    if not os.path.exists(os.path.join(diagnosis, "diagnosis.json")):
        need_frames(frames, spec)
        t = step("diagnose", log)
        cpu = run_logged(tools, ["diagnose", "--scenario", "calibrated/nominal.toml",
                                 "--frames", "frames", "--timestamps", "frames/timestamps.csv",
                                 "--out", "diagnosis", "--yes"] + args.diagnose_arg,
                         os.path.join(folder, "diagnose.log"), "diagnose", folder)
        seconds["diagnose_wall"] = time.time() - t
        seconds["diagnose_cpu"] = cpu
    if seconds:
        record_seconds(case_file, seconds)
        with open(case_file) as f:
            case = json.load(f)
        if "diagnose_wall" in seconds:
            case["geneva_commit"] = git_commit()
            with open(case_file, "w") as f:
                json.dump(case, f, indent=1)
                f.write("\n")
    if not args.keep_frames:
        shutil.rmtree(frames, ignore_errors=True)


def need_frames(frames, spec):
    if not os.path.isdir(frames):
        raise RuntimeError(f"{spec['name']}: its frames were deleted before this step finished; "
                           "delete the case's folder to render it again")


def run_logged(tools, args, log_file, step_name, cwd):
    """Runs `geneva ARGS` in `cwd` into `log_file`; returns its CPU seconds."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(log_file, "w") as f:
        proc = subprocess.run([tools.geneva] + args, stdout=f, stderr=subprocess.STDOUT,
                              cwd=cwd)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    if proc.returncode != 0:
        with open(log_file) as f:
            tail = f.read()[-1500:]
        if proc.returncode < 0:
            # Killed (a signal): not the footage's fault; the step runs again on resume.
            raise RuntimeError(f"geneva {args[0]} was stopped by signal {-proc.returncode}")
        raise ChainFailed(step_name, f"geneva {args[0]} failed (log: {log_file}):\n{tail}")
    return cpu


def about(args, cases, tools):
    c = {"duration": args.duration_s, "samples": args.samples}
    lines = [
        "# Diagnosis of path-traced footage (a third source)",
        "",
        "Footage drawn by a physically based path tracer (Blender's Cycles, driven by "
        "`tools/pbr/`) that shares no code with the project's two renderers: the rig as 3D "
        "geometry with textured materials (an orange printed disc with print-line relief, the "
        "ArUco marker from OpenCV's own dictionaries printed on paper and taped down, a hub, a "
        "wooden base plate, red fabric behind), one soft box, depth of field, motion blur over "
        "the shutter, Cycles' rolling shutter (where a case withholds it), and the tool's own "
        "phone: a Bayer sensor with shot and read noise, a veiling glare and a filmic tone "
        "curve, sharpening, and H.264 at 0.27 bit per pixel (1.2 Mbit/s at 384×384 and 30 fps) "
        "with B-frames (JPEG for the compression case). Only the mechanism's motion is "
        "the project's (`geneva kinematics --times`). Each case goes through the user's chain: "
        "`geneva calibrate` with `tools/pbr/rig.toml` as the base, then `geneva diagnose` with "
        "every candidate against the calibrated scenario — with the withheld effect switched off "
        "(`geneva scenario show --without`) where a case withholds one, as the self-check's "
        "nominal lacks what it withholds — and `geneva diagnose-score` scores the diagnoses "
        "with `src/diagnose/scoring.rs`. `tools/pbr/README.md` says how each effect is drawn.",
        "",
        f"The rig (`tools/pbr/rig.toml`): the self-check's `fast` rig, its marker 64 px across "
        f"as in the self-check's footage, cropped to 384×384 px around the marker's path; "
        f"{c['duration']:g} s at 30 fps (one index of the wheel), {c['samples']} path-tracing "
        "samples per pixel.",
        "",
        "The columns beside this footage's are the self-checks of the project's two renderers "
        "(their own plans on the 1280×720 `fast` rig, 6 s, the nominal their own rig without "
        "the cause; no calibration in between).",
        "",
        f"This report holds the cases diagnosed so far: {diagnosed(args.work, cases)} of the "
        f"plan's {len(cases)} (`tools/pbr/pbr.py suite --list`).",
        "",
        "Made by `cargo xtask pbr-suite` (`python3 tools/pbr/pbr.py suite`); resumable. "
        "The diagnosis' tolerances were frozen before this footage's first run: the "
        "commit each case was diagnosed with is in its `case.json` (`geneva_commit`); "
        + commits_line(args.work, cases),
    ]
    return "\n".join(lines) + "\n"


def diagnosed(work, cases):
    return sum(os.path.exists(os.path.join(work, "cases", c["name"], "diagnosis", "diagnosis.json"))
               or os.path.exists(os.path.join(work, "cases", c["name"], "failed.json"))
               for c in cases)


def commits_line(work, cases):
    commits = set()
    for spec in cases:
        path = os.path.join(work, "cases", spec["name"], "case.json")
        if os.path.exists(path):
            with open(path) as f:
                c = json.load(f).get("geneva_commit")
            if c:
                commits.add(c)
    if not commits:
        return "no case has been diagnosed yet."
    if len(commits) == 1:
        return f"all were diagnosed with `{commits.pop()}`."
    return "**the cases were diagnosed with different commits**: " + ", ".join(
        f"`{c}`" for c in sorted(commits)) + "."


def run(args, tools_from):
    tools = tools_from(args)
    cases = plan(tools, args)
    names = [c["name"] for c in cases]
    wanted = QUICK if args.quick else (args.cases.split(",") if args.cases else names)
    unknown = [w for w in wanted if w not in names]
    if unknown:
        raise SystemExit(f"pbr suite: not cases of the plan: {', '.join(unknown)}\n"
                         f"the plan: {', '.join(names)}")
    if args.list:
        for c in cases:
            print(f"{c['name']:42s} {c['description']}")
        return
    os.makedirs(os.path.join(args.work, "cases"), exist_ok=True)
    failed = []
    for spec in cases:
        if spec["name"] not in wanted:
            continue
        folder = os.path.join(args.work, "cases", spec["name"])
        print(f"pbr suite: {spec['name']}", flush=True)
        try:
            run_case(spec, folder, tools, args, lambda m: print(m, flush=True))
        except (RuntimeError, ValueError, subprocess.CalledProcessError) as e:
            print(f"pbr suite: {spec['name']} failed: {e}", file=sys.stderr, flush=True)
            failed.append(spec["name"])
    if not args.render_only:
        about_file = os.path.join(args.work, "about.md")
        with open(about_file, "w") as f:
            f.write(about(args, cases, tools))
        score = [tools.geneva, "diagnose-score", "--cases", os.path.join(args.work, "cases"),
                 "--about", about_file, "--out", args.report]
        for name, folder in BESIDE:
            summary = os.path.join(REPO, "reports", folder, "summary.json")
            if os.path.exists(summary):
                # Relative to the repository, so that the report names no machine's paths.
                score += ["--beside",
                          f"{name} (`reports/{folder}/`)={os.path.relpath(summary, REPO)}"]
        subprocess.run(score, check=True, cwd=REPO)
    if failed:
        raise SystemExit(f"pbr suite: {len(failed)} case(s) failed: {', '.join(failed)}")
