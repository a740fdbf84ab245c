"""export_project: a tiny synthetic capture, a few training steps, an exported avatar folder."""

from __future__ import annotations

import json

import numpy as np
import pytest

from morf.errors import ProjectError
from morf.export.project_export import ProjectExportConfig, export_project, pick_run, project_views
from morf.pipeline.control import StageControl
from morf.synth.ground_truth import load_ground_truth
from tests.conftest import copy_capture


@pytest.fixture(scope="module")
def trained_capture(tmp_path_factory, tiny_capture_source, body_model):
    """``morf synth --preset tiny`` + 3 training steps of the tiny preset on the ground-truth fits."""
    from morf.train.config import preset
    from morf.train.project_run import train_project

    project = copy_capture(tiny_capture_source, tmp_path_factory.mktemp("export") / "tiny")
    train_project(project, preset("tiny", steps=3, inpaint_steps=0), model=body_model)
    return project


def test_export_project_writes_the_avatar_folder_and_reports_progress(trained_capture, body_model, tmp_path):
    seen = []
    out = tmp_path / "avatar"
    manifest = export_project(trained_capture, ProjectExportConfig(out=str(out), calibration_views=4),
                              StageControl(seen.append), body_model=body_model)
    assert (out / "renderer_int8.onnx").is_file() and (out / "renderer.onnx").is_file()
    on_disk = json.loads((out / "manifest.json").read_text())
    assert on_disk["source"]["run"] == "morf-tiny" == manifest["source"]["run"]
    assert manifest["renderer"]["int8"]["calibration_views"] <= 4
    assert manifest["renderer"]["coverage"]["channel"] == 0  # the raster contract a third-party player follows
    assert manifest["int8_quality"]["on"] == "heldout"  # 12 frames: every 8th is held out
    q = manifest["int8_quality"]  # which activation ranges were kept, and both scores
    assert q["calibration"] in q["calibration_scores_db"] and set(q["calibration_scores_db"]) == {"percentile", "minmax"}
    assert q["calibration_scores_db"][q["calibration"]] == max(q["calibration_scores_db"].values())
    # the largest training scale: the working camera at the body's root, times the zoomed crops' factor
    from morf.raster.view_scale import pixels_per_metre
    from morf.train.trained_avatar import load_trained_avatar

    trained = load_trained_avatar(trained_capture.runs_dir / "morf-tiny")
    cfg = trained.config
    zoom = cfg.zoom_resolution / cfg.resolution if cfg.zoom_resolution else 1.0
    gt_root = np.asarray(load_ground_truth(trained_capture).transl[0], float)
    scale = manifest["trained_scale"]["max_pixels_per_metre"]
    assert scale >= pixels_per_metre(trained.camera, gt_root) * zoom * 0.99
    assert scale < pixels_per_metre(trained.camera, gt_root) * zoom * 1.5  # the person turns in place
    assert [p.stage for p in seen] == ["export"] * len(seen) and seen[-1].message == "done"
    assert not any(p.name.startswith(".") for p in tmp_path.iterdir())  # no temporary folder left


def test_views_hold_out_every_kth_training_frame(trained_capture, body_model):
    cam = trained_capture.camera()
    calib, held = project_views(trained_capture, cam, len(body_model.bone_names), "auto", heldout_every=4)
    n = len(trained_capture.training_frames())
    assert len(held) == n // 4 and len(calib) + len(held) == n
    assert calib[0].rotvecs.shape == (len(body_model.bone_names), 3)


def test_bad_runs_and_configs_are_one_line_errors(trained_capture, tmp_path):
    assert pick_run(trained_capture, None).name == "morf-tiny"
    with pytest.raises(ProjectError, match="no run named 'nope'"):
        pick_run(trained_capture, "nope")
    (trained_capture.runs_dir / "unfinished").mkdir(exist_ok=True)
    with pytest.raises(ProjectError, match="has not finished"):
        pick_run(trained_capture, "unfinished")
    with pytest.raises(ProjectError, match="layout"):
        export_project(trained_capture, ProjectExportConfig(input_layout="hwcn"))
    from morf.capture.project import CaptureProject

    empty = CaptureProject.create(tmp_path / "empty", num_frames=1, width=8, height=8, fps=1.0, source={"kind": "test"})
    with pytest.raises(ProjectError, match="no finished training run"):
        export_project(empty, ProjectExportConfig())


def test_a_run_trained_on_zoomed_crops_is_calibrated_as_close_as_the_player_draws(trained_capture, body_model,
                                                                                   tmp_path):
    """A run with ``zoom_resolution`` twice its resolution: the player draws the body up to twice as
    large as the training views show it, so the export calibrates and checks int8 there too."""
    from morf.train.config import preset
    from morf.train.project_run import train_project

    train_project(trained_capture, preset("tiny", steps=3, inpaint_steps=0, zoom_resolution=128), name="zoomed",
                  model=body_model)
    manifest = export_project(trained_capture, ProjectExportConfig(run="zoomed", out=str(tmp_path / "z"),
                                                                   calibration_views=4), body_model=body_model)
    close = manifest["int8_quality"]["playback_scale"]
    assert 1.9 < close["zoom"] < 2.6  # twice the crops, times the largest over the median training scale
    assert manifest["renderer"]["int8"]["calibration_zoom"] == pytest.approx([1.0, close["zoom"] ** 0.5, close["zoom"]],
                                                                              abs=1e-3)
    assert close["views"] >= 1 and np.isfinite(close["psnr_person_db"])
    plain = export_project(trained_capture, ProjectExportConfig(run="morf-tiny", out=str(tmp_path / "p"),
                                                                calibration_views=4), body_model=body_model)
    assert "playback_scale" not in plain["int8_quality"]  # no zoomed crops: the training views' scale is the player's


def test_builds_a_killed_export_left_beside_the_avatar_are_removed(tmp_path):
    from morf.export.project_export import _remove_stale_builds

    (tmp_path / ".avatar.k1ll3d.tmp").mkdir()
    (tmp_path / ".avatar.k1ll3d.tmp" / "mesh.npz").write_bytes(b"half")
    keep = [tmp_path / ".avatar.old.txt", tmp_path / "avatar.tmp", tmp_path / ".avatar-notes.tmp"]
    for p in keep:
        p.write_text("the user's")
    (tmp_path / ".eval.x.tmp").mkdir()  # another command's
    _remove_stale_builds(tmp_path / "avatar")
    assert not (tmp_path / ".avatar.k1ll3d.tmp").exists()
    assert all(p.read_text() == "the user's" for p in keep) and (tmp_path / ".eval.x.tmp").is_dir()
