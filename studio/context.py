"""What the panels get besides :class:`AppState`: the open project, textures, the worker's newest snapshot."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

from studio.commands import Command
from studio.project_view import ProjectView
from studio.snapshot import Snapshot
from studio.state import LivePanelState
from studio.textures import TextureCache


@dataclass
class UiContext:
    """Rebuilt by the app each frame (cheap: references only)."""

    view: ProjectView | None  # the open project, None on the start screen
    textures: TextureCache
    snapshot: Snapshot  # the worker's newest snapshot
    send: Callable[[Command], None]  # to the worker's command queue
    stages: dict[str, str | None]  # stage name -> None when available, else why not
    stage_labels: dict[str, str]  # stage name -> button text
    actions: dict[str, Callable[[], None]]  # keyboard actions (buttons reuse them)
    open_project: Callable[[str], bool]  # the start screen's "Open"
    start_pipeline: Callable[[Any], None] = lambda request: None  # "Make avatar": a studio.pipeline_run.PipelineRequest
    live_render: Any = None  # studio.live_render.LiveRenderer, when an avatar was exported
    player_note: str | None = None  # why there is no player
    stage_presets: dict[str, tuple[str, ...]] = field(default_factory=dict)  # stage -> its config presets
    default_presets: dict[str, str] = field(default_factory=dict)  # stage -> preset used when none is chosen
    stage_errors: dict[str, str] = field(default_factory=dict)  # stage -> why its library code failed to load
    frame_ms: float = 0.0  # the UI's own recent frame time
    live: LivePanelState = field(default_factory=LivePanelState)  # the live render panel's loaded clip
    motions: Any = None  # studio.motion_browser.MotionBrowser: the motion folder's listing, off the UI thread
    redraw_within: Callable[[float], None] = lambda seconds: None  # want a frame within this many seconds (any thread)
