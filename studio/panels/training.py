"""Training: start stages, pause / resume / stop, progress, time per step, ETA and loss curves."""

from __future__ import annotations

from imgui_bundle import ImVec2, imgui, implot

from studio.commands import StartStage
from studio.context import UiContext
from studio.pipeline_run import PipelineRequest
from studio.snapshot import STATE_WORDS
from studio.state import AppState
from studio.widgets import GREY, RED, fit_size, hms, remember_item, run_buttons, tex_ref

PREVIEW_H = 150
PRESET_W = 80  # width of a stage's preset picker


def draw(state: AppState, ui: UiContext) -> None:
    snap = ui.snapshot
    _stage_buttons(state, ui)
    imgui.separator()
    if snap.stage is None:
        _on_disk(state, ui)
        return
    step = f" ({snap.chain_step[0]} of {snap.chain_step[1]})" if snap.chain_step else ""
    imgui.text(f"{snap.stage}{step}: {STATE_WORDS.get(snap.state, snap.state)}")
    p = snap.progress
    if p is not None and p.message:
        imgui.same_line()
        imgui.text_colored(GREY, f"- {p.message}")
    if p is not None:
        frac = p.step / p.total if p.total else 0.0
        label = f"step {p.step} / {p.total}" if p.total else f"step {p.step}"
        imgui.progress_bar(min(max(frac, 0.0), 1.0), ImVec2(-1, 0), label)
    sps = snap.seconds_per_step
    imgui.text(f"time per step: {sps:.3f} s" if sps is not None else "time per step: --")
    imgui.same_line(spacing=30)
    imgui.text(f"elapsed: {hms(snap.elapsed_s)}")
    imgui.same_line(spacing=30)
    imgui.text(f"ETA: {hms(snap.eta_s)}")
    if snap.error:
        imgui.text_colored(RED, snap.error)
    if p is not None and p.losses:
        imgui.text("latest: " + "   ".join(f"{k} {v:.4g}" for k, v in p.losses.items()))
    avail = imgui.get_content_region_avail()
    has_previews = p is not None and bool(p.images)
    plot_h = max(avail.y - (PREVIEW_H + 30 if has_previews else 0), 120)
    _loss_plot(snap, plot_h)
    if has_previews:
        for k, (name, img) in enumerate(p.images.items()):
            tex = ui.textures.preview(f"train:{name}", img, snap.seq)
            w, h = fit_size(tex.width, tex.height, 3 * PREVIEW_H, PREVIEW_H)
            if k:
                imgui.same_line()
            imgui.begin_group()
            imgui.image(tex_ref(tex), ImVec2(w, h))
            imgui.text_colored(GREY, name)
            imgui.end_group()


def _on_disk(state: AppState, ui: UiContext) -> None:
    """Before anything ran in this session: what the project already holds (fits, runs)."""
    view = ui.view
    if view is None or not view.residuals:
        imgui.text_colored(GREY, "Nothing has run in this session. Fit the body first, then train the avatar.")
        return
    imgui.text_colored(GREY, f"Nothing has run in this session. Body fits: {len(view.residuals)} of "
                             f"{view.num_frames} frames.")
    if not view.runs:
        imgui.text_colored(GREY, "No training runs yet: train the avatar.")
        return
    imgui.text(f"Training runs in {view.name}/runs ({len(view.runs)}, newest first)")
    flags = imgui.TableFlags_.row_bg | imgui.TableFlags_.borders_inner_h | imgui.TableFlags_.sizing_fixed_fit
    if imgui.begin_table("runs", 5, flags):
        for head in ("run", "method", "preset", "status", "held-out person PSNR"):
            imgui.table_setup_column(head)
        imgui.table_headers_row()
        for run in view.runs:
            imgui.table_next_row()
            cells = (run.name, run.method, run.preset, run.status,
                     "--" if run.holdout_psnr is None else f"{run.holdout_psnr:.2f} dB")
            for k, text in enumerate(cells):
                imgui.table_set_column_index(k)
                imgui.text(text)
        imgui.end_table()
    remember_item(state.item_rects, "runs-table")
    imgui.text_colored(GREY, "Scores come from PROJECT/eval/eval.json ('morf eval PROJECT').")


