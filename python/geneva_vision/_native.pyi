"""Type stubs of the extension module; `geneva_vision/__init__.py` documents each job."""

from typing import Any, Callable, Optional

import numpy as np
import numpy.typing as npt

ProgressFn = Optional[Callable[[str, int, int], Any]]

class GenevaError(Exception): ...
class ScenarioError(GenevaError): ...

def builtin_scenarios() -> list[str]: ...
def scenario_json(spec: str, overrides: Optional[str] = None) -> str: ...
def check_scenario(spec: str, overrides: Optional[str] = None) -> str: ...
def kinematics(
    spec: str, overrides: Optional[str] = None, t_s: Optional[npt.NDArray[np.float64]] = None
) -> dict[str, Any]: ...
def render(
    spec: str,
    overrides: Optional[str],
    start: int,
    end: int,
    renderer_name: str,
    progress: ProgressFn = None,
) -> npt.NDArray[np.uint8]: ...
def render_files(
    spec: str,
    overrides: Optional[str],
    out: str,
    start: Optional[int],
    end: Optional[int],
    video: Optional[str],
    renderer_name: str,
    progress: ProgressFn = None,
) -> list[str]: ...
def analyze(
    out: str,
    video: Optional[str],
    frames: Optional[str],
    timestamps: Optional[str],
    tracks: Optional[str],
    spec: Optional[str],
    overrides: Optional[str],
    angle_sign: float,
    error_bar_seeds: int,
    k_sigma: float,
    progress: ProgressFn = None,
) -> dict[str, Any]: ...
def run(
    spec: str, overrides: Optional[str], out: str, full_frame: bool, progress: ProgressFn = None
) -> tuple[str, list[str]]: ...
def montecarlo(
    spec: str,
    overrides: Optional[str],
    out: str,
    seeds: int,
    full_frame: bool,
    progress: ProgressFn = None,
) -> tuple[str, bool]: ...
def calibrate(
    base: str,
    out: str,
    video: Optional[str],
    frames: Optional[str],
    timestamps: Optional[str],
    image: Optional[str],
    single_frame: bool,
    progress: ProgressFn = None,
) -> str: ...
def diagnose(
    spec: str,
    overrides: Optional[str],
    out: str,
    video: Optional[str],
    frames: Optional[str],
    timestamps: Optional[str],
    tracks: Optional[str],
    effects: Optional[list[str]],
    seeds: int,
    max_minutes: Optional[float],
    progress: ProgressFn = None,
) -> tuple[str, list[str]]: ...
