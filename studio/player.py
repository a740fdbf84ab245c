"""How the live-render panel meets the avatar player (``morf.playback``).

The panel needs only an object with ``render(pose, camera)`` returning an (H, W, 3) uint8 RGB
image (float in [0, 1] is accepted too) and a ``size`` (the side of the square images it renders);
``pose`` is one frame of the chosen motion (None: the rest pose) and ``camera`` a
:class:`morf.camera.PinholeCamera` from the orbit camera. The library's player is imported lazily;
when it is missing or the avatar cannot be opened the panel says why.
"""

from __future__ import annotations

from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Any, Callable, Protocol

import numpy as np

from morf.camera import PinholeCamera
from morf.errors import MorfError
from morf.motion.clip import MotionClip
import morf.motion.library  # noqa: F401  (imported here on purpose: see below)
# Imported with the studio, on its main thread: the live panel lists motions on the UI thread while
# the motion loader's thread imports the motion package too, and a first import of a package racing
# on two threads can meet it half-initialized ("cannot import name ... partially initialized module").


class PoseRenderer(Protocol):
    """What the live-render panel draws with: renders one pose seen from one camera."""

    def render(self, pose: Any, camera: PinholeCamera) -> Any:
        """One frame: (H, W, 3) uint8 RGB of camera.width x camera.height, on the live-render thread."""


# onnxruntime threads of the live renderer: two, as ``morf bench render`` measures it. The UI draws
# only when something changed (studio/pacing.py), so between its frames the render has the cores;
# onnxruntime's pool is created on the render thread and inherits its lower priority
# (live_render.py), so the UI and a running stage still come first when the CPU is short.
LIVE_RENDER_THREADS = 2
LIVE_RENDER_SIZE = 640
# Clips slower than this are resampled to it for the live panel (slerp between the clip's frames):
# the panel asks for one render per motion frame, so a 30 fps clip would hold a renderer that
# makes 40 frames a second at 30, and show each pose twice where it makes more.
LIVE_MOTION_FPS = 60.0


class PlaybackPlayer:
    """Adapts ``morf.playback``'s player (``render(rotvecs, transl, camera)``) to :class:`PoseRenderer`.

    ``pose`` is None (the rest pose: Anny's A-pose) or (rotvecs (J, 3), transl (3,)). It renders
    square (size, size, 3) uint8 images in the GL context of the thread that opened it (made
    current around each call), so open, render and release it on one thread.
    """

    def __init__(self, player: Any, gl: Any = None):
        self._player = player
        self._gl = gl  # morf.raster.gl_context.GLState of the opening thread, or None
        self.size = int(player.size)
        self.num_bones = int(player.avatar.skeleton.num_bones)
        self.on_rasterized: Callable[[], None] | None = None  # called between GL work and the renderer
        self._buffers: list[np.ndarray] | None = None  # prepare()'s two input buffers

    def _pose(self, pose: Any) -> tuple[np.ndarray, np.ndarray]:
        if pose is None:
            return np.zeros((self.num_bones, 3), np.float32), np.zeros(3, np.float32)
        return pose

    def _in_context(self, fn: Callable, *args, **kwargs):
        """``fn(*args, **kwargs)`` with this player's GL context current (where it has its own)."""
        if self._gl is None:
            return fn(*args, **kwargs)
        from morf.raster.gl_context import current

        with current(self._gl):
            return fn(*args, **kwargs)

    def render(self, pose: Any, camera: PinholeCamera) -> np.ndarray:
        rotvecs, transl = self._pose(pose)
        return self._in_context(self._player.render, rotvecs, transl, camera, on_rasterized=self.on_rasterized)

    # ---- the two stages of a frame, for a pipelined render thread (studio.live_render) ----------
    def prepare(self, pose: Any, camera: PinholeCamera, slot: int) -> Any:
        """The frame's GL work, into input buffer ``slot`` (0 or 1): a frame may be prepared
        into one slot while the frame in the other completes on another thread."""
        if self._buffers is None:
            self._buffers = [self._player.new_input() for _ in range(2)]
        rotvecs, transl = self._pose(pose)
        return self._in_context(self._player.prepare, rotvecs, transl, camera, out=self._buffers[slot])

    def complete(self, prepared: Any) -> np.ndarray:
        """The frame's renderer and compositing (no GL: any thread)."""
        return self._player.complete(prepared)

    def release(self) -> None:
        if self._gl is None:
            self._player.release()
            return
        from morf.raster.gl_context import current, release_gl_context

        with current(self._gl):
            self._player.release()
        release_gl_context()


def open_live_player(avatar_dir: Path, size: int = LIVE_RENDER_SIZE,
                     threads: int = LIVE_RENDER_THREADS) -> tuple[PoseRenderer | None, str | None]:
    """(player, None) for an exported avatar, or (None, why not in words).

    Call it on the thread that will render: the player draws in that thread's own headless GL
    context (``morf.raster.gl_context``), never in the window's.
    """
    try:
        from morf.playback.player import open_player as open_playback
        from morf.raster.gl_context import current, gl_state
    except ImportError as e:
        return None, f"the avatar player (morf.playback) cannot be loaded: {e}"
    try:
        gl = gl_state()
        with current(gl):
            player = open_playback(avatar_dir, ctx=gl.ctx, size=size, threads=threads)
        return PlaybackPlayer(player, gl), None
    except MorfError as e:
        return None, str(e)
    except Exception as e:  # a broken avatar must not take the studio down
        return None, f"{type(e).__name__}: {e}"


def load_live_motion(path: Path, num_bones: int) -> tuple[MotionClip | None, str | None]:
    """A motion clip for the player at :data:`LIVE_MOTION_FPS` or faster, or (None, why not in words).
    Frame ``t`` is the player's pose ``(clip.rotvecs[t], clip.transl[t])`` (indexing the clip itself
    gives a torch ``BodyPose``)."""
    try:
        from morf.playback.motion_input import load_playback_motion
    except ImportError as e:
        return None, f"motions need the avatar player (morf.playback): {e}"
    try:
        clip = load_playback_motion(path, num_bones)
        if clip.fps < LIVE_MOTION_FPS and len(clip) > 1:
            from morf.motion.clip import resample

            clip = resample(clip, LIVE_MOTION_FPS)
        return clip, None
    except MorfError as e:
        return None, str(e)
    except Exception as e:
        return None, f"{type(e).__name__}: {e}"


_MOTION_POOL: ThreadPoolExecutor | None = None


def load_live_motion_async(path: Path, num_bones: int) -> "Future[tuple[MotionClip | None, str | None]]":
    """:func:`load_live_motion` on a background thread (reading and retargeting a BVH takes seconds)."""
    global _MOTION_POOL
    if _MOTION_POOL is None:
        _MOTION_POOL = ThreadPoolExecutor(max_workers=1, thread_name_prefix="morf-motion")
    return _MOTION_POOL.submit(load_live_motion, path, num_bones)


def shutdown_motion_loader() -> None:
    """End the motion-loading thread (the app calls this when it closes; a later load starts it again)."""
    global _MOTION_POOL
    pool, _MOTION_POOL = _MOTION_POOL, None
    if pool is not None:
        pool.shutdown(wait=False, cancel_futures=True)


def as_rgb(image: Any) -> np.ndarray:
    """A player's array output as contiguous (H, W, 3) uint8."""
    a = np.asarray(image)
    if a.dtype != np.uint8:
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if a.ndim == 2:
        a = np.repeat(a[..., None], 3, axis=2)
    return np.ascontiguousarray(a[..., :3])
