"""Shared footage for the tests: a short rig rendered once per session."""

import pytest

import geneva_vision as gv

# A 1.5 s run of the built-in `fast` rig (1280x720, 30 fps): one engagement and dwells.
NOMINAL = 'extend = "fast"\nduration_s = 1.5\n'


@pytest.fixture(scope="session")
def rig(tmp_path_factory):
    """A folder with `nominal.toml`, and `frames/` rendered from it on another seed (the
    footage a user would film of that rig: same design, other noise)."""
    d = tmp_path_factory.mktemp("rig")
    (d / "nominal.toml").write_text(NOMINAL)
    (d / "footage.toml").write_text(NOMINAL + "seed = 101\n")
    gv.render_files(d / "footage.toml", d / "frames", progress=False)
    return d
