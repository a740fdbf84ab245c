"""``morf.presets``: one registry of every stage's named presets, the preset a stage runs with when
none is named, and the command line looking presets up through it."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from morf import presets
from morf.errors import InputError
from morf.fitting.config import PRESETS as FIT_PRESETS
from morf.fitting.config import FitConfig
from morf.presets.demo import PRESETS as DEMO_PRESETS
from morf.presets.demo import DemoPreset
from morf.presets.stability import PRESETS as STABILITY_PRESETS
from morf.presets.stability import StabilityPreset
from morf.presets.sweep import PRESETS as SWEEP_PRESETS
from morf.presets.sweep import SweepPreset
from morf.synth.config import PRESETS as SYNTH_PRESETS
from morf.synth.config import SynthConfig
from morf.train.config import PRESETS as TRAIN_PRESETS
from morf.train.config import TrainConfig

# The presets of whole commands: stage -> (config class, the command line that runs one, up to its
# output folder).
COMMAND_STAGES = {
    "demo": (DemoPreset, ["demo"]),
    "stability": (StabilityPreset, ["bench", "stability", "--out"]),
    "sweep": (SweepPreset, ["bench", "pareto", "--out"]),
}


def test_the_registry_holds_each_stages_own_table():
    assert dict(presets.PRESETS) == {"synth": SYNTH_PRESETS, "fit": FIT_PRESETS, "train": TRAIN_PRESETS,
                                     "demo": DEMO_PRESETS, "stability": STABILITY_PRESETS, "sweep": SWEEP_PRESETS}
    for stage, cls in (("synth", SynthConfig), ("fit", FitConfig), ("train", TrainConfig)):
        table = presets.presets_of(stage)
        assert table is presets.PRESETS[stage] and table
        for name, config in table.items():
            assert isinstance(config, cls)
            assert presets.preset(stage, name) is config
            config.validate()
    for stage, (cls, _) in COMMAND_STAGES.items():
        table = presets.presets_of(stage)
        assert table is presets.PRESETS[stage] and "tiny" in table
        for name, config in table.items():
            assert isinstance(config, cls) and presets.preset(stage, name) is config


def test_the_registry_imports_no_command():
    """The command presets are plain data below the commands: reading them loads no benchmark or CLI."""
    import subprocess
    import sys

    code = ("import sys, morf.presets; loaded = [m for m in sys.modules if m.startswith(('morf.bench', 'morf.cli', "
            "'morf.sizing'))]; print(loaded); sys.exit(bool(loaded))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert done.returncode == 0, done.stdout + done.stderr


KNOWN = {"fit": "default, fast, tiny, baseline, cpu, gpu", "train": "tiny, cpu, gpu, detail", "synth": "tiny, default, cpu, gpu",
         "demo": "tiny, quick, full", "stability": "tiny, default", "sweep": "tiny, quick, default"}


def test_unknown_stages_and_preset_names_are_input_errors_listing_the_known_ones():
    with pytest.raises(InputError, match="stages with presets: synth, fit, train, demo, stability, sweep"):
        presets.preset("paint", "default")
    for stage, known in KNOWN.items():
        name = "auto" if stage == "train" else "huge"  # auto is chosen from a capture, not a table entry
        with pytest.raises(InputError, match=f"unknown {stage} preset '{name}'; choose one of {known}$"):
            presets.preset(stage, name)


def test_every_pipeline_stage_answers_to_tiny_cpu_and_gpu():
    assert presets.COMMON_NAMES == ("tiny", "cpu", "gpu")
    for stage in ("synth", "fit", "train"):
        assert set(presets.COMMON_NAMES) <= set(presets.presets_of(stage)), stage
        for name in presets.COMMON_NAMES:
            presets.preset(stage, name).validate()


def test_fit_cpu_and_gpu_are_the_fit_that_was_the_default():
    """Fitting is a per-frame optimisation whose step counts are set by convergence: cpu, gpu and
    "default" (still the name a fit runs with when none is named) are one config, the one the
    default preset was before cpu and gpu were added."""
    default = FitConfig()
    assert [s.iterations for s in default.stages] == [60, 140, 60]  # the previous default's steps
    for name in ("default", "cpu", "gpu"):
        assert presets.preset("fit", name) == default, name
    for name in ("fast", "tiny", "baseline"):  # the other names keep working
        assert presets.preset("fit", name) != default, name
    # a fits/fit_config.json written before (a FitConfig records no preset name) loads as cpu's
    assert FitConfig.from_dict(json.loads(json.dumps(default.to_dict()))) == presets.preset("fit", "cpu")


def test_synth_cpu_and_gpu_are_the_capture_that_was_the_default_under_their_own_names():
    """A synthetic capture is data, not compute: cpu and gpu make the default capture and record
    the name that was asked for; "default" still records "default"."""
    default = SynthConfig()
    assert (default.preset, default.frames, default.size, default.holdout_frames) == ("default", 240, 512, 60)
    assert presets.preset("synth", "default") == default
    for name in ("cpu", "gpu"):
        config = presets.preset("synth", name)
        assert config.preset == name and config.replace(preset="default") == default, name
    assert presets.preset("synth", "tiny").preset == "tiny"
    # a ground_truth/synth_config.json written before (preset "default") still loads
    old = json.loads(json.dumps({"config": default.to_dict()}))["config"]
    assert old["preset"] == "default" and SynthConfig.from_dict(old) == presets.preset("synth", "default")


def test_the_default_training_preset_follows_the_device(monkeypatch):
    import torch

    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert presets.default_preset("train") == "gpu"
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    assert presets.default_preset("train") == "cpu"
    assert presets.default_preset("fit") == presets.default_preset("synth") == "default"
    # ... which for fit and synth is the device's preset by another name, on either device
    assert presets.preset("fit", "default") == presets.preset("fit", "cpu") == presets.preset("fit", "gpu")
    assert presets.default_preset("demo") == "quick"
    assert presets.default_preset("stability") == presets.default_preset("sweep") == "default"
    with pytest.raises(InputError, match="stages with presets"):
        presets.default_preset("paint")


def test_morf_train_without_a_preset_uses_the_registrys_default(monkeypatch):
    import torch

    from morf.cli.train import resolve_config

    args = SimpleNamespace(preset=None, method="morf", steps=None, resolution=None, crop=None, batch_size=None,
                           device="cpu", renderer=None)
    for cuda, name in ((True, "gpu"), (False, "cpu")):
        monkeypatch.setattr(torch.cuda, "is_available", lambda cuda=cuda: cuda)
        cfg, _ = resolve_config(args)
        assert cfg == TRAIN_PRESETS[name].replace(device="cpu")


def test_morf_fit_names_the_known_presets_of_an_unknown_one(tmp_path, capsys):
    from morf.capture.project import CaptureProject
    from morf.cli.fit import resolve_config
    from morf.cli.main import main

    CaptureProject.create(tmp_path / "p", num_frames=1, width=8, height=8, fps=None, source={"kind": "test"})
    with pytest.raises(SystemExit) as stop:
        main(["fit", str(tmp_path / "p"), "--preset", "huge"])
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert stop.value.code == 2 and "argument --preset: invalid choice: 'huge'" in line
    assert all(repr(name) in line for name in presets.presets_of("fit")), line
    assert not (tmp_path / "p" / "fits").exists()
    # called as a library (no argparse in front): the registry's InputError
    args = SimpleNamespace(preset="huge", config=None, set=[])
    with pytest.raises(InputError, match="unknown fit preset 'huge'; choose one of default, fast, tiny, baseline, cpu, gpu$"):
        resolve_config(args)


@pytest.mark.parametrize("command, stage", [("synth", "synth"), ("fit", "fit"), ("train", "train"),
                                            ("run", "train"), ("demo", "demo")])
def test_stage_commands_take_their_preset_choices_from_the_registry_and_list_them(command, stage):
    import argparse

    from morf.cli.main import build_parser

    (sub,) = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)]
    (flag,) = [a for a in sub.choices[command]._actions if "--preset" in a.option_strings]
    names = tuple(presets.presets_of(stage))
    extra = ("auto",) if stage == "train" else ()
    assert tuple(flag.choices) == (*names, *extra), command
    assert " | ".join((*names, *extra)) in " ".join(flag.help.split()) or command == "train", flag.help


def test_replace_refuses_unknown_fields_with_an_input_error():
    with pytest.raises(InputError, match="bogus"):
        TRAIN_PRESETS["cpu"].replace(bogus=1)
    with pytest.raises(InputError, match="bogus"):
        FitConfig().replace(bogus=1)


def _error_of(tmp_path, capsys, argv) -> str:
    """The one-line error (after argparse's usage) ``morf ARGV`` stops with, exit status 2, no traceback."""
    from morf.cli.main import main

    with pytest.raises(SystemExit) as stop:
        main(argv)
    err = capsys.readouterr().err
    assert stop.value.code == 2 and "Traceback" not in err
    assert not any(tmp_path.iterdir())  # nothing made before the refusal
    return err.strip().splitlines()[-1]


@pytest.mark.parametrize("stage", sorted(COMMAND_STAGES))
def test_commands_offer_the_registrys_presets_and_refuse_unknown_ones(stage, tmp_path, capsys):
    line = _error_of(tmp_path, capsys, [*COMMAND_STAGES[stage][1], str(tmp_path / "out"), "--preset", "nope"])
    assert "argument --preset: invalid choice: 'nope'" in line
    assert all(repr(name) in line for name in presets.presets_of(stage)), line


@pytest.mark.parametrize("bench", ["quality", "step"])
def test_training_benchmarks_offer_the_registrys_training_presets(bench, tmp_path, capsys):
    line = _error_of(tmp_path, capsys, ["bench", bench, "--out", str(tmp_path / "out"), "--preset", "nope"])
    assert "argument --preset: invalid choice: 'nope'" in line
    assert all(repr(name) in line for name in presets.presets_of("train")), line


def test_every_benchmark_preset_flag_takes_its_choices_and_default_from_the_registry():
    import argparse

    from morf.cli import bench

    parser = bench.add_parser(argparse.ArgumentParser().add_subparsers())
    (benchmarks,) = [a.choices for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    stages = {"quality": "train", "step": "train", "stability": "stability", "pareto": "sweep"}
    for name, stage in stages.items():
        (flag,) = [a for a in benchmarks[name]._actions if "--preset" in a.option_strings]
        assert tuple(flag.choices) == tuple(presets.presets_of(stage)), name
        assert flag.default in flag.choices, name


def test_command_functions_refuse_unknown_presets_with_input_errors(tmp_path):
    """Called as a library (no argparse in front), an unknown name is the registry's InputError,
    raised before anything is made or loaded."""
    from morf.bench.auto_check import auto_check
    from morf.bench.pareto import run_sweep
    from morf.bench.stability import run_stability
    from morf.cli import demo

    with pytest.raises(InputError, match="unknown stability preset 'nope'; choose one of tiny, default"):
        run_stability(tmp_path / "s", "nope")
    with pytest.raises(InputError, match="unknown sweep preset 'nope'; choose one of tiny, quick, default"):
        run_sweep(tmp_path / "p", "nope")
    with pytest.raises(InputError, match="unknown sweep preset 'nope'; choose one of tiny, quick, default"):
        auto_check(tmp_path / "a", "nope", scenes=("print",))
    with pytest.raises(InputError, match="unknown demo preset 'nope'; choose one of tiny, quick, full"):
        demo.run(SimpleNamespace(dir=str(tmp_path / "d"), preset="nope", motion=None))
    assert not any(tmp_path.iterdir())



def test_a_method_without_warp_gets_the_same_config_from_the_registry_and_the_train_preset():
    from morf.train.config import preset as train_preset

    for name in presets.presets_of("train"):
        for method in ("stylepeople", "anr", "morf"):
            via_registry = presets.preset("train", name).replace(method=method)
            assert via_registry == train_preset(name, method), (name, method)
    assert train_preset("cpu", "stylepeople").warp_fade_end == 1.0
    assert train_preset("cpu", "stylepeople", warp_fade_end=0.5, warp_fade_start=0.2).warp_fade_end == 0.5
