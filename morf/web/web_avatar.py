"""An exported avatar in the files a browser reads: ``avatar/`` of a web folder.

Layout (format "morf-web-avatar", version 1)::

    avatar/
      avatar.json     what the page needs to play: counts, the texture's and the mesh's byte layout,
                      the skeleton (for forward kinematics in the page), the renderer's contract
                      (its mode, inputs, outputs and the full-resolution tail's constants), the
                      trained scale, the motions, and size + sha256 of every file
      texture.bin     (Ht, Wt, 16) uint8 neural texture, row 0 = top of the atlas (zero point 128)
      mesh.bin        rest vertices (Vr, 3) f32, uvs (Vr, 2) f32, bone weights (Vr, 8) f32,
                      bone indices (Vr, 8) u8 (u16 past 255 bones), faces (F, 3) u32, and the faces
                      of the lighter levels (Fl, 3) u32 over the same vertices (:mod:`morf.web.light_mesh`:
                      what the page draws on software WebGL); offsets in avatar.json
      renderer.onnx   the int8 renderer (fp32 where the export measured int8 far from it), cut
                      before its full-resolution tail when the avatar folder has one (and with the
                      web-only rewrites of :mod:`morf.web.graph_rewrite`): the page's
                      WebGL pass plays the tail (:mod:`morf.export.compiled_tail`), as the native
                      player's compiled pass does, and the page computes the colour fill's pyramid
                      (:mod:`morf.web.page_fill`, ``fill_levels`` in the tail's spec; the graph then
                      has the head as its one output); otherwise the whole graph up to the composited image

The page does what :class:`morf.playback.player.Player` does per frame: bone matrices from the
pose (the same forward kinematics as :class:`morf.export.skeleton.SkinningSkeleton`), skinning in
the vertex shader, the 16 channels rasterized as bytes into an RGBA32UI attachment cleared to the
zero point, read back as the renderer's (1, H, W, 16) uint8 input, the renderer, the tail and the
composite over the background with the renderer's mask.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.export.avatar_folder import ExportedAvatar, int8_check_db, sha256_of
from morf.playback.graph_outputs import cut_graph, keep_outputs
from morf.playback.native_tail import spec_for
from morf.web.graph_rewrite import slice_before_transpose
from morf.web.light_mesh import LightMesh, light_meshes
from morf.web.page_fill import without_fill

FORMAT = "morf-web-avatar"
VERSION = 1
LEVEL_NAMES = ("light", "lighter")  # the names of morf.web.light_mesh.LEVELS_M's levels in the page
INT8_MIN_PSNR_DB = 30.0  # as morf play: below it the int8 renderer is visibly off, and fp32 plays instead


@dataclass(frozen=True)
class WebRenderer:
    """The renderer graph the page runs.

    Fields:
        graph: serialized ONNX bytes; precision: "int8" or "fp32".
        mode: "tail" (outputs the tail's half-resolution tensors, the page plays the tail) or
            "image" (outputs the composited (1, H, W, 3) uint8 image; input ``background``).
        contract: what avatar.json says about it (inputs, outputs, the tail's spec).
    """

    graph: bytes
    precision: str
    mode: str
    contract: dict


def web_renderer(avatar: ExportedAvatar, precision: str = "auto", page_fill: bool = True) -> WebRenderer:
    """The graph for the page: cut before the tail where the manifest has the tail's spec, else
    the whole graph with ``image`` as its only output. ``precision``: "int8", "fp32", or "auto"
    (int8 unless the export measured it under 30 dB from fp32). ``page_fill``: the colour fill
    left to the page where it can compute it (:mod:`morf.web.page_fill`); False keeps it in the
    graph (the page then uses the graph's)."""
    if precision == "auto":
        quality = int8_check_db(avatar.manifest)
        precision = "fp32" if quality is not None and quality < INT8_MIN_PSNR_DB else "int8"
    path = avatar.renderer_path(precision)
    raw = path.read_bytes()
    renderer = avatar.manifest["renderer"]
    spec = spec_for(avatar.manifest, precision)
    if spec is not None:
        # Cut at HEAD itself, not before the head stage as the native player does: in software WebGL
        # (SwiftShader) the head stage's 80 texel reads per half-resolution pixel cost more than the
        # graph's own layers in onnxruntime-web.
        spec = dataclasses.replace(spec, head_stage=None)
        # The colour fill's pyramid in the page (morf/web/page_fill.py), where it matches the graph's.
        graph, fill_levels = cut_graph(raw, spec.cut), None
        if page_fill:
            graph, fill_levels = without_fill(graph, spec, avatar.size_multiple)
        outputs = [name for name in spec.cut if fill_levels is None or name != spec.fill]
        contract = {"mode": "tail", "input": renderer["input"], "outputs": outputs,
                    "tail": {**spec.to_dict(), "fill_levels": fill_levels}}
        return WebRenderer(slice_before_transpose(graph), precision, "tail", contract)
    if avatar.input_layout != "nhwc" or "composite" not in renderer:
        from morf.errors import InputError

        raise InputError(f"{avatar.root}: the page plays renderers that read the raster channels-last and "
                         "composite in the graph (exports of morf 0.1 with --layout nhwc); export the avatar again")
    lean = keep_outputs(raw, ("image",))
    contract = {"mode": "image", "input": renderer["input"], "outputs": ["image"],
                "background": renderer["composite"]["input"]}
    return WebRenderer(slice_before_transpose(lean if lean is not None else raw), precision, "image", contract)


def _mesh_bytes(avatar: ExportedAvatar, levels: dict[str, LightMesh]) -> tuple[bytes, dict]:
    """mesh.bin and its layout: {array: {"offset", "type", "shape"}}, every array 4-byte aligned."""
    m = avatar.mesh
    index_type = np.uint8 if avatar.skeleton.num_bones <= 256 else np.uint16
    arrays = {
        "rest_vertices": np.ascontiguousarray(m.rest_vertices, np.float32),
        "uvs": np.ascontiguousarray(m.uvs, np.float32),
        "bone_weights": np.ascontiguousarray(m.bone_weights, np.float32),
        "bone_indices": np.ascontiguousarray(m.bone_indices, index_type),
        "faces": np.ascontiguousarray(m.faces, np.uint32),
        # the levels' faces in the full mesh's vertex numbers
        **{f"faces_{name}": np.ascontiguousarray(lm.kept[lm.mesh.faces], np.uint32) for name, lm in levels.items()},
    }
    parts, layout, offset = [], {}, 0
    for name, a in arrays.items():
        layout[name] = {"offset": offset, "type": a.dtype.name, "shape": list(a.shape)}
        data = a.tobytes()
        pad = (-len(data)) % 4
        parts.append(data + b"\0" * pad)
        offset += len(data) + pad
    return b"".join(parts), layout


def _skeleton(avatar: ExportedAvatar) -> dict:
    s = avatar.skeleton
    return {"names": [str(n) for n in s.names], "parents": [int(p) for p in s.parents],
            "rest_rotations": np.round(s.rest_rotations, 12).reshape(-1).tolist(),
            "rest_heads": np.round(s.rest_heads, 12).reshape(-1).tolist(),
            "reference_rotations": np.round(s.reference_rotations, 12).reshape(-1).tolist()}


def write_web_avatar(avatar: ExportedAvatar, folder: Path, motions: list[dict], precision: str = "auto") -> dict:
    """Write ``avatar/`` (texture.bin, mesh.bin, renderer.onnx, avatar.json) into ``folder``;
    ``motions``: the entries of the motions written beside it (:func:`morf.web.motions.write_motions`);
    ``precision``: the renderer's (:func:`web_renderer`).
    Returns avatar.json's content."""
    import json

    folder.mkdir(parents=True, exist_ok=True)
    tex = avatar.texture
    (folder / "texture.bin").write_bytes(np.ascontiguousarray(tex.data, np.uint8).tobytes())
    views = avatar.view_colours
    if views is not None:  # the colour channels by view, blended per frame by view_colours.js
        (folder / "view_colours.bin").write_bytes(np.ascontiguousarray(views.data, np.uint8).tobytes())
        if views.head is not None:  # the head's own colours: texels (int32 LE), shares, then K x n x 3 bytes
            h = views.head
            (folder / "head_colours.bin").write_bytes(np.ascontiguousarray(h.texels, "<i4").tobytes()
                                                      + np.ascontiguousarray(h.share, np.uint8).tobytes()
                                                      + np.ascontiguousarray(h.data, np.uint8).tobytes())
    levels = dict(zip(LEVEL_NAMES, light_meshes(avatar.mesh, avatar.skeleton.names, avatar.skeleton.parents)))
    mesh, layout = _mesh_bytes(avatar, levels)
    (folder / "mesh.bin").write_bytes(mesh)
    renderer = web_renderer(avatar, precision)
    (folder / "renderer.onnx").write_bytes(renderer.graph)
    manifest = avatar.manifest
    files = {p.name: {"bytes": p.stat().st_size, "sha256": sha256_of(p)} for p in sorted(folder.iterdir())}
    doc = {
        "format": FORMAT, "version": VERSION,
        # no paths of the exporting machine: the folder is meant to be published
        "source": {"created": manifest.get("created"), "run": (manifest.get("source") or {}).get("run")},
        "image_size": manifest.get("image_size"),
        "size_multiple": avatar.size_multiple,
        "texture": {"file": "texture.bin", "height": int(tex.data.shape[0]), "width": int(tex.data.shape[1]),
                    "channels": int(tex.data.shape[2]), "zero_point": 128},
        "mesh": {"file": "mesh.bin", "vertices": avatar.mesh.num_vertices, "faces": int(avatar.mesh.faces.shape[0]),
                 "arrays": layout, "levels": [
                     {"name": name, "array": f"faces_{name}", "faces": int(lm.mesh.faces.shape[0]),
                      "vertices": int(len(lm.kept)), "max_error_mm": round(lm.max_error_m * 1000, 3)}
                     for name, lm in levels.items()]},
        "skeleton": _skeleton(avatar),
        "renderer": {"file": "renderer.onnx", "precision": renderer.precision, **renderer.contract},
        "trained_scale": manifest.get("trained_scale"),
        "motions": motions,
        "files": files,
    }
    if views is not None:
        doc["view_colours"] = {"file": "view_colours.bin", "count": int(views.anchors.shape[0]),
                               "anchors": np.round(views.anchors.astype(np.float64), 9).reshape(-1).tolist()}
        if views.head is not None:
            h = views.head
            doc["view_colours"]["head"] = {
                "file": "head_colours.bin", "count": int(h.anchors.shape[0]), "bone": int(h.bone),
                "texels": int(len(h.texels)), "anchors": np.round(h.anchors.astype(np.float64), 9).reshape(-1).tolist()}
    (folder / "avatar.json").write_text(json.dumps(doc, separators=(",", ":")))
    return doc
