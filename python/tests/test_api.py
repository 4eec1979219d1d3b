"""The Python module against the library it wraps: what each job returns, in which units, and
that it is what the command line computes."""

import json
import os

import numpy as np
import pytest

import geneva_vision as gv


def test_scenarios_load_with_overrides_and_fail_naming_file_and_field(tmp_path):
    assert "fast" in gv.builtin_scenarios()
    s = gv.load_scenario("fast")
    assert (s["camera"]["width_px"], s["frame_timing"]["fps"]) == (1280, 30.0)
    s = gv.load_scenario("fast", overrides={"frame_timing.fps": 60.0})
    assert s["frame_timing"]["fps"] == 60.0
    bad = tmp_path / "bad.toml"
    bad.write_text('extend = "fast"\n[camera]\nwidth_px = -3\n')
    with pytest.raises(gv.ScenarioError) as e:
        gv.load_scenario(bad)
    assert "bad.toml" in str(e.value) and "width_px" in str(e.value)
    with pytest.raises(gv.ScenarioError, match="camera.distance_m"):
        gv.load_scenario("fast", overrides={"camera.distance_m": "far"})
    assert isinstance(gv.ScenarioError("x"), gv.GenevaError)
    checked = gv.check_scenario("fast")
    assert checked["name"] == "fast" and checked["frames"] == 60


def test_kinematics_are_consistent_derivatives_at_any_times():
    frames = gv.kinematics("fast")
    assert len(frames["t_s"]) == 60
    assert np.allclose(np.diff(frames["t_s"]), 1 / 30.0, rtol=0.2)
    # At 0.1 ms spacing the central difference of θ2 is ω2 to O(h²): ω2 changes by at most
    # |α2| h per step, so the difference stays far below 1e-3 of the peak ω2.
    t = np.linspace(0.2, 1.8, 16001)
    k = gv.kinematics("fast", t_s=t)
    omega_fd = np.gradient(k["theta2_rad"], t)
    peak = np.max(np.abs(k["omega2_rad_s"]))
    assert peak > 0.5
    assert np.max(np.abs(omega_fd[1:-1] - k["omega2_rad_s"][1:-1])) < 1e-3 * peak
    assert set(k["phase"]) >= {"dwell"}
    with pytest.raises(ValueError, match="finite"):
        gv.kinematics("fast", t_s=[0.0, float("nan")])


def test_render_returns_the_pixels_the_png_files_hold(tmp_path):
    one = gv.render("fast", 3, progress=False)
    assert one.shape == (720, 1280) and one.dtype == np.uint8
    some = gv.render("fast", range(2, 5), progress=False)
    assert some.shape == (3, 720, 1280)
    assert np.array_equal(some[1], one)
    assert np.array_equal(gv.render("fast", 3, progress=False), one), "deterministic"
    files = gv.render_files("fast", tmp_path / "r", frames=(3, 4), progress=False)
    png = [f for f in files if f.suffix == ".png"]
    assert len(png) == 1
    from matplotlib.image import imread

    assert np.array_equal(np.round(imread(png[0]) * 255).astype(np.uint8), one)
    independent = gv.render("fast", 3, renderer="independent", progress=False)
    assert independent.shape == one.shape and not np.array_equal(independent, one)
    with pytest.raises(gv.GenevaError, match="past the last frame"):
        gv.render("fast", range(55, 70), progress=False)
    with pytest.raises(ValueError, match="renderer"):
        gv.render("fast", 0, renderer="blender", progress=False)


