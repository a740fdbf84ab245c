"""The page in headless Chromium: the folder served by :class:`morf.web.server.WebServer`, the page
opened with a harness query (``bench=N``, ``check=1``, ``report=N``: resources/web/harness.js) and
what it posts to ``/result`` returned. WebGL runs on SwiftShader (software, the same on every
machine); WASM threads need the isolation headers, which the server sends unless told not to.
The tests and ``morf bench web`` use it; Node is never needed.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time
from collections.abc import Callable
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

# WebGPU in headless Chromium: on a machine without a GPU, SwiftShader's Vulkan adapter (software)
WEBGPU_FLAGS = ("--enable-unsafe-webgpu", "--enable-features=Vulkan", "--use-webgpu-adapter=swiftshader")


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


def group_cpu_seconds(pgid: int) -> float | None:
    """CPU seconds (user + system) used so far by the live processes of process group ``pgid``
    (Linux /proc; None elsewhere). On a shared machine a page's CPU time is steadier than its wall
    time, which other processes' load stretches."""
    by = group_cpu_by_process(pgid)
    return None if by is None else sum(by.values())


def _stat_fields(stat: str) -> list[str]:
    """The fields of a /proc stat line after the name: state, ppid, pgrp, ..., utime (index 11),
    stime (12)."""
    return stat.rsplit(")", 1)[1].split()


def _cpu_seconds(fields: list[str]) -> float:
    """utime + stime of :func:`_stat_fields`, in seconds."""
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _group_processes(pgid: int):
    """(/proc/PID, kind, CPU seconds) of the live processes of process group ``pgid``; kind: the
    Chromium process type ("renderer", "gpu-process", ...; "browser" for the main process)."""
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            fields = _stat_fields((d / "stat").read_text())
            if int(fields[2]) != pgid:
                continue
            cmdline = (d / "cmdline").read_bytes()
        except (OSError, ValueError):
            continue
        # Chromium rewrites its children's titles: the arguments may be NUL- or space-separated
        found = re.search(rb"--type=([\w-]+)", cmdline)
        yield d, found.group(1).decode() if found else "browser", _cpu_seconds(fields)


def group_cpu_by_process(pgid: int) -> dict[str, float] | None:
    """:func:`group_cpu_seconds` per kind of Chromium process ("renderer": the page's JavaScript and
    WASM; "gpu-process": WebGL, i.e. SwiftShader; "browser", "utility", ...), summed over processes
    of a kind; None where there is no /proc."""
    if not Path("/proc").is_dir():
        return None
    by: dict[str, float] = {}
    for _, kind, seconds in _group_processes(pgid):
        by[kind] = by.get(kind, 0.0) + seconds
    return by


def group_cpu_by_thread(pgid: int) -> dict[str, float] | None:
    """CPU seconds per "KIND THREAD" of the group's processes: the thread's name ("main" for a
    process's first thread; same-named threads of a kind summed: "renderer DedicatedWorker" are the
    page's workers, onnxruntime-web's thread pool among them; "gpu-process Thread<00>" SwiftShader's);
    None where there is no /proc."""
    if not Path("/proc").is_dir():
        return None
    by: dict[str, float] = {}
    for d, kind, _ in _group_processes(pgid):
        try:
            tasks = list((d / "task").iterdir())
        except OSError:
            continue
        for t in tasks:
            try:
                stat = (t / "stat").read_text()
            except OSError:
                continue
            name = "main" if t.name == d.name else stat[stat.index("(") + 1:stat.rindex(")")]
            key = f"{kind} {name}"
            by[key] = by.get(key, 0.0) + _cpu_seconds(_stat_fields(stat))
    return by


def browse_until(url: str, done: threading.Event, timeout: float = 300.0, chromium: str | None = None,
                 log: Path | None = None, flags: tuple[str, ...] = BROWSER_FLAGS,
                 started: Callable[[int], None] | None = None) -> float | None:
    """Open ``url`` in headless Chromium (a fresh profile) and wait until ``done`` is set (the page
    posted its result to the caller's server); then end the browser. Returns the CPU seconds the
    browser's processes used by then (:func:`group_cpu_seconds`). ``log``: a file for the browser's
    own output. ``started``: called with the browser's process group once it runs. Raises
    InputError when Chromium is missing, TimeoutError when ``done`` is not set
    within ``timeout`` seconds, RuntimeError when the browser exits first."""
    browser = find_chromium(chromium)
    if browser is None:
        raise InputError(missing_browser(chromium))
    sandbox = ("--no-sandbox",) if os.geteuid() == 0 else ()  # Chromium refuses root with its sandbox on
    with tempfile.TemporaryDirectory(prefix="morf-web-", ignore_cleanup_errors=True) as profile:
        out = open(log, "wb") if log else subprocess.DEVNULL
        # A session of its own: Debian's /usr/bin/chromium* are shell scripts that do not exec, so
        # the browser is ended as the process group started here, not by the wrapper's pid alone.
        proc = subprocess.Popen([browser, *flags, *sandbox, f"--user-data-dir={profile}", url],
                                stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        if started:
            started(proc.pid)
        try:
            deadline = time.monotonic() + timeout
            while not done.wait(0.25):
                if proc.poll() is not None:
                    raise RuntimeError(f"Chromium exited ({proc.returncode}) before the page reported"
                                       + (f"; see {log}" if log else ""))
                if time.monotonic() > deadline:
                    raise TimeoutError(f"the page did not report within {timeout:.0f} s")
            return group_cpu_seconds(proc.pid)
        finally:
            end_group(proc)
            if log:
                out.close()


def run_page(folder: str | Path, query: str, extra: dict[str, Path] | None = None, isolation: bool = True,
             chromium: str | None = None, timeout: float = 300.0, log: Path | None = None,
             webgpu: bool = False) -> dict:
    """Open ``folder``'s index.html?``query`` in headless Chromium; returns what the page posted.

    ``extra``: URL path -> file served beside the folder (``/check.json``). ``webgpu``: offer the
    page WebGPU (:data:`WEBGPU_FLAGS`: headless Chromium has none by default). The result's
    ``browser_cpu_s`` is the CPU time the browser's processes used until the page posted, its
    ``marks`` the page's marks with the browser's CPU seconds at each (:class:`WebServer`). Raises
    as :func:`browse_until` does."""
    if find_chromium(chromium) is None:
        raise InputError(missing_browser(chromium))
    server = WebServer(folder, isolation=isolation, extra=extra, accept_results=True).start()
    try:
        def started(pgid: int) -> None:
            server.cpu_probe = lambda: group_cpu_by_process(pgid)
            server.thread_probe = lambda: group_cpu_by_thread(pgid)

        cpu = browse_until(f"{server.url}index.html?{query}", server.posted, timeout, chromium, log,
                           BROWSER_FLAGS + (WEBGPU_FLAGS if webgpu else ()), started)
    finally:
        server.stop()
    result = server.results[0]
    result["requests"] = server.log
    result["browser_cpu_s"] = cpu
    result["marks"] = server.marks
    return result
