"""``morf train`` options that change the configuration (no training here)."""

from types import SimpleNamespace

import pytest

from morf.cli.train import resolve_config
from morf.errors import InputError


def _args(**kw):
    base = dict(preset="cpu", method="morf", steps=None, resolution=None, crop=None, batch_size=None,
                device="cpu", renderer=None, lr_decay_start=None, ema=None)
    return SimpleNamespace(**{**base, **kw})


def test_renderer_option_replaces_the_presets_renderer():
    cfg, reasons = resolve_config(_args(renderer="stem2_b16"))
    assert reasons == []
    assert (cfg.renderer.stem, cfg.renderer.width, cfg.renderer.max_width) == (2, 16, 64)
    assert cfg.renderer.in_channels == cfg.texture_channels
    assert cfg.renderer.rgb_skip  # only the size changes, not the preset's colour skip
    assert cfg.renderer.head_stride == 1  # the name gives the whole architecture: stem2_b16's head is full-res
    default, _ = resolve_config(_args())
    assert (default.renderer.stem, default.renderer.width, default.renderer.head_stride) == (4, 16, 2)
    plain, _ = resolve_config(_args(renderer="plain_b16"))
    assert plain.renderer.stem == 1 and plain.renderer.head_stride == 1


def test_bad_renderer_choices_are_user_errors():
    with pytest.raises(InputError, match="unknown renderer"):
        resolve_config(_args(renderer="huge"))
    with pytest.raises(InputError, match="--preset auto"):
        resolve_config(_args(renderer="stem4_b16", preset="auto"))
    with pytest.raises(InputError, match="multiples"):  # the renderer's size multiple (64) vs a 96 px crop
        resolve_config(_args(renderer="stem4_b16", resolution=96, crop=96))


def test_lr_decay_option_sets_the_schedule():
    cfg, _ = resolve_config(_args(lr_decay_start=0.5))
    assert cfg.lr_decay_start == 0.5 and cfg.lr_factor(cfg.steps) == pytest.approx(cfg.lr_decay_floor)
    assert resolve_config(_args(lr_decay_start=1.0))[0].lr_factor(100) == 1.0
    assert resolve_config(_args(preset="gpu"))[0].lr_decay_start == 1.0
    with pytest.raises(InputError, match="lr_decay_start"):
        resolve_config(_args(lr_decay_start=1.5))[0].validate()


def test_ema_option_sets_the_weight_average():
    assert resolve_config(_args(ema=0.998))[0].ema_decay == 0.998
    assert resolve_config(_args(ema=0.0))[0].ema_decay == 0.0
    assert resolve_config(_args(preset="gpu"))[0].ema_decay == 0.0


def test_holdout_and_the_rgb_floor_are_train_options():
    from morf.cli.main import build_parser

    args = build_parser().parse_args(["train", "p", "--method", "rgb", "--holdout", "4", "--preset", "tiny"])
    cfg, _ = resolve_config(args)
    assert (cfg.method, cfg.holdout) == ("rgb", 4)
    assert resolve_config(_args())[0].holdout == 0
    with pytest.raises(InputError, match="holdout"):
        resolve_config(_args(holdout=1))


def test_set_changes_any_field_nested_ones_too():
    cfg, _ = resolve_config(_args(set=["texture_size=512", "renderer.width=24", "w_ssim=0.5", "bf16=false"]))
    assert (cfg.texture_size, cfg.renderer.width, cfg.w_ssim, cfg.bf16) == (512, 24, 0.5, False)
    with pytest.raises(InputError, match="unknown config field 'nope'"):
        resolve_config(_args(set=["nope=1"]))
    with pytest.raises(InputError, match="unknown config section"):
        resolve_config(_args(set=["steps.x=1"]))
    with pytest.raises(InputError, match="FIELD=VALUE"):
        resolve_config(_args(set=["steps"]))
    with pytest.raises(InputError, match="resolution"):  # validated like every other config
        resolve_config(_args(set=["resolution=100"]))


def test_a_run_can_start_from_its_config_file(tmp_path):
    from morf.cli.main import build_parser

    first, _ = resolve_config(_args(set=["texture_size=128", "steps=7"]))
    path = tmp_path / "config.json"
    path.write_text(__import__("json").dumps(first.to_dict()))
    args = build_parser().parse_args(["train", "p", "--config", str(path), "--set", "steps=9", "--device", "cpu"])
    cfg, _ = resolve_config(args)
    assert cfg == first.replace(steps=9)
    path.write_text("[1, 2]")
    with pytest.raises(InputError, match="not a training config"):
        resolve_config(args)
    args = build_parser().parse_args(["train", "p", "--config", str(path), "--preset", "cpu"])
    with pytest.raises(InputError, match="--set"):
        resolve_config(args)


def test_a_config_file_with_an_unknown_nested_key_is_a_user_error(tmp_path):
    from morf.cli.main import build_parser

    cfg, _ = resolve_config(_args())
    for section in ("renderer", "warp"):
        d = cfg.to_dict()
        d[section]["nope"] = 1
        path = tmp_path / f"{section}.json"
        path.write_text(__import__("json").dumps(d))
        args = build_parser().parse_args(["train", "p", "--config", str(path), "--device", "cpu"])
        with pytest.raises(InputError, match=f"unknown {section} config keys: \\['nope'\\]"):
            resolve_config(args)
