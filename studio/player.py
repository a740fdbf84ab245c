"""How the live-render panel meets the avatar player (``morf.playback``).

The panel needs only an object with ``render(pose, camera)`` returning either an (H, W, 3) uint8
RGB image or a moderngl texture; ``pose`` is one frame of the chosen motion (None: the player's
own default pose) and ``camera`` a :class:`morf.camera.PinholeCamera` from the orbit camera.
The player is looked up lazily in the library; until it exists the panel says so.
"""

from __future__ import annotations

import importlib
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from morf.camera import PinholeCamera
from morf.errors import MorfError

MOTION_SUFFIXES = (".bvh", ".npz")


class Player(Protocol):
    def render(self, pose: Any, camera: PinholeCamera) -> Any:
        """One frame: (H, W, 3) uint8 RGB or a moderngl.Texture of camera.width x camera.height."""


def open_player(avatar_dir: Path) -> tuple[Player | None, str | None]:
    """(player, None) for an exported avatar, or (None, why not in words)."""
    try:
        playback = importlib.import_module("morf.playback")
    except ImportError:
        return None, "the avatar player (morf.playback) is not part of this build yet"
    opener = next((getattr(playback, n) for n in ("load_player", "open_player") if callable(getattr(playback, n, None))), None)
    if opener is None:
        return None, "morf.playback has no load_player(avatar_dir)"
    try:
        return opener(avatar_dir), None
    except MorfError as e:
        return None, str(e)
    except Exception as e:  # a broken avatar must not take the studio down
        return None, f"{type(e).__name__}: {e}"


def load_motion(path: Path) -> tuple[Any | None, str | None]:
    """A motion clip (a sequence of poses with ``len``) for the player, or (None, why not)."""
    try:
        playback = importlib.import_module("morf.playback")
    except ImportError:
        return None, "motions need the avatar player (morf.playback)"
    loader = getattr(playback, "load_motion", None)
    if not callable(loader):
        return None, "morf.playback has no load_motion(path)"
    try:
        return loader(path), None
    except MorfError as e:
        return None, str(e)
    except Exception as e:
        return None, f"{type(e).__name__}: {e}"


def list_motions(folder: str | Path) -> list[Path]:
    """.bvh and .npz files under ``folder`` (recursively, sorted), empty when it is not a folder."""
    folder = Path(folder).expanduser()
    if not folder.is_dir():
        return []
    return sorted(p for p in folder.rglob("*") if p.suffix.lower() in MOTION_SUFFIXES and p.is_file())


def as_rgb(image: Any) -> np.ndarray:
    """A player's array output as contiguous (H, W, 3) uint8."""
    a = np.asarray(image)
    if a.dtype != np.uint8:
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])
