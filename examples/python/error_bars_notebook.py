# %% [markdown]
# # Which spikes are real? Error bars on a filmed Geneva drive, from Python
#
# A notebook-style walk through the toolkit on footage that looks like a phone's: an external
# Geneva drive rendered by the project's *second* renderer (anti-aliasing in display space),
# with variable frame timing, sensor noise, blur and H.264 compression. The steps are those a
# user takes with real footage:
#
# 1. film the rig (here: render it, with a truth we keep to check against),
# 2. `calibrate` a scenario to the footage from what is known of the rig,
# 3. `analyze` the footage with that scenario: θ2, ω2, α2 with an error bar on every sample,
# 4. plot ω2 and α2 with their ±σ bands and the frames whose α2 stands beyond the noise.
#
# Run it as a script (`python examples/python/error_bars_notebook.py`) or cell by cell; it
# writes into `GENEVA_EXAMPLE_DIR` (default: a new temporary folder).

# %%
import os
import pathlib
import tempfile

import matplotlib

if __name__ == "__main__" or os.environ.get("GENEVA_EXAMPLE_DIR"):
    matplotlib.use("Agg")  # as a script or a test: draw into a file, no window
import matplotlib.pyplot as plt
import numpy as np

import geneva_vision as gv

work = pathlib.Path(os.environ.get("GENEVA_EXAMPLE_DIR") or tempfile.mkdtemp())
work.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## 1. Footage
# The rig as it really is. The user does not know these numbers: `calibrate` measures the
# image scale, the rotation centre, the crank speed and phase, the levels, blur and noise.

# %%
(work / "rig.toml").write_text(
    """extend = "fast"
name = "filmed-rig"
seed = 2024
duration_s = 2.5

[mechanism]
kind = "external"
slots = 4
theta1_start_rad = 0.7

[drive_speed]
kind = "constant"
omega1_rad_s = 2.6

[scene]
disc_radius_mm = 95.0

[scene.marker]
size_mm = 32.0
radius_mm = 55.0

[camera]
width_px = 640
height_px = 480
rotation_centre_px = [318.0, 236.0]

[camera.focal]
kind = "image_scale"
mm_per_px = 0.45

[frame_timing]
fps = 30.0

[frame_timing.model]
kind = "vfr"
first_interval_s = 0.05
jitter_s = 0.0001
rate_error_ppm = -4500.0

[effects.optical_blur]
sigma_px = 0.9

[effects.pixel_noise]
full_well_e = 9000.0
read_noise_e = 120.0
"""
)
video = work / "footage.mp4"
gv.render_files(work / "rig.toml", work / "render", video=video, renderer="independent")

# %% [markdown]
# ## 2. Calibrate
# What the user knows: the mechanism, the marker's side. Everything else comes from the video.

# %%
(work / "base.toml").write_text(
    'extend = "fast"\n[mechanism]\nkind = "external"\nslots = 4\n[scene.marker]\nsize_mm = 32.0\n'
)
cal = gv.calibrate(work / "base.toml", work / "calibration", video=video)
scale = cal["geometry"]["mm_per_px"]
speed = cal["motion"]["omega1_rad_s"]
print(f"image scale {scale['value']:.4f} ± {scale['u95']:.4f} mm/px (95 %)")
print(f"crank speed {speed['value']:.4f} ± {speed['u95']:.4f} rad/s (95 %)")
print(f"re-render check passed: {cal['check']['passed']}")

# %% [markdown]
# ## 3. Analyze with error bars
# The calibrated rig is simulated at the footage's own frame times on 16 seeds; every θ2, ω2,
# α2 gets the RMS of its simulated error against the true motion.

# %%
a = gv.analyze(work / "analysis", video=video, scenario=cal["scenario_file"])
fused = a["signals"]["fused"]
for line in a["error_bars"]["summary"]:
    print(line)
flagged = np.nan_to_num(fused["alpha2_beyond_noise"]) == 1.0
print(f"{flagged.sum()} of {len(flagged)} frames show an α2 beyond {a['error_bars']['k_sigma']} σ")

# %% [markdown]
# ## 4. Plot
# Bands are ±σ about the measured values; red points are frames whose α2 departs from the
# modelled motion by more than k σ of the noise: features the camera resolved.

# %%
t = a["t_s"]
fig, (ax_w, ax_a) = plt.subplots(2, 1, sharex=True, figsize=(9, 6))
w, sw = fused["omega2_rad_s"], fused["omega2_sigma_rad_s"]
ax_w.plot(t, w, ".-", lw=0.8, label="measured ω2")
ax_w.fill_between(t, w - sw, w + sw, alpha=0.3, label="± σ")
ax_w.set_ylabel("ω2 (rad/s)")
ax_w.legend(loc="upper right")
al, sa = fused["alpha2_rad_s2"], fused["alpha2_sigma_rad_s2"]
ax_a.plot(t, al, ".-", lw=0.8, label="measured α2")
ax_a.fill_between(t, al - sa, al + sa, alpha=0.3, label="± σ")
ax_a.plot(t, fused["alpha2_model_rad_s2"], "k--", lw=0.8, label="modelled motion")
ax_a.plot(t[flagged], al[flagged], "o", color="red", label=f"beyond {a['error_bars']['k_sigma']} σ")
ax_a.set_xlabel("t (s)")
ax_a.set_ylabel("α2 (rad/s²)")
ax_a.legend(loc="upper right")
fig.tight_layout()
figure = work / "error_bars.png"
fig.savefig(figure, dpi=100)
print(f"wrote {figure}")
