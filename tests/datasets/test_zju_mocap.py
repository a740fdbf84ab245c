"""ZJU-MoCap import on a tiny sequence written in the dataset's layout."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morf.capture.project import CaptureProject
from morf.datasets import ZjuMocapConfig, import_zju_mocap
from morf.datasets.zju_mocap import HUMANNERF_FRAMES
from morf.errors import InputError
from morf.io import load_npz, read_image
from tests.datasets.fakes import RunsCommand, make_zju, person_box, zju_camera


def _cfg(**kw):
    return ZjuMocapConfig(detect=False, **kw)


def _box_mask(i):
    x0, y0, x1, y1 = person_box(i)
    m = np.zeros((80, 96), bool)
    m[y0:y1, x0:x1] = True
    return m


def test_camera_one_with_novel_views(tmp_path, monkeypatch):
    monkeypatch.setitem(HUMANNERF_FRAMES, "387", 6)  # the real limit is 540 frames
    folder = make_zju(tmp_path)
    res = import_zju_mocap(folder, tmp_path / "proj", _cfg(view_every=2))
    project = CaptureProject.open(tmp_path / "proj")
    ds = project.manifest["dataset"]
    assert res.num_frames == 6 and ds["source_frames"] == list(range(6)) and ds["subject"] == "387"
    for n in range(6):  # masks are the union of mask/ and mask_cihp/, aligned with camera 1's frame n
        assert (project.load_mask(n) == _box_mask(n)).all()
        gray = project.load_frame(n).mean(2)
        assert gray[_box_mask(n)].mean() > 150 and gray[~_box_mask(n)].mean() < 60
    K, R, T = zju_camera(0)
    cam = project.camera()
    assert np.allclose(cam.K, K) and np.allclose(cam.R, R) and np.allclose(cam.t, T[:, 0] / 1000)
    views = json.loads((tmp_path / "proj" / "dataset" / "views.json").read_text())
    assert views["project_frames"] == [0, 2, 4] and sorted(views["cameras"]) == ["camera_02", "camera_03"]
    K3, R3, T3 = zju_camera(2)
    c3 = views["cameras"]["camera_03"]["camera"]
    assert np.allclose(c3["R"], R3) and np.allclose(c3["t"], T3[:, 0] / 1000) and c3["fx"] == K3[0, 0]
    for n, j in enumerate(views["project_frames"]):  # camera 3 sees frame j with its person at box(j + 2)
        m = read_image(tmp_path / "proj" / "dataset" / "views" / "camera_03" / "masks" / f"{n:06d}.png", grayscale=True)
        assert ((m > 127) == _box_mask(j + 2)).all()
    smpl = load_npz(tmp_path / "proj" / "dataset" / "smpl.npz")
    assert smpl["valid"].all() and np.allclose(smpl["poses"][:, 0], np.arange(6)) and smpl["Th"].shape == (6, 3)


def test_other_camera_every_and_all(tmp_path):
    folder = make_zju(tmp_path, subject="999", n=5)
    res = import_zju_mocap(folder, tmp_path / "proj", _cfg(camera=2, every=2, view_every=0))
    assert any("no HumanNeRF frame count" in w for w in res.warnings)
    project = CaptureProject.open(tmp_path / "proj")
    assert project.manifest["dataset"]["source_frames"] == [0, 2, 4]
    assert (project.load_mask(1) == _box_mask(2 + 1)).all()  # camera 2 draws frame i at box(i + 1)
    assert not (tmp_path / "proj" / "dataset" / "views").exists()
    with pytest.raises(InputError, match="--camera 4: the sequence has cameras 1..3"):
        import_zju_mocap(folder, tmp_path / "p2", _cfg(camera=4))


def test_bad_inputs_name_the_file(tmp_path):
    folder = make_zju(tmp_path, n=2, cams=2)
    for d in ("mask", "mask_cihp"):
        (folder / d / "Camera_B1" / "000001.png").unlink()
    with pytest.raises(InputError, match=r"no mask for Camera_B1/000001.jpg: expected .*mask/Camera_B1/000001.png"):
        import_zju_mocap(folder, tmp_path / "proj", _cfg())
    assert not (tmp_path / "proj").exists()
    np.save(folder / "annots.npy", np.array({"cams": {}, "ims": [{"ims": ["../../etc/passwd", "x"]}]}, dtype=object),
            allow_pickle=True)
    with pytest.raises(InputError, match="annots.npy"):
        import_zju_mocap(folder, tmp_path / "proj", _cfg())
    (folder / "annots.npy").unlink()
    with pytest.raises(InputError, match="file not found: .*annots.npy"):
        import_zju_mocap(folder, tmp_path / "proj", _cfg())


def test_path_outside_the_folder_is_refused(tmp_path):
    folder = make_zju(tmp_path, n=1, cams=1)
    annots = {"cams": {k: [v] for k, v in zip("KRT", zju_camera(0))}, "ims": [{"ims": ["../outside.jpg"]}]}
    np.save(folder / "annots.npy", np.array(annots, dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="outside the sequence folder"):
        import_zju_mocap(folder, tmp_path / "proj", _cfg())


def test_malicious_annots_is_refused_without_running(tmp_path):
    folder = make_zju(tmp_path, n=1, cams=1)
    marker = tmp_path / "ran"
    np.save(folder / "annots.npy", np.array({"cams": RunsCommand(marker), "ims": []}, dtype=object), allow_pickle=True)
    with pytest.raises(InputError, match="refused to load .*annots.npy"):
        import_zju_mocap(folder, tmp_path / "proj", _cfg())
    assert not marker.exists()


def test_cli(tmp_path, capsys, monkeypatch):
    from morf.cli.main import main

    monkeypatch.setitem(HUMANNERF_FRAMES, "387", 4)
    folder = make_zju(tmp_path, n=5)
    assert main(["dataset", "zju-mocap", str(folder), str(tmp_path / "proj"), "--no-detect", "--view-every", "3"]) == 0
    out = capsys.readouterr().out
    assert "4 frames (4 train)" in out and "novel views: 2 cameras x 2 frames" in out
    assert main(["dataset", "zju-mocap", str(tmp_path / "missing"), str(tmp_path / "p2"), "--no-detect"]) == 2
    assert "ZJU-MoCap sequence folder not found" in capsys.readouterr().err
    assert main(["dataset", "people-snapshot", str(tmp_path / "missing"), str(tmp_path / "p3")]) == 2
    assert "People-Snapshot folder not found" in capsys.readouterr().err
