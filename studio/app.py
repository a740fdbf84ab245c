"""``morf-studio``: the desktop app. This file owns the GL context and the frame loop.

One GLFW window with an OpenGL context; imgui-bundle's native GLFW and OpenGL3 backends draw the
UI; moderngl shares the same context for textures. Without a display (or with
``--headless-frames``) GLFW's null platform with an EGL context renders off-screen, which is also
how the screenshot tests run. Frames are deterministic there: no imgui.ini, no cursor blink, a
fixed frame time and the bundled font; tests draw each frame themselves with :meth:`StudioApp.frame`.

:meth:`StudioApp.run` draws only when something changed (see :mod:`studio.pacing`): input, a new
worker snapshot, a new live frame, a decoded image, a resize, an animation's next step, or the
idle rate. Without a GPU every frame is CPU work that the live render and training need.
"""

from __future__ import annotations

import ctypes
import math
import os
import sys
import time
import traceback
from pathlib import Path
from typing import Any, Callable

import numpy as np
from imgui_bundle import imgui, implot  # before glfw: glfw must load imgui-bundle's GLFW library

import glfw  # noqa: E402  (import order above is required)
import moderngl  # noqa: E402

from morf.errors import MorfError  # noqa: E402
from morf.raster.gl_context import GLUnavailable  # noqa: E402
from studio.actions import advance_playback, make_actions  # noqa: E402
from studio.cli import build_parser, run_cli  # noqa: E402  (build_parser: the hint test reads it here too)
from studio.commands import Command, OpenProject, RunPipeline  # noqa: E402
from studio.context import UiContext  # noqa: E402
from studio.drops import DropClassifier, kind_by_name, suggested_folder  # noqa: E402
from studio.input_events import KeyQueue, install_callbacks  # noqa: E402
from studio.keys import handle_keys  # noqa: E402
from studio.layout import draw_ui  # noqa: E402
from studio.live_render import LiveRenderer  # noqa: E402
from studio.loader import ImageLoader  # noqa: E402
from studio.motion_browser import MotionBrowser  # noqa: E402
from studio.panels.live import commit_motion_dir, post_request as post_live_request  # noqa: E402
from studio.pacing import IDLE_FPS, MAX_FPS, SNAPSHOT_FPS, FramePacer, Wakeup  # noqa: E402
from studio.pipeline_run import STAGES as PIPELINE_STAGES, PipelineRequest  # noqa: E402
from studio.player import PoseRenderer, open_live_player, shutdown_motion_loader  # noqa: E402
from studio.project_view import ProjectView  # noqa: E402
from studio.stages import LIBRARY_STAGES, LoadedStages, cpu_load_stage, load_library_stages  # noqa: E402
from studio.state import PANELS, AppState, LivePanelState  # noqa: E402
from studio.sub_buffer import open_sub_buffer  # noqa: E402
from studio.x_image import open_x_image  # noqa: E402
from morf.raster.gl_context import software_gl  # noqa: E402
from morf.raster.gl_finish import gil_free_finish  # noqa: E402
from studio.textures import TextureCache  # noqa: E402
from studio.ui_cache import UiCache  # noqa: E402
from studio.worker import StageFn, Worker  # noqa: E402
from morf.resources import FONT

FONT_PATH = FONT
FONT_SIZE = 15.0
FIXED_DT = 1.0 / 60.0
CLEAR_RGB = (0.06, 0.06, 0.07)
LIVE_PANEL = PANELS.index("Live render")
# while the live panel plays, frames between full UI frames only redraw the live image (studio.ui_cache);
# a full frame (text, training progress) still comes at least this often. Each costs llvmpipe about
# as much as a live frame's rasterization: at 0.25 s the UI skipped about one live frame in twenty
FULL_FRAME_INTERVAL_S = 0.5
RASTER_WAIT_S = 0.02  # the longest a light frame waits for the live render's rasterization
DEFAULT_MOTION = "walk_forward.npz"  # of the shipped motions: what a freshly made avatar plays


