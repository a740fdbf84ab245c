"""``morf train --holdout K`` then ``morf eval``: scores, the floor, the images, the split, bad input."""

import json
import math

import cv2
import numpy as np
import pytest

from morf.cli.main import main

pytestmark = [pytest.mark.slow, pytest.mark.gl]
METRICS = ("psnr", "psnr_person", "ssim", "ssim_person", "temporal")


def test_eval_scores_every_run_and_the_floor(evaluated):
    ev, run = evaluated["eval"], evaluated["run"]
    assert set(ev["runs"]) == {run, "rgb-holdout3"}  # the floor was built with the run's hold-out
    assert list(ev["targets"]) == ["holdout-k3", "novel-poses"]
    assert ev["runs"]["rgb-holdout3"]["floor"] and ev["runs"][run]["holdout"] == 3
    for name, entry in ev["runs"].items():
        for key, m in entry["targets"].items():
            assert all(math.isfinite(m[k]) for k in METRICS), (name, key, m)
            assert m["lpips"] is None and m["lpips_person"] is None and m["resolution"] == 64
            assert m["frames"] == len(ev["targets"][key]["frame_ids"])
    held = ev["targets"]["holdout-k3"]
    assert held["columns"] == ["real", run, "rgb-holdout3"] and len(held["frame_ids"]) == 4
    floor = ev["runs"]["rgb-holdout3"]["targets"]["holdout-k3"]
    assert floor["psnr_person"] > ev["runs"][run]["targets"]["holdout-k3"]["psnr_person"]  # 2 steps learn nothing
    assert "holdout-k3" in evaluated["stdout"] and "rgb-holdout3" in evaluated["stdout"]


def test_eval_json_reads_back_unchanged(evaluated):
    from morf.evaluate.results import EvalResult

    ev = evaluated["eval"]
    back = EvalResult.from_dict(ev)
    assert json.dumps(back.to_dict()) == json.dumps(ev)  # same keys in the same order
    run = evaluated["run"]
    assert back.scored_runs("holdout-k3") == [run, "rgb-holdout3"]
    assert back.scores(run, "holdout-k3").trained_on == 0 and back.scores(run, "novel-poses").trained_on is None
    assert back.scores("nope", "holdout-k3") is None


def test_sheet_and_slices_have_the_documented_sizes(evaluated):
    from morf.evaluate.sheet import CAPTION_H, GAP, LABEL_H, cell_size, slice_panel_width

    for key, t in evaluated["eval"]["targets"].items():
        sheet = cv2.imread(str(evaluated["out"] / t["sheet"]))
        slices = cv2.imread(str(evaluated["out"] / t["slices"]))
        cell, n = cell_size([64]), len(t["columns"])
        assert sheet.shape == (LABEL_H + len(t["sheet_frames"]) * cell, n * cell, 3)
        assert [sheet.shape[1], sheet.shape[0]] == t["sheet_size"]
        _, panel = slice_panel_width(len(t["frame_ids"]))
        assert slices.shape == (LABEL_H + cell + CAPTION_H, n * panel + (n - 1) * GAP, 3)
        assert sheet[LABEL_H:].std() > 5 and slices[LABEL_H:LABEL_H + cell].std() > 5  # images, not blanks


def test_held_out_frames_never_reach_training(evaluated):
    from morf.io import load_npz
    from morf.train.data import load_body_fits, split_holdout, usable_frame_ids

    project, ev = evaluated["project"], evaluated["eval"]
    usable = usable_frame_ids(project, load_body_fits(project, "auto"))
    held = ev["targets"]["holdout-k3"]["frame_ids"]
    assert held == split_holdout(usable, 3)[1] == [i for i in usable if i % 3 == 0]
    for name in (evaluated["run"], "rgb-holdout3"):
        log = (project.runs_dir / name / "train.log").read_text()
        cache = log.split("frames cache: ")[1].split()[0]
        trained = load_npz(cache)["frame_ids"].tolist()  # the FrameSet the run trained on
        assert not set(trained) & set(held) and sorted(set(trained) | set(held)) == usable
        assert ev["runs"][name]["targets"]["holdout-k3"]["trained_on"] == 0


