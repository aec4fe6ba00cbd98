"""The Dask example: a folder on a LocalCluster of two workers gives the CLI's folder."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from PIL import Image

from conftest import picture, run

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "dask_encode.py"


def test_dask_example_matches_cli_folder_mode(cli, tmp_path: Path):
    pytest.importorskip("dask.distributed")
    src = tmp_path / "in"
    (src / "sub").mkdir(parents=True)
    Image.fromarray(picture(seed=1)).save(src / "a.png")
    Image.fromarray(picture(48, 64, seed=2)).save(src / "sub" / "b.jpg", quality=95)
    Image.fromarray(picture(40, 40, 4, seed=3)).save(src / "sub" / "c.png")
    (src / "notes.txt").write_text("not an image")

    run(cli, ["encode", str(src), "-o", str(tmp_path / "cli"), "-q", "60"])
    done = subprocess.run(
        [sys.executable, str(EXAMPLE), str(src), str(tmp_path / "dask"), "--workers", "2", "-q", "60"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    assert "dashboard: http" in done.stdout

    def files(root: Path):
        return {p.relative_to(root): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}

    cli_files, dask_files = files(tmp_path / "cli"), files(tmp_path / "dask")
    assert sorted(map(str, cli_files)) == ["a.cae", "sub/b.cae", "sub/c.cae"]
    assert dask_files == cli_files

    again = subprocess.run(
        [sys.executable, str(EXAMPLE), str(src), str(tmp_path / "dask"), "--workers", "2", "--resume"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert again.returncode == 0, again.stderr
    assert "(3 already complete, 0 failed)" in again.stderr
