"""The page's libraries: onnxruntime-web's prebuilt files, pinned by version and lockfile hash in
``resources/web-libs/package-lock.json`` (shipped in the wheel) and fetched once from the npm
registry into the user's cache (``morf web --fetch-libs``; ``~/.cache/morf/web-libs``, or under
``$XDG_CACHE_HOME``). Exporting a web folder copies them from that cache, so it needs no network
and no Node; a missing cache is a one-line error naming the fetch command.

The WASM binaries go into the folder gzip-compressed (14 MB -> 3.7 MB): the page inflates them
itself (``DecompressionStream``), so any static host serves them as plain files.
"""

from __future__ import annotations

import gzip
import json
import os
import shutil
from dataclasses import dataclass
from pathlib import Path

from morf.errors import InputError

ORT_PACKAGE = "onnxruntime-web"
ORT_VERSION = "1.30.0"  # as resources/web-libs/package-lock.json pins it
ENV = "MORF_WEB_LIBS"  # a folder holding onnxruntime-web/ (package.json + dist/), instead of the user's cache
FETCH = "morf web --fetch-libs"


@dataclass(frozen=True)
class Backend:
    """One onnxruntime-web build: its loader module, the pthread worker module and the WASM binary."""

    name: str
    loader: str
    worker: str
    wasm: str


WASM = Backend("wasm", "ort.wasm.min.mjs", "ort-wasm-simd-threaded.mjs", "ort-wasm-simd-threaded.wasm")
WEBGPU = Backend("webgpu", "ort.webgpu.min.mjs", "ort-wasm-simd-threaded.asyncify.mjs",
                 "ort-wasm-simd-threaded.asyncify.wasm")


def user_cache() -> Path:
    """Where ``morf web --fetch-libs`` installs: ``$XDG_CACHE_HOME/morf/web-libs`` (default
    ``~/.cache``), shared by every checkout and install of this user."""
    return Path(os.environ.get("XDG_CACHE_HOME") or "~/.cache").expanduser() / "morf" / "web-libs"


def cache_root() -> Path:
    """The folder that holds ``onnxruntime-web/``: ``$MORF_WEB_LIBS`` or the user's cache."""
    env = os.environ.get(ENV)
    return Path(env).expanduser() if env else user_cache() / "node_modules"


def fetch_libraries() -> int:
    """Install the pinned onnxruntime-web's browser files into the user's cache from the npm
    registry (checked against the shipped lockfile's sha512); nothing is fetched when they are
    there. Returns 0, or 1 with the reason on stderr."""
    from morf.resources import resource
    from morf.web.npm import install_locked

    dist = tuple(f"dist/{name}" for b in (WASM, WEBGPU) for name in (b.loader, b.worker, b.wasm))
    return install_locked(user_cache(), ORT_PACKAGE, dist, lock=resource("web-libs", "package-lock.json"))


def ort_dist(backends: tuple[Backend, ...] = (WASM,)) -> Path:
    """The cached ``dist/`` of the pinned onnxruntime-web with every file ``backends`` need; an
    InputError (one line, naming the fetch command) when it is missing or another version."""
    package = cache_root() / ORT_PACKAGE
    fix = f"run `{FETCH}` once (it needs the npm registry), or set {ENV} to a folder holding {ORT_PACKAGE}/"
    try:
        version = json.loads((package / "package.json").read_text()).get("version")
    except (OSError, ValueError):
        raise InputError(f"{ORT_PACKAGE} {ORT_VERSION} is not in the local cache {package}; {fix}") from None
    if version != ORT_VERSION:
        raise InputError(f"the cached {ORT_PACKAGE} in {package} is {version}, the page needs {ORT_VERSION}; {fix}")
    dist = package / "dist"
    for b in backends:
        for name in (b.loader, b.worker, b.wasm):
            if not (dist / name).is_file():
                raise InputError(f"{dist / name} is missing from the cached {ORT_PACKAGE}; {fix}")
    return dist


def _gzipped(src: Path, dst: Path) -> None:
    """``src`` gzip-compressed into ``dst``, through a copy cached beside ``src`` when that folder is
    writable (compressing 14 MB takes seconds; the cached copy is reused while ``src`` is unchanged)."""
    cached = src.with_name(src.name + ".gz")
    if cached.is_file() and cached.stat().st_mtime >= src.stat().st_mtime:
        shutil.copyfile(cached, dst)
        return
    with open(src, "rb") as f, open(dst, "wb") as raw, gzip.GzipFile(fileobj=raw, mode="wb", compresslevel=9, mtime=0) as g:
        shutil.copyfileobj(f, g, 1 << 20)
    try:
        tmp = cached.with_name(f".{cached.name}.{os.getpid()}")
        shutil.copyfile(dst, tmp)
        os.replace(tmp, cached)
    except OSError:
        pass  # a read-only cache: compress again next time


def copy_libraries(lib: Path, webgpu: bool = False) -> list[dict]:
    """Copy the page's onnxruntime-web files into the folder ``lib`` (created); returns what each
    build offers the page: ``{"backend", "loader", "worker", "wasm"}`` (file names in ``lib``)."""
    backends = (WASM, WEBGPU) if webgpu else (WASM,)
    dist = ort_dist(backends)
    lib.mkdir(parents=True, exist_ok=True)
    offered = []
    for b in backends:
        shutil.copyfile(dist / b.loader, lib / b.loader)
        shutil.copyfile(dist / b.worker, lib / b.worker)
        _gzipped(dist / b.wasm, lib / f"{b.wasm}.gz")
        offered.append({"backend": b.name, "loader": b.loader, "worker": b.worker, "wasm": f"{b.wasm}.gz"})
    return offered