def test_floor_is_reused_and_options_apply(evaluated, tmp_path, body_model):
    from morf.train.data import crop_of
    from morf.train.floor import floor_request, train_floor
    from morf.train.trained_avatar import load_trained_avatar

    project, run = evaluated["project"], evaluated["run"]
    again = train_floor(project, floor_request(64, 3), "rgb-holdout3", model=body_model)
    assert again.losses == {}  # already built: nothing redone
    assert main(["eval", str(project.root), "--run", run, "--no-floor", "--resolution", "native", "--seen",
                 "--out", str(tmp_path)]) == 0
    import json

    ev = json.loads((tmp_path / "eval.json").read_text())
    assert list(ev["runs"]) == [run] and ev["targets"]["holdout-k3"]["columns"] == ["real", run]
    seen = ev["targets"]["seen-k3"]  # --seen: the training frames next to the held-out ones
    assert set(seen["frame_ids"]) == set(ev["targets"]["holdout-k3"]["reference"]["frames"])
    assert ev["runs"][run]["targets"]["seen-k3"]["trained_on"] == len(seen["frame_ids"]) > 0
    assert "reference" not in seen  # the reference belongs to the hold-out
    av = load_trained_avatar(project.runs_dir / run)
    m = av.renderer.cfg.multiple
    native = int(round(crop_of(project.camera(), av.camera)[2] / m)) * m
    assert ev["runs"][run]["targets"]["holdout-k3"]["resolution"] == native != 64
    assert np.isfinite(ev["runs"][run]["targets"]["holdout-k3"]["psnr"])


def test_a_run_of_the_older_hold_out_rule_keeps_its_own_target(evaluated, tmp_path):
    """A run whose config.json has no holdout_by (made when every K-th usable frame was held out)
    is scored on that rule's frames, under its own target key, not on the frame rule's."""
    import json
    import shutil

    from morf.train.data import load_body_fits, usable_frame_ids
    from morf.train.run_dir import RunDir

    project, run = evaluated["project"], evaluated["run"]
    old = project.runs_dir / "older"
    shutil.copytree(project.runs_dir / run, old)
    cfg = json.loads((old / "config.json").read_text())
    del cfg["holdout_by"]
    (old / "config.json").write_text(json.dumps(cfg))
    assert RunDir(old).load_config().holdout_by == "position"
    project.set_user_decision(1, "drop")  # a frame dropped after training moves the older rule's frames
    try:
        usable = usable_frame_ids(project, load_body_fits(project, "auto"))
        assert main(["eval", str(project.root), "--run", "older", "--run", run, "--no-floor", "--no-detail",
                     "--out", str(tmp_path)]) == 0
    finally:
        shutil.rmtree(old)
        project.set_user_decision(1, None)
    ev = json.loads((tmp_path / "eval.json").read_text())
    assert set(ev["runs"]["older"]["targets"]) == {"holdout-k3-positions", "novel-poses"}
    assert ev["targets"]["holdout-k3-positions"]["frame_ids"] == usable[::3] != evaluated["eval"]["targets"][
        "holdout-k3"]["frame_ids"]
    # the frame rule's frames stay where they were: the frames numbered 0, 3, 6, ...
    assert ev["targets"]["holdout-k3"]["frame_ids"] == evaluated["eval"]["targets"]["holdout-k3"]["frame_ids"]
    assert ev["targets"]["holdout-k3"]["columns"] == ["real", run]
    assert ev["runs"][run]["targets"]["holdout-k3"]["trained_on"] == 0


def test_refined_poses_score_every_run_alike(evaluated, tmp_path, capsys, monkeypatch):
    """--refine-poses refines the poses of every run and of the floor; each target records the
    render's L1 before and after, and the refinement never leaves it worse."""
    import dataclasses

    from morf.evaluate import pose_refine

    project, run = evaluated["project"], evaluated["run"]
    real, seen = pose_refine.refine_poses, []

    def fewer_steps(*args, **kwargs):
        """The command's refinement, with 10 Adam steps a frame instead of 40: what is checked here
        (every run and the floor refined, never worse) does not wait for convergence."""
        seen.append(args[-1])
        return real(*args[:-1], dataclasses.replace(args[-1], steps=10), **kwargs)

    monkeypatch.setattr(pose_refine, "refine_poses", fewer_steps)
    assert main(["eval", str(project.root), "--refine-poses", "--out", str(tmp_path)]) == 0
    import json

    ev = json.loads((tmp_path / "eval.json").read_text())
    # the command's own settings, once for each run and the floor on each target
    assert set(seen) == {pose_refine.RefineConfig()}
    assert len(seen) == sum(len(entry["targets"]) for entry in ev["runs"].values())
    given = evaluated["eval"]
    assert ev["poses"] == "refined" and given["poses"] == "given"
    assert set(ev["runs"]) == {run, "rgb-holdout3"}
    for name, entry in ev["runs"].items():
        for key, m in entry["targets"].items():
            before, after = m["refined_l1"]
            assert 0 < after <= before, (name, key)
            assert "refined_l1" not in given["runs"][name]["targets"][key]
    floor = ev["runs"]["rgb-holdout3"]["targets"]["holdout-k3"]
    assert floor["refined_l1"][1] < floor["refined_l1"][0]  # the projected colours do pull the poses
    assert "poses refined" in capsys.readouterr().out


