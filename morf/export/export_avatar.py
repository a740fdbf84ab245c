"""Build an exported avatar folder from a trained avatar (needs torch; the result does not).

Steps: quantise the baked neural texture, shape the render mesh and skeleton, rasterize the
capture's own views with the same GL pipeline the player uses (so int8 calibration sees exactly
the bytes it will see live; with ``playback_zoom`` also as close as the player draws them,
``calibration_views.py``), write the fp32 and int8 renderers, measure what int8 costs on views
held out of calibration, and write the manifest. The folder is built beside the target and moved
into place at the end, so a failed export leaves the previous avatar intact.
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from morf.avatar.view_colour import quantize_view_colours
from morf.export.avatar_folder import (MANIFEST, RENDERERS, VIEW_COLOURS_FILE, replace_folder, write_arrays,
                                       write_manifest, write_view_colours)
from morf.export.calibration_views import closer_scales, mosaic, zoomed_camera
from morf.export.onnx_renderer import OPSET, export_fp32, export_int8
from morf.export.skeleton import SkinningSkeleton, skeleton_from_body_model
from morf.io.outputs import OutputClaim, staged_folder
from morf.pipeline.control import Progress, StageControl
from morf.raster.gl_context import create_headless_context
from morf.raster.neural_raster import COVERAGE_CHANNEL, NUM_CHANNELS, NeuralRasterizer, SkinnedMesh, to_layout
from morf.raster.texture_quant import ZERO_POINT, QuantizedTexture, quantize_texture


@dataclass(frozen=True)
class View:
    """One body pose seen by one camera.

    Fields:
        rotvecs: (J, 3) axis-angle pose; transl: (3,) root translation; camera: PinholeCamera.
    """

    rotvecs: np.ndarray
    transl: np.ndarray
    camera: object


@dataclass(frozen=True)
class ExportConfig:
    """Choices of the exporter."""

    input_layout: str = "nhwc"  # see morf.raster.neural_raster.LAYOUTS; nhwc is the GL read-back as it is
    max_calibration_views: int = 32  # int8 calibration rasterizations (more: slower export, same ranges)
    max_heldout_views: int = 8  # views for the int8-vs-fp32 quality report
    # The same poses seen this many times closer, the player's largest scale (calibration_views.py):
    # int8 is calibrated and checked on them too. 0: the given views only.
    playback_zoom: float = 0.0
    max_playback_views: int = 16  # calibration views at the player's scale (half as many halfway there)
    extra: dict = field(default_factory=dict)  # free-form facts copied into the manifest


def skinned_mesh_from_body_model(model, shape, offsets: np.ndarray | None = None) -> SkinnedMesh:
    """The shaped render mesh of a body model (seams split, top-8 bones); with clothing
    ``offsets`` (V,) its rest vertices are the dressed ones the avatar trained on
    (:func:`morf.fitting.offsets.dressed_rest_vertices`), so every player skins the dressed body."""
    from morf.body.render_mesh import render_mesh_for
    from morf.fitting.offsets import dressed_rest_vertices

    rm = render_mesh_for(model)
    rest = dressed_rest_vertices(model, shape, offsets)[0].float().cpu().numpy()
    return SkinnedMesh(rest_vertices=np.ascontiguousarray(rest[rm.vertex_map], np.float32), uvs=rm.uvs,
                       faces=rm.faces, bone_indices=rm.bone_indices, bone_weights=rm.bone_weights)


def rasterize_views(ctx, mesh: SkinnedMesh, texture: QuantizedTexture, skeleton: SkinningSkeleton,
                    views: Sequence[View]) -> list[np.ndarray]:
    """uint8 (1, 16, H, W) neural rasterizations of ``views`` (all cameras of one size)."""
    if not views:
        return []
    cam = views[0].camera
    nr = NeuralRasterizer(ctx, mesh, texture, cam.width, cam.height, skeleton.num_bones)
    try:
        out = []
        for v in views:
            nr.draw(skeleton.bone_transforms(v.rotvecs, v.transl), v.camera)
            out.append(to_layout(nr.read(), "nchw"))
        return out
    finally:
        nr.release()


def _closer(views: Sequence[View], zoom: float) -> list[View]:
    return [dataclasses.replace(v, camera=zoomed_camera(v.camera, zoom)) for v in views]


def nchw_to_layout(raster: np.ndarray, layout: str) -> np.ndarray:
    """(1, 16, H, W) uint8 -> the renderer's input layout."""
    if layout == "nchw":
        return raster
    return to_layout(np.ascontiguousarray(raster[0].transpose(1, 2, 0)), layout).copy()


