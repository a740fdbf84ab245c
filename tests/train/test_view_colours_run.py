"""View colours through the commands a user runs: ``morf train --set view_colours=K`` writes them
into avatar.pt, ``morf eval`` scores with them, ``morf export`` writes them and the player draws them."""

import dataclasses

import numpy as np
import pytest

from morf.cli.main import main
from tests.train.colour_runs import eval_person_psnr, export_run

pytestmark = [pytest.mark.slow, pytest.mark.gl]


@pytest.fixture(scope="module")
def viewed(tmp_path_factory, gl, tiny_capture_source):
    from tests.conftest import copy_capture

    root = tmp_path_factory.mktemp("views") / "cap"
    project = copy_capture(tiny_capture_source, root)
    assert main(["train", str(root), "--preset", "tiny", "--steps", "2", "--holdout", "3", "--device", "cpu",
                 "--name", "v", "--set", "view_colours=3", "--set", "view_colour_frames=2"]) == 0
    return project


def test_training_writes_view_colours_once(viewed):
    from morf.train.trained_avatar import load_trained_avatar

    run = viewed.runs_dir / "v"
    av = load_trained_avatar(run)
    assert av.view_colours is not None and av.view_colours.count == 3 and av.view_colours.frames == 2
    assert av.view_colours.colours.shape == (3, 3, *av.texture.shape[1:])
    log = (run / "train.log").read_text()
    assert log.count("view colours: 3 anchor orientations") == 1
    before = (run / "avatar.pt").stat().st_mtime_ns
    assert main(["train", str(viewed.root), "--preset", "tiny", "--steps", "2", "--holdout", "3", "--device", "cpu",
                 "--name", "v", "--set", "view_colours=3", "--set", "view_colour_frames=2"]) == 0
    assert (run / "avatar.pt").stat().st_mtime_ns == before  # finished: nothing projected again
    # the render follows the pose's orientation: two far-apart roots draw different colours
    from morf.train.data import load_body_fits, usable_frame_ids

    fits = load_body_fits(viewed, "auto")
    ids = usable_frame_ids(viewed, fits)
    a = av.texture_for(fits.rotvecs[ids[0], 0])
    far = max(ids, key=lambda i: np.linalg.norm(fits.rotvecs[i, 0] - fits.rotvecs[ids[0], 0]))
    b = av.texture_for(fits.rotvecs[far, 0])
    assert float((a[3:] - av.texture[3:]).abs().max()) == 0.0
    assert float((a[:3] - b[:3]).abs().max()) > 0.0


def test_eval_scores_the_view_colours(viewed, tmp_path):
    assert np.isfinite(eval_person_psnr(viewed, "v", tmp_path))


def test_export_writes_them_and_the_player_draws_them(viewed, tmp_path):
    from morf.avatar.view_colour import ViewColourBytes, anchor_weights, quantize_view_colours, view_orientation
    from morf.export.avatar_folder import VIEW_COLOURS_FILE, load_exported_avatar
    from morf.raster.texture_quant import ZERO_POINT
    from morf.playback.player import Player
    from morf.train.data import load_body_fits, usable_frame_ids
    from morf.train.trained_avatar import load_trained_avatar

    out = tmp_path / "avatar"
    manifest = export_run(viewed, "v", out)
    assert VIEW_COLOURS_FILE in manifest["files"] and manifest["view_colours"]["count"] == 3
    av = load_exported_avatar(out)
    assert av.view_colours.data.shape == (3, *av.texture.data.shape[:2], 3)
    trained = load_trained_avatar(viewed.runs_dir / "v")
    want = quantize_view_colours(trained.view_colours, av.texture.scales[:3], ZERO_POINT)
    assert np.array_equal(want.data, av.view_colours.data)
    # the player draws each pose in the blend of its nearest anchors: three flat colours make the
    # blend readable in the renderer's input
    flat = np.stack([np.full(av.view_colours.data.shape[1:], v, np.uint8) for v in (140, 180, 230)])
    av = dataclasses.replace(av, view_colours=ViewColourBytes(av.view_colours.anchors, flat))
    fits = load_body_fits(viewed, "auto")
    ids = usable_frame_ids(viewed, fits)
    cam = trained.camera.scaled(64 / trained.camera.width)
    kinds = ["gl"]
    try:
        import morf.raster.cpu_raster_kernels  # noqa: F401  (numba: the CPU rasterizer)
        kinds.append("cpu")
    except ImportError:
        pass
    for kind in kinds:  # one player (and GL context) at a time
        with Player(av, size=64, raster=kind) as player:
            for i in ids:
                o = view_orientation(cam.R, av.skeleton.reference_rotations[0], fits.rotvecs[i, 0])
                idx, w = anchor_weights(av.view_colours.anchors, o)
                expect = sum(wi * (140, 180, 230)[k] for k, wi in zip(idx, w))
                x = np.asarray(player.rasterize(fits.rotvecs[i], fits.transl[i], cam)).reshape(-1, 16)
                body = x[x[:, 0] != 128]  # covered pixels (the background reads the zero point)
                assert len(body) > 20 and np.abs(body[:, :3].astype(float) - expect).max() <= 1.0, (kind, i)