def test_lpips_from_weights_on_disk(evaluated, lpips_weights, tmp_path, capsys):
    lin, vgg = lpips_weights
    root = str(evaluated["project"].root)
    assert evaluated["eval"]["lpips"].startswith("not computed")  # no weights: null, with the note
    assert main(["eval", root, "--lpips", str(lin), "--vgg", str(vgg), "--out", str(tmp_path / "e")]) == 0
    assert "LPIPS" in capsys.readouterr().out
    ev = json.loads((tmp_path / "e" / "eval.json").read_text())
    assert str(lin) in ev["lpips"] and str(vgg) in ev["lpips"]
    assert set(ev["runs"]) == {evaluated["run"], "rgb-holdout3"}
    for name, entry in ev["runs"].items():
        for key, m in entry["targets"].items():
            assert all(math.isfinite(m[k]) and m[k] > 0 for k in ("lpips", "lpips_person")), (name, key, m)
            assert m["psnr"] == evaluated["eval"]["runs"][name]["targets"][key]["psnr"]  # the other scores unchanged
    _one_line_error(capsys, ["eval", root, "--lpips", str(tmp_path / "none.pth"), "--vgg", str(vgg)],
                    "LPIPS weights not found")
    _one_line_error(capsys, ["eval", root, "--lpips", str(lin), "--vgg", str(lin)], "VGG-16")


def _one_line_error(capsys, argv, text):
    rc = main(argv)
    err = capsys.readouterr().err.strip().splitlines()
    assert rc != 0 and len(err) == 1 and text in err[0], err


def test_bad_input_is_a_one_line_error(evaluated, tmp_path, capsys):
    from morf.capture.project import CaptureProject

    root = str(evaluated["project"].root)
    _one_line_error(capsys, ["train", root, "--preset", "tiny", "--holdout", "1", "--name", "h1"], "holdout")
    _one_line_error(capsys, ["eval", root, "--run", "nope"], "no run named 'nope'")
    _one_line_error(capsys, ["eval", root, "--resolution", "13"], "multiple of")
    _one_line_error(capsys, ["eval", root, "--resolution", "big"], "--resolution")
    _one_line_error(capsys, ["export", root, "--run", "rgb-holdout3"], "RGB floor")
    bare = CaptureProject.create(tmp_path / "bare", num_frames=1, width=32, height=32, fps=None,
                                 source={"kind": "test"})
    _one_line_error(capsys, ["eval", str(bare.root)], "no body fits")
    _one_line_error(capsys, ["train", str(bare.root), "--preset", "tiny", "--holdout", "3"], "no body fits")