def int8_quality(fp32_path: Path, int8_path: Path, rasters: Sequence[np.ndarray], layout: str = "nchw") -> dict:
    """PSNR / SSIM of the int8 renderer against fp32 on ``rasters`` (RGB premultiplied, i.e. on black)."""
    import onnxruntime as ort
    import torch

    from morf.avatar.metrics import psnr, ssim

    opts = ort.SessionOptions()
    opts.intra_op_num_threads = 2
    s32, s8 = (ort.InferenceSession(str(p), opts, providers=["CPUExecutionProvider"]) for p in (fp32_path, int8_path))
    ps, ss, ps_person = [], [], []
    for r in rasters:
        r = nchw_to_layout(r, layout)
        feed = {"raster": r, "background": np.zeros((1, 3, 1, 1), np.float32)}
        a = torch.from_numpy(s32.run(["rgba"], feed)[0])
        b = torch.from_numpy(s8.run(["rgba"], feed)[0])
        ps.append(psnr(b[:, :3], a[:, :3]))
        ss.append(ssim(b[:, :3], a[:, :3]))
        ps_person.append(psnr(b[:, :3], a[:, :3], mask=a[:, 3] > 0.5))
    return {"views": len(rasters), "psnr_db": float(np.mean(ps)), "ssim": float(np.mean(ss)),
            "psnr_person_db": float(np.mean(ps_person))}


def native_tails(folder: Path, specs: dict, layout: str, rasters: Sequence[np.ndarray]) -> dict:
    """The player's compiled full-resolution tail for each graph in ``folder`` whose exporter
    wrote one (``specs``: precision -> :class:`~morf.export.compiled_tail.TailSpec` or None) and
    whose pass agrees with the whole graph (:mod:`morf.export.native_tail_spec`)."""
    from morf.export.native_tail_spec import native_tail_entry

    views = [nchw_to_layout(r, layout) for r in rasters]
    entries = {p: native_tail_entry(folder / name, specs.get(p), views) for p, name in RENDERERS.items()}
    return {p: e for p, e in entries.items() if e is not None}


def export_avatar(out_dir: str | Path, *, texture, renderer, body_model, shape, calibration: Sequence[View],
                  heldout: Sequence[View], cfg: ExportConfig = ExportConfig(), ctx=None,
                  control: StageControl | None = None, claim: OutputClaim | None = None,
                  offsets: np.ndarray | None = None, view_colours=None) -> dict:
    """Write an avatar folder; returns its manifest.

    Args:
        texture: (16, Ht, Wt) baked neural texture (torch or numpy), row 0 = atlas top.
        renderer: the torch renderer, (1, 16, H, W) -> (1, 4, H, W) premultiplied RGB + mask logit.
        body_model, shape: the body model and the avatar's (1, 6) shape.
        calibration: views whose rasterizations calibrate int8 (the capture's training views).
        heldout: views kept out of calibration for the quality report (may be empty).
        claim: what :func:`morf.io.outputs.claim_output_folder` allowed at ``out_dir`` (None: the
            caller owns ``out_dir`` whole, e.g. a benchmark's work folder).
        offsets: (V,) clothing offsets the avatar trained with (None: the naked body); mesh.npz
            then stores the dressed rest vertices and the manifest's ``body`` says so.
        view_colours: the trained avatar's :class:`~morf.avatar.view_colour.ViewColours` (None:
            none), written as view_colours.npz in the texture's bytes.
    """
    control = control or StageControl()
    t0 = time.time()
    out_dir = Path(out_dir)
    if not calibration:
        raise ValueError("export needs at least one calibration view")
    tex = texture.detach().cpu().numpy() if hasattr(texture, "detach") else np.asarray(texture, np.float32)
    if tex.shape[0] > NUM_CHANNELS:
        raise ValueError(f"the player handles at most {NUM_CHANNELS} texture channels, got {tex.shape[0]}")
    # Fewer channels (small presets): pad with zero channels, which quantise to 128 = background.
    tex = np.concatenate([tex, np.zeros((NUM_CHANNELS - tex.shape[0], *tex.shape[1:]), tex.dtype)])
    peak = None
    if view_colours is not None:  # the colour channels' scales cover every view's colours too
        peak = np.zeros(NUM_CHANNELS, np.float32)
        peak[:3] = view_colours.colours.reshape(view_colours.count, 3, -1).max(axis=(0, 2)) / 255.0
        if view_colours.head is not None:
            peak[:3] = np.maximum(peak[:3], view_colours.head.colours.max(axis=(0, 1)) / 255.0)
    qtex = quantize_texture(tex, peak)
    mesh = skinned_mesh_from_body_model(body_model, shape, offsets)
    skeleton = skeleton_from_body_model(body_model, shape)
    step = lambda i, msg: control.report(Progress("export", i, 5, msg))  # noqa: E731
    views = _rasterize_export_views(ctx, mesh, qtex, skeleton, calibration, heldout, cfg, step)
    calib, held = views.calibration, views.heldout
    control.check()
    with staged_folder(out_dir) as tmp:
        renderer = renderer.eval().float().cpu()
        H, W = calib[0].shape[2:]
        step(1, "writing texture, mesh and skeleton")
        write_arrays(tmp, qtex, mesh, skeleton)
        if view_colours is not None:
            write_view_colours(tmp, quantize_view_colours(view_colours, qtex.scales[:3], ZERO_POINT))
        specs, quality = _export_renderers(tmp, renderer, qtex, views, cfg, step, control)
        rcfg = getattr(renderer, "cfg", None)
        fields = _manifest_fields(qtex, skeleton, mesh, rcfg, (H, W), shape, cfg, quality,
                                  len(calib) + len(views.close_calibration), time.time() - t0)
        fields["body"]["clothing"] = clothing_entry(offsets)
        if view_colours is not None:
            fields["view_colours"] = {"count": view_colours.count, "frames_each": view_colours.frames,
                                      "file": VIEW_COLOURS_FILE}
            if view_colours.head is not None:
                fields["view_colours"]["head"] = {"count": view_colours.head.count,
                                                  "frames_each": view_colours.head.frames,
                                                  "texels": int(len(view_colours.head.texels))}
        tails = native_tails(tmp, specs, cfg.input_layout, held or calib[:4])
        if tails:
            fields["renderer"]["native_tail"] = tails
        manifest = write_manifest(tmp, fields)
        place_avatar_folder(tmp, out_dir, claim)
    step(5, "done")
    return manifest


