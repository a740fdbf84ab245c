"""The live render panel's motion folder: listed on a thread of its own, remembered between runs.

The panel calls :meth:`MotionBrowser.commit` when the user commits a path (Enter, a drop, a
recent folder) and reads :meth:`MotionBrowser.latest` each frame; neither waits on the disk. A
newer commit supersedes an older one still being listed. Folders that listed are remembered
(newest first) in a small JSON file (:func:`settings_path`), written on the same thread.
"""

from __future__ import annotations

import json
import os
import threading
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from typing import Callable

from morf.io import atomic_write_json
from studio.motion_scan import MotionScan, scan_motions

MAX_RECENT = 8
SETTINGS_ENV = "MORF_STUDIO_SETTINGS"  # a settings file to use instead of the user's


def settings_path() -> Path:
    """$MORF_STUDIO_SETTINGS, else $XDG_CONFIG_HOME/morf/studio.json (~/.config when unset)."""
    if os.environ.get(SETTINGS_ENV):
        return Path(os.environ[SETTINGS_ENV]).expanduser()
    base = os.environ.get("XDG_CONFIG_HOME") or Path.home() / ".config"
    return Path(base) / "morf" / "studio.json"


class MotionBrowser:
    """Lists committed motion folders off the UI thread; keeps the recent ones.

    Args:
        on_done: called (on the browser's thread) when a listing is ready: the app asks for a frame.
        settings: the JSON file recent folders are kept in; None: :func:`settings_path`.
        remember: False keeps recent folders in memory only.
    """

    def __init__(self, on_done: Callable[[], None] = lambda: None, settings: Path | None = None,
                 remember: bool = True):
        self._on_done = on_done
        self._settings = settings or settings_path()
        self._remember = remember
        self._lock = threading.Lock()
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="morf-motion-scan")
        self._gen = 0
        self._scan: MotionScan | None = None
        self._pending: str | None = None  # the folder being listed
        self.recent: list[str] = []
        self._pool.submit(self._load_recent)

    # ---- UI thread ----------------------------------------------------------------------
    def commit(self, folder: str) -> Future:
        """List ``folder`` on the browser's thread; the newest commit wins."""
        with self._lock:
            self._gen += 1
            gen, self._pending = self._gen, folder
        return self._pool.submit(self._list, folder, gen)

    def latest(self) -> MotionScan | None:
        """The newest finished listing (None before the first)."""
        return self._scan

    @property
    def scanning(self) -> str | None:
        """The folder being listed, or None."""
        return self._pending

    def close(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)

    # ---- the browser's thread -------------------------------------------------------------
    def _list(self, folder: str, gen: int) -> MotionScan | None:
        with self._lock:
            if gen != self._gen:  # superseded before it started
                return None
        scan = scan_motions(folder)
        with self._lock:
            if gen != self._gen:
                return None
            self._scan, self._pending = scan, None
            if scan.error is None and folder.strip():
                self.recent = [folder] + [f for f in self.recent if f != folder][:MAX_RECENT - 1]
                recent = list(self.recent)
            else:
                recent = None
        if recent is not None:
            self._save_recent(recent)
        self._on_done()
        return scan

    def _load_recent(self) -> None:
        if not self._remember:
            return
        try:
            data = json.loads(self._settings.read_text())
            folders = data.get("recent_motion_folders", []) if isinstance(data, dict) else []
            loaded = [f for f in folders if isinstance(f, str) and f.strip()][:MAX_RECENT]
        except (OSError, ValueError):
            return  # none yet, or damaged: start afresh
        with self._lock:
            self.recent = self.recent + [f for f in loaded if f not in self.recent][:MAX_RECENT - len(self.recent)]

    def _save_recent(self, recent: list[str]) -> None:
        if not self._remember:
            return
        try:
            data = json.loads(self._settings.read_text()) if self._settings.is_file() else {}
            data = data if isinstance(data, dict) else {}
        except (OSError, ValueError):
            data = {}
        data["recent_motion_folders"] = recent
        try:
            self._settings.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_json(self._settings, data)
        except OSError:
            pass  # a read-only home: the list lives for this run only
