"""The options several commands share (morf.cli.options) behave alike in each of them."""

from __future__ import annotations

import argparse
import json

import pytest

from morf.cli.main import build_parser
from morf.cli.options import FITS_CHOICES, check_frame_rate, read_config_option
from morf.errors import InputError


def _sub(name: str) -> argparse.ArgumentParser:
    return next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)).choices[name]


def _option(parser: argparse.ArgumentParser, flag: str) -> argparse.Action:
    return next(a for a in parser._actions if flag in a.option_strings)


def test_fits_choices_are_the_training_data_sources():
    from morf.train.data import FIT_SOURCES

    assert FITS_CHOICES == FIT_SOURCES
    for command in ("train", "export"):
        assert tuple(_option(_sub(command), "--fits").choices) == FIT_SOURCES


@pytest.mark.parametrize("command", ["fit", "train", "synth"])
def test_config_and_set_alike(command):
    config, settings = _option(_sub(command), "--config"), _option(_sub(command), "--set")
    assert (config.metavar, config.default) == ("JSON", None)
    assert config.help.startswith("start from a config file (") and config.help.endswith(") instead of a preset")
    assert (settings.metavar, settings.default, type(settings).__name__) == ("FIELD=VALUE", [], "_AppendAction")
    assert settings.help.startswith("set any config field, e.g. --set ")
    assert settings.help.endswith(" (repeatable; applied last)")


@pytest.mark.parametrize("command", ["export", "play", "animate", "web"])
def test_motion_fps_is_a_float_without_default(command):
    action = _option(_sub(command), "--motion-fps")
    assert action.type is float and action.default is None


def test_frame_rate_checks():
    check_frame_rate("--fps", 30.0)
    check_frame_rate("--motion-fps", None)
    for bad in (0.0, -1.0, float("nan"), float("inf"), 1000.5):
        with pytest.raises(InputError, match=r"--fps must be positive \(a frame rate of at most 1000\)"):
            check_frame_rate("--fps", bad)


def test_config_file_refused_beside_what_also_picks_the_config(tmp_path):
    path = tmp_path / "c.json"
    path.write_text(json.dumps({"steps": 3}))
    args = argparse.Namespace(config=str(path), preset=None, renderer=None)
    assert read_config_option(args, "training config", ("preset", "renderer")) == {"steps": 3}
    assert read_config_option(argparse.Namespace(config=None), "fit config") is None
    args.renderer = "stem2_b16"
    with pytest.raises(InputError, match="not --preset/--renderer$"):
        read_config_option(args, "training config", ("preset", "renderer"))
    path.write_text("[1, 2]")
    with pytest.raises(InputError, match="is not a fit config"):
        read_config_option(argparse.Namespace(config=str(path), preset=None), "fit config")
    path.write_text('{"lr": NaN}')
    with pytest.raises(InputError, match="must be finite"):
        read_config_option(argparse.Namespace(config=str(path), preset=None), "training config")
