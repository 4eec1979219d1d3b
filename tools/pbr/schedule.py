"""When the frames are taken and what their stamps say, written for this tool.

A phone's schedule: frame 0 at 0 s; after a long first interval the frames follow a clock that
runs `rate_error_ppm` off the nominal rate; consecutive intervals alternate by
± `pair_alternation_s`; each frame time jitters (Gaussian, σ = `jitter_s`, cut at ±4σ); frames
after the second are dropped with `drop_probability`. The stamps are the true times, or — a
recorder that stamps a constant rate (a `timebase` case) — k / fps.
"""

import numpy as np


def constant(fps, duration_s):
    n = int(np.floor(duration_s * fps - 1e-9)) + 1
    return np.arange(n) / fps


def phone(fps, duration_s, rng, jitter_s=0.0, first_interval_s=0.0, rate_error_ppm=0.0,
          drop_probability=0.0, pair_alternation_s=0.0):
    """Frame times of a phone-like schedule on [0, duration_s)."""
    rate = fps * (1.0 + rate_error_ppm * 1e-6)
    interval = 1.0 / rate
    first = first_interval_s if first_interval_s > 0.0 else interval
    times = [0.0]
    slot = 1
    while True:
        t = first + (slot - 1) * interval
        if t >= duration_s + interval:
            break
        t += 0.5 * pair_alternation_s * (-1.0) ** slot
        if jitter_s > 0.0:
            t += float(np.clip(rng.normal(0.0, jitter_s), -4 * jitter_s, 4 * jitter_s))
        dropped = slot >= 2 and drop_probability > 0.0 and rng.random() < drop_probability
        if not dropped and t < duration_s:
            times.append(t)
        slot += 1
    times = np.array(times)
    if np.any(np.diff(times) <= 0.0):
        raise ValueError("schedule: jitter and alternation reorder frames; make them smaller")
    return times


def exposure_windows(stamps, exposure_s, readout_s, marks):
    """Start of row 0's exposure for each frame, from what its stamp marks."""
    stamps = np.asarray(stamps, float)
    if marks == "first_row_exposure_centre":
        return stamps - exposure_s / 2
    if marks == "first_row_exposure_start":
        return stamps.copy()
    if marks == "middle_row_exposure_centre":
        return stamps - readout_s / 2 - exposure_s / 2
    raise ValueError(f"frame_timing.timestamp_marks `{marks}`: not one this tool knows")
