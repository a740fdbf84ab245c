"""The run folder's files (``morf.train.run_files``): names, metrics lines, the fits note, the header."""

from __future__ import annotations

import json
import re
from types import SimpleNamespace

import pytest

from morf.errors import ProjectError
from morf.train.config import TrainConfig
from morf.train.run_dir import RunDir
from morf.train.run_files import RunFiles, last_step, read_metrics_file
from morf.train.start_log import log_start


def test_one_layout_for_training_and_readers(tmp_path):
    files, run = RunFiles(tmp_path / "r"), RunDir(tmp_path / "r")
    names = [p.name for p in (files.config_path, files.checkpoint_path, files.avatar_path, files.log_path,
                              files.metrics_path)]
    assert names == ["config.json", "checkpoint.pt", "avatar.pt", "train.log", "metrics.jsonl"]
    assert [run.config_path, run.checkpoint_path, run.avatar_path, run.log_path, run.metrics_path] == \
        [files.config_path, files.checkpoint_path, files.avatar_path, files.log_path, files.metrics_path]
    assert not files.is_done and not files.has_checkpoint


def test_a_missing_run_reads_as_empty(tmp_path):
    files = RunFiles(tmp_path / "absent")
    assert files.read_metrics() == [] and files.last_step() == 0 and files.fits_source() == "auto"
    with pytest.raises(FileNotFoundError):
        files.read_config_dict()
    with pytest.raises(ProjectError, match="has no config.json"):
        RunDir(tmp_path / "absent").load_config()


def test_metrics_lines_cut_by_a_kill_are_skipped(tmp_path):
    run = RunDir(tmp_path / "r")
    run.root.mkdir()
    run.append_metrics({"step": 10, "l1": 0.5, "bad": float("nan")})
    run.append_metrics({"step": 20, "l1": 0.25})
    with open(run.metrics_path, "a") as f:
        f.write('{"step": 3')
    assert run.read_metrics() == [{"step": 10, "l1": 0.5, "bad": None}, {"step": 20, "l1": 0.25}]
    assert read_metrics_file(run.metrics_path) == run.read_metrics()
    assert run.last_step() == 20


@pytest.mark.parametrize("rows, step", [
    ([], 0),
    ([{"step": 5}, {"step": None}], 5),  # a row whose step is unusable is passed over
    ([{"step": 5}, 7], 5),  # so is a line that is JSON but no object
    ([{"step": 5}, {"l1": 0.1}], 0),  # a row without a step counts as step 0
    ([{"step": "12"}], 12),
])
def test_last_step(rows, step):
    assert last_step(rows) == step


def test_config_reads_as_a_dict_and_as_a_train_config(tmp_path):
    run = RunDir(tmp_path / "r")
    run.root.mkdir()
    cfg = TrainConfig(steps=7)
    run.save_config(cfg)
    assert run.read_config_dict()["steps"] == 7 and run.load_config() == cfg
    run.config_path.write_text("{not json")
    with pytest.raises(ProjectError, match="damaged run config"):
        run.load_config()


@pytest.mark.parametrize("line, source", [
    ("fits: ground-truth; frames cache: x.npz", "ground-truth"),
    ("fits: fits; frames cache: x.npz", "fits"),
    ("fits: something-else; frames cache: x.npz", "auto"),
    ("start: method rgb", "auto"),
])
def test_fits_source_from_the_log(tmp_path, line, source):
    run = RunFiles(tmp_path / "r")
    run.log(line)
    assert run.fits_source() == source


def _header(run: RunFiles) -> list[str]:
    lines = run.log_path.read_text().splitlines()
    assert all(re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d ", line) for line in lines)
    return [line[20:] for line in lines]


def test_start_header(tmp_path):
    frames = SimpleNamespace(num_frames=6, resolution=32)
    cfg = TrainConfig(method="morf", preset="tiny", bf16=True, w_gan=0.0, w_ssim=0.5)
    run = RunFiles(tmp_path / "a")
    log_start(run, cfg, frames, "cpu", False, False, ["fits: fits; frames cache: c.npz"])
    assert _header(run) == [
        "start: method morf, preset tiny, 6 frames at 32 px, device cpu",
        "perceptual loss: none (no VGG-16 weights given with --vgg / MORF_VGG16_WEIGHTS); "
        "structure from the SSIM term (weight 0.5)",
        "bfloat16 autocast: off (this CPU has neither AMX-BF16 nor AVX512-BF16; emulated it is slower)",
        "fits: fits; frames cache: c.npz",
    ]
    run = RunFiles(tmp_path / "b")
    log_start(run, TrainConfig(bf16=False, w_gan=0.1, w_feature_matching=1.0), frames, "cuda", True, False)
    assert _header(run)[1:] == ["perceptual loss: no VGG-16 weights (--vgg / MORF_VGG16_WEIGHTS); using "
                                "discriminator feature matching instead"]
    run = RunFiles(tmp_path / "c")
    log_start(run, TrainConfig(bf16=True), frames, "cuda", True, True)
    assert _header(run)[1:] == ["perceptual loss: VGG-16", "bfloat16 autocast: on"]
    run = RunFiles(tmp_path / "d")  # the trainer's own reason wins
    log_start(run, TrainConfig(bf16=True), frames, "cpu", False, True, bf16_note="off (wrong kernel)")
    assert _header(run)[1:] == ["perceptual loss: VGG-16", "bfloat16 autocast: off (wrong kernel)"]


def test_metrics_are_plain_json(tmp_path):
    run = RunFiles(tmp_path / "r")
    run.root.mkdir()
    run.append_metrics({"step": 1, "time_s": 0.5})
    assert json.loads(run.metrics_path.read_text()) == {"step": 1, "time_s": 0.5}
