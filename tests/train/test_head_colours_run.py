"""The head's own colours through the commands a user runs: ``morf train --set head_view_colours=K``
writes them beside the view colours, a head turned on its own changes only the head's texels,
``morf eval`` scores with them, ``morf export`` writes them and the player lays them over."""

import dataclasses
import json

import numpy as np
import pytest

from morf.cli.main import main
from tests.train.colour_runs import eval_person_psnr, export_run

pytestmark = [pytest.mark.slow, pytest.mark.gl]

ARGS = ["--preset", "tiny", "--steps", "2", "--holdout", "3", "--device", "cpu", "--name", "h",
        "--set", "view_colours=2", "--set", "view_colour_frames=2", "--set", "head_view_colours=4",
        "--set", "head_view_colour_frames=2"]


@pytest.fixture(scope="module")
def headed(tmp_path_factory, gl, tiny_capture_source):
    from tests.conftest import copy_capture

    root = tmp_path_factory.mktemp("heads") / "cap"
    project = copy_capture(tiny_capture_source, root)
    assert main(["train", str(root), *ARGS]) == 0
    return project


def _pose(project):
    from morf.train.data import load_body_fits, usable_frame_ids

    fits = load_body_fits(project, "auto")
    ids = usable_frame_ids(project, fits)
    return fits, ids


def test_training_writes_the_heads_colours_and_a_turned_head_changes_only_its_texels(headed, body_model):
    from morf.avatar.head_colour import head_share
    from morf.train.trained_avatar import load_trained_avatar

    run = headed.runs_dir / "h"
    av = load_trained_avatar(run)
    head = av.view_colours.head
    assert head is not None and head.count == 4 and head.frames == 2
    log = (run / "train.log").read_text()
    assert "the head's 4 more by the head's own orientation" in log
    assert "head colours: " in log and "back-projection pass(es), chosen on" in log  # the default: chosen
    size = av.texture.shape[1]
    share = head_share(body_model, size).reshape(-1)
    assert set(head.texels.tolist()) == set(np.flatnonzero(share >= 1 / 255).tolist())
    fits, ids = _pose(headed)
    pose = fits.rotvecs[ids[0]].astype(np.float64)
    bone = list(body_model.bone_names).index("head")
    changed = []
    for turn in np.linspace(-1.2, 1.2, 7):
        turned = pose.copy()
        turned[bone] = (0.0, turn, 0.0)
        a, b = av.texture_for(pose), av.texture_for(turned)
        diff = (a - b).abs().amax(0).reshape(-1).numpy()
        assert diff[share < 1 / 255].max() == 0.0  # the body keeps its view colour
        assert float((a[3:] - b[3:]).abs().max()) == 0.0
        changed.append(diff.max())
    assert max(changed) > 0.0
    # the root's orientation alone (as callers without the whole pose give it): no head colours
    root_only = av.texture_for(pose[0])
    assert float((root_only[:3] - av.texture_for(pose)[:3]).abs().max()) > 0.0


def test_eval_scores_with_them(headed, tmp_path):
    assert np.isfinite(eval_person_psnr(headed, "h", tmp_path))


