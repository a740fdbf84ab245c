"""The live render's own thread: the avatar player renders there; the UI thread only uploads.

int8 shading costs 20-90 ms a frame at 640 x 640 on a small CPU, which on the UI thread alone
would break a 33 ms frame budget. So the player lives on this thread, with its own OpenGL
context (a GL context is current on one thread only; ``morf.raster.gl_context`` gives one per
thread). The UI posts the pose and camera it wants into a one-slot box and picks up the newest
finished image from another; both are newest-wins, so a slow renderer skips poses instead of
falling behind, and neither lock is held for more than swapping a reference.

A player's GL rasterization holds Python's GIL (moderngl does not release it), the renderer
after it does not. The UI, having asked for the next frame, can wait for that rasterization
(:meth:`LiveRenderer.wait_rasterized`) before drawing the frame it has: its own GL calls then
run while the renderer runs instead of holding the render thread off the GIL (measured in
docs/studio.md).
"""

from __future__ import annotations

import collections
import os
import sys
import threading
import time
import traceback
from dataclasses import dataclass
from typing import Any, Callable, Hashable

import numpy as np

from morf.camera import PinholeCamera
from studio.player import PoseRenderer, as_rgb

FPS_WINDOW_S = 1.0  # the render fps counts frames finished in this trailing window
RENDER_NICENESS = 10  # the render thread's nice value: the UI thread wins when the CPU is short

PlayerOpener = Callable[[], tuple[PoseRenderer | None, str | None]]


@dataclass(frozen=True)
class LiveRequest:
    """What the UI wants on screen.

    Fields:
        pose: None (the rest pose) or (rotvecs (J, 3) float32, transl (3,) float32).
        camera: the orbit camera at the player's size.
        key: names this pose and camera (motion, frame index, camera); a request whose key equals
            the last rendered one is not rendered again.
    """

    pose: Any
    camera: PinholeCamera
    key: Hashable


@dataclass(frozen=True)
class LiveFrame:
    """One finished live render.

    Fields:
        image: (H, W, 3) uint8 RGB, read-only; key: the request's key; seq: 1, 2, ... per frame;
        render_ms: this frame's time on the render thread; fps: frames finished per second
        over the last second (None until two frames finished in it).
    """

    image: np.ndarray
    key: Hashable
    seq: int
    render_ms: float
    fps: float | None


def lower_thread_priority(niceness: int = RENDER_NICENESS) -> None:
    """Make the calling thread yield the CPU to the UI thread (Linux: threads have their own nice value)."""
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), niceness)
    except (AttributeError, OSError):  # other systems, or not permitted: run at normal priority
        pass


class LiveRenderer:
    """Runs a player on its own thread. Create, :meth:`start`, :meth:`request`, :meth:`latest`, :meth:`close`.

    Args:
        open_player: called once on the render thread: () -> (player, None) or (None, why not).
            It runs there so that the player's GL objects belong to that thread's context.
        on_frame: called on the render thread whenever there is something new to show (a
            finished frame, a failure, the player opened or not): the UI's frame loop wakes on it.
    """

    def __init__(self, open_player: PlayerOpener, on_frame: Callable[[], None] | None = None):
        self._open_player = open_player
        self._on_frame = on_frame or (lambda: None)
        self._cond = threading.Condition()
        self._pending: LiveRequest | None = None  # newest request (UI writes, render thread reads)
        self._frame: LiveFrame | None = None  # newest finished frame (render thread writes)
        self._done_key: Hashable = object()  # key of the last request rendered (or failed)
        self._closing = False
        self._opened = threading.Event()
        self._rasterized = threading.Event()  # cleared by a new request, set once its GL work is done
        self._rasterized.set()
        self._thread = threading.Thread(target=self._main, name="morf-live-render", daemon=True)
        self.ready = False  # the player opened
        self.note: str | None = None  # why there is no player, or the last render error
        self.size = 0  # side of the player's square images (once ready)
        self.num_bones = 0

    # ---- UI side ------------------------------------------------------------------------
    def start(self) -> "LiveRenderer":
        self._thread.start()
        return self

    def wait_open(self, timeout: float | None = None) -> bool:
        """Wait until the player opened or failed to; True when that happened within ``timeout``."""
        return self._opened.wait(timeout)

    def request(self, req: LiveRequest) -> bool:
        """Ask for a render; replaces any request the thread has not started yet.

        Returns False when ``req`` has the key of the newest request already (nothing new to render).
        """
        with self._cond:
            if self._pending is not None and self._pending.key == req.key:
                return False
            self._pending = req
            self._rasterized.clear()
            self._cond.notify()
        return True

    def wait_rasterized(self, timeout: float) -> bool:
        """Wait (without the GIL) until the newest request's GL rasterization is done, its render
        ended, or ``timeout`` seconds passed; True unless the timeout ended it. Returns at once
        when no request is on its way."""
        return self._rasterized.wait(timeout)

    def latest(self) -> LiveFrame | None:
        return self._frame

    def idle(self) -> bool:
        """Nothing left to do: the newest request is rendered, or the player could not open."""
        if not self._opened.is_set():
            return False
        if not self.ready or not self._thread.is_alive():
            return True
        with self._cond:
            return self._pending is None or self._pending.key == self._done_key

    @property
    def native_id(self) -> int | None:
        """The render thread's OS id (for per-thread CPU accounting), once started."""
        return self._thread.native_id

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def close(self, timeout: float = 10.0) -> bool:
        """End the thread (it releases the player and its GL context); True when it ended."""
        with self._cond:
            self._closing = True
            self._cond.notify()
        if self._thread.is_alive():
            self._thread.join(timeout)
        return not self._thread.is_alive()

    # ---- render thread ------------------------------------------------------------------
    def _main(self) -> None:
        lower_thread_priority()
        try:
            player, note = self._open_player()
        except Exception as e:  # a broken avatar must not take the studio down
            traceback.print_exc(file=sys.stderr)
            player, note = None, f"{type(e).__name__}: {e}"
        if player is None:
            self.note = note or "the avatar player could not be opened"
            self._opened.set()
            self._on_frame()
            return
        if hasattr(player, "on_rasterized"):
            player.on_rasterized = self._rasterized.set
        self.size = int(getattr(player, "size", 0) or 0)
        self.num_bones = int(getattr(player, "num_bones", 0) or 0)
        self.ready = True
        self._opened.set()
        self._on_frame()
        finished: collections.deque[float] = collections.deque()
        seq = 0
        try:
            while True:
                with self._cond:
                    while not self._closing and (self._pending is None or self._pending.key == self._done_key):
                        self._cond.wait()
                    if self._closing:
                        self._rasterized.set()
                        return
                    req = self._pending
                t0 = time.perf_counter()
                try:
                    image = as_rgb(player.render(req.pose, req.camera))
                except Exception as e:  # shown under the render; the next pose may work
                    self.note = f"the player failed: {type(e).__name__}: {e}"
                    with self._cond:
                        self._done_key = req.key
                    self._on_frame()
                    continue
                finally:  # players without the hook, or a failed render: nobody waits longer than the render
                    self._rasterized.set()
                now = time.perf_counter()
                image.flags.writeable = False
                finished.append(now)
                while finished and now - finished[0] > FPS_WINDOW_S:
                    finished.popleft()
                fps = (len(finished) - 1) / (now - finished[0]) if len(finished) >= 2 else None
                seq += 1
                self.note = None
                self._frame = LiveFrame(image, req.key, seq, (now - t0) * 1e3, fps)
                with self._cond:
                    self._done_key = req.key
                self._on_frame()
        finally:
            release = getattr(player, "release", None)
            if callable(release):
                release()
