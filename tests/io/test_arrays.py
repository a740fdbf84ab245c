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
    with pytest.raises(ProjectError, match="not an .npz archive"):
        load_npz(tmp_path / "bad.npz")
    save_npz(tmp_path / "ok.npz", a=np.ones(2))
    assert load_npz(tmp_path / "ok.npz")["a"].sum() == 2


def test_text_or_npy_named_npz_says_what_it_is(tmp_path):
    """numpy would try such a file as a pickle and suggest allow_pickle; the message says what is wrong."""
    (tmp_path / "notes.npz").write_text("rotvecs = [0, 0, 0]\n")
    with pytest.raises(InputError, match="notes.npz is not an .npz archive") as e:
        load_npz(tmp_path / "notes.npz", error=InputError)
    assert "pickle" not in str(e.value)
    np.save(tmp_path / "one.npy", np.zeros(3))
    (tmp_path / "one.npy").rename(tmp_path / "one.npz")
    with pytest.raises(InputError, match="single .npy array, not an .npz archive"):
        load_npz(tmp_path / "one.npz", error=InputError)
    (tmp_path / "empty.npz").write_bytes(b"")
    with pytest.raises(InputError, match="empty"):
        load_npz(tmp_path / "empty.npz", error=InputError)


def _zip_with_header(path, shape, dtype="<f4", payload=b""):
    """An .npz whose one member declares ``shape`` but holds only ``payload`` (a lying header)."""
    import io
    import zipfile

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": dtype, "fortran_order": False, "shape": shape})
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("poses.npy", buf.getvalue() + payload)


def test_declared_shape_over_the_limit_is_refused_before_reading(tmp_path):
    _zip_with_header(tmp_path / "bomb.npz", (1_000_000_000, 3))
    with pytest.raises(InputError) as e:
        load_npz(tmp_path / "bomb.npz", error=InputError)
    msg = str(e.value)
    assert "bomb.npz" in msg and "'poses'" in msg and "11.2 GiB" in msg and "256.0 MiB" in msg
    assert "\n" not in msg
    # project files may be larger, but a header claiming more than any capture is still refused
    _zip_with_header(tmp_path / "huge.npz", (10**12, 1000))
    with pytest.raises(ProjectError, match="'poses' would take"):
        load_npz(tmp_path / "huge.npz")


def test_member_expanding_over_the_limit_is_refused(tmp_path):
    np.savez_compressed(tmp_path / "zeros.npz", a=np.zeros(300_000), b=np.ones(3))  # 2.4 MB of zeros, a few KB stored
    with pytest.raises(InputError, match=r"member 'a.npy' would take 2.3 MiB in memory \(stored in .*KiB\)"):
        load_npz(tmp_path / "zeros.npz", error=InputError, max_bytes=2**20)
    assert load_npz(tmp_path / "zeros.npz", error=InputError, max_bytes=4 * 2**20)["a"].shape == (300_000,)


def test_all_members_together_are_bounded(tmp_path):
    np.savez_compressed(tmp_path / "many.npz", **{f"a{i}": np.zeros(100_000) for i in range(6)})  # 6 x 800 KB
    with pytest.raises(InputError, match="6 members together would take 4.6 MiB in memory, more than the 4.0 MiB"):
        load_npz(tmp_path / "many.npz", error=InputError, max_bytes=2**20)


def test_default_limits_by_kind_of_file():
    from morf.io.arrays import PROJECT_FILE_MAX_BYTES, USER_FILE_MAX_BYTES, default_max_bytes
    from morf.synth.ground_truth import GroundTruthError

    assert default_max_bytes(InputError) == USER_FILE_MAX_BYTES == 256 * 2**20
    assert default_max_bytes(ProjectError) == default_max_bytes(GroundTruthError) == PROJECT_FILE_MAX_BYTES
    assert PROJECT_FILE_MAX_BYTES >= 16 * 2**30  # a long capture's frame cache


def test_truncated_member_is_damaged_not_a_traceback(tmp_path):
    _zip_with_header(tmp_path / "short.npz", (10, 3), payload=b"\0" * 16)
    with pytest.raises(InputError, match="damaged .npz"):
        load_npz(tmp_path / "short.npz", error=InputError)


def test_first_outside_finds_the_first_bad_entry_in_row_order():
    from morf.io.arrays import first_outside

    assert first_outside(np.zeros((3, 2)), -1, 1) is None
    a = np.zeros((4, 3))
    a[2, 1], a[1, 2] = np.nan, 5.0
    assert first_outside(a, -1, 1) == ((1, 2), 5.0)
    a[1, 2] = 0.0
    index, value = first_outside(a, -1, 1)
    assert index == (2, 1) and np.isnan(value)
    assert first_outside(np.array([np.inf]), -np.inf, np.inf) is None  # the bounds are inclusive
    # per-column bounds broadcast: x within [0, 10], y within [0, 2]
    assert first_outside(np.array([[5.0, 1.0], [5.0, 3.0]]), [0, 0], [10, 2]) == ((1, 1), 3.0)
