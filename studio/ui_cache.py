"""The last full UI frame, kept in a texture, and the live image drawn over a copy of it.

Without a GPU a full UI frame is llvmpipe rasterizing the whole window (about 17 ms of a core at
1280 x 800: panel backgrounds, text, the live image). While the live panel plays a motion and
nothing else moves, the only change from one frame to the next is the live image. A light frame
(:meth:`StudioApp._light_frame <studio.app.StudioApp>`) copies the cached window back and draws
the new image into the rectangle the panel last drew it in, leaving the cores to the live render.
"""

from __future__ import annotations

import moderngl
import numpy as np

from studio.state import ImageRect

_VERTEX = """
#version 330
in vec2 in_pos;
out vec2 v_uv;
void main() {
    v_uv = vec2(in_pos.x * 0.5 + 0.5, 0.5 - in_pos.y * 0.5);  // row 0 of the image at the top
    gl_Position = vec4(in_pos, 0.0, 1.0);
}
"""
_FRAGMENT = """
#version 330
uniform sampler2D image;
in vec2 v_uv;
out vec4 color;
void main() { color = vec4(texture(image, v_uv).rgb, 1.0); }
"""


class UiCache:
    """A copy of the window's last full frame (:meth:`store`) and :meth:`show`, which puts it back
    with a new live image over it. Owned by the UI thread, like the window's context."""

    def __init__(self, ctx: moderngl.Context):
        self._ctx = ctx
        self._fbo: moderngl.Framebuffer | None = None
        self._program = ctx.program(vertex_shader=_VERTEX, fragment_shader=_FRAGMENT)
        quad = np.array([-1, -1, 1, -1, -1, 1, 1, 1], np.float32)
        self._vbo = ctx.buffer(quad.tobytes())
        self._vao = ctx.vertex_array(self._program, [(self._vbo, "2f", "in_pos")])
        # clamped like imgui's own draw of the image: repeat would blend the far edge into the border pixels
        self._sampler = ctx.sampler(repeat_x=False, repeat_y=False, filter=(moderngl.LINEAR, moderngl.LINEAR))
        self.rect: ImageRect | None = None  # the live image's place in the stored frame

    def ready(self, size: tuple[int, int]) -> bool:
        """A stored frame of this framebuffer size, with a live image in it."""
        return self._fbo is not None and self.rect is not None and self._fbo.size == tuple(size)

    def store(self, size: tuple[int, int], rect: ImageRect) -> None:
        """Keep what the window's back buffer holds now (call after drawing, before swapping)."""
        if self._fbo is None or self._fbo.size != tuple(size):
            self.release_frame()
            self._fbo = self._ctx.framebuffer(color_attachments=[self._ctx.texture(tuple(size), 4)])
        self._ctx.copy_framebuffer(self._fbo, self._ctx.screen)
        self.rect = rect

    def forget(self) -> None:
        """The next frame must be a full one (the stored picture no longer shows the UI)."""
        self.rect = None

    def image_viewport(self) -> tuple[int, int, int, int]:
        """The live rectangle in GL window coordinates (x, y from the bottom left, width, height)."""
        r, h = self.rect, self._fbo.size[1]
        return int(round(r.x)), int(round(h - r.y - r.side)), int(round(r.side)), int(round(r.side))

    def show(self, image: moderngl.Texture) -> None:
        """The stored frame on the window's back buffer, ``image`` drawn over the live rectangle."""
        self._ctx.copy_framebuffer(self._ctx.screen, self._fbo)
        self.draw_image(image)

    def draw_image(self, image: moderngl.Texture) -> None:
        """``image`` over the live rectangle of the back buffer, leaving the rest as it is (for a
        back buffer that still holds the stored frame: :mod:`studio.sub_buffer`)."""
        ctx = self._ctx
        w, h = self._fbo.size
        ctx.screen.use()
        ctx.disable(moderngl.BLEND | moderngl.DEPTH_TEST | moderngl.CULL_FACE)
        ctx.viewport = self.image_viewport()
        image.use(0)
        exact = round(self.rect.side) == self.rect.render_side  # pixel for pixel: no filtering to do
        self._sampler.filter = (moderngl.NEAREST, moderngl.NEAREST) if exact else (moderngl.LINEAR, moderngl.LINEAR)
        self._sampler.use(0)
        self._program["image"].value = 0
        self._vao.render(moderngl.TRIANGLE_STRIP)
        self._sampler.clear(0)  # unit 0 back to the texture's own parameters (imgui draws through it)
        ctx.viewport = (0, 0, w, h)

    def release_frame(self) -> None:
        if self._fbo is not None:
            for t in self._fbo.color_attachments:
                t.release()
            self._fbo.release()
        self._fbo, self.rect = None, None

    def release(self) -> None:
        self.release_frame()
        self._sampler.release()
        self._vao.release()
        self._vbo.release()
        self._program.release()
