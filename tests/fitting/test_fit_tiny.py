"""A tiny end-to-end fit: a few frames made from the body model itself."""

import json

import numpy as np
import pytest
import torch

from morf.body.model import BodyPose
from morf.capture.project import CaptureProject
from morf.fitting import FitConfig, fit_project, fit_sequence, finalize, load_fits, preset
from morf.fitting.fit_body import FitBody
from morf.fitting.proxy_mesh import body_proxy

from .synthetic import SHAPE, make_inputs, turning_poses, write_project

def _vertex_error_mm(model, state, gt) -> np.ndarray:
    with torch.no_grad():
        out = model(BodyPose(state.rotvecs, state.transl), state.shape)
    d = (out.vertices - out.joints[:, :1]) - (gt.vertices - gt.joints[:, :1])
    return d.norm(dim=-1).mean(1).numpy() * 1000


def test_fit_body_matches_the_full_model(body_model):
    fb = FitBody(body_model, body_proxy(body_model, 0.03))
    g = torch.Generator().manual_seed(0)
    pose = BodyPose(0.2 * torch.randn(3, 104, 3, generator=g), torch.randn(3, 3, generator=g))
    full = body_model(pose, SHAPE)
    for shape in (SHAPE, SHAPE.expand(3, 6)):
        out = fb(pose, shape)
        assert (out.keypoints3d - full.keypoints3d).norm(dim=-1).max() < 1e-3  # pruned regressor: < 1 mm
        assert torch.allclose(out.proxy_vertices, full.vertices[:, fb.proxy_ids], atol=1e-5)


def test_fit_recovers_pose_roughly(body_model):
    n = 6
    # slow motion, as in a capture (the temporal term is tuned for it): 9 degrees of turn a frame
    pose = turning_poses(body_model, n, turn=np.pi / 4, cycles=0.25)
    inputs, gt = make_inputs(body_model, pose, SHAPE, size=256)
    cfg = preset("fast")
    state = fit_sequence(body_model, inputs, cfg, device=torch.device("cpu"))
    fits, rejected = finalize(body_model, inputs, cfg, state)
    err = _vertex_error_mm(body_model, state, gt)
    assert err.mean() < 60, err
    assert np.median(fits.keypoint_residual_px) < 3.0
    # The median IoU of these six small silhouettes depends on the CPU's float kernels: above 0.85
    # on the AMD EPYC where the bound was set, 0.847 on an Intel Xeon with AMX (0.847 with the
    # "default" fit preset too), with the same vertex error and keypoint residual.
    assert np.nanmedian(fits.silhouette_iou) > 0.83
    assert rejected == {}


def test_fit_project_writes_resumes_and_filters(tmp_path, body_model):
    project = write_project(tmp_path / "cap", body_model)
    cfg = preset("fast").replace(silhouette_resolution=64, iou_resolution=64, overlays=True)
    report = fit_project(project, cfg, model=body_model, device=torch.device("cpu"))
    out = project.fits_dir
    for name in ("fits.npz", "filter.json", "fit_config.json", "checkpoint.npz", "overlays/000007.jpg"):
        assert (out / name).is_file(), name
    fits = load_fits(project)
    assert fits.rotvecs.shape == (8, 104, 3) and fits.shape.shape == (1, 6)
    assert FitConfig.from_dict(json.loads((out / "fit_config.json").read_text())) == cfg
    assert 4 in project.auto_filter(), report.rejected
    assert set(project.auto_filter()) == {4}
    assert 4 not in project.training_frames()
    again = fit_project(project, cfg, model=body_model, device=torch.device("cpu"))
    assert again.up_to_date and again.resumed_from == len(cfg.stages)


def test_missing_keypoints_is_a_clear_error(tmp_path, body_model):
    from morf.errors import MorfError

    project = CaptureProject.create(tmp_path / "empty", num_frames=2, width=64, height=64, fps=None,
                                    source={"kind": "test"})
    with pytest.raises(MorfError, match="keypoints"):
        fit_project(project, preset("fast"), model=body_model)
