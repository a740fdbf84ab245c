"""The avatar carries the fit's clothing offsets end to end: ``morf train`` rasterizes the dressed
body, ``morf export`` stores it as the mesh the player skins, and ``morf play`` draws it."""

from __future__ import annotations

import numpy as np
import pytest

from morf.cli.main import main
from morf.export.avatar_folder import load_exported_avatar
from morf.io import save_npz
from tests.train.dressed_fits import height_offsets, write_dressed_fits


def _coverage(avatar, mesh, rot, tr, camera) -> int:
    """Pixels the player's rasterizer covers with ``mesh`` in one pose."""
    from morf.raster.gl_context import create_headless_context
    from morf.raster.neural_raster import COVERAGE_CHANNEL, NeuralRasterizer, to_layout

    ctx = create_headless_context()
    try:
        nr = NeuralRasterizer(ctx, mesh, avatar.texture, camera.width, camera.height, avatar.skeleton.num_bones)
        nr.draw(avatar.skeleton.bone_transforms(rot, tr), camera)
        raster = to_layout(nr.read(), "nchw")
        nr.release()
    finally:
        ctx.release()
    return int((raster[0, COVERAGE_CHANNEL] != 128).sum())


def test_trained_exported_and_played_avatar_is_dressed(tiny_capture, body_model, gl, one_torch_thread, tmp_path):
    from morf.export.export_avatar import skinned_mesh_from_body_model
    from morf.train.trained_avatar import load_trained_avatar

    offsets = height_offsets(body_model)
    fits = write_dressed_fits(tiny_capture, body_model, offsets)
    root = str(tiny_capture.root)
    assert main(["train", root, "--preset", "tiny", "--steps", "2", "--set", "inpaint_steps=0"]) == 0
    trained = load_trained_avatar(tiny_capture.runs_dir / "morf-tiny")
    assert trained.dressed
    assert main(["export", root]) == 0
    avatar = load_exported_avatar(tiny_capture.avatar_dir)
    clothing = avatar.manifest["body"]["clothing"]
    assert clothing["dressed"] and clothing["offset_max_mm"] == pytest.approx(50.0, abs=0.01)
    dressed = skinned_mesh_from_body_model(body_model, trained.shape, offsets)
    naked = skinned_mesh_from_body_model(body_model, trained.shape)
    np.testing.assert_allclose(avatar.mesh.rest_vertices, dressed.rest_vertices, atol=1e-6)  # mesh.npz is dressed
    assert np.abs(avatar.mesh.rest_vertices - naked.rest_vertices).max() > 0.04
    # The player skins mesh.npz: in a capture pose it covers more pixels than the naked body would.
    cam = trained.camera
    rot, tr = fits.rotvecs[0], fits.transl[0]
    assert _coverage(avatar, avatar.mesh, rot, tr, cam) > 1.05 * _coverage(avatar, naked, rot, tr, cam)
    motion = tmp_path / "m.npz"
    save_npz(motion, rotvecs=fits.rotvecs[:2], transl=fits.transl[:2], fps=np.array(30.0))
    assert main(["play", str(tiny_capture.avatar_dir), "--motion", str(motion), "--out", str(tmp_path / "frames"),
                 "--size", "64"]) == 0
    assert len(list((tmp_path / "frames").glob("*.png"))) == 2
