"""The plain-data unpickler: numpy arrays and containers load, anything that runs code is refused."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from morf.datasets.safe_pickle import load_npy, load_plain_pickle, loads_plain
from morf.errors import InputError
from tests.datasets.fakes import RunsCommand


@pytest.mark.parametrize("protocol", [0, 2, 3, 4, 5])
def test_plain_data_round_trips(protocol):
    d = {"f": np.array([1.5, 2.5]), "m": np.arange(12, dtype=np.int16).reshape(3, 4), "s": np.float32(3.0),
         "w": 1080, "name": "cam", "list": [np.eye(3), (1, 2)], "bytes": b"\x00\x01", "set": {1, 2},
         "objects": np.array([{"k": np.ones(2)}], dtype=object)}
    out = loads_plain(pickle.dumps(d, protocol=protocol))
    assert out["m"].dtype == np.int16 and np.array_equal(out["m"], d["m"])
    assert np.array_equal(out["f"], d["f"]) and out["s"] == np.float32(3.0)
    assert out["w"] == 1080 and out["name"] == "cam" and out["bytes"] == b"\x00\x01" and out["set"] == {1, 2}
    assert np.array_equal(out["list"][0], np.eye(3)) and np.array_equal(out["objects"][0]["k"], np.ones(2))


@pytest.mark.parametrize("protocol", [0, 2, 4])
def test_code_running_pickle_is_refused_without_running(tmp_path, protocol):
    marker = tmp_path / "ran"
    path = tmp_path / "camera.pkl"
    path.write_bytes(pickle.dumps({"camera_f": np.ones(2), "x": RunsCommand(marker)}, protocol=protocol))
    with pytest.raises(InputError, match="refused to load .*camera.pkl.*system"):
        load_plain_pickle(path)
    assert not marker.exists()
    # the same file through an ordinary pickle.load does run the command: the test is real
    pickle.loads(path.read_bytes())
    assert marker.exists()


def test_other_globals_are_refused():
    for payload in (pickle.dumps(eval), pickle.dumps(np.load), pickle.dumps(pickle.Unpickler),
                    b"cbuiltins\ngetattr\n."):
        with pytest.raises(InputError, match="refused"):
            loads_plain(payload)


def test_damaged_pickle_is_one_line_error(tmp_path):
    with pytest.raises(InputError, match="not a readable pickle"):
        loads_plain(b"\x80\x04garbage")
    with pytest.raises(InputError, match="not found"):
        load_plain_pickle(tmp_path / "missing.pkl")


def test_npy_object_payload(tmp_path):
    p = tmp_path / "annots.npy"
    np.save(p, np.array({"cams": {"K": [np.eye(3)]}, "ims": [{"ims": ["a.jpg"]}]}, dtype=object), allow_pickle=True)
    d = load_npy(p).item()
    assert np.array_equal(d["cams"]["K"][0], np.eye(3)) and d["ims"][0]["ims"] == ["a.jpg"]
    plain = tmp_path / "plain.npy"
    np.save(plain, np.arange(5.0))
    assert np.array_equal(load_npy(plain), np.arange(5.0))


def test_npy_with_code_running_payload_is_refused(tmp_path):
    marker = tmp_path / "ran"
    p = tmp_path / "annots.npy"
    np.save(p, np.array({"cams": RunsCommand(marker)}, dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="refused to load .*annots.npy"):
        load_npy(p)
    assert not marker.exists()


def test_python2_pickle_of_an_array():
    """People-Snapshot's pickles come from Python 2: array buffers are str opcodes (latin-1)."""
    data = np.array([1.5, -2.0], "<f8").tobytes()
    py2 = (b"\x80\x02}q\x00U\x08camera_fq\x01cnumpy.core.multiarray\n_reconstruct\nq\x02cnumpy\nndarray\nq\x03"
           b"K\x00\x85U\x01b\x87Rq\x04(K\x01K\x02\x85cnumpy\ndtype\nq\x05U\x02f8K\x00K\x01\x87Rq\x06(K\x03U\x01<NNN"
           b"J\xff\xff\xff\xffJ\xff\xff\xff\xffK\x00tb\x89U\x10" + data + b"tbs.")
    assert np.array_equal(loads_plain(py2)["camera_f"], [1.5, -2.0])
