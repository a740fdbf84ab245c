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

Needs numpy (and onnxruntime/moderngl to play); never torch, never pickle.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.export.skeleton import SkinningSkeleton
from morf.io import atomic_write_json, load_npz, save_npz
from morf.raster.neural_raster import SkinnedMesh
from morf.raster.texture_quant import QuantizedTexture

FORMAT = "morf-avatar"
VERSION = 1
MANIFEST = "manifest.json"
RENDERERS = {"fp32": "renderer.onnx", "int8": "renderer_int8.onnx"}


@dataclass(frozen=True)
class ExportedAvatar:
    """A loaded avatar folder.

    Fields:
        root: the folder; manifest: manifest.json as a dict.
        texture: 16-channel uint8 neural texture; mesh: the shaped render mesh; skeleton: for posing.
    """

    root: Path
    manifest: dict
    texture: QuantizedTexture
    mesh: SkinnedMesh
    skeleton: SkinningSkeleton

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


def is_avatar_folder(root: str | Path) -> bool:
    """Whether ``root`` holds an avatar folder's manifest (nothing is read or checked)."""
    return (Path(root) / MANIFEST).is_file()


def read_manifest(root: str | Path) -> dict:
    """The manifest of the avatar folder ``root``; an InputError when it is missing, damaged, of
    another format or of a newer version."""
    root = Path(root)
    mpath = root / MANIFEST
    if not mpath.is_file():
        raise InputError(f"not an exported avatar (no {MANIFEST}): {root}")
    try:
        manifest = json.loads(mpath.read_text())
    except json.JSONDecodeError as e:
        raise InputError(f"damaged {mpath}: {e}") from None
    if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
        raise InputError(f"{mpath} is not a {FORMAT} manifest")
    if int(manifest.get("version", 0)) > VERSION:
        raise InputError(f"avatar format version {manifest.get('version')} is newer than this morf ({VERSION})")
    return manifest


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


def load_exported_avatar(root: str | Path, verify: bool = False) -> ExportedAvatar:
    """Open an avatar folder written by ``morf export``.

    ``verify=True`` also checks every file's sha256 against the manifest.
    """
    root = Path(root)
    manifest = read_manifest(root)
    for name, info in manifest.get("files", {}).items():
        p = root / name
        if not p.is_file():
            raise InputError(f"avatar file missing: {p}")
        if verify and sha256_of(p) != info["sha256"]:
            raise InputError(f"avatar file damaged (checksum mismatch): {p}")
    t, m, s = (load_npz(root / n) for n in ("texture.npz", "mesh.npz", "skeleton.npz"))
    texture = QuantizedTexture(data=t["texture"], scales=t["scales"].astype(np.float32))
    mesh = SkinnedMesh(rest_vertices=m["rest_vertices"], uvs=m["uvs"], faces=m["faces"],
                       bone_indices=m["bone_indices"], bone_weights=m["bone_weights"])
    return ExportedAvatar(root=root, manifest=manifest, texture=texture, mesh=mesh,
                          skeleton=SkinningSkeleton.from_arrays(s))
