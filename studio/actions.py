"""What keys and buttons do: small functions over the UI state, the open project and the worker."""

from __future__ import annotations

from typing import Callable

from studio.commands import Command, DropFrame, RestoreFrame
from studio.project_view import ProjectView
from studio.state import PANELS, AppState


def make_actions(state: AppState, view: Callable[[], ProjectView | None],
                 send: Callable[[Command], None]) -> dict[str, Callable[[], None]]:
    """Action name (see studio.keys.BINDINGS) -> function. ``view`` gives the open project now."""

    def go(delta: int) -> None:
        v = view()
        if v is not None and v.num_frames:
            state.frame = (state.frame + delta) % v.num_frames
            state.scroll_strip = True

    def next_flagged() -> None:
        v = view()
        if v is None:
            return
        j = v.next_flagged(state.frame)
        if j is None:
            state.note = "no flagged frames"
        else:
            state.frame, state.scroll_strip, state.note = j, True, f"frame {j}: {v.decisions[j].reason}"

    def review(cmd: type) -> Callable[[], None]:
        def run() -> None:
            if view() is not None:
                send(cmd(state.frame))
                state.note = ""  # the worker's message says what happened

        return run

    def toggle(attr: str) -> Callable[[], None]:
        return lambda: setattr(state, attr, not getattr(state, attr))

    def play_pause() -> None:
        state.playing = not state.playing
        state.play_clock = 0.0

    actions = {
        "next_frame": lambda: go(+1),
        "prev_frame": lambda: go(-1),
        "next_flagged": next_flagged,
        "drop_frame": review(DropFrame),
        "restore_frame": review(RestoreFrame),
        "play_pause": play_pause,
        "toggle_keypoints": toggle("show_keypoints"),
        "toggle_mask": toggle("show_mask"),
        "toggle_fit": toggle("show_fit"),
        "next_panel": lambda: state.select_panel(state.panel + 1),
        "toggle_help": toggle("show_help"),
        "close_help": lambda: setattr(state, "show_help", False),
    }
    for k in range(len(PANELS)):
        actions[f"panel_{k}"] = (lambda k=k: state.select_panel(k))
    return actions


def advance_playback(state: AppState, v: ProjectView | None, dt: float) -> None:
    """While playing, step frames at the capture's frame rate (10 fps when unknown)."""
    if not state.playing or v is None or not v.num_frames:
        return
    period = 1.0 / (v.project.fps or 10.0)
    state.play_clock += dt
    while state.play_clock >= period:
        state.play_clock -= period
        state.frame = (state.frame + 1) % v.num_frames
        state.scroll_strip = True
