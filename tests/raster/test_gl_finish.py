"""glFinish through ctypes: it waits for the GL work like moderngl's, without holding the GIL."""

from __future__ import annotations

import sys
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


def _when_a_waiting_thread_runs(finish, ctx) -> tuple[float, float, float]:
    """(``finish`` called, it returned, a woken thread ran its first Python line), in
    ``perf_counter`` seconds.

    The other thread is woken just before ``finish`` is called. The switch interval is raised for
    the measurement so that it cannot take the GIL by asking for it: it runs during the wait only
    when ``finish`` releases the GIL, and that does not depend on how busy the machine is (a slow
    machine only lengthens the wait).
    """
    fbo = ctx.simple_framebuffer((512, 512))
    fbo.use()
    prog = ctx.program(vertex_shader=VS, fragment_shader=FS)
    vao = ctx.vertex_array(prog, [])
    go, ran = threading.Event(), []
    t = threading.Thread(target=lambda: (go.wait(), ran.append(time.perf_counter())))
    t.start()
    interval = sys.getswitchinterval()
    sys.setswitchinterval(30.0)
    try:
        vao.render(vertices=3)  # a slow full-screen triangle: llvmpipe shades it on its own threads
        go.set()
        called = time.perf_counter()
        finish()
        returned = time.perf_counter()
    finally:
        sys.setswitchinterval(interval)
        go.set()
        t.join()
        vao.release()
        prog.release()
        fbo.release()
    return called, returned, ran[0]


def test_other_threads_run_while_it_waits():
    """A Python thread runs while this one sits in the ctypes glFinish; moderngl's finish holds the
    GIL, so the same thread runs only after it returns. (How much of its pace a thread keeps while
    the player waits is a matter of the machine's load, measured by ``morf bench``, not here.)"""
    ctx = create_headless_context()
    try:
        free = [_when_a_waiting_thread_runs(gil_free_finish(ctx), ctx) for _ in range(3)]
        held = [_when_a_waiting_thread_runs(ctx.finish, ctx) for _ in range(3)]
    finally:
        ctx.release()
    if min(returned - called for called, returned, _ in free + held) < 0.03:
        pytest.skip("the driver finished too fast to tell")
    # the woken thread needs the OS to schedule it within the wait: on a crowded machine one of
    # three tries may miss, never all three
    assert any(called < ran < returned for called, returned, ran in free), free
    assert all(ran > returned for _, returned, ran in held), held
