"""``morf serve OUT``: a web folder on a local HTTP server, with the cross-origin isolation headers
(``Cross-Origin-Opener-Policy: same-origin``, ``Cross-Origin-Embedder-Policy: require-corp``) that
let the page share memory with its WASM threads. Without them (``isolation=False``, as a plain
static host serves) the page runs onnxruntime on one thread and says so.

The same server, with a ``/result`` endpoint the page posts to, drives the page in headless
Chromium for the tests and ``morf bench web`` (:mod:`morf.web.browser`).
"""

from __future__ import annotations

import json
import threading
import time
from urllib.parse import parse_qs, urlsplit
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

ISOLATION_HEADERS = {"Cross-Origin-Opener-Policy": "same-origin", "Cross-Origin-Embedder-Policy": "require-corp",
                     "Cross-Origin-Resource-Policy": "same-origin"}
MIME = {".js": "text/javascript", ".mjs": "text/javascript", ".wasm": "application/wasm", ".gz": "application/gzip",
        ".json": "application/json", ".onnx": "application/octet-stream", ".bin": "application/octet-stream",
        ".css": "text/css", ".html": "text/html"}


class WebServer(ThreadingHTTPServer):
    """Serves ``root`` (read-only) on ``host:port`` (port 0: any free one).

    Fields beyond the server's: ``isolation`` (send the headers), ``extra`` (URL path -> file, e.g.
    a check's request), ``results`` (what the page posted to ``/result``, in order), ``posted`` (an
    Event set on each post), ``log`` (the requests, "METHOD path status"), ``marks`` (the page's
    posts to ``/mark?name=NAME``: name, monotonic seconds and ``cpu_probe()``'s CPU seconds then, so
    that a measurement's own CPU time can be told from the page's loading), ``cpu_probe`` (a
    callable giving the browser's CPU seconds so far per kind of process, or None), ``thread_probe``
    (the same per thread, recorded in each mark as ``threads``)."""

    daemon_threads = True

    def __init__(self, root: str | Path, host: str = "127.0.0.1", port: int = 0, isolation: bool = True,
                 extra: dict[str, Path] | None = None, accept_results: bool = False):
        self.root, self.isolation = Path(root).resolve(), isolation
        self.extra = dict(extra or {})
        self.accept_results = accept_results
        self.results: list[dict] = []
        self.posted = threading.Event()
        self.log: list[str] = []
        self.marks: list[dict] = []
        self.cpu_probe = None
        self.thread_probe = None  # the same per thread (morf.web.browser.group_cpu_by_thread)
        super().__init__((host, port), _Handler)

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        return f"http://{host}:{port}/"

    def start(self) -> "WebServer":
        threading.Thread(target=self.serve_forever, daemon=True).start()
        return self

    def stop(self) -> None:
        self.shutdown()
        self.server_close()


class _Handler(SimpleHTTPRequestHandler):
    extensions_map = {**SimpleHTTPRequestHandler.extensions_map, **MIME}

    def __init__(self, *args, **kwargs):
        super().__init__(*args, directory=str(args[2].root), **kwargs)

    def end_headers(self) -> None:
        if self.server.isolation:
            for k, v in ISOLATION_HEADERS.items():
                self.send_header(k, v)
        self.send_header("Cache-Control", "no-cache")
        super().end_headers()

    def translate_path(self, path: str) -> str:
        mapped = self.server.extra.get(path.split("?", 1)[0])
        return str(mapped) if mapped else super().translate_path(path)

    def do_POST(self) -> None:  # noqa: N802 (http.server's naming)
        body = self.rfile.read(int(self.headers.get("Content-Length", 0)))
        url = urlsplit(self.path)
        if self.server.accept_results and url.path == "/mark":  # taken before answering: the page waits for it
            probe = self.server.cpu_probe
            name = parse_qs(url.query).get("name", [""])[0]
            threads = self.server.thread_probe
            self.server.marks.append({"name": name, "time": time.monotonic(), "cpu": probe() if probe else None,
                                      "threads": threads() if threads else None})
        ok = self.server.accept_results and url.path in ("/result", "/mark")
        self.send_response(204 if ok else 404)
        self.end_headers()
        if ok and url.path == "/result":
            self.server.results.append(json.loads(body))
            self.server.posted.set()

    def log_request(self, code="-", size="-") -> None:
        self.server.log.append(f"{self.command} {self.path} {code}")

    def log_message(self, *args) -> None:
        pass
