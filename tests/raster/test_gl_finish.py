"""glFinish through ctypes: it waits for the GL work like moderngl's, without holding the GIL."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from morf.raster.gl_context import create_headless_context
from morf.raster.gl_finish import gil_free_finish

pytestmark = pytest.mark.gl

VS = """#version 330
void main() { vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2); gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0); }
"""
FS = """#version 330
out vec4 colour;
void main() {
    float a = gl_FragCoord.x * 1e-3;
    for (int i = 0; i < 100; i++) a = sin(a * 1.7 + 0.3);
    colour = vec4(a, 0.0, 0.0, 1.0);
}
"""


def test_the_ctypes_finish_is_found_for_a_headless_context_and_waits_for_the_draw():
    ctx = create_headless_context()
    finish = gil_free_finish(ctx)
    assert finish is not ctx.finish  # found through EGL, not moderngl's fallback
    fbo = ctx.simple_framebuffer((64, 64))
    fbo.use()
    fbo.clear(0.25, 0.5, 1.0, 1.0)
    finish()
    px = np.frombuffer(fbo.read(components=3), np.uint8).reshape(64, 64, 3)
    assert tuple(px[10, 10]) == (64, 128, 255)
    ctx.release()


def _spinner_share_during_finish(finish, ctx) -> tuple[float, float]:
    """(the share of a free-running thread's pace kept while ``finish`` waits, the wait in s)."""
    fbo = ctx.simple_framebuffer((1024, 1024))
    fbo.use()
    prog = ctx.program(vertex_shader=VS, fragment_shader=FS)
    vao = ctx.vertex_array(prog, [])
    count, stop = [0], threading.Event()

    def spin():
        while not stop.is_set():
            count[0] += 1

    t = threading.Thread(target=spin)
    t.start()
    try:
        c0, t0 = count[0], time.perf_counter()
        time.sleep(0.05)  # the spinner alone: its pace
        rate = (count[0] - c0) / (time.perf_counter() - t0)
        vao.render(vertices=3)  # a slow full-screen triangle: llvmpipe shades it on its own threads
        c0, t0 = count[0], time.perf_counter()
        finish()
        seconds = time.perf_counter() - t0
        counted = count[0] - c0
    finally:
        stop.set()
        t.join()
        vao.release()
        prog.release()
        fbo.release()
    return counted / (rate * seconds), seconds


def test_other_threads_run_while_it_waits():
    """A Python thread keeps most of its pace while this one sits in the ctypes glFinish; moderngl's
    finish holds the GIL and stops it (at most one switch interval before the call)."""
    ctx = create_headless_context()
    try:
        share, seconds = _spinner_share_during_finish(gil_free_finish(ctx), ctx)
        held, held_seconds = _spinner_share_during_finish(ctx.finish, ctx)
    finally:
        ctx.release()
    if min(seconds, held_seconds) < 0.03:
        pytest.skip("the driver finished too fast to tell")
    assert share > 0.3 and held < 0.2