def test_export_writes_them_and_the_player_lays_them_over(headed, tmp_path):
    from morf.avatar.head_colour import HeadColourBytes, head_orientation
    from morf.avatar.view_colour import ViewColourBytes, anchor_weights, quantize_view_colours, view_orientation
    from morf.export.avatar_folder import load_exported_avatar
    from morf.playback.player import Player
    from morf.raster.texture_quant import ZERO_POINT
    from morf.train.trained_avatar import load_trained_avatar

    out = tmp_path / "avatar"
    manifest = export_run(headed, "h", out)
    assert manifest["view_colours"]["head"]["count"] == 4
    av = load_exported_avatar(out)
    trained = load_trained_avatar(headed.runs_dir / "h")
    want = quantize_view_colours(trained.view_colours, av.texture.scales[:3], ZERO_POINT).head
    got = av.view_colours.head
    assert got.bone == int(trained.view_colours.head.chain.bones[-1])
    for f in ("anchors", "texels", "share", "data"):
        assert np.array_equal(getattr(got, f), getattr(want, f)), f
    # flat colours make the blend readable in the renderer's input: the body's two anchors 140 / 200,
    # the head's four 20 / 60 / 100 / 240, every head texel fully the head's
    body = np.stack([np.full(av.view_colours.data.shape[1:], v, np.uint8) for v in (140, 200)])
    flat = np.stack([np.full((len(got.texels), 3), v, np.uint8) for v in (20, 60, 100, 240)])
    head = HeadColourBytes(got.anchors, got.bone, got.texels, np.full(len(got.texels), 255, np.uint8), flat)
    av = dataclasses.replace(av, view_colours=ViewColourBytes(av.view_colours.anchors, body, head))
    fits, ids = _pose(headed)
    cam = trained.camera.scaled(64 / trained.camera.width)
    with Player(av, size=64, raster="gl") as player:
        for i in ids:
            o = view_orientation(cam.R, av.skeleton.reference_rotations[0], fits.rotvecs[i, 0])
            idx, w = anchor_weights(av.view_colours.anchors, o)
            body_value = sum(wi * (140, 200)[k] for k, wi in zip(idx, w))
            T = av.skeleton.bone_transforms(fits.rotvecs[i], fits.transl[i])
            idx, q = head.blend_weights(head_orientation(cam.R, T[head.bone, :3, :3]))  # in 256ths, as laid over
            head_value = (128 + sum(qi * (20, 60, 100, 240)[k] for k, qi in zip(idx, q))) >> 8
            x = np.asarray(player.rasterize(fits.rotvecs[i], fits.transl[i], cam)).reshape(-1, 16)
            px = x[x[:, 0] != 128][:, 0].astype(float)  # covered pixels (the background reads the zero point)
            near_body, near_head = np.abs(px - body_value) <= 1.0, np.abs(px - head_value) <= 1.0
            assert near_body.sum() > 20 and near_head.sum() > 3, (i, body_value, head_value)
            assert (near_body | near_head).mean() > 0.97, i  # edge pixels may mix the two


def test_damaged_head_colours_are_one_line(headed, tmp_path):
    import shutil

    import torch

    from morf.errors import InputError, ProjectError
    from morf.export.avatar_folder import MANIFEST, VIEW_COLOURS_FILE, load_exported_avatar, write_manifest
    from morf.io import load_npz, save_npz
    from morf.train.trained_avatar import load_trained_avatar

    d = torch.load(headed.runs_dir / "h" / "avatar.pt", weights_only=True)
    head = d["view_colours"]["head"]
    bad = {**d, "view_colours": {**d["view_colours"], "head": {**head, "texels": head["texels"] + 10**7}}}
    torch.save(bad, tmp_path / "bad.pt")
    with pytest.raises(ProjectError) as e:
        load_trained_avatar(tmp_path / "bad.pt")
    assert "view colours" in str(e.value) and "\n" not in str(e.value)
    out = tmp_path / "avatar"
    assert main(["export", str(headed.root), "--run", "h", "--out", str(out), "--calibration-views", "2"]) == 0
    for key, change in (("head_texels", lambda a: a + 10**7), ("head_colours", lambda a: a[:, :5]),
                        ("head_bone", lambda a: a + 1000)):
        broken = tmp_path / f"broken-{key}"
        shutil.copytree(out, broken)
        arrays = load_npz(broken / VIEW_COLOURS_FILE)
        save_npz(broken / VIEW_COLOURS_FILE, **{**arrays, key: change(arrays[key])})
        fields = {k: v for k, v in json.loads((broken / MANIFEST).read_text()).items()
                  if k not in ("format", "version", "files")}
        write_manifest(broken, fields)
        with pytest.raises(InputError) as e:
            load_exported_avatar(broken)
        assert key in str(e.value) and "\n" not in str(e.value), key
