"""The fit configuration follows the training config's rules: named presets, unknown keys and
preset names are user errors that say what is known, and nonsense values are refused."""

from __future__ import annotations

import dataclasses
import json

import pytest

from morf.errors import InputError
from morf.fitting.config import PRESETS, FilterConfig, FitConfig, default_stages, preset


@pytest.mark.parametrize("name", list(PRESETS))
def test_every_preset_is_valid_and_survives_a_round_trip_through_json(name):
    cfg = preset(name)
    cfg.validate()
    assert FitConfig.from_dict(json.loads(json.dumps(cfg.to_dict()))) == cfg


def test_the_tiny_preset_is_the_default_fit_with_few_steps():
    tiny = PRESETS["tiny"]
    steps = [s.iterations for s in tiny.stages]
    assert steps == [10, 20, 6] and sum(steps) < sum(s.iterations for s in PRESETS["fast"].stages)
    stages = tuple(dataclasses.replace(s, iterations=n) for s, n in zip(default_stages(), steps))
    assert tiny == PRESETS["default"].replace(stages=stages)


def test_an_unknown_preset_lists_the_known_ones():
    with pytest.raises(InputError, match="unknown fit preset 'huge'; choose one of default, fast, tiny, baseline"):
        preset("huge")


@pytest.mark.parametrize("change, unknown", [
    ({"silhouete": False}, "unknown fit config keys: ['silhouete']"),
    ({"stages": [{"name": "global", "iterations": 5, "lr": 0.1, "body_pose": False, "shape": False,
                  "silhouette": False, "momentum": 0.9}]}, "unknown fit stage keys: ['momentum']"),
    ({"filter": {"iou_drop": 0.1, "iou_jump": 2}}, "unknown frame filter config keys: ['iou_jump']"),
])
def test_from_dict_names_unknown_keys(change, unknown):
    d = {**FitConfig().to_dict(), **change}
    with pytest.raises(InputError) as e:
        FitConfig.from_dict(d)
    assert str(e.value) == unknown


def test_a_fit_needs_a_stage():
    with pytest.raises(InputError, match="at least one stage"):
        FitConfig().replace(stages=())
    assert FitConfig.from_dict({}) == FitConfig()  # a file without stages: the default ones


@pytest.mark.parametrize("change, words", [
    ({"stages": (dataclasses.replace(default_stages()[0], iterations=-1),)}, "iterations must be >= 0"),
    ({"stages": (dataclasses.replace(default_stages()[0], lr=0.0),)}, "learning rate must be positive"),
    ({"keypoint_weight": -1.0}, "keypoint_weight must be >= 0"),
    ({"silhouette_frame_fraction": 0.0}, "silhouette_frame_fraction must lie in"),
    ({"silhouette_sigma": 0.0}, "silhouette_sigma must be positive"),
    ({"offset_min": 0.01}, "offset_min <= 0 <= offset_max"),
    ({"offset_max": -0.01}, "offset_min <= 0 <= offset_max"),
    ({"chunk_frames": 0}, "chunk_frames must be >= 1"),
    ({"yaw_hypotheses": 0}, "yaw_hypotheses must be >= 1"),
    ({"cpu_threads": -1}, "cpu_threads must be >= 0"),
    ({"filter": FilterConfig(min_confidence=1.5)}, "filter.min_confidence must lie in"),
    ({"filter": FilterConfig(jump_factor=0.0)}, "filter.jump_factor must be positive"),
])
def test_validate_refuses_nonsense_in_replace_and_from_dict(change, words):
    with pytest.raises(InputError, match=words):
        FitConfig().replace(**change)
    d = FitConfig().to_dict()
    d.update(json.loads(json.dumps(dataclasses.asdict(FitConfig(**change)))))  # the same value read from JSON
    with pytest.raises(InputError, match=words):
        FitConfig.from_dict(d)


@pytest.mark.parametrize("change, words", [
    ({"keypoint_weight": "x"}, "fit config field keypoint_weight must be a finite number, got 'x'"),
    ({"temporal_weight": float("nan")}, "temporal_weight must be a finite number"),
    ({"cpu_threads": 1.5}, "cpu_threads must be a whole number"),
    ({"overlays": "yes"}, "overlays must be true or false"),
    ({"seed": -1}, "seed must be >= 0"),
    ({"filter": {"min_keypoints": "3"}}, "filter.min_keypoints must be a whole number"),
    ({"stages": [{"name": "global", "iterations": "10", "lr": 0.1, "body_pose": False, "shape": False,
                  "silhouette": False}]}, "stage 'global' iterations must be a whole number"),
])
def test_values_of_the_wrong_kind_in_a_config_file_are_one_line_errors(change, words):
    # a config file (--config) may hold anything: compared with numbers, a string was a TypeError traceback
    with pytest.raises(InputError, match=words.replace("(", r"\(").replace(")", r"\)")):
        FitConfig.from_dict({**json.loads(json.dumps(preset("tiny").to_dict())), **change})