@dataclass(frozen=True)
class ExportViews:
    """The rasterized views an export calibrates int8 on and checks it against: the capture's
    views, and (``playback_zoom`` > 0) the same views drawn as close as the player draws them."""

    calibration: list
    heldout: list
    close_calibration: list
    close_heldout: list


def _rasterize_export_views(ctx, mesh: SkinnedMesh, qtex: QuantizedTexture, skeleton: SkinningSkeleton,
                            calibration: Sequence[View], heldout: Sequence[View], cfg: ExportConfig,
                            step) -> ExportViews:
    """Rasterize the calibration and held-out views (``ctx``: a GL context, or None for one of its own)."""
    own_ctx = ctx is None
    ctx = ctx or create_headless_context()
    try:
        step(0, "rasterizing calibration views")
        calib_views, held_views = list(calibration)[:cfg.max_calibration_views], list(heldout)[:cfg.max_heldout_views]
        calib = rasterize_views(ctx, mesh, qtex, skeleton, calib_views)
        held = rasterize_views(ctx, mesh, qtex, skeleton, held_views)
        close_calib, close_held = [], []
        if cfg.playback_zoom > 0:
            step(0, f"rasterizing calibration views up to {cfg.playback_zoom:.2f}x closer")
            for zoom, share in closer_scales(cfg.playback_zoom):
                every = max(1, -(-len(calib_views) // max(1, round(cfg.max_playback_views * share))))
                close_calib += rasterize_views(ctx, mesh, qtex, skeleton, _closer(calib_views[::every], zoom))
            close_held = rasterize_views(ctx, mesh, qtex, skeleton, _closer(held_views, cfg.playback_zoom))
    finally:
        if own_ctx:
            ctx.release()
    return ExportViews(calib, held, close_calib, close_held)


def _export_renderers(tmp: Path, renderer, qtex: QuantizedTexture, views: ExportViews, cfg: ExportConfig,
                      step, control: StageControl) -> tuple[dict, dict]:
    """Write the fp32 and int8 renderers into ``tmp``; returns their native tail specs and the
    int8-against-fp32 quality report (on held-out views, else on calibration views, and on views
    at playback scale)."""
    calib, held, close_calib = views.calibration, views.heldout, views.close_calibration
    step(2, "exporting the fp32 renderer")
    specs = {"fp32": export_fp32(renderer, qtex.scales, tmp / RENDERERS["fp32"], cfg.input_layout)}
    control.check()
    step(3, "quantising the renderer to int8")
    chosen = export_int8(renderer, qtex.scales, tmp / RENDERERS["int8"],
                         mosaic(calib) + close_calib if close_calib else calib, cfg.input_layout)
    specs["int8"] = chosen.get("native_tail")
    step(4, "measuring int8 against fp32")
    # With no held-out views the report falls back on calibration views (and says so).
    quality = int8_quality(tmp / RENDERERS["fp32"], tmp / RENDERERS["int8"], held or calib[:4], cfg.input_layout)
    quality["on"] = "heldout" if held else "calibration"
    quality["calibration"] = chosen["calibration"]  # the activation ranges kept, and why
    quality["calibration_scores_db"] = chosen["scores_db"]
    if close_calib:  # the same check on views as close as the player draws them
        quality["playback_scale"] = {"zoom": round(float(cfg.playback_zoom), 3),
                                     **int8_quality(tmp / RENDERERS["fp32"], tmp / RENDERERS["int8"],
                                                    views.close_heldout or close_calib[:4], cfg.input_layout)}
    return specs, quality


def clothing_entry(offsets: np.ndarray | None) -> dict:
    """The manifest's ``body.clothing``: whether mesh.npz holds the dressed body and how far its
    clothing offsets reach (mean and largest, mm along the rest normals)."""
    from morf.fitting.offsets import offset_summary

    s = offset_summary(offsets)
    return {**s, "meaning": "mesh.npz rest_vertices are the shaped body moved outward along its rest normals by "
                            "the fit's clothing offsets (the surface the renderer trained on)" if s["dressed"]
            else "mesh.npz rest_vertices are the shaped body without clothing offsets"}


def place_avatar_folder(tmp: Path, out_dir: Path, claim: OutputClaim | None) -> None:
    """Move the finished folder ``tmp`` to ``out_dir``.

    Where ``out_dir`` holds nothing but an earlier export (or nothing), the whole folder is swapped,
    so a failure leaves the previous avatar whole. Where it also holds files of others (allowed by
    ``--force``), only the export's own files are replaced one by one, the manifest last, and the
    files the earlier export listed and this one does not are deleted; the others stay.
    """
    if claim is None or not claim.foreign:
        replace_folder(tmp, out_dir)
        return
    new = {p.name for p in tmp.iterdir()}
    for name in sorted(new - {MANIFEST}) + [MANIFEST]:
        os.replace(tmp / name, out_dir / name)
    for name in claim.previous - new:
        (out_dir / name).unlink(missing_ok=True)
    tmp.rmdir()


def _manifest_fields(qtex, skeleton, mesh, rcfg, image_hw, shape, cfg, quality, n_calib, seconds) -> dict:
    import onnx
    import onnxruntime
    import torch

    from morf import __version__

    shape_list = shape.detach().cpu().numpy().reshape(-1).tolist() if hasattr(shape, "detach") else list(np.ravel(shape))
    return {
        "created": time.strftime("%Y-%m-%d %H:%M:%S"),
        "versions": {"morf": __version__, "torch": torch.__version__, "onnx": onnx.__version__,
                     "onnxruntime": onnxruntime.__version__, "opset": OPSET},
        "image_size": list(map(int, image_hw)),
        "body": {"model": "anny", "shape": shape_list, "num_bones": skeleton.num_bones,
                 "render_vertices": mesh.num_vertices, "faces": int(mesh.faces.shape[0])},
        "texture": {"channels": qtex.channels, "size": list(qtex.data.shape[:2]), "zero_point": 128,
                    "channel_scales": qtex.scales.tolist()},
        "renderer": {"input": "raster", "input_layout": cfg.input_layout,
                     "coverage": {"channel": COVERAGE_CHANNEL,
                                  "meaning": "on the body this channel's byte is never the zero point (the "
                                             "rasterizer writes zero point + 1 for it); off it every byte is"},
                     "output": "rgba",
                     "output_meaning": "RGB premultiplied by the mask, then mask probability",
                     "composite": {"input": "background", "output": "image",
                                   "meaning": "uint8 (1, H, W, 3): rgba over background (float32 (1, 3, H|1, W|1), 0-255)"},
                     "size_multiple": int(rcfg.multiple) if rcfg is not None else 32,
                     "config": dataclasses.asdict(rcfg) if dataclasses.is_dataclass(rcfg) else None,
                     "int8": {"format": "QDQ", "weights": "int8 per-channel", "activations": "uint8",
                              "calibration_views": n_calib,
                              "calibration_method": {"percentile": "percentile 99.99", "minmax": "min-max"}.get(
                                  quality.get("calibration"), quality.get("calibration")),
                              "calibration_zoom": [1.0] + ([round(z, 3) for z, _ in closer_scales(cfg.playback_zoom)]
                                                           if "playback_scale" in quality else []),
                              "equalized": True}},
        "int8_quality": quality,
        "export_seconds": round(seconds, 1),
        **cfg.extra,
    }
