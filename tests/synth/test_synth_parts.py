"""The pieces of a synthetic capture: config, regions, motion, nuisances, and the CLI."""

import numpy as np
import pytest

from morf.body.normals import vertex_normals
from morf.errors import InputError
from morf.synth import synth_config
from morf.synth.nuisance import corrupt_keypoints, loose_offsets, make_slide_field
from morf.synth.regions import HAIR, REGIONS, SHIRT, SHOES, SKIN, TROUSERS, region_weights


def test_config_presets_and_validation():
    tiny = synth_config("tiny", seed=3)
    assert tiny.frames == 12 and tiny.size == 128 and tiny.seed == 3 and tiny.detector == "none"
    assert synth_config("default").frames >= 200
    for bad in (dict(frames=0), dict(size=8), dict(corrupt=1.5), dict(detector="openpose"), dict(shape=(0.5,) * 5)):
        with pytest.raises(InputError):
            synth_config("tiny", **bad)
    with pytest.raises(InputError, match="unknown synth preset"):
        synth_config("huge")


@pytest.fixture(scope="module")
def rest(body_model):
    out = body_model(body_model.zero_pose(1), body_model.default_shape())
    return out.vertices[0].detach().numpy(), out.keypoints3d[0].detach().numpy()


def test_regions_follow_the_body(body_model, rest):
    v, kp = rest
    w = region_weights(body_model.dense_weights.numpy(), body_model.bone_names, v, kp)
    assert w.shape == (v.shape[0], len(REGIONS))
    np.testing.assert_allclose(w.sum(1), 1, atol=1e-5)
    label = w.argmax(1)
    z = v[:, 2]
    hips, shoulders, ankles = kp[11:13, 2].mean(), kp[5:7, 2].mean(), kp[15:17, 2].mean()
    assert z[label == HAIR].min() > shoulders  # hair is on the head
    assert z[label == SHOES].max() < ankles + 0.1  # shoes are on the feet
    assert np.median(z[label == SHIRT]) > hips > np.median(z[label == TROUSERS])
    assert (label == SKIN).sum() > 0
    # the chest front is shirt, the knees are trousers
    chest = np.argmin(np.linalg.norm(v - np.array([0, v[:, 1].min(), 0.5 * (hips + shoulders)]), axis=1))
    assert label[chest] == SHIRT


def test_loose_offsets_and_normals(body_model, rest):
    v, kp = rest
    w = region_weights(body_model.dense_weights.numpy(), body_model.bone_names, v, kp)
    off = loose_offsets(v, w, kp, 0.03)
    label = w.argmax(1)
    assert off.max() <= 0.03 + 1e-6 and np.all(off[label == SKIN] < 0.01)
    assert off[label == SHIRT].mean() > 0.01
    n = vertex_normals(v[None], body_model.faces.numpy())[0]
    # normals point away from the body axis on the torso (outward, not inward)
    torso = (label == SHIRT) & (np.abs(v[:, 0]) < 0.1)
    radial = v[torso] * np.array([1, 1, 0])
    assert np.mean((n[torso] * radial).sum(1) > 0) > 0.9


def test_slide_field_is_bounded_and_smooth():
    rng = np.random.default_rng(0)
    f = make_slide_field(50, 0.01, rng)
    uv = rng.uniform(0, 1, (500, 2))
    d = np.stack([f.displacement(uv, t) for t in range(50)])
    assert np.abs(d).max() <= 0.01 + 1e-9 and np.abs(d).max() > 0.002
    assert np.abs(np.diff(d, axis=0)).max() < 0.002  # drifts slowly from frame to frame
    assert f.grid(3).shape == (32, 32, 2)


def test_corruption_moves_a_limb_far():
    rng = np.random.default_rng(1)
    # a simple upright person, 200 px tall
    pts = np.zeros((23, 3), np.float32)
    pts[:, 2] = 1
    xy = {5: (120, 60), 6: (80, 60), 7: (140, 100), 8: (60, 100), 9: (145, 140), 10: (55, 140),
          11: (112, 130), 12: (88, 130), 13: (115, 190), 14: (85, 190), 15: (115, 250), 16: (85, 250)}
    for j, p in xy.items():
        pts[j, :2] = p
    kinds = set()
    for _ in range(30):
        bad, kind = corrupt_keypoints(pts, rng)
        kinds.add(kind)
        assert np.linalg.norm(bad[:, :2] - pts[:, :2], axis=1).max() > 30
        assert np.array_equal(bad[:, 2], pts[:, 2])
    assert kinds == {"swap_arms", "rotate_arm", "rotate_leg"}


def test_cli_synth_and_bad_arguments(tmp_path, capsys, gl):
    from morf.cli.main import main

    assert main(["synth", str(tmp_path / "bad"), "--preset", "tiny", "--frames", "0"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--frames" in err[0] and not (tmp_path / "bad" / "morf_project.json").exists()
    assert main(["synth", str(tmp_path / "bad"), "--preset", "tiny", "--shape", "0.5,0.5"]) == 2
    with pytest.raises(SystemExit) as e:
        main(["synth", str(tmp_path / "x"), "--detector", "openpose"])
    assert e.value.code != 0
    out = tmp_path / "ok"
    assert main(["synth", str(out), "--preset", "tiny", "--frames", "2", "--holdout-frames", "1", "--size", "64"]) == 0
    assert "wrote 2 frames" in capsys.readouterr().out
    from morf.capture.project import CaptureProject

    assert CaptureProject.open(out).num_frames == 2
    # a second run into the same folder is refused with one line
    assert main(["synth", str(out), "--preset", "tiny", "--frames", "2"]) == 2
    assert "not empty" in capsys.readouterr().err


def test_plain_clothing_has_less_detail_and_same_scene(tmp_path, body_model):
    import numpy as np

    from morf.io import read_image
    from morf.synth import make_synthetic_capture, synth_config

    def detail(p):
        tex = read_image(p.ground_truth_dir / "texture.png").astype(np.float32)
        return np.abs(np.diff(tex, axis=1)).mean()

    printed = make_synthetic_capture(tmp_path / "print", synth_config("tiny", frames=2, holdout_frames=0),
                                     model=body_model)
    plain = make_synthetic_capture(tmp_path / "plain", synth_config("tiny", frames=2, holdout_frames=0, clothing="plain"),
                                   model=body_model)
    assert detail(plain) < 0.7 * detail(printed)
    a = np.load(printed.ground_truth_path)
    b = np.load(plain.ground_truth_path)
    assert np.array_equal(a["rotvecs"], b["rotvecs"]) and np.array_equal(a["shape"], b["shape"])


def test_turn_degrees_limits_the_turn(body_model):
    import numpy as np

    from morf.synth.motion import capture_motion

    names = body_model.bone_names
    full = capture_motion(names, 40, np.random.default_rng(0))
    half = capture_motion(names, 40, np.random.default_rng(0), turn_degrees=120)
    assert np.rad2deg(full.yaw.max() - full.yaw.min()) > 350
    assert np.rad2deg(half.yaw.max() - half.yaw.min()) < 125
