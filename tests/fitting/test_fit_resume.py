"""A fit is complete only once every output exists, and a stopped or killed fit ends with the
numbers of one that ran through."""

import json
import os
import signal
import subprocess
import sys

import numpy as np
import torch

from morf.cli.project_steps import fit_plan
from morf.fitting import fit_project, fit_sequence, preset
from morf.fitting.fits_io import read_fits
from morf.fitting.project_fit import DONE_FILE, fit_progress, missing_outputs

from .synthetic import SHAPE, make_inputs, turning_poses, write_project

CPU = torch.device("cpu")


def _cfg():
    return preset("tiny")  # a preset, so that 'morf run' can resume it with the same options


def test_a_fit_resumed_after_any_stage_ends_with_the_same_numbers(body_model):
    inputs, _ = make_inputs(body_model, turning_poses(body_model, 4, turn=0.5), SHAPE, size=128, sil_res=32,
                            eval_res=32)
    cfg = _cfg()
    saved = []
    straight = fit_sequence(body_model, inputs, cfg, device=CPU, on_stage=saved.append)
    assert [s.stage for s in saved] == [1, 2, 3]
    for after in saved[:2]:
        resumed = fit_sequence(body_model, inputs, cfg, device=CPU, start=after)
        for name in ("rotvecs", "transl", "shape", "offsets"):
            assert torch.equal(getattr(resumed, name), getattr(straight, name)), (after.stage, name)


def test_a_missing_overlay_makes_the_fit_incomplete_and_is_redone(tmp_path, body_model):
    project = write_project(tmp_path / "cap", body_model)
    cfg = _cfg()
    fit_project(project, cfg, model=body_model, device=CPU)
    out = project.fits_dir
    assert fit_progress(project).complete and (out / DONE_FILE).is_file()
    assert fit_plan(project.root, "tiny").action == "skip"
    (out / "overlays" / "000003.jpg").unlink()
    assert missing_outputs(project, True) == ["overlays/000003.jpg"]
    progress = fit_progress(project)
    assert not progress.complete and progress.started
    assert fit_plan(project.root, "tiny").action == "resume"
    again = fit_project(project, cfg, model=body_model, device=CPU)
    assert not again.up_to_date and again.resumed_from == len(cfg.stages)  # no stage fitted again
    assert (out / "overlays" / "000003.jpg").is_file() and fit_progress(project).complete
    assert fit_project(project, cfg, model=body_model, device=CPU).up_to_date


def test_done_file_must_name_this_fit(tmp_path, body_model):
    project = write_project(tmp_path / "cap", body_model)
    cfg = _cfg()
    fit_project(project, cfg, model=body_model, device=CPU)
    # another filter setting changes filter.json: the fit is finalized again, not "up to date"
    other = cfg.replace(frame_filter=False)
    report = fit_project(project, other, model=body_model, device=CPU)
    assert not report.up_to_date and report.rejected == {}
    assert json.loads((project.fits_dir / DONE_FILE).read_text())["config"]["frame_filter"] is False
    # a record of another number of frames is stale
    record = json.loads((project.fits_dir / DONE_FILE).read_text())
    (project.fits_dir / DONE_FILE).write_text(json.dumps({**record, "frames": 99}))
    assert not fit_progress(project).complete


KILL_AFTER_3_OVERLAYS = """
import os, signal, sys
import morf.fitting.project_fit as pf
real, count = pf.write_image, [0]
def write_then_die(*args, **kwargs):
    real(*args, **kwargs)
    count[0] += 1
    if count[0] == 3:
        os.kill(os.getpid(), signal.SIGKILL)
pf.write_image = write_then_die
from morf.cli.main import main
sys.exit(main(sys.argv[1:]))
"""


def test_kill_9_during_the_overlays_leaves_the_fit_incomplete_and_the_next_fit_finishes_it(tmp_path, body_model):
    project = write_project(tmp_path / "cap", body_model)
    args = ["fit", str(project.root), "--preset", "tiny"]
    env = dict(os.environ, MORF_QUIET="1")
    killed = subprocess.run([sys.executable, "-c", KILL_AFTER_3_OVERLAYS, *args], env=env, capture_output=True,
                            timeout=600)
    assert killed.returncode == -signal.SIGKILL, killed.stderr.decode()[-2000:]
    out = project.fits_dir
    # what a kill there left before: fits and filter written, 3 of 8 overlays, and the fit taken for done
    assert (out / "fits.npz").is_file() and (out / "filter.json").is_file()
    assert len(list((out / "overlays").glob("*.jpg"))) == 3
    assert not (out / DONE_FILE).exists()
    progress = fit_progress(project)
    assert not progress.complete and progress.stages_done == 3
    plan = fit_plan(project.root, "tiny")
    assert plan.action == "resume" and plan.argv == tuple(args)
    before = read_fits(project.fits_path)
    again = subprocess.run([sys.executable, "-c", "import sys; from morf.cli.main import main; sys.exit(main())",
                            *plan.argv], env=env, capture_output=True, timeout=600)
    assert again.returncode == 0, again.stderr.decode()[-2000:]
    assert "resumed after stage 3" in again.stdout.decode()
    assert missing_outputs(project, True) == [] and fit_progress(project).complete
    np.testing.assert_array_equal(read_fits(project.fits_path).rotvecs, before.rotvecs)
