"""``morf bench pareto --auto-check``: the scene lists it refuses. Its runs on the tiny preset are in
test_pareto.py, where they share the sweep's trainings of the same capture."""

import pytest

from morf.bench.auto_check import auto_check
from morf.errors import InputError


def test_auto_check_rejects_bad_scene_lists(tmp_path):
    with pytest.raises(InputError, match="unknown scenes"):
        auto_check(tmp_path, "tiny", scenes=("stripes",))
    with pytest.raises(InputError, match="exactly one scene"):
        auto_check(tmp_path, "tiny", scenes=("plain", "print"), project_path=str(tmp_path))
    with pytest.raises(InputError, match="seeds must be at least 1"):
        auto_check(tmp_path, "tiny", scenes=("print",), seeds=0)


def test_scene_projects_forms():
    from morf.bench.auto_check import scene_projects

    assert scene_projects(["plain", "print"], None) == {"plain": None, "print": None}
    assert scene_projects(["print"], "/cap") == {"print": "/cap"}
    assert scene_projects(["plain", "print", "loose"], "print=/cap, loose=/l") == \
        {"plain": None, "print": "/cap", "loose": "/l"}
    assert scene_projects(["plain", "print"], {"print": "/cap"}) == {"plain": None, "print": "/cap"}
    with pytest.raises(InputError, match="not checked"):
        scene_projects(["plain"], "print=/cap")
    with pytest.raises(InputError, match="scene=PATH"):
        scene_projects(["plain", "print"], "print=")
