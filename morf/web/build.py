"""``morf web AVATAR OUT`` / ``morf export PROJECT --web OUT``: the static folder that plays an
exported avatar in a browser.

    OUT/
      index.html, *.js, style.css   the page and the player (resources/web/)
      player.json                   the libraries the folder carries, the avatar's place
      lib/                          onnxruntime-web (:mod:`morf.web.libraries`), WASM gzip-compressed
      avatar/                       the avatar (:mod:`morf.web.web_avatar`)
      motions/                      NAME.bin per motion (:mod:`morf.web.motions`)

Every script is in the folder: the page asks no other host for anything. The folder follows the
output rule (:mod:`morf.io.outputs`): a non-empty OUT is refused without ``--force``, and with it
only the names this command writes are replaced.
"""

from __future__ import annotations

import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from morf.io.outputs import claim_output_folder, staged_folder, write_record
from morf.web.head_rewrite import rewrite_web_renderer
from morf.web.libraries import ORT_VERSION, copy_libraries
from morf.web.motions import motion_sources, write_motions
from morf.web.paths import page_files
from morf.web.web_avatar import write_web_avatar


@dataclass(frozen=True)
class WebFolder:
    """What was written: ``path``; ``bytes`` in all; ``motions`` names; ``renderer`` mode ("tail" /
    "image") and precision; ``backends`` the onnxruntime-web builds the folder carries."""

    path: Path
    bytes: int
    motions: tuple[str, ...]
    renderer: str
    precision: str
    backends: tuple[str, ...]


def folder_bytes(path: Path) -> int:
    return sum(p.stat().st_size for p in Path(path).rglob("*") if p.is_file())


def build_web_folder(avatar_dir: str | os.PathLike, out: str | os.PathLike, motions: list[str] | None = None,
                     force: bool = False, webgpu: bool = False, command: str = "morf web",
                     motion_fps: float | None = None, precision: str = "auto") -> WebFolder:
    """Write the web folder of the avatar folder ``avatar_dir`` into ``out``.

    Args:
        motions: motion files to add to the shipped ones (any kind ``morf play`` reads).
        force: write into a non-empty ``out``, replacing only this command's names.
        webgpu: also carry onnxruntime-web's WebGPU build (6.6 MB more), used where the browser has WebGPU.
        motion_fps: the frame rate of user motion files that store none.
        precision: the renderer, "int8", "fp32" or "auto" (int8 unless the export measured it under
            30 dB from fp32).
    Raises:
        InputError: a missing or damaged avatar, a bad motion, a refused output, the libraries not cached.
    """
    from morf.playback.player import load_avatar

    claim = claim_output_folder(out, command, force)
    sources = motion_sources(motions)  # checked before anything is loaded or written
    avatar = load_avatar(avatar_dir)
    with staged_folder(out) as tmp:
        backends = copy_libraries(tmp / "lib", webgpu=webgpu)
        entries = write_motions(sources, tmp / "motions", avatar.skeleton.num_bones,
                                (avatar.manifest.get("body") or {}).get("shape"), command, motion_fps)
        doc = write_web_avatar(avatar, tmp / "avatar", entries, precision)
        rewrite_web_renderer(tmp / "avatar")  # the head's and the fill's rewrites (outputs the same)
        for f in page_files():
            shutil.copyfile(f, tmp / f.name)
        (tmp / "player.json").write_text(json.dumps({"onnxruntime_web": ORT_VERSION, "backends": backends,
                                                     "avatar": "avatar/avatar.json"}, indent=1))
        names = sorted(p.name for p in tmp.iterdir())
        _move_into_place(tmp, Path(out), names, claim)
    write_record(out, command, names)
    return WebFolder(Path(out), folder_bytes(Path(out)), tuple(e["name"] for e in entries), doc["renderer"]["mode"],
                     doc["renderer"]["precision"], tuple(b["backend"] for b in backends))


def _move_into_place(tmp: Path, out: Path, names: list[str], claim) -> None:
    """Move the staged folder's entries into ``out``: the whole folder when ``out`` is new, else each
    of this command's names (replacing its earlier ones, deleting those it no longer writes)."""
    if not claim.existed or not any(out.iterdir()):
        if out.exists():
            out.rmdir()
        tmp.rename(out)
        return
    for name in set(claim.previous) - set(names):
        _remove(out / name)
    for name in names:
        _remove(out / name)
        (tmp / name).rename(out / name)
    tmp.rmdir()


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path)
    elif path.exists() or path.is_symlink():
        path.unlink()
