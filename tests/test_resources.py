"""The shipped files live inside the package and an installed wheel carries every one of them."""

from __future__ import annotations

import fnmatch
import tomllib
from pathlib import Path

from morf.resources import FONT, MOTIONS, ROOT, SHADERS

REPO = Path(__file__).resolve().parents[1]


def test_every_shipped_file_is_package_data_of_the_wheel():
    data = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["package-data"]
    patterns = data["morf.resources"]
    files = [p.relative_to(ROOT).as_posix() for p in ROOT.rglob("*") if p.is_file() and p.suffix != ".py"
             and "__pycache__" not in p.parts]
    assert files
    missing = [f for f in files if not any(fnmatch.fnmatch(f, pat) for pat in patterns)]
    assert not missing, f"not listed as package data in pyproject.toml: {missing}"


def test_the_paths_point_inside_the_package():
    assert FONT.is_file() and SHADERS.is_dir() and sorted(MOTIONS.glob("*.npz"))
    for path in (FONT, SHADERS, MOTIONS):
        assert path.resolve().is_relative_to(REPO / "morf")
