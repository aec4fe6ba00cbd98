"""Shared fixtures: small deterministic images, and the `caoen` command line the
comparisons run (its path in CAOEN_CLI; tests/python_package.rs sets it)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path
from typing import List

import numpy as np
import pytest


def picture(h: int = 64, w: int = 96, channels: int = 3, seed: int = 1) -> np.ndarray:
    """A smooth picture with some texture, 8-bit, HxWxC (HxW for one channel)."""
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    planes = [
        0.5 + 0.4 * np.sin(x / (7.0 + 3 * c) + y / (11.0 + c)) + 0.05 * rng.standard_normal((h, w))
        for c in range(channels)
    ]
    a = np.clip(np.stack(planes, axis=-1), 0.0, 1.0)
    a = (a * 255.0 + 0.5).astype(np.uint8)
    return a[..., 0] if channels == 1 else a


@pytest.fixture
def cli() -> Path:
    """The `caoen` binary, or skip when it is not given."""
    path = os.environ.get("CAOEN_CLI")
    if not path:
        pytest.skip("CAOEN_CLI is not set (tests/python_package.rs sets it)")
    return Path(path)


def run(cli: Path, args: List[str]) -> subprocess.CompletedProcess:
    """Runs the command line, failing the test with its stderr if it fails."""
    done = subprocess.run([str(cli), "--quiet", *args], capture_output=True)
    assert done.returncode == 0, done.stderr.decode()
    return done


@pytest.fixture
def png(tmp_path: Path) -> Path:
    """A 96x64 RGB PNG without metadata."""
    from PIL import Image

    path = tmp_path / "picture.png"
    Image.fromarray(picture()).save(path)
    return path
