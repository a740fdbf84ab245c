"""UI state of the studio: what the user is looking at (:class:`AppState`) and what the live render
panel has loaded for it (:class:`LivePanelState`). No models, no GL objects, no threads."""

from __future__ import annotations

from concurrent.futures import Future
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from studio.orbit import OrbitCamera

if TYPE_CHECKING:
    import numpy as np

    from morf.motion.clip import MotionClip

PANELS = ("Frames", "Filtered frames", "Warp field", "Training", "Live render")


@dataclass
class AppState:
    """Everything the panels read and change from one frame to the next."""

    project_root: str | None = None  # the open project's folder, None on the start screen
    project_error: str | None = None  # why the last open failed (shown on the start screen)
    open_path: str = ""  # the start screen's path field
    new_source: str = ""  # the start screen's new project: a video file or a folder of frames ...
    new_folder: str = ""  # ... the project folder it makes ...
    new_preset: str | None = None  # ... and the training size (None: the one 'morf run' picks)
    panel: int = 0  # index into PANELS
    panel_request: int | None = None  # a panel chosen by key; the tab bar selects it next frame
    frame: int = 0  # the current frame index
    scroll_strip: bool = True  # bring the current frame's thumbnail into view
    show_keypoints: bool = True
    show_mask: bool = True
    show_fit: bool = True
    show_help: bool = False
    playing: bool = False  # frames advance at the capture's fps (Space)
    play_clock: float = 0.0  # seconds accumulated towards the next frame while playing
    note: str = ""  # the UI's own last event in words ("frame 3 dropped")
    motion_dir: str = ""  # folder the motion picker lists (committed: Enter, a drop, a recent folder)
    motion_dir_field: str | None = None  # the motion folder field's text while edited (None: motion_dir)
    motion_file: str | None = None  # chosen .bvh / .npz motion
    motion_time: float = 0.0  # seconds into the chosen motion (advances while playing)
    stage_presets: dict[str, str] = field(default_factory=dict)  # stage -> preset chosen in the Training panel
    stage_options: dict[str, dict] = field(default_factory=dict)  # stage -> config overrides sent with it
    orbit: OrbitCamera = field(default_factory=OrbitCamera)
    item_rects: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)  # named controls as last drawn

    def select_panel(self, index: int) -> None:
        self.panel_request = index % len(PANELS)


@dataclass(frozen=True)
class ImageRect:
    """Where the live panel drew its image in a full UI frame, in window pixels (top left origin,
    as imgui places it): ``x``, ``y``, ``side``; ``render_side``: the side it asked the player for."""

    x: float
    y: float
    side: float
    render_side: int


@dataclass
class LivePanelState:
    """The live render panel's scratch for the open avatar: the loaded clip (the motion list is the
    app's :class:`studio.motion_browser.MotionBrowser`).

    The app owns one and starts a fresh one when the avatar closes; only the panel changes it (the
    app clears ``image_rect`` before each full UI frame).
    """

    clip_path: str | None = None  # the motion file ``clip`` is (being) loaded from
    clip: MotionClip | None = None  # the loaded motion, None while loading or when it failed
    clip_note: str | None = None  # why the motion could not be loaded
    clip_loading: Future | None = None  # the background load, until the panel picks its result up
    clip_centre: np.ndarray | None = None  # (3,) mean root position of the clip: its height is the orbit's
    # where the last full UI frame drew the live image when it was whole on screen, else None
    image_rect: ImageRect | None = None
