"""geneva-vision from Python: the toolkit's jobs on NumPy arrays.

Every function runs the Rust library underneath (the same code as the ``geneva`` command) with
the GIL released. Angles are in rad, angular velocities in rad/s, accelerations in rad/s², times
in s, pixel positions in px and grey levels in DN (0–255), as the names of the array keys say.

A scenario is a file path or a built-in name (``builtin_scenarios()``), optionally with
``overrides``: a mapping of dotted field paths to values, ``{"frame_timing.fps": 60.0}``,
applied and validated as ``geneva scenario show`` would.

Jobs that write files take ``out``, an output folder that is replaced all at once when the job
succeeds (a folder that geneva did not make is refused). ``progress`` is ``True`` (a line on
stderr), ``False``/``None`` (silent) or a callable ``progress(what, done, total)``.

Errors: ``ScenarioError`` (a scenario that does not load: the message names the file and the
field), ``GenevaError`` (any other failure: the message names the file, field or frame),
``ValueError`` (an argument out of range).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _native
from ._native import GenevaError, ScenarioError

__all__ = [
    "GenevaError",
    "ScenarioError",
    "builtin_scenarios",
    "load_scenario",
    "check_scenario",
    "kinematics",
    "render",
    "render_files",
    "analyze",
    "run",
    "montecarlo",
    "calibrate",
    "diagnose",
]

PathLike = Union[str, "os.PathLike[str]"]
Progress = Union[bool, None, Callable[[str, int, int], Any]]


class _StderrProgress:
    """``what done/total`` on stderr, redrawn at most twice a second and on completion."""

    def __init__(self) -> None:
        self._last = 0.0
        self._what = ""

    def __call__(self, what: str, done: int, total: int) -> None:
        now = time.monotonic()
        finished = total > 0 and done >= total
        if not finished and what == self._what and now - self._last < 0.5:
            return
        self._last, self._what = now, what
        end = "\n" if finished else ""
        sys.stderr.write(f"\r{what} {done}/{total}{end}")
        sys.stderr.flush()


def _progress(progress: Progress) -> Optional[Callable[[str, int, int], Any]]:
    if progress is True:
        return _StderrProgress()
    if progress is False or progress is None:
        return None
    if callable(progress):
        return progress
    raise TypeError("progress: expected True, False, None or a callable (what, done, total)")


def _path(p: Optional[PathLike]) -> Optional[str]:
    return None if p is None else os.fspath(p)


def _overrides(overrides: Optional[Mapping[str, Any]]) -> Optional[str]:
    if not overrides:
        return None
    return json.dumps(dict(overrides))


def builtin_scenarios() -> list[str]:
    """The names of the built-in scenarios (``fast``, ``seed-internal-4k``, …)."""
    return list(_native.builtin_scenarios())


def load_scenario(scenario: PathLike, overrides: Optional[Mapping[str, Any]] = None) -> dict:
    """The scenario resolved (``extend`` applied, defaults filled in) and validated, as a dict
    with the units in its field names (``camera.distance_m``, ``frame_timing.fps``, …)."""
    return json.loads(_native.scenario_json(os.fspath(scenario), _overrides(overrides)))


def check_scenario(scenario: PathLike, overrides: Optional[Mapping[str, Any]] = None) -> dict:
    """What ``geneva scenario check`` says: ``name``, ``frames`` (None when the work is over the
    limits and the rig was not built), ``work``, ``over_limits`` and ``warnings``."""
    return json.loads(_native.check_scenario(os.fspath(scenario), _overrides(overrides)))


def kinematics(
    scenario: PathLike,
    t_s: Optional[Sequence[float]] = None,
    overrides: Optional[Mapping[str, Any]] = None,
) -> dict:
    """The true motion at the times ``t_s`` (s; default: the scenario's frame times).

    Returns arrays ``t_s``, ``theta1_rad``, ``omega1_rad_s`` (crank), ``theta2_rad``,
    ``omega2_rad_s``, ``alpha2_rad_s2``, ``jerk2_rad_s3`` (wheel, ideal kinematics), the same with
    an ``actual_`` prefix where the scenario has dynamics (clearance, compliance), and ``phase``
    (the motion phase at each time: dwell, entry, indexing, exit …).
    """
    times = None if t_s is None else np.ascontiguousarray(t_s, dtype=np.float64)
    if times is not None and times.ndim != 1:
        raise ValueError("t_s: expected a one-dimensional sequence of times in seconds")
    return _native.kinematics(os.fspath(scenario), _overrides(overrides), times)


def _frame_range(scenario: PathLike, overrides, frames) -> tuple[int, int, bool]:
    if frames is None:
        count = len(kinematics(scenario, overrides=overrides)["t_s"])
        return 0, count, False
    if isinstance(frames, (int, np.integer)):
        if frames < 0:
            raise ValueError(f"frames: {frames} is not a frame number")
        return int(frames), int(frames) + 1, True
    if isinstance(frames, range):
        if frames.step != 1:
            raise ValueError("frames: a range with step 1")
        return frames.start, frames.stop, False
    start, stop = frames
    return int(start), int(stop), False


def render(
    scenario: PathLike,
    frames: Union[None, int, range, tuple[int, int]] = None,
    *,
    renderer: str = "own",
    overrides: Optional[Mapping[str, Any]] = None,
    progress: Progress = True,
) -> np.ndarray:
    """Frames of the scenario as ``uint8`` grey levels (DN).

    ``frames``: one frame number (returns an array of shape (height, width)), a ``range`` or
    ``(start, stop)`` with ``stop`` excluded, or None for every frame (shape (frames, height,
    width)). ``renderer``: ``"own"`` (exact area coverage in linear radiance) or
    ``"independent"`` (the second renderer, for cross-renderer checks). The pixels are those
    ``geneva render`` writes, bit for bit.
    """
    start, stop, single = _frame_range(scenario, overrides, frames)
    images = _native.render(
        os.fspath(scenario), _overrides(overrides), start, stop, renderer, _progress(progress)
    )
    return images[0] if single else images


def render_files(
    scenario: PathLike,
    out: PathLike,
    *,
    frames: Union[None, range, tuple[int, int]] = None,
    video: Optional[PathLike] = None,
    renderer: str = "own",
    overrides: Optional[Mapping[str, Any]] = None,
    progress: Progress = True,
) -> list[Path]:
    """``geneva render``: PNG frames (or, with ``video``, an MP4 through ffmpeg that keeps the
    variable timestamps) with ``timestamps.csv`` and ``truth.csv`` in ``out``. Returns the files
    written."""
    start = stop = None
    if frames is not None:
        start, stop, _ = _frame_range(scenario, overrides, frames)
    files = _native.render_files(
        os.fspath(scenario),
        _overrides(overrides),
        os.fspath(out),
        start,
        stop,
        _path(video),
        renderer,
        _progress(progress),
    )
    return [Path(f) for f in files]


def analyze(
    out: PathLike,
    *,
    video: Optional[PathLike] = None,
    frames: Optional[PathLike] = None,
    timestamps: Optional[PathLike] = None,
    tracks: Optional[PathLike] = None,
    scenario: Optional[PathLike] = None,
    overrides: Optional[Mapping[str, Any]] = None,
    angle_sense: str = "cw",
    error_bar_seeds: int = 16,
    k_sigma: float = 3.0,
    progress: Progress = True,
) -> dict:
    """``geneva analyze``: measure real footage (a video, a folder of frames with a timestamps
    CSV, or a corner track) and, with a scenario, give every sample an error bar.

    Returns a dict: ``t_s``, ``frame``, ``in_input`` (False for a frame number absent from the
    input, whose values are NaN), and under ``signals`` one dict per signal (``fused``,
    ``centre``, ``corner0`` … ``corner3``) with ``theta2_rad`` (from the first frame),
    ``omega2_rad_s``, ``alpha2_rad_s2``; with error bars also ``theta2_sigma_rad``,
    ``omega2_sigma_rad_s``, ``alpha2_sigma_rad_s2`` (standard uncertainty against the true
    motion, simulated on ``error_bar_seeds`` seeds of the rig at the footage's own frame times),
    ``*_model_*`` (the simulated rig's true motion), ``omega2_jump_sigma_rad_s``, the flags
    ``alpha2_beyond_noise`` and ``omega2_jump_beyond_noise`` (1.0 beyond ``k_sigma`` σ of the
    noise: a feature the camera resolved; 0.0 within it; NaN without a value) and
    ``sigma_seeds``. Also ``rotation_centre_px``, ``rotation_centre_sigma_px``,
    ``detected_frames``, ``error_bars`` (None, or ``seeds``, ``k_sigma``, ``sigma_relative_se``
    — the σ's own relative uncertainty, 1/√(2 seeds) —, ``motion_rms_rad`` and ``summary``),
    ``warnings`` (why there are no error bars, frames unreadable …), ``out`` and ``files``.

    ``angle_sense``: ``"cw"`` (clockwise on screen positive, the seed study's convention) or
    ``"ccw"``. The σ holds detection and timing noise and the estimator's own error; it does
    not hold model error (what ``diagnose`` is for).
    """
    signs = {"cw": -1.0, "ccw": 1.0}
    if angle_sense not in signs:
        raise ValueError(f"angle_sense `{angle_sense}`: expected cw or ccw")
    return _native.analyze(
        os.fspath(out),
        _path(video),
        _path(frames),
        _path(timestamps),
        _path(tracks),
        _path(scenario),
        _overrides(overrides),
        signs[angle_sense],
        int(error_bar_seeds),
        float(k_sigma),
        _progress(progress),
    )


def run(
    scenario: PathLike,
    out: PathLike,
    *,
    full_frame: bool = False,
    overrides: Optional[Mapping[str, Any]] = None,
    progress: Progress = True,
) -> dict:
    """``geneva run``: render, detect, estimate and judge the scenario against its truth.
    Returns ``budget.json`` as a dict (θ2, ω2, α2 errors per signal and motion phase, the
    half-pixel bound), with ``out`` and ``files``."""
    text, files = _native.run(
        os.fspath(scenario), _overrides(overrides), os.fspath(out), full_frame, _progress(progress)
    )
    budget = json.loads(text)
    budget["out"] = Path(out)
    budget["files"] = [Path(f) for f in files]
    return budget


def montecarlo(
    scenario: PathLike,
    out: PathLike,
    *,
    seeds: int = 10,
    full_frame: bool = False,
    overrides: Optional[Mapping[str, Any]] = None,
    progress: Progress = True,
) -> dict:
    """``geneva montecarlo``: the error budget over ``seeds`` seeds with 95 % confidence
    intervals. Returns ``budget.json`` as a dict, with ``out``. A study interrupted (the process
    killed) resumes from the seeds it finished when called again with the same ``out``."""
    text, _ = _native.montecarlo(
        os.fspath(scenario),
        _overrides(overrides),
        os.fspath(out),
        int(seeds),
        full_frame,
        _progress(progress),
    )
    budget = json.loads(text)
    budget["out"] = Path(out)
    return budget


def calibrate(
    base: PathLike,
    out: PathLike,
    *,
    video: Optional[PathLike] = None,
    frames: Optional[PathLike] = None,
    timestamps: Optional[PathLike] = None,
    image: Optional[PathLike] = None,
    single_frame: bool = False,
    progress: Progress = True,
) -> dict:
    """``geneva calibrate``: fit a scenario to footage. ``base`` states what is known of the
    rig (at least ``scene.marker.size_mm``, the mechanism, the marker's dictionary and id).

    Returns ``scenario`` (the calibrated scenario as a dict), ``scenario_file`` (its
    ``scenario.toml``, usable wherever a scenario is), ``frames``, ``detected_frames``,
    ``geometry``, ``motion``, ``imaging`` (each fitted value as ``{"value", "u95"}``: the
    half-width of its ≈95 % interval), ``check`` (the re-render check), ``notes`` and
    ``files``."""
    result = json.loads(
        _native.calibrate(
            os.fspath(base),
            os.fspath(out),
            _path(video),
            _path(frames),
            _path(timestamps),
            _path(image),
            single_frame,
            _progress(progress),
        )
    )
    if result.get("scenario_file"):
        result["scenario_file"] = Path(result["scenario_file"])
    result["files"] = [Path(f) for f in result["files"]]
    return result


def diagnose(
    scenario: PathLike,
    out: PathLike,
    *,
    video: Optional[PathLike] = None,
    frames: Optional[PathLike] = None,
    timestamps: Optional[PathLike] = None,
    tracks: Optional[PathLike] = None,
    effects: Optional[Sequence[str]] = None,
    seeds: int = 6,
    max_minutes: Optional[float] = None,
    overrides: Optional[Mapping[str, Any]] = None,
    progress: Progress = True,
) -> dict:
    """``geneva diagnose``: where the gap between the footage and the rig as believed
    (``scenario``) lies, which effect explains it and how far it shrinks once added.

    ``effects``: candidate names (default: the whole vocabulary, ``geneva scenario effects``).
    Returns ``diagnosis.json`` as a dict (``verdict``, the ranking, the fitted values with their
    95 % intervals), with ``out`` and ``files``. Progress reports the stage and the simulations
    run of those planned."""
    text, files = _native.diagnose(
        os.fspath(scenario),
        _overrides(overrides),
        os.fspath(out),
        _path(video),
        _path(frames),
        _path(timestamps),
        _path(tracks),
        None if effects is None else [str(e) for e in effects],
        int(seeds),
        None if max_minutes is None else float(max_minutes),
        _progress(progress),
    )
    diagnosis = json.loads(text)
    diagnosis["out"] = Path(out)
    diagnosis["files"] = [Path(f) for f in files]
    return diagnosis