def test_a_run_stopped_before_its_view_colours_gets_them_from_morf_run(viewed):
    """Stopped in the seconds between avatar.pt and its view colours: 'morf run' does not skip the
    run as finished, and training it again adds them without training again."""
    import torch

    from morf.cli.project_steps import train_plan
    from morf.io import atomic_path
    from morf.train.run_dir import RunDir
    from morf.train.trained_avatar import load_trained_avatar
    from morf.train.view_colours import view_colours_missing

    run = RunDir(viewed.runs_dir / "v")
    d = torch.load(run.avatar_path, weights_only=True)
    del d["view_colours"]
    with atomic_path(run.avatar_path) as tmp:
        torch.save(d, tmp)
    assert view_colours_missing(run)
    plan = train_plan(viewed.root, "v", ("train", str(viewed.root)))
    assert plan.action == "resume" and "view colours" in plan.note
    steps = run.last_step()
    assert main(list(plan.argv)) == 0
    assert load_trained_avatar(run.root).view_colours is not None and not view_colours_missing(run)
    assert run.last_step() == steps  # nothing trained again
    assert train_plan(viewed.root, "v", ("train", str(viewed.root))).action == "skip"


def test_views_of_an_aligned_colour_come_from_aligned_frames(tiny_capture):
    """A run whose one colour texture came from flow-aligned frames projects its views from the
    frames aligned to that colour, and says so."""
    from morf.train.trained_avatar import load_trained_avatar

    assert main(["train", str(tiny_capture.root), "--preset", "tiny", "--steps", "2", "--device", "cpu", "--name", "a",
                 "--set", "view_colours=2", "--set", "colour_align_passes=1"]) == 0
    log = (tiny_capture.runs_dir / "a" / "train.log").read_text()
    assert "view colours: 2 anchor orientations" in log and "first aligned to the avatar's colour" in log
    assert load_trained_avatar(tiny_capture.runs_dir / "a").view_colours.count == 2


def test_damaged_view_colours_in_avatar_pt_are_one_line(viewed, tmp_path):
    import torch

    from morf.errors import ProjectError
    from morf.train.trained_avatar import load_trained_avatar

    d = torch.load(viewed.runs_dir / "v" / "avatar.pt", weights_only=True)
    assert d.get("view_colours") is not None
    for key, value in (("colours", d["view_colours"]["colours"][:, :, :8]),  # other texel count
                       ("colours", d["view_colours"]["colours"][:2]),  # other anchor count
                       ("root_frame", torch.zeros(2, 2, dtype=torch.float64))):
        bad = {**d, "view_colours": {**d["view_colours"], key: value}}
        path = tmp_path / f"bad-{key}.pt"
        torch.save(bad, path)
        with pytest.raises(ProjectError) as e:
            load_trained_avatar(path)
        assert "view colours" in str(e.value) and "\n" not in str(e.value)
