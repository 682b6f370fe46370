"""Shared fixtures: the repository's scenes and the CLI binary the Python
results are compared with."""

import os
import shutil
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
SCENES = REPO / "scenes"

# 2 frames of a level-2 sphere: fast scenes for API tests.
SMALL_SCENE = """Scene(
    name: "small",
    membrane: Icosphere(level: 2),
    energy: [Bending(kappa: 1.0), Area(k: 1.0, target: OfInitial(1.0)), Volume(k: 1.0, target: OfInitial(0.95))],
    dynamics: (max_displacement: 0.01, iterations: 50, frames: 2),
)"""


def cli_binary() -> Path:
    """The remembrane CLI: $REMEMBRANE_BIN, else the newest of the
    workspace's target/{release,debug}/remembrane."""
    env = os.environ.get("REMEMBRANE_BIN")
    if env:
        return Path(env)
    found = [p for p in (REPO / "target" / d / "remembrane" for d in ("release", "debug")) if p.exists()]
    if not found:
        on_path = shutil.which("remembrane")
        if on_path:
            return Path(on_path)
        pytest.fail("no remembrane CLI binary: build it (cargo build) or set REMEMBRANE_BIN")
    return max(found, key=lambda p: p.stat().st_mtime)


@pytest.fixture
def cli() -> Path:
    return cli_binary()
