"""When the UI draws its next frame: when something changed, never faster than a cap, else rarely.

Without a GPU every UI frame is CPU work (llvmpipe rasterizes the window), and a UI that redraws
as fast as it can takes the cores the live render and training need (measured on 2 cores: the UI
at 73 frames/s left the live render 25% of a core). So the frame loop waits for a reason to draw:
input, a new worker snapshot, a new live frame, a decoded image, a resize; or the idle rate, which
keeps clocks and hover effects alive. After input it draws a few frames more (imgui settles
auto-sized windows and splits a press and release over two frames); never more than ``max_fps``
frames a second.

:class:`FramePacer` is the pure scheduling rule (UI thread only); :class:`Wakeup` is how other
threads and input callbacks interrupt the loop's wait.
"""

from __future__ import annotations

import math
import threading
import time
from typing import Callable

MAX_FPS = 60.0  # cap on redraws a second, whatever asks for them
IDLE_FPS = 4.0  # redraws a second with nothing happening
SNAPSHOT_FPS = 10.0  # a running stage's snapshots redraw at most this often (loss curves, progress)
SETTLE_FRAMES = 2  # frames drawn after a change, at the cap


class FramePacer:
    """Decides when the next UI frame is due. Times are ``clock()`` seconds.

    Args:
        max_fps: never draw more often than this; 0 or None: no cap, and no waiting at all
            (every loop iteration draws, the behaviour of a plain render loop).
        idle_fps: draw at least this often.
        settle_frames: frames drawn at the cap after each input.
    """

    def __init__(self, max_fps: float | None = MAX_FPS, idle_fps: float = IDLE_FPS,
                 settle_frames: int = SETTLE_FRAMES, clock: Callable[[], float] = time.perf_counter):
        self.max_fps = float(max_fps) if max_fps else 0.0
        self.idle_fps = float(idle_fps)
        self.settle_frames = int(settle_frames)
        self._clock = clock
        self._last = -math.inf  # when the last frame started
        self._wanted = math.inf  # earliest time a change asks for a frame
        self._settle = 0

    @property
    def continuous(self) -> bool:
        """No cap: draw every time round the loop."""
        return self.max_fps <= 0.0

    @property
    def min_interval(self) -> float:
        return 1.0 / self.max_fps if self.max_fps > 0 else 0.0

    def input(self) -> None:
        """The user did something: draw now (as the cap allows), then ``settle_frames`` more."""
        self.want_within(0.0)
        self._settle = self.settle_frames + 1  # counted down from the input's own frame on

    def want_within(self, seconds: float) -> None:
        """Something on screen changed (a live frame, a snapshot): draw within ``seconds``."""
        self._wanted = min(self._wanted, self._clock() + seconds)

    def due(self) -> float:
        """When the next frame should start."""
        if self.continuous:
            return -math.inf
        cap = self._last + self.min_interval
        idle = self._last + 1.0 / self.idle_fps if self.idle_fps > 0 else math.inf
        settle = cap if self._settle > 0 else math.inf
        return max(min(self._wanted, idle, settle), cap)

    def wait_s(self) -> float:
        """Seconds until the next frame is due (0 when it is due now)."""
        return max(0.0, self.due() - self._clock())

    def frame_started(self) -> None:
        self._last = self._clock()
        self._wanted = math.inf
        self._settle = max(0, self._settle - 1)


class Wakeup:
    """Interrupts the frame loop's wait from any thread.

    ``notify(within_s)`` records that something changed and calls ``poke`` (e.g.
    ``glfw.post_empty_event``, which ends a ``glfw.wait_events_timeout``); :meth:`wait` serves
    loops without a window event queue (GLFW's null platform). :meth:`take` returns the most
    urgent ``within_s`` asked for since the last take, or None.
    """

    def __init__(self, poke: Callable[[], None] | None = None):
        self._poke = poke
        self._lock = threading.Lock()
        self._event = threading.Event()
        self._within: float | None = None

    def notify(self, within_s: float = 0.0) -> None:
        with self._lock:
            self._within = within_s if self._within is None else min(self._within, within_s)
        self._event.set()
        poke = self._poke
        if poke is not None:
            try:
                poke()
            except Exception:  # the window is going away: the loop no longer waits
                pass

    def take(self) -> float | None:
        with self._lock:
            within, self._within = self._within, None
            self._event.clear()
        return within

    def wait(self, timeout_s: float) -> None:
        self._event.wait(timeout_s)

    def disconnect(self) -> None:
        """Stop poking (call before the window is destroyed)."""
        self._poke = None
