"""The page in headless Chromium: the folder served by :class:`morf.web.server.WebServer`, the page
opened with a harness query (``bench=N``, ``check=1``, ``report=N``: resources/web/harness.js) and
what it posts to ``/result`` returned. WebGL runs on SwiftShader (software, the same on every
machine); WASM threads need the isolation headers, which the server sends unless told not to.
The tests and ``morf bench web`` use it; Node is never needed.
"""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import tempfile
import time
from pathlib import Path

from morf.errors import InputError
from morf.web.server import WebServer

BROWSERS = ("chromium-headless-shell", "chromium", "chromium-browser", "google-chrome")
BROWSER_FLAGS = ("--headless", "--use-gl=angle", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
                 "--ignore-gpu-blocklist", "--disable-dev-shm-usage", "--no-first-run", "--mute-audio",
                 "--disable-extensions", "--hide-scrollbars", "--window-size=800,900",
                 "--disable-background-timer-throttling", "--disable-renderer-backgrounding",
                 # every host but the local server unresolvable: a page that asked another would fail
                 "--host-resolver-rules=MAP * ~NOTFOUND , EXCLUDE 127.0.0.1")


def find_chromium(explicit: str | None = None) -> str | None:
    """The Chromium binary: ``explicit``, else $CHROMIUM, else the first of :data:`BROWSERS` on PATH."""
    if explicit or os.environ.get("CHROMIUM"):
        return shutil.which(explicit or os.environ["CHROMIUM"])
    return next((p for p in map(shutil.which, BROWSERS) if p), None)


def missing_browser(explicit: str | None = None) -> str | None:
    """Why the page cannot be driven here (a sentence), or None."""
    if find_chromium(explicit) is None:
        return (f"no Chromium ({' / '.join(BROWSERS)} on PATH, or $CHROMIUM); "
                "Debian: apt-get install chromium-headless-shell")
    return None


def end_group(proc: subprocess.Popen, wait: float = 10.0) -> None:
    """End the process group led by ``proc`` (started with ``start_new_session``): SIGTERM, then
    SIGKILL for what is left after ``wait`` seconds (Debian's chromium wrappers do not exec)."""

    def gone() -> bool:
        proc.poll()  # reap the leader, so that an emptied group reads as gone
        try:
            os.killpg(proc.pid, 0)
            return False
        except ProcessLookupError:
            return True

    for sig in (signal.SIGTERM, signal.SIGKILL):
        if gone():
            break
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            break
        deadline = time.monotonic() + wait
        while not gone() and time.monotonic() < deadline:
            time.sleep(0.1)
    proc.wait()


def run_page(folder: str | Path, query: str, extra: dict[str, Path] | None = None, isolation: bool = True,
             chromium: str | None = None, timeout: float = 300.0, log: Path | None = None) -> dict:
    """Open ``folder``'s index.html?``query`` in headless Chromium; returns what the page posted.

    ``extra``: URL path -> file served beside the folder (``/check.json``). Raises InputError when
    Chromium is missing, TimeoutError when the page does not post within ``timeout`` seconds,
    RuntimeError when the browser exits first."""
    browser = find_chromium(chromium)
    if browser is None:
        raise InputError(missing_browser(chromium))
    server = WebServer(folder, isolation=isolation, extra=extra, accept_results=True).start()
    url = f"{server.url}index.html?{query}"
    sandbox = ("--no-sandbox",) if os.geteuid() == 0 else ()  # Chromium refuses root with its sandbox on
    with tempfile.TemporaryDirectory(prefix="morf-web-", ignore_cleanup_errors=True) as profile:
        out = open(log, "wb") if log else subprocess.DEVNULL
        proc = subprocess.Popen([browser, *BROWSER_FLAGS, *sandbox, f"--user-data-dir={profile}", url],
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            deadline = time.monotonic() + timeout
            while not server.posted.wait(0.25):
                if proc.poll() is not None:
                    raise RuntimeError(f"Chromium exited ({proc.returncode}) before the page reported")
                if time.monotonic() > deadline:
                    raise TimeoutError(f"the page did not report within {timeout:.0f} s")
        finally:
            end_group(proc)
            server.stop()
            if log:
                out.close()
    result = server.results[0]
    result["requests"] = server.log
    return result
