"""The exported avatar folder: everything a player needs, readable without torch.

Layout (format "morf-avatar", version 1)::

    AVATAR/
      manifest.json        versions, image size, channel scales, renderer graph contract, int8
                           quality, where the player may cut each graph before its compiled
                           full-resolution tail (renderer.native_tail, see
                           morf.export.compiled_tail), and size + sha256 of every file below
      texture.npz          texture (Ht, Wt, 16) uint8 (zero point 128), scales (16,) float32
      mesh.npz             rest_vertices (Vr, 3), uvs (Vr, 2), faces (F, 3), bone_indices (Vr, 8),
                           bone_weights (Vr, 8): the shaped render mesh, seams split
      skeleton.npz         bone_names, bone_parents, rest_rotations, rest_heads, reference_rotations
      renderer.onnx        fp32 renderer, uint8 input (see morf.export.onnx_renderer)
      renderer_int8.onnx   the same, int8 QDQ
      view_colours.npz     optional: anchors (K, 3, 3) float32 root orientations relative to the
                           camera, colours (K, Ht, Wt, 3) uint8 in texture.npz's bytes: channels
                           0-2 by view (morf.avatar.view_colour); the player blends the nearest;
                           head_anchors, head_bone, head_texels, head_share, head_colours
                           (optional): the head's own colours, blended by the head bone's
                           orientation and laid over (morf.avatar.head_colour)

Needs numpy (and onnxruntime/moderngl to play); never torch, never pickle.

A folder is a user's file like any other: it may be copied half, edited by hand, or come from
someone else. Loading checks it before anything reads it (:func:`read_manifest`,
:func:`verify_files`, :func:`load_exported_avatar`): the manifest's fields have the types and
ranges the player uses, its file names are plain names inside the folder (a link out of it is
refused the same way whether or not its target exists, so an error tells nothing about other
paths), every file has the size and sha256 recorded at export, and the arrays have the shapes,
index ranges and finite values the rasterizers index with. Each problem is one InputError line
that names the file and says to export the avatar again.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.avatar.head_colour import HeadColourBytes
from morf.avatar.view_colour import ViewColourBytes
from morf.errors import InputError
from morf.export.skeleton import SkinningSkeleton
from morf.io import atomic_write_json, load_npz, save_npz
from morf.raster.neural_raster import LAYOUTS, NUM_CHANNELS, SkinnedMesh
from morf.raster.texture_quant import QuantizedTexture

FORMAT = "morf-avatar"
VERSION = 1
MANIFEST = "manifest.json"
RENDERERS = {"fp32": "renderer.onnx", "int8": "renderer_int8.onnx"}
ARRAYS = ("texture.npz", "mesh.npz", "skeleton.npz")
VIEW_COLOURS_FILE = "view_colours.npz"  # optional: the colour channels by view (morf.avatar.view_colour)
REQUIRED_FILES = (*ARRAYS, *RENDERERS.values())
MAX_MANIFEST_BYTES = 4 * 2**20  # a manifest is a few kB (tens with native tails); more is not one
MAX_SIZE_MULTIPLE = 1024
AGAIN = "export the avatar again (morf export)"


@dataclass(frozen=True)
class ExportedAvatar:
    """A loaded avatar folder.

    Fields:
        root: the folder; manifest: manifest.json as a dict (checked by :func:`read_manifest`).
        texture: 16-channel uint8 neural texture; mesh: the shaped render mesh; skeleton: for posing;
        view_colours: the texture's channels 0-2 by view (None: the texture's own for every view).
    """

    root: Path
    manifest: dict
    texture: QuantizedTexture
    mesh: SkinnedMesh
    skeleton: SkinningSkeleton
    view_colours: ViewColourBytes | None = None

    def renderer_path(self, precision: str = "int8") -> Path:
        if precision not in RENDERERS:
            raise InputError(f"renderer precision must be one of {sorted(RENDERERS)}")
        return self.root / RENDERERS[precision]

    @property
    def input_layout(self) -> str:
        return self.manifest["renderer"]["input_layout"]

    @property
    def size_multiple(self) -> int:
        return int(self.manifest["renderer"].get("size_multiple", 32))


def sha256_of(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def write_arrays(folder: Path, texture: QuantizedTexture, mesh: SkinnedMesh, skeleton: SkinningSkeleton) -> None:
    """Write texture.npz, mesh.npz and skeleton.npz into ``folder``."""
    save_npz(folder / "texture.npz", texture=texture.data, scales=texture.scales)
    save_npz(folder / "mesh.npz", rest_vertices=mesh.rest_vertices.astype(np.float32), uvs=mesh.uvs.astype(np.float32),
             faces=mesh.faces.astype(np.int32), bone_indices=mesh.bone_indices.astype(np.int32),
             bone_weights=mesh.bone_weights.astype(np.float32))
    save_npz(folder / "skeleton.npz", **skeleton.to_arrays())


def write_view_colours(folder: Path, views: ViewColourBytes) -> None:
    """Write view_colours.npz: anchors (K, 3, 3) float32 and colours (K, Ht, Wt, 3) uint8 texture
    bytes; with the head's own colours also head_anchors (Kh, 3, 3) float32, head_bone (1,) int32,
    head_texels (n,) int32, head_share (n,) uint8 and head_colours (Kh, n, 3) uint8."""
    arrays = {"anchors": views.anchors.astype(np.float32), "colours": views.data}
    if views.head is not None:
        h = views.head
        arrays.update(head_anchors=h.anchors.astype(np.float32), head_bone=np.array([h.bone], np.int32),
                      head_texels=h.texels.astype(np.int32), head_share=h.share.astype(np.uint8),
                      head_colours=h.data)
    save_npz(folder / VIEW_COLOURS_FILE, **arrays)


def write_manifest(folder: Path, fields: dict) -> dict:
    """Add format, version and per-file size + sha256 to ``fields`` and write manifest.json."""
    files = {}
    for p in sorted(folder.iterdir()):
        if p.is_file() and p.name != MANIFEST and not p.name.startswith("."):
            files[p.name] = {"bytes": p.stat().st_size, "sha256": sha256_of(p)}
    manifest = {"format": FORMAT, "version": VERSION, **fields, "files": files}
    atomic_write_json(folder / MANIFEST, manifest)
    return manifest


def replace_folder(tmp: Path, target: Path) -> None:
    """Move a finished ``tmp`` folder onto ``target`` (the old one is removed only after)."""
    old = target.with_name(f".{target.name}.old")
    if old.exists():
        shutil.rmtree(old)
    if target.exists():
        target.rename(old)
    tmp.rename(target)
    if old.exists():
        shutil.rmtree(old)


def previous_avatar_files(folder: str | Path) -> frozenset[str]:
    """The files an earlier export wrote into ``folder``: its manifest and the files it lists."""
    try:
        manifest = json.loads((Path(folder) / MANIFEST).read_text())
        names = manifest["files"] if manifest.get("format") == FORMAT else {}
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return frozenset()
    if not isinstance(names, dict):
        return frozenset()
    return frozenset({MANIFEST} | {n for n in names if isinstance(n, str) and n and "/" not in n
                                   and "\\" not in n and n not in (".", "..")})


def is_avatar_folder(root: str | Path) -> bool:
    """Whether ``root`` holds an avatar folder's manifest (nothing is read or checked)."""
    return (Path(root) / MANIFEST).is_file()