def chosen_preset(state: AppState, ui: UiContext, stage: str) -> str | None:
    """The preset the stage runs with: the user's choice, else the stage's default (the one the CLI
    picks, ``morf.presets.default_preset``), else the first."""
    presets = ui.stage_presets.get(stage, ())
    if not presets:
        return None
    choice = state.stage_presets.get(stage) or ui.default_presets.get(stage)
    return choice if choice in presets else presets[0]


def _stage_buttons(state: AppState, ui: UiContext) -> None:
    snap = ui.snapshot
    for k, (name, why) in enumerate(ui.stages.items()):
        if k:
            imgui.same_line(spacing=16 if ui.stage_presets.get(name) else -1)
        imgui.begin_disabled(why is not None or snap.busy or ui.view is None)
        preset = chosen_preset(state, ui, name)
        if imgui.button(ui.stage_labels.get(name, name)):
            options = {"preset": preset} if preset else {}
            ui.send(StartStage(name, {**options, **state.stage_options.get(name, {})}))
        remember_item(state.item_rects, f"stage:{name}")
        hovered = imgui.is_item_hovered(imgui.HoveredFlags_.allow_when_disabled)
        if preset is not None:
            imgui.same_line(spacing=2)
            imgui.set_next_item_width(PRESET_W)
            opened = imgui.begin_combo(f"##preset_{name}", preset)
            if not opened:  # once open, the last item is inside the popup
                remember_item(state.item_rects, f"preset:{name}")
                if imgui.is_item_hovered():
                    imgui.set_tooltip(f"{ui.stage_labels.get(name, name)}: configuration preset")
            else:
                for option in ui.stage_presets[name]:
                    if imgui.selectable(option, option == preset)[0]:
                        state.stage_presets[name] = option
                    remember_item(state.item_rects, f"preset:{name}:{option}")
                imgui.end_combo()
        imgui.end_disabled()
        if why is not None and hovered:
            imgui.set_tooltip(why)
    imgui.same_line(spacing=16)
    _make_avatar_button(state, ui)
    imgui.same_line(spacing=30)
    imgui.begin_disabled(not snap.busy)
    run_buttons(ui)
    remember_item(state.item_rects, "stop")
    imgui.end_disabled()
    for name, why in ui.stages.items():
        label = ui.stage_labels.get(name, name)
        if name in ui.stage_errors:
            imgui.text_colored(RED, f"{label} cannot be loaded: {ui.stage_errors[name]}")
            remember_item(state.item_rects, f"stage-error:{name}")
        elif why:
            imgui.text_colored(GREY, f"{label}: not available ({why})")


def _make_avatar_button(state: AppState, ui: UiContext) -> None:
    """Every stage still to do, as 'morf run PROJECT' does it: done ones skipped, a stopped one resumed."""
    imgui.begin_disabled(ui.snapshot.busy or ui.view is None or bool(ui.stage_errors))
    if imgui.button("Make avatar") and ui.view is not None:
        preset = state.stage_presets.get("train")
        ui.start_pipeline(PipelineRequest(str(ui.view.root), preset=preset))
    remember_item(state.item_rects, "make_avatar")
    hovered = imgui.is_item_hovered(imgui.HoveredFlags_.allow_when_disabled)
    imgui.end_disabled()
    if hovered:
        imgui.set_tooltip("fit, train and export what is not done yet (finished stages are skipped, a stopped one "
                          "resumes), as 'morf run PROJECT' does")


def _loss_plot(snap, height: float) -> None:
    if not snap.curves:
        imgui.text_colored(GREY, "no losses reported yet")
        return
    if implot.begin_plot("losses", ImVec2(-1, height)):
        implot.setup_axes("step", "loss", implot.AxisFlags_.auto_fit, implot.AxisFlags_.auto_fit)
        implot.setup_axis_scale(implot.ImAxis_.y1, implot.Scale_.log10)
        for name, curve in snap.curves.items():
            if len(curve.steps):
                implot.plot_line(name, curve.steps, curve.values)
        implot.end_plot()