def test_detail_scores_at_native_size_and_head_crops(evaluated):
    """Every score carries the region scores at the crop's native size (not the 64 px evaluation
    side), and each target writes its enlarged head crops."""
    from morf.evaluate.sheet import HEAD_CELL, LABEL_H
    from morf.train.data import crop_of
    from morf.train.trained_avatar import load_trained_avatar

    project, ev = evaluated["project"], evaluated["eval"]
    av = load_trained_avatar(project.runs_dir / evaluated["run"])
    m = av.renderer.cfg.multiple
    native = int(round(crop_of(project.camera(), av.camera)[2] / m)) * m
    d = ev["runs"][evaluated["run"]]["targets"]["holdout-k3"]["detail"]
    assert d["resolution"] == native > 64 and d["max_shift"] == 4
    assert d["person_count"] == 4 and d["head_count"] >= 3
    for g in ("person", "head"):
        assert 0 < d[f"{g}_ssim_shift"] <= 1 and d[f"{g}_gmsd"] >= 0 and d[f"{g}_hf_ratio"] > 0
    assert "person_hf_ratio_inside" in d  # None where a 30-step render has no inside 3 px from its edge
    for key, t in ev["targets"].items():
        heads = cv2.imread(str(evaluated["out"] / t["heads"]))
        assert heads.shape[:2] == (t["heads_size"][1], t["heads_size"][0])
        columns = len(t["columns"]) + ("reference" in t)  # the nearest seen frame's heads last
        assert heads.shape[1] == columns * HEAD_CELL and (heads.shape[0] - LABEL_H) % HEAD_CELL == 0
        assert heads[LABEL_H:, :HEAD_CELL].std() > 5  # the real heads, not a blank
    heads = d["head_frames"]  # each scored head by frame, for finding where the fit is off
    assert len(heads) == d["head_count"]
    assert [h["frame"] for h in heads] == sorted(h["frame"] for h in heads)
    assert {h["frame"] for h in heads} <= set(ev["targets"]["holdout-k3"]["frame_ids"])
    assert abs(np.mean([h["ssim_shift"] for h in heads]) - d["head_ssim_shift"]) < 1e-4
    assert all(h["at_bound"] == (max(map(abs, h["shift"])) == 4) for h in heads)
    assert "detail at native size" in evaluated["stdout"] and "lowest heads (frame SSIM)" in evaluated["stdout"]


def test_nearest_seen_frame_is_the_hold_outs_reference(evaluated, body_model):
    """The hold-out's detail carries the nearest training frame, copied, scored like a run; a frame
    copied onto itself scores perfectly, so the reference measures the capture's change, not noise."""
    import dataclasses

    import torch

    from morf.body.parts import part_atlas
    from morf.evaluate.detail_eval import copy_scores
    from morf.evaluate.frames import capture_frames, scaled_camera
    from morf.evaluate.targets import nearest_seen
    from morf.train.data import load_body_fits
    from morf.train.trained_avatar import load_trained_avatar

    project, ev = evaluated["project"], evaluated["eval"]
    held = ev["targets"]["holdout-k3"]
    ref = held["reference"]
    fits = load_body_fits(project, "auto")
    assert ref["name"] == "nearest seen frame" and len(ref["frames"]) == len(held["frame_ids"])
    assert tuple(ref["frames"]) == nearest_seen(project, fits, 3, held["frame_ids"])
    assert not set(ref["frames"]) & set(held["frame_ids"])
    d = ref["detail"]
    run = ev["runs"][evaluated["run"]]["targets"]["holdout-k3"]["detail"]
    assert d["resolution"] == run["resolution"] and d["person_count"] == run["person_count"]
    assert 0 < d["head_ssim_shift"] < 1 and len(d["head_frames"]) == d["head_count"]
    assert "reference" not in ev["targets"]["novel-poses"]  # novel poses have no seen neighbours
    assert "(nearest seen frame)" in evaluated["stdout"]

    model = body_model
    av = load_trained_avatar(project.runs_dir / evaluated["run"])
    frames = capture_frames(project, model, fits, held["frame_ids"][:2], scaled_camera(av.camera, 96))
    grey = torch.full((3,), 0.5)
    same = copy_scores(frames, frames, grey, part_atlas(model), 2)
    assert same.scores["person_ssim_shift"] > 0.999 and abs(same.scores["person_hf_ratio"] - 1) < 1e-6
    assert abs(same.scores["person_hf_ratio_inside"] - 1) < 1e-6
    # a copy where the person stood 7 px lower and 5 px to the left is moved back onto the frame
    moved = dataclasses.replace(frames, **{k: np.roll(getattr(frames, k), (7, -5), axis=(1, 2))
                                           for k in ("images", "masks", "uv", "uv_mask", "facing")})
    back = copy_scores(frames, moved, grey, part_atlas(model), 2)
    for g in ("person", "head"):
        assert back.scores[f"{g}_count"] == same.scores[f"{g}_count"] > 0
        assert back.scores[f"{g}_ssim_shift"] > 0.99, g
    assert all(h["shift"] == [0, 0] for h in back.head_frames)
