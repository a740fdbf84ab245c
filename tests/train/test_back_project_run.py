"""Back-projection through the command a user runs: ``morf train --set colour_back_projections=N``
projects the colour channels with N passes (or chooses them with -1) and says so in train.log."""

import re

import numpy as np
import pytest

from morf.cli.main import main

pytestmark = pytest.mark.slow


def _train(root, name: str, passes: int) -> str:
    assert main(["train", str(root), "--preset", "tiny", "--steps", "2", "--device", "cpu", "--name", name,
                 "--set", f"colour_back_projections={passes}"]) == 0
    return (root / "runs" / name / "train.log").read_text()


def test_train_back_projects_the_colour_or_chooses_how_often(tmp_path, tiny_capture_source):
    from morf.train.trained_avatar import load_trained_avatar
    from tests.conftest import copy_capture

    project = copy_capture(tiny_capture_source, tmp_path / "cap")
    plain, two, chosen = _train(project.root, "plain", 0), _train(project.root, "two", 2), _train(project.root, "auto", -1)
    assert "back-projection" not in plain and "then 2 back-projection pass(es)" in two
    got = re.search(r"(\d) back-projection pass\(es\), chosen on (\d+) frames held aside", chosen)
    assert got is not None and int(got.group(1)) in (0, 1) and int(got.group(2)) > 0
    colour = {n: load_trained_avatar(project.runs_dir / n).texture[:3].numpy() for n in ("plain", "two")}
    assert not np.allclose(colour["plain"], colour["two"])  # the passes changed the projected colour ...
    assert abs(colour["plain"].mean() - colour["two"].mean()) < 0.02  # ... not its overall level
