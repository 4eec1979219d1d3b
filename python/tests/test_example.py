"""The notebook-style example runs as a user would run it, and what it prints is true of the
footage it films: the calibration finds the rig's scale and speed within their intervals, and
the error bars cover the true motion."""

import os
import pathlib
import runpy

import numpy as np

import geneva_vision as gv

EXAMPLE = pathlib.Path(__file__).parents[2] / "examples" / "python" / "error_bars_notebook.py"


def test_the_error_bar_notebook_runs_and_its_bars_cover_the_truth(tmp_path, monkeypatch):
    monkeypatch.setenv("GENEVA_EXAMPLE_DIR", os.fspath(tmp_path))
    g = runpy.run_path(os.fspath(EXAMPLE), run_name="example")
    assert (tmp_path / "error_bars.png").stat().st_size > 10_000
    truth = gv.load_scenario(tmp_path / "rig.toml")
    scale, speed = g["scale"], g["speed"]
    # Fitted values against the rig's, within their stated 95 % interval (a 2 % floor keeps the
    # test about the fit, not about how narrow an interval is on one footage).
    true_scale = truth["camera"]["focal"]["mm_per_px"]
    assert abs(scale["value"] - true_scale) <= max(scale["u95"], 0.02 * true_scale)
    true_speed = truth["drive_speed"]["omega1_rad_s"]
    assert abs(speed["value"] - true_speed) <= max(speed["u95"], 0.02 * abs(true_speed))
    a = g["a"]
    assert a["error_bars"]["seeds"] == 16
    # The ω2 errors against the rig's true motion, in units of their bars. The bars come from
    # the calibrated rig drawn by the first renderer, the footage from the second through a
    # codec, and across renderers they are not exact (reports/error-bars: z RMS 1.5–1.6 on
    # whole-pixel corners; 0.67 on this footage when the test was written): a factor of 2.5
    # either way fails, and so does any frame 10 σ out.
    k = gv.kinematics(tmp_path / "rig.toml", t_s=a["t_s"])
    fused = a["signals"]["fused"]
    z = (fused["omega2_rad_s"] - k["omega2_rad_s"]) / fused["omega2_sigma_rad_s"]
    z = z[np.isfinite(z)]
    assert len(z) >= 60
    z_rms = float(np.sqrt(np.mean(z**2)))
    assert 0.4 < z_rms < 2.5, z_rms
    assert np.max(np.abs(z)) < 10