def damaged(where: str | Path, problem: str) -> InputError:
    """The one-line error for a damaged or foreign avatar folder."""
    return InputError(f"{where}: {problem}; the avatar folder is damaged or was not written by morf export: {AGAIN}")


def read_manifest(root: str | Path) -> dict:
    """The manifest of the avatar folder ``root``, checked (:func:`check_manifest`); an InputError
    when it is missing, damaged, of another format or of a newer version."""
    root = Path(root)
    mpath = root / MANIFEST
    _check_inside(root, MANIFEST)
    if not mpath.is_file():
        raise InputError(f"not an exported avatar (no {MANIFEST}): {root}")
    try:
        if mpath.stat().st_size > MAX_MANIFEST_BYTES:
            raise damaged(mpath, f"{mpath.stat().st_size} bytes, far more than a manifest holds")
        manifest = json.loads(mpath.read_bytes())
    except (ValueError, RecursionError) as e:  # not JSON, not UTF-8, or nested past the parser's depth
        raise damaged(mpath, f"not readable as JSON ({str(e)[:120] or type(e).__name__})") from None
    except OSError as e:
        raise InputError(f"cannot read {mpath}: {e.strerror or e}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise InputError(f"{mpath} is not a {FORMAT} manifest; give the folder 'morf export' wrote")
    check_manifest(manifest, mpath)
    return manifest


def check_manifest(manifest: dict, where: str | Path = MANIFEST) -> None:
    """Check the fields the player reads: version, ``renderer`` (input layout, size multiple,
    native tails), ``files`` (plain names, sizes, sums; every file the player opens listed),
    ``trained_scale`` and ``int8_quality`` (finite numbers). An InputError names the field."""
    version = manifest.get("version")
    if not _is_int(version) or version < 1:
        raise damaged(where, f"'version' must be a whole number, got {_short(version)}")
    if version > VERSION:
        raise InputError(f"avatar format version {version} is newer than this morf ({VERSION}); update morf to play it")
    renderer = manifest.get("renderer")
    if not isinstance(renderer, dict):
        problem = "it has no 'renderer' section" if renderer is None else \
            f"its 'renderer' section must be an object, got {_short(renderer)}"
        raise damaged(where, f"{problem} (the renderer's input layout and size multiple)")
    if renderer.get("input_layout") not in LAYOUTS:
        raise damaged(where, f"'renderer.input_layout' must be one of {', '.join(LAYOUTS)}, "
                             f"got {_short(renderer.get('input_layout'))}")
    mult = renderer.get("size_multiple", 32)
    if not _is_int(mult) or not 1 <= mult <= MAX_SIZE_MULTIPLE:
        raise damaged(where, f"'renderer.size_multiple' must be a whole number from 1 to {MAX_SIZE_MULTIPLE}, "
                             f"got {_short(mult)}")
    _check_native_tails(renderer.get("native_tail"), where)
    _check_files_field(manifest.get("files"), where)
    trained = manifest.get("trained_scale")
    if trained is not None:
        ppm = trained.get("max_pixels_per_metre") if isinstance(trained, dict) else trained
        if not isinstance(trained, dict) or not (ppm is None or _is_number(ppm) and ppm > 0):
            raise damaged(where, f"'trained_scale.max_pixels_per_metre' must be a positive number, got {_short(ppm)}")
    quality = manifest.get("int8_quality")
    if quality is not None:
        checks = [quality] + ([quality.get("playback_scale")] if isinstance(quality, dict)
                              and quality.get("playback_scale") is not None else [])
        for check in checks:
            if not isinstance(check, dict):
                raise damaged(where, f"'int8_quality' must be an object, got {_short(check)}")
            for key in ("psnr_db", "psnr_person_db"):
                value = check.get(key)  # infinite where int8 and fp32 agreed exactly
                if value is not None and not (_is_number(value) or value == math.inf):
                    raise damaged(where, f"'int8_quality' {key} must be a number, got {_short(value)}")


def _check_files_field(files, where) -> None:
    if not isinstance(files, dict):
        raise damaged(where, "'files' must map each file name to its size and sha256")
    for name, info in files.items():
        check_file_name(name, where)
        if not (isinstance(info, dict) and _is_int(info.get("bytes")) and info["bytes"] >= 0
                and isinstance(info.get("sha256"), str) and len(info["sha256"]) == 64
                and all(c in "0123456789abcdef" for c in info["sha256"])):
            raise damaged(where, f"'files' entry {name} must give 'bytes' (a whole number) and 'sha256' "
                                 "(64 hex digits)")
    missing = [n for n in REQUIRED_FILES if n not in files]
    if missing:
        raise damaged(where, f"'files' does not list {', '.join(missing)}")


def _check_native_tails(tails, where) -> None:
    """The compiled tail indexes the raster with these numbers: out of range, it would read memory
    outside its arrays, so they are checked here (an entry of an unknown kind is ignored later)."""
    if tails is None:
        return
    if not isinstance(tails, dict):
        raise damaged(where, "'renderer.native_tail' must map a precision to its tail")
    for precision, spec in tails.items():
        if not isinstance(spec, dict):
            continue  # not a tail this morf understands: the player runs the whole graph
        field = f"'renderer.native_tail.{precision}'"
        ints = {"zero_point": (0, 255), "coverage_channel": (0, NUM_CHANNELS - 1), "opaque_margin": (0, 1024)}
        for key, (low, high) in ints.items():
            if key in spec and not (_is_int(spec[key]) and low <= spec[key] <= high):
                raise damaged(where, f"{field} {key} must be a whole number from {low} to {high}, "
                                     f"got {_short(spec[key])}")
        for key in ("logit_scale", "logit_offset", "weight_min"):
            if key in spec and not _is_number(spec[key]):
                raise damaged(where, f"{field} {key} must be a finite number, got {_short(spec[key])}")
        scale = spec.get("colour_scale", [0.0] * 3)
        if not (isinstance(scale, list) and len(scale) == 3 and all(_is_number(v) for v in scale)):
            raise damaged(where, f"{field} colour_scale must be 3 finite numbers")
        stage = spec.get("head_stage")
        if stage:
            stage = stage if isinstance(stage, dict) else {}
            weight, bias = stage.get("weight"), stage.get("bias")
            rows_ok = isinstance(weight, list) and len(weight) == 4 and all(
                isinstance(r, list) and r and len(r) == len(weight[0]) and all(_is_number(v) for v in r)
                for r in weight)
            if not (rows_ok and isinstance(bias, list) and len(bias) == 4 and all(_is_number(v) for v in bias)
                    and all(_is_number(stage.get(k)) for k in ("skip_scale", "alpha"))
                    and _is_int(stage.get("skip_zero_point")) and 0 <= stage["skip_zero_point"] <= 255):
                raise damaged(where, f"{field} head_stage must give a 4-row weight, 4 biases, skip_scale and alpha "
                                     "(finite numbers) and skip_zero_point (0 to 255)")


def check_file_name(name, where=MANIFEST) -> str:
    """``name`` when it is a plain file name (one path component, not the manifest); an
    InputError otherwise, decided from the text alone (nothing outside the folder is looked at)."""
    if not (isinstance(name, str) and name and name not in (".", "..", MANIFEST)
            and not any(c in name for c in "/\\\0") and not os.path.isabs(name)
            and not (len(name) > 1 and name[1] == ":")):
        raise damaged(where, f"'files' lists {_short(name)}, which is not the name of a file inside the avatar folder")
    return name


def _check_inside(root: Path, name: str) -> None:
    """Refuse ``root/name`` when it is a link to somewhere outside ``root``. The same words
    whether or not the link's target exists: the error tells nothing about other paths."""
    real_root = os.path.realpath(root)
    if os.path.dirname(os.path.realpath(root / name)) != real_root:
        raise damaged(root, f"{name} is a link to a place outside the folder, and an avatar's files must be in it")


def verify_files(root: str | Path, manifest: dict, checksums: bool = True) -> None:
    """Check that every file the (checked) manifest lists is inside ``root``, a plain file, of
    the recorded size and, with ``checksums``, of the recorded sha256.

    The sums cost a read of the folder: measured on a 2-core Intel Xeon with the files in the OS
    cache, 1.0 ms for a tiny-preset avatar (0.8 MB) and 5.5 ms for a cpu-preset renderer with a
    256-px texture (4.4 MB), against 13 and 21 ms for loading their arrays and 50-70 ms for a
    whole :class:`~morf.playback.player.Player` (sizes alone: 0.2 ms), so loading checks them by
    default."""
    root = Path(root)
    for name, info in manifest["files"].items():
        _check_inside(root, name)
        path = root / name
        if not path.is_file():
            raise InputError(f"avatar file missing: {path}; copy the whole avatar folder, or {AGAIN}")
        size = path.stat().st_size
        if size != info["bytes"]:
            raise InputError(f"avatar file {name} in {root} is damaged: {size} bytes where the manifest recorded "
                             f"{info['bytes']}; {AGAIN}")
        if checksums and sha256_of(path) != info["sha256"]:
            raise InputError(f"avatar file {name} in {root} is damaged: its sha256 differs from the one recorded "
                             f"at export; {AGAIN}")


def int8_check_db(manifest: dict) -> float | None:
    """The export's int8-against-fp32 PSNR on held-out views, the lowest of the whole image's and
    the person's, at the training views' scale and, where measured, at the player's (folders
    exported before the person's or the player's scale was measured: what they have); None when
    the manifest has no int8 check."""
    q = manifest.get("int8_quality")
    if not isinstance(q, dict) or q.get("psnr_db") is None:
        return None
    checks = [q] + ([q["playback_scale"]] if isinstance(q.get("playback_scale"), dict) else [])
    values = [float(c[k]) for c in checks for k in ("psnr_db", "psnr_person_db") if c.get(k) is not None]
    return min(values)


def load_exported_avatar(root: str | Path, verify: bool = True) -> ExportedAvatar:
    """Open an avatar folder written by ``morf export``, checked as the module docstring says.

    ``verify=False`` skips only the sha256 sums (sizes, names and arrays are still checked), for
    a caller that has just verified the same folder (see :func:`verify_files` for their cost).
    """
    root = Path(root)
    manifest = read_manifest(root)
    verify_files(root, manifest, checksums=verify)
    t, m, s = (load_npz(root / n, error=InputError) for n in ARRAYS)
    skeleton = _skeleton(s, root / "skeleton.npz")
    texture = _texture(t, root / "texture.npz")
    views = None
    if VIEW_COLOURS_FILE in manifest["files"]:
        views = _view_colours(load_npz(root / VIEW_COLOURS_FILE, error=InputError), root / VIEW_COLOURS_FILE,
                              texture.data.shape[:2], skeleton.num_bones)
    return ExportedAvatar(root=root, manifest=manifest, texture=texture,
                          mesh=_mesh(m, root / "mesh.npz", skeleton.num_bones), skeleton=skeleton,
                          view_colours=views)


# ---- the arrays ------------------------------------------------------------------------------
def _array(arrays: dict, key: str, path: Path, kind: str, shape: tuple) -> np.ndarray:
    """``arrays[key]`` when its dtype kind is in ``kind`` ("f" float, "i" integer, "u" uint8,
    "s" text) and its shape matches ``shape`` (None: any length; the rank must match)."""
    if key not in arrays:
        raise damaged(path, f"it has no '{key}' array")
    a = arrays[key]
    ok_kind = {"f": a.dtype.kind == "f", "i": a.dtype.kind in "iu", "u": a.dtype == np.uint8,
               "s": a.dtype.kind in "US"}[kind]
    if not ok_kind or a.ndim != len(shape) or any(n is not None and got != n for got, n in zip(a.shape, shape)):
        want = "x".join("N" if n is None else str(n) for n in shape)
        words = {"f": "float", "i": "integer", "u": "uint8", "s": "text"}[kind]
        raise damaged(path, f"'{key}' is {a.dtype} {a.shape}, not {want} {words}")
    if kind == "f" and not np.isfinite(a).all():
        raise damaged(path, f"'{key}' holds NaN or infinite values")
    return a


def _in_range(a: np.ndarray, key: str, path: Path, count: int, what: str) -> np.ndarray:
    if a.size and (a.min() < 0 or a.max() >= count):
        raise damaged(path, f"'{key}' holds indices outside the {count} {what}")
    return a


def _texture(t: dict, path: Path) -> QuantizedTexture:
    data = _array(t, "texture", path, "u", (None, None, NUM_CHANNELS))
    if 0 in data.shape:
        raise damaged(path, f"'texture' is empty {data.shape}")
    scales = _array(t, "scales", path, "f", (NUM_CHANNELS,))
    return QuantizedTexture(data=data, scales=scales.astype(np.float32))


def _view_colours(v: dict, path: Path, texels: tuple[int, int], num_bones: int) -> ViewColourBytes:
    anchors = _array(v, "anchors", path, "f", (None, 3, 3))
    if len(anchors) == 0:
        raise damaged(path, "it has no anchors")
    head = _head_colours(v, path, texels[0] * texels[1], num_bones) if "head_anchors" in v else None
    return ViewColourBytes(anchors.astype(np.float32), _array(v, "colours", path, "u", (len(anchors), *texels, 3)),
                           head)


def _head_colours(v: dict, path: Path, texel_count: int, num_bones: int) -> HeadColourBytes:
    anchors = _array(v, "head_anchors", path, "f", (None, 3, 3))
    if len(anchors) == 0:
        raise damaged(path, "it has no head anchors")
    bone = _in_range(_array(v, "head_bone", path, "i", (1,)), "head_bone", path, num_bones, "bones")
    texels = _in_range(_array(v, "head_texels", path, "i", (None,)), "head_texels", path, texel_count, "texels")
    n = len(texels)
    return HeadColourBytes(anchors.astype(np.float32), int(bone[0]), texels.astype(np.int32),
                           _array(v, "head_share", path, "u", (n,)), _array(v, "head_colours", path, "u",
                                                                            (len(anchors), n, 3)))


def _mesh(m: dict, path: Path, num_bones: int) -> SkinnedMesh:
    v = _array(m, "rest_vertices", path, "f", (None, 3))
    n = len(v)
    k = _array(m, "bone_indices", path, "i", (n, None)).shape[1]
    return SkinnedMesh(rest_vertices=v, uvs=_array(m, "uvs", path, "f", (n, 2)),
                       faces=_in_range(_array(m, "faces", path, "i", (None, 3)), "faces", path, n, "vertices"),
                       bone_indices=_in_range(m["bone_indices"], "bone_indices", path, num_bones, "bones"),
                       bone_weights=_array(m, "bone_weights", path, "f", (n, k)))


def _skeleton(s: dict, path: Path) -> SkinningSkeleton:
    parents = _array(s, "bone_parents", path, "i", (None,))
    j = len(parents)
    if j == 0:
        raise damaged(path, "it has no bones")
    for key, shape, kind in (("bone_names", (j,), "s"), ("rest_rotations", (j, 3, 3), "f"),
                             ("rest_heads", (j, 3), "f"), ("reference_rotations", (j, 3, 3), "f")):
        _array(s, key, path, kind, shape)
    try:
        return SkinningSkeleton.from_arrays(s)
    except ValueError as e:
        raise damaged(path, str(e)) from None


# ---- small checks ------------------------------------------------------------------------------
def _is_int(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _short(v) -> str:
    text = repr(v)
    return text if len(text) <= 60 else text[:57] + "..."
