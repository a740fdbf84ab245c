"""The no-learning floor, ``morf train --method rgb``: what the training frames give with no
network at all.

The training frames (the same FrameSet, hold-out included, as a learned run with that config)
are projected into an RGB texture (:mod:`morf.train.floor_texture`: side matched to the frames'
texel density, unseen texels filled over the UV islands); rendering a pose rasterizes the body
and samples that texture: RGB = the texture, mask = the mesh coverage
(:mod:`morf.avatar.passthrough`). It is stored as a normal run (``config.json``, ``train.log``,
``avatar.pt``), so ``load_trained_avatar`` and ``morf eval`` treat it like any other; it cannot
be exported (there is no network to run). Building it takes seconds, once the frames are cached.
"""

from __future__ import annotations

import time

import torch

from morf.avatar.renderer import RendererConfig
from morf.errors import InputError
from morf.io.lock import project_lock
from morf.pipeline.control import Progress, StageControl
from morf.train.config import TrainConfig
from morf.train.holdout import holdout_note
from morf.train.floor_texture import MIN_SIDE
from morf.train.run_files import restart_run, run_path

# What TrainConfig records as the floor's renderer: 4 input channels (RGB + coverage), size multiple 1.
# The module itself is morf.avatar.passthrough.PassthroughRenderer.
FLOOR_RENDERER = RendererConfig(in_channels=4, width=4, depth=0, max_width=4, stem=1, skip_hidden=4)


def floor_config(cfg: TrainConfig, texture_size: int) -> TrainConfig:
    """The config a floor run records: ``cfg`` with the floor's texture and nothing to train.

    Kept from ``cfg``: resolution, holdout, preset name, seed, device; the rest of the training
    settings are recorded as given but unused.
    """
    return cfg.replace(method="rgb", texture_channels=4, texture_size=texture_size, renderer=FLOOR_RENDERER,
                       crop=0, steps=0, inpaint_steps=0)


def floor_request(resolution: int, holdout: int, holdout_by: str = "frame") -> TrainConfig:
    """A floor config from scratch (what ``morf eval`` builds when a project has none)."""
    return TrainConfig(method="rgb", preset="floor", resolution=resolution, holdout=holdout, holdout_by=holdout_by,
                       texture_channels=4,
                       texture_size=MIN_SIDE, renderer=FLOOR_RENDERER, steps=0, inpaint_steps=0, device="cpu")


def train_floor(project, cfg: TrainConfig, name: str | None = None, fits_source: str = "auto", model=None,
                control: StageControl | None = None, restart: bool = False):
    """Build (or find already built) the RGB floor run ``PROJECT/runs/<name>``.

    Args:
        project: a CaptureProject; cfg: a config with ``method == "rgb"`` (its resolution and
        holdout are used); name: run name (default ``rgb-<preset>``); fits_source: auto | fits |
        ground-truth; model: a loaded body model (optional); restart: delete an existing run first.
    Returns:
        a :class:`morf.train.loop.TrainResult` with step 0; ``losses`` holds the L1 of the floor on
        its own frames (premultiplied RGB, as training reports it), empty when the run was already built.
    """
    if cfg.method != "rgb":
        raise InputError(f"the RGB floor needs method 'rgb', got {cfg.method!r}")
    from morf.train.run_dir import RunDir

    control = control or StageControl()
    run = RunDir(run_path(project, name or f"{cfg.method}-{cfg.preset}"))
    with project_lock(project.root, f"run-{run.root.name}"):
        if restart:
            restart_run(run.root)
        return _build_floor(project, run, cfg, fits_source, model, control)


def _build_floor(project, run, cfg: TrainConfig, fits_source: str, model, control: StageControl):
    """:func:`train_floor` for one run folder, with its lock held."""
    from morf.avatar.passthrough import PassthroughRenderer
    from morf.avatar.spectral import body_uv_atlas
    from morf.body import load_body_model
    from morf.train.data import build_frames
    from morf.train.floor_texture import choose_floor_size, floor_texture
    from morf.train.loop import TrainResult
    from morf.train.trained_avatar import save_trained_avatar

    t0 = time.monotonic()
    control.report(Progress("train", 0, None, "loading body model"))
    model = model or load_body_model("anny")
    pf = build_frames(project, model, cfg.resolution, fits_source, control, holdout=cfg.holdout,
                      holdout_by=cfg.holdout_by)
    choice = choose_floor_size(pf.frames)
    resolved = floor_config(cfg, choice.size)
    if run.config_path.is_file():
        if run.load_config() != resolved:
            raise InputError(f"run {run.root.name!r} exists with a different configuration; build it with the same "
                             "options, or pass --restart or another --name")
        if run.is_done:
            return TrainResult(run.root, 0, {}, 0.0, 0)
    run.save_config(resolved)
    run.log(f"start: method rgb (no learning), preset {cfg.preset}, {pf.frames.num_frames} frames at "
            f"{pf.frames.resolution} px")
    run.log(f"fits: {pf.fits.source}; frames cache: {pf.cache_path}")
    if cfg.holdout:
        run.log(holdout_note(cfg.holdout, cfg.holdout_by))
    run.log(choice.describe())
    control.report(Progress("train", 0, None, "projecting the frames into the texture"))
    atlas = body_uv_atlas(model, choice.size, choice.size)
    texture, seen = floor_texture(pf.frames, atlas.covered, cfg.texture_dilate)
    texture = torch.from_numpy(texture)
    renderer = PassthroughRenderer()
    l1 = frames_l1(texture, renderer, pf.frames)
    seen_share = float(seen.sum() / max(atlas.covered.sum(), 1))
    save_trained_avatar(run.avatar_path, texture, renderer, resolved.to_dict(), torch.from_numpy(pf.fits.shape),
                        pf.camera, {"steps": 0, "texture_rule": choice.describe(), "hit_share": choice.hit_share,
                                    "seen_fraction": seen_share})
    run.log(f"seen: {seen_share:.1%} of the atlas; L1 on the training frames {l1:.4f}")
    run.log(f"avatar written: {run.avatar_path}")
    control.report(Progress("train", 0, None, "done"))
    return TrainResult(run.root, 0, {"l1": l1}, (time.monotonic() - t0) / 60, 0)


@torch.no_grad()
def frames_l1(texture: torch.Tensor, renderer: torch.nn.Module, frames, batch: int = 8) -> float:
    """Mean |render - frame * mask| over the frames (premultiplied RGB, the trainer's L1)."""
    from morf.avatar.texture import sample_texture

    total = 0.0
    for s in range(0, frames.num_frames, batch):
        b = frames.batch(list(range(s, min(s + batch, frames.num_frames))))
        rgb = renderer(sample_texture(texture, b.uv, b.uv_mask))[:, :3].clamp(0, 1)
        total += float((rgb - b.image * b.mask).abs().mean()) * b.image.shape[0]
    return total / frames.num_frames