class StudioApp:
    """The studio: window, GL context, UI state, worker. Drive it with :meth:`frame` or :meth:`run`.

    Args:
        project: a project folder to open (a bad one shows its error on the start screen).
        size: window size in pixels.
        headless: GLFW null platform + EGL (no display needed); also fixes the frame time.
        stages: stage name -> function for the worker; None: the library's stages
            (:data:`studio.stages.LIBRARY_STAGES`, with their presets; one that fails to load shows its error).
        unavailable: stage name -> why it is missing (with ``stages``).
        player_opener: avatar folder -> (player, note); None: :func:`studio.player.open_live_player`.
            It is called on the live render's own thread (see :mod:`studio.live_render`).
        motion_dir: the folder the live render's motion picker lists first; None: the motions
            shipped with the project (``morf.motion.library.BUILTIN_MOTIONS``).
        deterministic: a fixed 1/60 s frame time (screenshots, tests); None: when headless.
        settings: the JSON file recent motion folders are kept in (None: the user's,
            :func:`studio.motion_browser.settings_path`); ``remember_folders=False`` keeps none.
        max_fps, idle_fps: :meth:`run` draws at most ``max_fps`` frames a second (0: as fast as
            it can, every time round the loop) and at least ``idle_fps`` (see :mod:`studio.pacing`).
    """

    def __init__(self, project: str | os.PathLike | None = None, *, size: tuple[int, int] = (1280, 800),
                 headless: bool = True, stages: dict[str, StageFn] | None = None,
                 unavailable: dict[str, str] | None = None,
                 player_opener: Callable[[Path], tuple[Any, str | None]] | None = None,
                 motion_dir: str | os.PathLike | None = None, deterministic: bool | None = None,
                 max_fps: float = MAX_FPS, idle_fps: float = IDLE_FPS, live_pipelined: bool = True,
                 settings: Path | None = None, remember_folders: bool = True):
        self._headless = headless
        self._live_pipelined = live_pipelined
        self._fixed_dt = FIXED_DT if (headless if deterministic is None else deterministic) else None
        self.pacer = FramePacer(max_fps, idle_fps)
        self._inputs = 0  # input events seen (callbacks), and how many the last full frame had seen
        self._inputs_at_full = 0
        self._init_window(size, headless)
        # other threads end the frame loop's wait through this (no event queue to post to when headless)
        self._wakeup = Wakeup(None if headless else glfw.post_empty_event)
        self._init_input_callbacks()
        self._init_imgui()
        self._stages = load_library_stages() if stages is None else LoadedStages(
            functions=dict(stages), errors={}, presets={}, default_presets={})
        unavailable = {**(unavailable or {}), **self._stages.errors}
        self._stage_labels = {s.name: s.label for s in LIBRARY_STAGES}
        shown = [s.name for s in LIBRARY_STAGES] + [n for n in self._stages.functions if n not in self._stage_labels]
        self._stage_status = {n: None if n in self._stages.functions else unavailable.get(n, "not part of this build")
                              for n in shown}
        runnable = {**self._stages.functions, "cpu-load": cpu_load_stage}  # cpu-load: benchmark only, no button
        self.worker = Worker(runnable, unavailable, stage_threads=max(1, (os.cpu_count() or 2) - 1),
                             on_publish=lambda: self._wakeup.notify(1.0 / SNAPSHOT_FPS)).start()
        if motion_dir is None:
            from morf.motion.library import BUILTIN_MOTIONS

            motion_dir = BUILTIN_MOTIONS
        self.state = AppState(motion_dir=str(motion_dir))
        # the motion folder is listed on a thread of its own, when committed (studio.motion_browser)
        self.motions = MotionBrowser(on_done=lambda: self._wakeup.notify(0.0), settings=settings,
                                     remember=remember_folders)
        self.motions.commit(self.state.motion_dir)
        self.drops = DropClassifier(on_done=lambda: self._wakeup.notify(0.0))  # dropped folders, looked into off the UI thread
        self._project_rev = self._stage_rev = 0  # the worker's counters last acted on (studio.snapshot)
        self.view: ProjectView | None = None
        self.loader: ImageLoader | None = None
        self.textures = TextureCache(self.ctx, None)
        self.live: LiveRenderer | None = None  # the live render's thread, once an avatar is exported
        self._player_opener = player_opener or open_live_player
        self.live_panel = LivePanelState()  # the live render panel's motion list and loaded clip
        self._review_rev = 0
        self._was_busy = False
        self.frame_times: list[float] = []  # seconds per frame (UI work and its GL rasterization, no vsync wait)
        self.live_stats: list[tuple[float | None, float]] = []  # (render fps, render ms) per live frame shown
        self._live_seq = 0
        self.light_frames = True  # run() redraws only the live image when nothing else changed
        self.light_frame_count = 0
        self._ui_cache = UiCache(self.ctx)
        # X windows with GLX_MESA_copy_sub_buffer: light frames present the live rectangle alone
        self._sub_buffer = None if headless else open_sub_buffer(self.window)
        # software GL in an X window: light frames put the live image into the window without GL
        self._x_image = None if headless or not software_gl(self.ctx) else open_x_image(self.window)
        self._back_is_ui = False  # the back buffer holds the stored UI (no swap since a light frame drew it)
        self._last_full_t = -math.inf
        self._last_frame_t: float | None = None
        self._actions = make_actions(self.state, lambda: self.view, self.send)
        self._closed = False
        if project is not None:
            self.open_project(str(project))

    # ---- window and contexts ------------------------------------------------------------
    def _init_window(self, size: tuple[int, int], headless: bool) -> None:
        if headless:
            glfw.init_hint(glfw.PLATFORM, glfw.PLATFORM_NULL)
        if not glfw.init():
            raise GLUnavailable("cannot start GLFW (no display? try "
                               "'morf-studio PROJECT --headless-frames N --screenshot PNG')")
        if headless:
            glfw.window_hint(glfw.CONTEXT_CREATION_API, glfw.EGL_CONTEXT_API)
            glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
        glfw.window_hint(glfw.CONTEXT_VERSION_MAJOR, 3)
        glfw.window_hint(glfw.CONTEXT_VERSION_MINOR, 3)
        glfw.window_hint(glfw.OPENGL_PROFILE, glfw.OPENGL_CORE_PROFILE)
        glfw.window_hint(glfw.OPENGL_FORWARD_COMPAT, glfw.TRUE)
        self.window = glfw.create_window(int(size[0]), int(size[1]), "MoRF Studio", None, None)
        if not self.window:
            glfw.terminate()
            raise GLUnavailable("cannot open an OpenGL 3.3 window (is libEGL / a GL driver installed?)")
        glfw.make_context_current(self.window)
        if not headless:
            glfw.swap_interval(1)
        # Wrap the window's current context. Not moderngl.create_context(): once any standalone
        # context exists in the process (the live render's, a library stage's), it switches to
        # X11 detection, which fails on EGL windows.
        moderngl.init_context()
        self.ctx = moderngl.get_context()
        if self.ctx.version_code < 330:
            raise GLUnavailable(f"OpenGL 3.3 is needed, the window got {self.ctx.version_code}")
        self._gl_finish = gil_free_finish(self.ctx)  # the live render's threads run while it waits
        self._window_addr = ctypes.cast(self.window, ctypes.c_void_p).value

    def _init_imgui(self) -> None:
        imgui.create_context()
        implot.create_context()
        io = imgui.get_io()
        io.set_ini_filename(None)  # no imgui.ini: layouts never leak between runs (or tests)
        io.config_input_text_cursor_blink = False
        imgui.style_colors_dark()
        style = imgui.get_style()
        style.window_rounding = style.frame_rounding = style.tab_rounding = 2.0
        if FONT_PATH.is_file():
            io.fonts.add_font_from_file_ttf(str(FONT_PATH), FONT_SIZE)
        imgui.backends.glfw_init_for_opengl(self._window_addr, False)  # the app's callbacks feed it
        imgui.backends.opengl3_init("#version 330")
        # GLFW's null platform never reports the cursor entering the window; without this,
        # injected mouse positions are dropped.
        imgui.backends.glfw_cursor_enter_callback(self._window_addr, 1)

    def _init_input_callbacks(self) -> None:
        """The window's callbacks (:func:`studio.input_events.install_callbacks`): keys wait in
        :attr:`keys` for the next frame, dropped paths in ``_dropped``; each event asks for a frame."""
        def on_input(*_):
            self._inputs += 1
            self.pacer.input()

        self.keys = KeyQueue()
        self._dropped: list[str] = []  # paths dropped on the window, handled by the next full frame
        install_callbacks(self.window, self._window_addr, self.keys, on_input, self._dropped.extend)

    # ---- project ------------------------------------------------------------------------
    def open_project(self, path: str) -> bool:
        """Open a project folder; on failure the start screen shows why. True when it opened."""
        opened = self._open_view(path)
        self.send(OpenProject(str(self.view.root) if opened else None))
        return opened

    def start_pipeline(self, request: PipelineRequest) -> None:
        """Make (or continue) a project as 'morf run' does, in the worker; the project opens here
        as soon as its frames exist (see :meth:`_follow_worker`)."""
        if self.worker.latest().busy:
            self.state.note = f"'{self.worker.latest().stage}' is still running: stop it first"
            return
        self.state.project_error = None
        self.state.new_folder = request.root
        self.send(RunPipeline(request))

    def _open_view(self, path: str) -> bool:
        """The UI's side of opening a project (the worker is told by the caller, or opened it itself)."""
        self._close_project()
        self.state.open_path = path
        try:
            view = ProjectView.open(path)
        except MorfError as e:
            self.state.project_root, self.state.project_error = None, str(e)
            if not self.state.new_folder and not Path(path).exists():
                self.state.new_folder = path  # a new folder: the start screen offers to make it from a video
            return False
        self.view = view
        self.state.project_root, self.state.project_error = str(view.root), None
        self.state.frame, self.state.scroll_strip, self.state.note = 0, True, ""
        self.loader = ImageLoader({"frame": view.project.frame_path, "mask": view.project.mask_path,
                                   "fit": view.fit_overlay_path}, on_ready=self._wakeup.notify)
        self.textures = TextureCache(self.ctx, self.loader)
        if view.avatar_ready():
            self._open_live(view.project.avatar_dir)
        return True

    def _close_project(self) -> None:
        if self.loader is not None:
            self.loader.close()
        self._close_live()
        self.textures.release()
        self.view, self.loader = None, None

    # ---- live render --------------------------------------------------------------------
    def _open_live(self, avatar_dir: Path) -> None:
        opener = self._player_opener
        self.show_player(lambda: opener(avatar_dir))

    def show_player(self, player: PoseRenderer | Callable[[], tuple[PoseRenderer | None, str | None]]) -> None:
        """Play ``player`` in the live render panel, on the live render's own thread.

        ``player``: a player object, or a function () -> (player, note) that opens one; it is
        called on that thread, so the player's GL objects belong to that thread's context.
        """
        self._close_live()
        opener = player if callable(player) and not hasattr(player, "render") else (lambda: (player, None))
        self.live = LiveRenderer(opener, on_frame=self._wakeup.notify, pipelined=self._live_pipelined).start()

    def _close_live(self) -> None:
        if self.live is not None and not self.live.close(timeout=10.0):
            print("morf-studio: the live render did not stop within 10 s; leaving it behind", file=sys.stderr)
        self.live, self._live_seq = None, 0
        self.live_panel = LivePanelState()
        self._ui_cache.forget()

    # ---- the frame loop -----------------------------------------------------------------
    def send(self, command: Command) -> None:
        self.worker.send(command)

    def frame(self, capture: bool = False) -> np.ndarray | None:
        """Run one UI frame; with ``capture``, return the screen as (H, W, 3) uint8 RGB."""
        t0 = time.perf_counter()
        glfw.poll_events()
        self._inputs_at_full = self._inputs
        self.keys.feed(imgui.get_io())  # a chord's modifier release may wait a frame (studio.input_events)
        imgui.backends.opengl3_new_frame()
        imgui.backends.glfw_new_frame()
        io = imgui.get_io()
        if self._fixed_dt is not None:
            io.delta_time = self._fixed_dt
        elif self._last_frame_t is not None:  # light frames in between advanced the clock too
            io.delta_time = max(t0 - self._last_frame_t, 1e-6)
        self._last_frame_t = self._last_full_t = t0
        self.live_panel.image_rect = None  # the live panel sets it again when it draws the image whole
        imgui.new_frame()
        ui = self._ui_context()
        recovery = imgui.internal.ErrorRecoveryState()
        imgui.internal.error_recovery_store_state(recovery)
        try:
            self._handle_drops(ui)
            handle_keys(ui.actions)
            advance_playback(self.state, self.view, io.delta_time)
            draw_ui(self.state, ui)
        except Exception as e:  # a bug in one panel must not close the app with the user's work
            traceback.print_exc(file=sys.stderr)
            self.state.note = f"display error: {type(e).__name__}: {e}"
            io.config_error_recovery_enable_assert = False  # recover quietly, just this once
            io.config_error_recovery_enable_tooltip = False
            imgui.internal.error_recovery_try_to_recover_state(recovery)
            io.config_error_recovery_enable_assert = True
        imgui.render()
        fw, fh = glfw.get_framebuffer_size(self.window)
        self.ctx.screen.use()
        self.ctx.viewport = (0, 0, fw, fh)
        self.ctx.clear(*CLEAR_RGB)
        imgui.backends.opengl3_render_draw_data(imgui.get_draw_data())
        # Wait for the GL work of this frame. Without a GPU it is CPU work (llvmpipe): counting
        # it is honest, and not waiting lets frames queue up until some texture upload has to
        # wait for all of them at once (measured: 100-300 ms stalls during live playback).
        rect = self.live_panel.image_rect
        # the picture light frames start from; not while a text field has the keyboard: each key
        # brings a full frame anyway, and the copy made those frames a quarter slower (llvmpipe,
        # measured under load: p50 69 -> 52 ms a typed key)
        if self.light_frames and rect is not None and self.state.playing and not io.want_text_input:
            self._ui_cache.store((fw, fh), rect)
        else:
            self._ui_cache.forget()
        self._gl_finish()
        self.frame_times.append(time.perf_counter() - t0)
        shot = None
        if capture:  # read before swapping: the back buffer is undefined afterwards
            data = self.ctx.screen.read(viewport=(0, 0, fw, fh), components=3, alignment=1)
            shot = np.frombuffer(data, np.uint8).reshape(fh, fw, 3)[::-1].copy()
        glfw.swap_buffers(self.window)
        self._back_is_ui = False
        return shot

    def drop(self, paths: list[str]) -> None:
        """Paths dropped on the window (what GLFW's drop callback hands over); the next frame handles them."""
        self._dropped.extend(paths)
        self.pacer.input()

    def _handle_drops(self, ui: UiContext) -> None:
        """Dropped paths do the obvious thing (:mod:`studio.drops`): a video or a folder of frames
        fills the start screen's new project, a project opens, a .bvh / .npz plays in the live
        render, another folder becomes the motion folder. Videos and motions are told by name at
        once; folders are looked into on the drop thread and acted on when it answers."""
        paths, self._dropped = self._dropped, []
        for path in paths:
            kind = kind_by_name(path)
            if kind is not None and not self.drops.busy:
                self._apply_drop(path, kind, ui)
            else:
                self.drops.add(path)
        for path, kind in self.drops.take():
            self._apply_drop(path, kind, ui)

    def _apply_drop(self, path: str, kind: str, ui: UiContext) -> None:
        name = Path(path).name or path
        if kind == "motion":
            self.state.motion_file = path
            self.state.select_panel(LIVE_PANEL)
        elif kind in ("video", "frames"):
            if self.view is not None:
                if self.worker.latest().busy:
                    self.state.note = f"'{self.worker.latest().stage}' is running: stop it before starting a project from {name}"
                    return
                self._close_project()
                self.state.project_root = None
                self.send(OpenProject(None))
            self.state.new_source, self.state.new_folder = path, suggested_folder(path)
            self.state.note = f"new project from {name}: check its folder, then Make avatar"
        elif kind == "project":
            self.open_project(path)
        elif kind == "folder" and self.view is not None:
            commit_motion_dir(self.state, ui, path)
            self.state.select_panel(LIVE_PANEL)
        else:
            self.state.open_path = path if kind == "folder" else self.state.open_path
            self.state.note = (f"{name}: drop a video, a folder of frames, a capture project, or a motion file "
                               "(.bvh, .npz) once an avatar is exported")

    def _light_frame_ok(self) -> bool:
        """Only the live image would change: the live panel plays, whole on screen, no input since
        the last full frame, nothing new from the worker or the image loader, and that full frame
        is recent (its text stays true enough)."""
        if not self.light_frames or self.live is None or not self.live.ready or self.live.note:
            return False
        lp = self.live_panel
        if self.state.panel != LIVE_PANEL or not self.state.playing or lp.clip is None or lp.clip_loading is not None:
            return False
        if self._inputs != self._inputs_at_full or self.keys.pending or self.textures.backlog():
            return False
        if time.perf_counter() - self._last_full_t >= FULL_FRAME_INTERVAL_S:
            return False
        snap = self.worker.latest()
        if snap.review_rev != self._review_rev or snap.busy != self._was_busy:
            return False
        return self._ui_cache.ready(glfw.get_framebuffer_size(self.window))

    def _light_frame(self) -> bool:
        """Advance the motion, ask for its next frame, and show the newest live image over the
        cached UI (:mod:`studio.ui_cache`). False when a full frame is needed instead (input came)."""
        t0 = time.perf_counter()
        glfw.poll_events()
        if self._inputs != self._inputs_at_full:
            return False
        rect = self._ui_cache.rect
        post_live_request(self.state, self.live_panel, self.live, self._wakeup.notify, rect.render_side,
                          t0 - self._last_frame_t)
        frame = self.live.latest()
        if frame is None:
            return False
        if frame.seq == self._live_seq:  # on screen already: this wake-up only asked for the next pose
            self._last_frame_t = t0
            return True
        # A serial render thread rasterizes the next frame only now: let it do that first (its GL
        # work holds the GIL, ours would hold it off) and draw while its renderer runs. A pipelined
        # one rasterized the next frame while this one shaded: draw at once (measured: 40 fps
        # against 37-38 with the wait, docs/studio.md).
        if not self.live.pipelined:
            self.live.wait_rasterized(RASTER_WAIT_S)
            frame = self.live.latest()
        self._live_seq = frame.seq
        self.live_stats.append((frame.fps, frame.render_ms))
        if self._x_image is not None and round(rect.side) == rect.render_side == frame.image.shape[0]:
            self._x_image.present(frame.image, round(rect.x), round(rect.y))  # pixel for pixel, no GL
            self._light_frame_done(t0)
            return True
        image = self.textures.preview("live", frame.image, frame.seq, ring=3)
        if self._sub_buffer is not None and self._back_is_ui:
            self._ui_cache.draw_image(image)  # the rest of the back buffer is still the stored UI
        else:
            self._ui_cache.show(image)
        self._gl_finish()
        self._light_frame_done(t0)
        if self._sub_buffer is not None:
            self._sub_buffer.present(*self._ui_cache.image_viewport())
            self._back_is_ui = True
        else:
            glfw.swap_buffers(self.window)
        return True

    def _light_frame_done(self, t0: float) -> None:
        self._last_frame_t = t0
        self.light_frame_count += 1
        self.frame_times.append(time.perf_counter() - t0)

    def _follow_worker(self, snap) -> bool:
        """Open the project a pipeline run made (the Frames panel: review starts while the body is
        fitted); True when a pipeline stage ended since the last frame (its files are new)."""
        if snap.project_rev != self._project_rev:
            self._project_rev = snap.project_rev
            if snap.project and (self.view is None or Path(snap.project).resolve() != self.view.root.resolve()):
                if self._open_view(snap.project):
                    self.state.select_panel(0)
        ended = snap.stage_rev != self._stage_rev
        self._stage_rev = snap.stage_rev
        return ended

    def _play_made_avatar(self, snap) -> None:
        """A pipeline run finished its export: play the avatar in the live render panel."""
        if snap.chain_step is None or snap.state != "finished" or snap.stage != PIPELINE_STAGES[-1]:
            return
        if self.view is None or not self.view.avatar_ready():
            return
        from morf.motion.library import BUILTIN_MOTIONS

        self.state.motion_file = self.state.motion_file or str(BUILTIN_MOTIONS / DEFAULT_MOTION)
        self.state.select_panel(LIVE_PANEL)
        self.state.playing = True

    def _ui_context(self) -> UiContext:
        snap = self.worker.latest()
        busy_ended = self._was_busy and not snap.busy
        rev_ended = self._follow_worker(snap)
        stage_ended = busy_ended or rev_ended
        self._was_busy = snap.busy
        if snap.review_rev != self._review_rev or stage_ended:
            self._review_rev = snap.review_rev
            if self.view is not None:
                try:
                    self.view.refresh() if stage_ended else self.view.reload_decisions()
                except MorfError as e:
                    self.state.note = str(e)
                # a finished export may have replaced the avatar: play the new one (a pipeline run's
                # export ends twice: its step, then the run)
                new_export = snap.stage == "export" and (rev_ended or snap.chain_step is None)
                if stage_ended and self.view.avatar_ready() and (self.live is None or new_export):
                    self._open_live(self.view.project.avatar_dir)
                if busy_ended:
                    self._play_made_avatar(snap)
        self.textures.pump()
        frame = self.live.latest() if self.live is not None else None
        if frame is not None and frame.seq != self._live_seq:
            self._live_seq = frame.seq
            self.live_stats.append((frame.fps, frame.render_ms))
        return UiContext(view=self.view, textures=self.textures, snapshot=snap, send=self.send,
                         stages=self._stage_status, stage_labels=self._stage_labels, actions=self._actions,
                         open_project=self.open_project, start_pipeline=self.start_pipeline, live_render=self.live,
                         stage_presets=self._stages.presets,
                         default_presets=self._stages.default_presets, stage_errors=self._stages.errors,
                         frame_ms=1000 * self.frame_times[-1] if self.frame_times else 0.0, live=self.live_panel,
                         redraw_within=self._wakeup.notify, motions=self.motions)

    def run(self, max_frames: int | None = None, pace_hz: float | None = None, capture_last: bool = False,
            seconds: float | None = None) -> np.ndarray | None:
        """Loop until the window closes, ``max_frames`` ran or ``seconds`` passed.

        With ``max_frames`` every iteration draws (``pace_hz`` sleeps like vsync would): a fixed
        number of frames, as scripted screenshots want. Otherwise frames are drawn when
        :attr:`pacer` says so, and the loop sleeps in between.
        """
        if max_frames is not None:
            n, shot = 0, None
            while not glfw.window_should_close(self.window) and n < max_frames:
                start = time.perf_counter()
                last = n == max_frames - 1
                shot = self.frame(capture=capture_last and last)
                n += 1
                if pace_hz:
                    time.sleep(max(0.0, 1.0 / pace_hz - (time.perf_counter() - start)))
            return shot
        end = time.perf_counter() + seconds if seconds is not None else None
        while not glfw.window_should_close(self.window):
            within = self._wakeup.take()
            if within is not None:
                self.pacer.want_within(within)
            wait = self.pacer.wait_s()
            if end is not None:
                left = end - time.perf_counter()
                if left <= 0:
                    break
                wait = min(wait, left)
            if wait > 0:
                if self._headless:  # GLFW's null platform has no event queue to wait on
                    self._wakeup.wait(wait)
                else:  # input callbacks (and posted empty events) end this early
                    glfw.wait_events_timeout(wait)
                continue
            self.pacer.frame_started()
            if not (self._light_frame_ok() and self._light_frame()):
                self.frame()
            self._schedule_animation()
        return None

    def _schedule_animation(self) -> None:
        """Ask for the frames that time itself brings: frame playback, uploads left for later."""
        if self.textures.backlog() or self.keys.pending:
            self.pacer.want_within(0.0)
        v = self.view
        if self.state.playing and v is not None and v.num_frames and self.state.panel != LIVE_PANEL:
            period = 1.0 / (v.project.fps or 10.0)
            self.pacer.want_within(max(0.0, period - self.state.play_clock))

    def request_close(self) -> None:
        """End :meth:`run` (from any thread), as the window's close button does."""
        glfw.set_window_should_close(self.window, True)
        self._wakeup.notify()

    def settle(self, max_frames: int = 300, timeout_s: float = 20.0) -> None:
        """Run frames until decoded images are uploaded, the worker applied every command and every
        dropped path was acted on (a folder is looked into on the drop thread)."""
        end = time.monotonic() + timeout_s
        for _ in range(max_frames):
            self.frame()
            if self.textures.settled() and self.worker.pending() == 0 and \
                    self.worker.latest().review_rev == self._review_rev and (self.live is None or self.live.idle()) \
                    and self.motions.scanning is None and not self._dropped and not self.drops.busy:
                break
            if time.monotonic() > end:
                break
            time.sleep(0.005)  # let the loader / worker threads run
        for _ in range(2):  # auto-sized windows take a frame to measure themselves
            self.frame()

    # ---- injected input (tests, scripted screenshots) --------------------------------------
    def press(self, key: imgui.Key, mods: tuple[imgui.Key, ...] = ()) -> None:
        """Press and release ``key`` over two frames."""
        io = imgui.get_io()
        for m in mods:
            io.add_key_event(m, True)
        io.add_key_event(key, True)
        self.frame()
        io.add_key_event(key, False)
        for m in mods:
            io.add_key_event(m, False)
        self.frame()

    def move_mouse(self, x: float, y: float) -> None:
        imgui.get_io().add_mouse_pos_event(float(x), float(y))
        self.frame()

    def click(self, x: float, y: float, button: int = 0) -> None:
        io = imgui.get_io()
        io.add_mouse_pos_event(float(x), float(y))
        self.frame()
        io.add_mouse_button_event(button, True)
        self.frame()
        io.add_mouse_button_event(button, False)
        self.frame()

    def click_item(self, name: str, button: int = 0) -> None:
        """Click the centre of a named control as drawn last frame (see ``AppState.item_rects``)."""
        for _ in range(2):  # a just-opened popup measures and places itself over two frames
            self.frame()
        if name not in self.state.item_rects:
            raise KeyError(f"no control named {name!r} was drawn; known: {sorted(self.state.item_rects)}")
        x0, y0, x1, y1 = self.state.item_rects[name]
        self.click((x0 + x1) / 2, (y0 + y1) / 2, button)

    def type_text(self, text: str) -> None:
        imgui.get_io().add_input_characters_utf8(text)
        self.frame()

    def key_event(self, key: int, action: int) -> None:
        """A GLFW key event (``glfw.KEY_*``, ``glfw.PRESS`` / ``RELEASE``) as the window reports
        one: queued for the next full frame. Call it on the UI thread, between frames."""
        self.keys.key(key, 0, action)
        self._inputs += 1
        self.pacer.input()

    def char_event(self, char: str) -> None:
        """A typed character as the window reports one (see :meth:`key_event`)."""
        self.keys.char(ord(char))
        self._inputs += 1
        self.pacer.input()

    # ---- shutting down ------------------------------------------------------------------
    def close(self) -> None:
        """Stop the worker (and any running stage), free GL objects, close the window."""
        if self._closed:
            return
        self._closed = True
        self._wakeup.disconnect()  # threads still finishing must not post to a destroyed window
        stopped = self.worker.close(timeout=15.0)
        if not stopped:
            print("morf-studio: the running stage did not stop within 15 s; leaving it behind", file=sys.stderr)
        self._close_project()
        self.motions.close()
        self.drops.close()
        shutdown_motion_loader()
        self._ui_cache.release()
        if self._x_image is not None:
            self._x_image.close()
        imgui.backends.opengl3_shutdown()
        imgui.backends.glfw_shutdown()
        implot.destroy_context()
        imgui.destroy_context()
        self.ctx.release()
        glfw.destroy_window(self.window)
        glfw.terminate()

    def __enter__(self) -> "StudioApp":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# ---- command line (studio/cli.py) ------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return run_cli(args, StudioApp)
    except MorfError as e:
        if os.environ.get("MORF_DEBUG"):
            raise
        print(f"morf-studio: error: {e}", file=sys.stderr)
        return e.exit_code
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
