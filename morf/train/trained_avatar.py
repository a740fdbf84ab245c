"""The trained avatar handed to export and evaluation: a baked (static) neural texture and the
renderer, nothing of the warp networks.

Stored as ``runs/<name>/avatar.pt`` (torch.save of tensors, state dicts and plain values;
read with ``weights_only=True``). ``renderer_kind`` names the renderer module: ``"unet"`` (the
trained U-Net; files without the key are U-Net avatars) or ``"passthrough"`` (the RGB floor of
``morf train --method rgb``, :mod:`morf.avatar.passthrough`).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from torch import nn

from morf.avatar.model import render_with_texture
from morf.avatar.passthrough import PassthroughConfig, PassthroughRenderer
from morf.avatar.renderer import RendererConfig, UNetRenderer
from morf.avatar.view_colour import ViewColours
from morf.camera import PinholeCamera
from morf.errors import ProjectError
from morf.train.config import TrainConfig
from morf.train.run_dir import load_torch_file
from morf.train.run_files import AVATAR_FILE

FORMAT = "morf-avatar"
VERSION = 1
# renderer kind -> (config class, module class)
RENDERERS = {"unet": (RendererConfig, UNetRenderer), "passthrough": (PassthroughConfig, PassthroughRenderer)}


@dataclass(frozen=True)
class TrainedAvatar:
    """A trained avatar ready for inference.

    Fields:
        texture: (C, Ht, Wt) float32 baked neural texture (row 0 = v 1, see morf.avatar.texture);
            for the RGB floor, RGB + a constant-1 channel.
        renderer: UNetRenderer (or the floor's PassthroughRenderer) in eval mode on the CPU
            (input (B, C, H, W) -> (B, 4, H, W)); ``renderer.cfg.multiple`` is its size multiple.
        config: the run's TrainConfig.
        shape: (1, S) float32 body shape the avatar was trained with.
        camera: the training camera at the working resolution, or None.
        method: "morf" | "stylepeople" | "anr" | "rgb".
        view_colours: the colour channels by view (:mod:`morf.avatar.view_colour`), or None: the
            texture's own channels 0-2 for every view.
    """

    texture: torch.Tensor
    renderer: nn.Module
    config: TrainConfig
    shape: torch.Tensor
    camera: PinholeCamera | None
    method: str
    view_colours: ViewColours | None = None

    @property
    def dressed(self) -> bool:
        """Whether the body was rasterized with the fits' clothing offsets in training (the run's
        ``dressed`` setting, on by default), so export and evaluation must draw it dressed too
        (:func:`morf.train.data.clothing_offsets`)."""
        return bool(getattr(self.config, "dressed", True))

    @torch.no_grad()
    def render(self, uv: torch.Tensor, uv_mask: torch.Tensor, poses=None) -> tuple[torch.Tensor, torch.Tensor]:
        """(B, H, W, 2) UVs + (B, H, W) coverage -> RGB (B, 3, H, W) premultiplied, mask (B, 1, H, W).
        ``poses``: (B, J, 3) the poses (axis-angle per bone, the root's in camera coordinates), or
        (B, 3) their root orientations alone, which pick the colour of an avatar with view colours
        (the head's own colour needs the whole pose; ignored without view colours; None: the one texture)."""
        if self.view_colours is None or poses is None:
            return render_with_texture(self.renderer, self.texture, uv, uv_mask)
        poses = np.asarray(poses.detach().cpu() if isinstance(poses, torch.Tensor) else poses, np.float64)
        outs = [render_with_texture(self.renderer, self.texture_for(poses[b]), uv[b:b + 1], uv_mask[b:b + 1])
                for b in range(uv.shape[0])]
        return torch.cat([o[0] for o in outs]), torch.cat([o[1] for o in outs])

    def texture_for(self, pose) -> torch.Tensor:
        """The texture a pose is drawn with: ``pose`` (J, 3) axis-angle per bone, or (3,) the root
        orientation alone (:meth:`morf.avatar.view_colour.ViewColours.colour`)."""
        if self.view_colours is None or pose is None:
            return self.texture
        pose = np.asarray(pose, np.float64)
        return self.view_colours.texture_for(self.texture, pose if pose.ndim == 2 else pose.reshape(3))


def render_batch(avatar, batch) -> tuple[torch.Tensor, torch.Tensor]:
    """``avatar.render`` of a FrameSet batch, each frame in its pose's view colour when the avatar
    has view colours."""
    if getattr(avatar, "view_colours", None) is None:
        return avatar.render(batch.uv, batch.uv_mask)
    return avatar.render(batch.uv, batch.uv_mask, batch.rotvecs)


def save_trained_avatar(path: str | Path, texture: torch.Tensor, renderer: nn.Module, config_dict: dict,
                        shape: torch.Tensor | None, camera: PinholeCamera | None, extra: dict | None = None) -> None:
    """Atomically write ``avatar.pt``."""
    from morf.io import atomic_path

    payload = {
        "format": FORMAT, "version": VERSION,
        "texture": texture.detach().float().cpu().contiguous(),
        "renderer": {k: v.detach().cpu() for k, v in renderer.state_dict().items()},
        "renderer_kind": getattr(renderer, "kind", "unet"),
        "renderer_config": dict(renderer.cfg.__dict__),
        "config": config_dict,
        "shape": None if shape is None else shape.detach().float().cpu().reshape(1, -1),
        # JSON text: camera fields may be numpy scalars, which weights_only loading refuses
        "camera": None if camera is None else json.dumps(camera.to_dict(), default=float),
        "extra": extra or {},
    }
    with atomic_path(path) as tmp:
        torch.save(payload, tmp)


def load_trained_avatar(run_dir: str | Path) -> TrainedAvatar:
    """Load ``run_dir/avatar.pt`` (written when ``morf train`` finishes)."""
    run_dir = Path(run_dir)
    path = run_dir / AVATAR_FILE if run_dir.is_dir() else run_dir
    if not path.is_file():
        raise ProjectError(f"no trained avatar in {run_dir}: training has not finished (run 'morf train' again to resume)")
    d = load_torch_file(path)
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise ProjectError(f"{path} is not a MoRF avatar file")
    if int(d.get("version", 0)) > VERSION:
        raise ProjectError(f"{path} was written by a newer MoRF (version {d.get('version')})")
    kind = d.get("renderer_kind", "unet")
    if kind not in RENDERERS:
        raise ProjectError(f"{path} uses an unknown renderer {kind!r}; update MoRF")
    config_cls, module_cls = RENDERERS[kind]
    renderer = module_cls(config_cls(**d["renderer_config"]))
    renderer.load_state_dict(d["renderer"])
    renderer.eval().requires_grad_(False)
    cfg = TrainConfig.from_dict(d["config"])
    shape = d["shape"] if d["shape"] is not None else torch.zeros(1, 0)
    camera = PinholeCamera.from_dict(json.loads(d["camera"])) if d.get("camera") else None
    views = None
    if d.get("view_colours") is not None:
        try:
            views = ViewColours.from_dict(d["view_colours"])
        except (KeyError, TypeError, ValueError) as e:
            raise ProjectError(f"{path}: damaged view colours ({e})") from None
        if views.colours.shape[2:] != tuple(d["texture"].shape[1:]):
            raise ProjectError(f"{path}: view colours of {views.colours.shape[2:]} texels for a texture of "
                               f"{tuple(d['texture'].shape[1:])}")
    return TrainedAvatar(texture=d["texture"], renderer=renderer, config=cfg, shape=shape, camera=camera,
                         method=cfg.method, view_colours=views)
