"""The live render's own thread: the avatar player renders there; the UI thread only uploads.

int8 shading costs 20-90 ms a frame at 640 x 640 on a small CPU, which on the UI thread alone
would break a 33 ms frame budget. So the player lives on this thread, with its own OpenGL
context (a GL context is current on one thread only; ``morf.raster.gl_context`` gives one per
thread). The UI posts the pose and camera it wants into a one-slot box and picks up the newest
finished image from another; both are newest-wins, so a slow renderer skips poses instead of
falling behind, and neither lock is held for more than swapping a reference.

A player that offers its two stages (``prepare``: the GL rasterization; ``complete``: the
renderer) is pipelined: this thread rasterizes frame t+1 while a helper thread shades frame t and
shows it, two input buffers taking turns. Otherwise frames run one after the other, and the UI,
having asked for the next one, can wait for its rasterization (:meth:`LiveRenderer.wait_rasterized`)
before drawing the frame it has: moderngl's GL calls hold Python's GIL, so the UI's own GL work
would otherwise hold the render thread off (measured in docs/studio.md).
"""

from __future__ import annotations

import collections
import os
import sys
import threading
import time
import traceback
from concurrent.futures import Future, ThreadPoolExecutor
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
        render_ms: the work of this frame (its GL work and its renderer, each on its thread);
        fps: frames finished per second over the last second (None until two frames finished in
        it); latency_ms: from the render thread taking the request to the frame being ready
        (longer than ``render_ms`` when the frame waited for the one before it to shade).
    """

    image: np.ndarray
    key: Hashable
    seq: int
    render_ms: float
    fps: float | None
    latency_ms: float = 0.0


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

    def __init__(self, open_player: PlayerOpener, on_frame: Callable[[], None] | None = None,
                 pipelined: bool = True):
        self._open_player = open_player
        self._want_pipelined = pipelined
        self._on_frame = on_frame or (lambda: None)
        self._cond = threading.Condition()
        self._pending: LiveRequest | None = None  # newest request (UI writes, render thread reads)
        self._frame: LiveFrame | None = None  # newest finished frame (render thread writes)
        self._done_key: Hashable = object()  # key of the last request rendered (or failed)
        self._taken_key: Hashable = object()  # key of the last request the render thread took
        self._finished: collections.deque[float] = collections.deque()  # times of recent frames
        self._seq = 0
        self._in_flight = 0  # pipelined: frames prepared and not yet shown (at most 2)
        self._closing = False
        self._opened = threading.Event()
        self._rasterized = threading.Event()  # cleared by a new request, set once its GL work is done
        self._rasterized.set()
        self._thread = threading.Thread(target=self._main, name="morf-live-render", daemon=True)
        self.ready = False  # the player opened
        self.note: str | None = None  # why there is no player, or the last render error
        self.size = 0  # side of the player's square images (once ready)
        self.num_bones = 0
        self.pipelined = False  # frames overlap (set once the player opened: it must offer two stages)

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
            if self._in_flight < 2:  # else the thread takes it once a frame is shown: nobody should wait
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
        staged = callable(getattr(player, "prepare", None)) and callable(getattr(player, "complete", None))
        self.pipelined = self._want_pipelined and staged
        self.ready = True
        self._opened.set()
        self._on_frame()
        try:
            self._run_pipelined(player) if self.pipelined else self._run_serial(player)
        finally:
            release = getattr(player, "release", None)
            if callable(release):
                release()

    def _next_request(self, free: Callable[[], bool] = lambda: True) -> LiveRequest | None:
        """Wait for a request not taken yet while ``free()`` (returned, and marked taken), or for
        closing (None)."""
        with self._cond:
            while not self._closing and (self._pending is None or self._pending.key == self._taken_key
                                         or not free()):
                self._cond.wait()
            if self._closing:
                return None
            self._taken_key = self._pending.key
            return self._pending

    def _publish(self, image: np.ndarray, req: LiveRequest, work_ms: float, t_taken: float) -> None:
        now = time.perf_counter()
        image.flags.writeable = False
        self._finished.append(now)
        while self._finished and now - self._finished[0] > FPS_WINDOW_S:
            self._finished.popleft()
        fps = (len(self._finished) - 1) / (now - self._finished[0]) if len(self._finished) >= 2 else None
        self._seq += 1
        self.note = None
        self._frame = LiveFrame(image, req.key, self._seq, work_ms, fps, (now - t_taken) * 1e3)
        with self._cond:
            self._done_key = req.key
        self._on_frame()

    def _failed(self, req: LiveRequest, e: Exception) -> None:
        self.note = f"the player failed: {type(e).__name__}: {e}"  # shown under the render; the next pose may work
        with self._cond:
            self._done_key = req.key
        self._on_frame()

    def _run_serial(self, player: PoseRenderer) -> None:
        """One frame after the other: rasterize, shade, show."""
        while True:
            req = self._next_request()
            if req is None:  # closing
                self._rasterized.set()
                return
            t0 = time.perf_counter()
            try:
                image = as_rgb(player.render(req.pose, req.camera))
            except Exception as e:
                self._failed(req, e)
                continue
            finally:  # players without the hook, or a failed render: nobody waits longer than the render
                self._rasterized.set()
            self._publish(image, req, (time.perf_counter() - t0) * 1e3, t0)

    def _run_pipelined(self, player: Any) -> None:
        """Frame t+1's GL work on this thread while frame t's renderer runs on a helper thread, as
        ``Player.render_sequence`` does. The helper shows each frame as soon as it is shaded; this
        thread takes the next pose as soon as it comes and a buffer is free (two: one frame shades
        while the next is prepared)."""

        def shade(prepared: Any, req: LiveRequest, prepare_ms: float, t_taken: float) -> None:
            try:
                t = time.perf_counter()
                image = as_rgb(player.complete(prepared))
                self._publish(image, req, prepare_ms + (time.perf_counter() - t) * 1e3, t_taken)
            except Exception as e:
                self._failed(req, e)
            finally:
                with self._cond:
                    self._in_flight -= 1
                    self._cond.notify_all()

        pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="morf-live-shade",
                                  initializer=lower_thread_priority)
        slot = 0
        try:
            while True:
                req = self._next_request(free=lambda: self._in_flight < 2)
                if req is None:  # closing
                    self._rasterized.set()
                    return
                t0 = time.perf_counter()
                try:
                    prepared = player.prepare(req.pose, req.camera, slot)
                except Exception as e:
                    self._failed(req, e)
                    continue
                finally:
                    self._rasterized.set()
                with self._cond:
                    self._in_flight += 1
                pool.submit(shade, prepared, req, (time.perf_counter() - t0) * 1e3, t0)
                slot ^= 1  # the next frame is prepared while this one shades
        finally:
            pool.shutdown(wait=True)
