"""The one .npz reader: no pickle ever, text and bytes strings load, errors of the caller's kind."""

import numpy as np
import pytest

from morf.errors import InputError, ProjectError
from morf.io import load_npz, save_npz


def test_strings_as_text_or_bytes(tmp_path):
    np.savez(tmp_path / "a.npz", g1=np.array("male"), g2=np.array(b"female"), x=np.arange(3))
    d = load_npz(tmp_path / "a.npz")
    assert str(d["g1"]) == "male" and d["g2"].item() == b"female" and list(d) == ["g1", "g2", "x"]


def test_pickled_arrays_are_refused_or_left_out(tmp_path):
    np.savez(tmp_path / "p.npz", x=np.zeros(2), meta=np.array({"C7": 1}, dtype=object))
    with pytest.raises(ProjectError, match="'meta' holds Python objects"):
        load_npz(tmp_path / "p.npz")
    with pytest.raises(InputError, match="pickled"):
        load_npz(tmp_path / "p.npz", error=InputError)
    assert list(load_npz(tmp_path / "p.npz", skip_pickled=True)) == ["x"]


def test_missing_and_damaged_files(tmp_path):
    with pytest.raises(InputError, match="missing file"):
        load_npz(tmp_path / "none.npz", error=InputError)
    (tmp_path / "bad.npz").write_bytes(b"not a zip")
    with pytest.raises(ProjectError, match="not a readable .npz"):
        load_npz(tmp_path / "bad.npz")
    save_npz(tmp_path / "ok.npz", a=np.ones(2))
    assert load_npz(tmp_path / "ok.npz")["a"].sum() == 2