def test_analyze_gives_every_sample_an_error_bar_that_covers_the_truth(rig, tmp_path):
    calls = []
    a = gv.analyze(
        tmp_path / "a",
        frames=rig / "frames",
        timestamps=rig / "frames" / "timestamps.csv",
        scenario=rig / "nominal.toml",
        error_bar_seeds=8,
        progress=lambda what, done, total: calls.append((what, done, total)),
    )
    assert {c[0] for c in calls} == {"detect", "simulate"}
    assert calls[-1][1] == calls[-1][2]
    n = len(a["t_s"])
    assert n == 45 and a["detected_frames"] == 45 and a["in_input"].all()
    fused = a["signals"]["fused"]
    for key in ("theta2_rad", "omega2_rad_s", "alpha2_sigma_rad_s2", "alpha2_beyond_noise"):
        assert fused[key].shape == (n,)
    assert a["error_bars"]["seeds"] == 8
    assert a["error_bars"]["sigma_relative_se"] == pytest.approx(1 / 4)
    # Against the truth (this footage's rig, the crank phase as fitted): the ω2 errors stand
    # within their bars. With σ correct the z RMS is 1 within the σ's own ±25 % (8 seeds) and
    # the sampling of ~40 correlated values; a σ off by 2× in either direction fails.
    truth = gv.kinematics(rig / "footage.toml", t_s=a["t_s"])
    sigma = fused["omega2_sigma_rad_s"]
    ok = np.isfinite(fused["omega2_rad_s"]) & np.isfinite(sigma)
    assert ok.sum() >= 40
    z = (fused["omega2_rad_s"][ok] - truth["omega2_rad_s"][ok]) / sigma[ok]
    assert 0.5 < np.sqrt(np.mean(z**2)) < 2.0
    # The table on disk holds the same values as the arrays.
    import csv

    with open(tmp_path / "a" / "kinematics.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["signal"] == "fused"]
    assert len(rows) == n
    on_disk = np.array([float(r["omega2_sigma_rad_s"]) for r in rows])
    assert np.allclose(on_disk, sigma, rtol=1e-12, equal_nan=True)
    names = sorted(p.name for p in a["files"])
    assert names == ["error_bars.md", "kinematics.csv", "measured.png", "tracks.csv"]


def test_analyze_refuses_bad_arguments_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="exactly one footage"):
        gv.analyze(tmp_path / "a", video="v.mp4", tracks="t.csv")
    with pytest.raises(ValueError, match="timestamps"):
        gv.analyze(tmp_path / "a", frames="frames")
    with pytest.raises(ValueError, match="at least 2 seeds"):
        gv.analyze(tmp_path / "a", tracks="t.csv", error_bar_seeds=1)
    with pytest.raises(ValueError, match="cw or ccw"):
        gv.analyze(tmp_path / "a", tracks="t.csv", angle_sense="up")
    with pytest.raises(gv.GenevaError, match="missing.csv"):
        gv.analyze(tmp_path / "a", tracks=tmp_path / "missing.csv")
    assert not (tmp_path / "a").exists()


def test_run_and_montecarlo_return_the_budget_they_write(tmp_path):
    b = gv.run("fast", tmp_path / "run", overrides={"duration_s": 1.0}, progress=False)
    assert b["frames"]["total"] == 30 and b["frames"]["detected"] == 30
    on_disk = json.loads((tmp_path / "run" / "budget.json").read_text())
    assert on_disk["omega"]["rms"] == b["omega"]["rms"] > 0
    mc = gv.montecarlo(
        "fast", tmp_path / "mc", seeds=2, overrides={"duration_s": 1.0}, progress=False
    )
    assert mc["seeds"] == 2
    assert (tmp_path / "mc" / "per_seed.csv").is_file()


def test_a_diagnosis_of_footage_of_the_rig_itself_finds_no_gap(rig, tmp_path):
    d = gv.diagnose(
        rig / "nominal.toml",
        tmp_path / "d",
        frames=rig / "frames",
        timestamps=rig / "frames" / "timestamps.csv",
        effects=["pixel_noise", "drive_speed"],
        seeds=4,
        progress=False,
    )
    assert d["verdict"] == "no_gap", d["verdict"]
    assert (tmp_path / "d" / "diagnosis.md").is_file()
    with pytest.raises(ValueError, match="not an effect"):
        gv.diagnose(rig / "nominal.toml", tmp_path / "e", tracks="t.csv", effects=["wobble"])


def test_an_analysis_that_cannot_estimate_keeps_its_detections(rig, tmp_path):
    # The detector looks for another marker id: every frame is searched, none has it, and
    # the estimator has nothing to work on. The searched track is kept for another try.
    with pytest.raises(gv.GenevaError, match="kept in"):
        gv.analyze(
            tmp_path / "a",
            frames=rig / "frames",
            timestamps=rig / "frames" / "timestamps.csv",
            scenario=rig / "nominal.toml",
            overrides={"detector.marker_id": 7, "scene.marker.id": 7},
            progress=False,
        )
    tracks = (tmp_path / "a" / "tracks.csv").read_text().splitlines()
    assert len(tracks) == 1 + 45
