"""Start screen: open a capture project, or make a new one from a video (or a folder of frames).

"Make avatar" runs ingest, fit, train and export in the worker as 'morf run' does; the project
opens in the Frames panel as soon as its frames exist. A video or a folder dropped on the window
fills the form (studio.drops).
"""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui

from studio.context import UiContext
from studio.pipeline_run import PipelineRequest
from studio.state import AppState
from studio.widgets import GREY, RED, remember_item, run_buttons

WIDTH = 640
LABEL_W = 110  # the form's labels
SIZE_W = 90  # the training size picker


def draw(state: AppState, ui: UiContext) -> None:
    avail = imgui.get_content_region_avail()
    imgui.dummy(ImVec2(0, avail.y * 0.12))
    x0 = imgui.get_cursor_pos_x() + max((avail.x - WIDTH) / 2, 0)
    imgui.set_cursor_pos_x(x0)
    imgui.begin_group()
    imgui.text("MoRF Studio")
    imgui.text_colored(GREY, "Full-body neural avatars from a video of a person turning in place.")
    imgui.dummy(ImVec2(0, 12))
    _open_form(state, ui, x0)
    imgui.dummy(ImVec2(0, 20))
    _new_form(state, ui, x0)
    imgui.dummy(ImVec2(0, 12))
    imgui.push_text_wrap_pos(x0 + WIDTH)
    imgui.text_colored(GREY, "Drop a video, a folder of frames or a project on this window. From a terminal: "
                             "'morf-studio NEWFOLDER --video FILE' does the same, 'morf run PROJECT --video FILE' "
                             "without the window; 'morf synth PROJECT' makes a synthetic capture. Press H for the keys.")
    imgui.pop_text_wrap_pos()
    imgui.end_group()


def _open_form(state: AppState, ui: UiContext, x0: float) -> None:
    imgui.text("Open a capture project folder:")
    imgui.set_next_item_width(WIDTH - 90)
    entered, state.open_path = imgui.input_text("##project_path", state.open_path,
                                                imgui.InputTextFlags_.enter_returns_true)
    remember_item(state.item_rects, "open_path")
    imgui.same_line()
    if (imgui.button("Open", ImVec2(80, 0)) or entered) and state.open_path.strip():
        ui.open_project(state.open_path.strip())
    if state.project_error:
        imgui.dummy(ImVec2(0, 4))
        imgui.push_text_wrap_pos(x0 + WIDTH)
        imgui.text_colored(RED, f"Cannot open this project: {state.project_error}")
        if state.new_folder and state.new_folder == state.open_path:
            imgui.text_colored(GREY, "To make it: choose a video below (or drop one on this window), then Make avatar.")
        imgui.pop_text_wrap_pos()


def _new_form(state: AppState, ui: UiContext, x0: float) -> None:
    """Video (or frames folder), project folder, training size, and Make avatar; while the
    worker ingests (before the project can open), its progress with Pause and Stop."""
    snap = ui.snapshot
    imgui.text("Make an avatar from a video (or a folder of frames):")
    _field("Video", "##new_source", state, "new_source")
    _field("New folder", "##new_folder", state, "new_folder")
    presets = ui.stage_presets.get("train", ())
    if presets:
        options = (*presets, "auto")
        chosen = state.new_preset or ui.default_presets.get("train") or options[0]
        imgui.align_text_to_frame_padding()
        imgui.text("Training size")
        imgui.same_line(LABEL_W)
        imgui.set_next_item_width(SIZE_W)
        if imgui.begin_combo("##new_preset", chosen):
            for option in options:
                if imgui.selectable(option, option == chosen)[0]:
                    state.new_preset = option
            imgui.end_combo()
        imgui.same_line()
        imgui.text_colored(GREY, "tiny: a test in seconds; cpu: the real thing on a CPU (hours)")
    ready = bool(state.new_source.strip() and state.new_folder.strip())
    imgui.begin_disabled(not ready or snap.busy)
    if imgui.button("Make avatar", ImVec2(120, 0)):
        ui.start_pipeline(PipelineRequest(state.new_folder.strip(), state.new_source.strip(), preset=state.new_preset))
    remember_item(state.item_rects, "make_avatar")
    imgui.end_disabled()
    imgui.same_line()
    imgui.text_colored(GREY, "ingest, fit, train, export; the frames open as soon as they are read")
    if snap.stage is not None and snap.chain_step is not None and (snap.busy or snap.error):
        _progress(ui, x0)


def _field(label: str, widget: str, state: AppState, attr: str) -> None:
    imgui.align_text_to_frame_padding()
    imgui.text(label)
    imgui.same_line(LABEL_W)
    imgui.set_next_item_width(WIDTH - LABEL_W)
    _, text = imgui.input_text(widget, getattr(state, attr))
    setattr(state, attr, text)
    remember_item(state.item_rects, attr)


def _progress(ui: UiContext, x0: float) -> None:
    snap = ui.snapshot
    p = snap.progress
    i, n = snap.chain_step
    frac = p.step / p.total if p is not None and p.total else 0.0
    label = f"{snap.stage} ({i} of {n}): " + (p.message if p is not None and p.message else snap.state)
    imgui.progress_bar(min(max(frac, 0.0), 1.0), ImVec2(WIDTH - 150, 0), label)
    if snap.busy:
        imgui.same_line()
        run_buttons(ui)
    if snap.error:
        imgui.push_text_wrap_pos(x0 + WIDTH)
        imgui.text_colored(RED, snap.error)
        imgui.pop_text_wrap_pos()
