#!/usr/bin/env python3
"""Path-traced footage of the rig, sharing no code with the project's renderers.

    pbr.py render CASE.json --out DIR [--geneva BIN] [--blender BIN] [--threads N]
    pbr.py suite ...            (see suite.py)

A case (JSON) names the base scenario, the seed, the duration, the path tracer's samples, the
vocabulary effects rendered (`vocabulary`: [{"effect", "values"}] in the registry's parameter
order) and the novel ones (`novel`: [{"kind", ...}]); see README.md. The footage folder gets
`frames/` (8-bit grey PNG + `timestamps.csv`), `truth.csv` (the mechanism's motion at the
instants the frames were taken), `case.json` (the case with everything the renderer decided:
nuisance, phone settings, cost) and `preview.png`.
"""

import argparse
import json
import os
import shutil
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import render  # noqa: E402


def default_geneva():
    root = os.path.dirname(os.path.dirname(HERE))
    for profile in ("release", "debug"):
        target = os.environ.get("CARGO_TARGET_DIR", os.path.join(root, "target"))
        path = os.path.join(target, profile, "geneva")
        if os.path.exists(path):
            return path
    return shutil.which("geneva") or "geneva"


def tools_from(args):
    blender = args.blender or shutil.which("blender")
    if blender is None:
        raise SystemExit("pbr: Blender is not installed (Debian: apt-get install blender)")
    geneva = args.geneva or default_geneva()
    # A path given relative to where the suite was started stays valid in any working folder.
    if os.sep in geneva:
        geneva = os.path.abspath(geneva)
    return render.Tools(geneva, blender,
                        args.threads or max(1, len(os.sched_getaffinity(0))))


def main(argv=None):
    parser = argparse.ArgumentParser(prog="pbr.py", description=__doc__.split("\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    r = sub.add_parser("render", help="render one case")
    r.add_argument("case")
    r.add_argument("--out", required=True)
    for p in (r,):
        p.add_argument("--geneva")
        p.add_argument("--blender")
        p.add_argument("--threads", type=int)
        p.add_argument("--keep-work", action="store_true",
                       help="keep the raw renders, the shot and Blender's log in OUT/.work")
    s = sub.add_parser("suite", help="render, calibrate, diagnose and score a set of cases")
    import suite  # noqa: E402
    suite.add_arguments(s)
    args = parser.parse_args(argv)
    if args.command == "render":
        with open(args.case) as f:
            spec = json.load(f)
        render.render_case(spec, args.out, tools_from(args), keep_work=args.keep_work)
    else:
        suite.run(args, tools_from)


if __name__ == "__main__":
    main()
