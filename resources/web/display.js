// The image onto a 2D canvas, for the tail played in JavaScript (software WebGL): the window's
// pixels are put straight from the tail's buffer (putImageData of the window only), instead of
// uploaded into a WebGL texture and copied onto a WebGL canvas of the whole output, which
// SwiftShader then hands to the browser's compositor. Outside the window the canvas shows the
// background: the part of the last window the new one does not cover is filled with it.

export class CanvasDisplay {
  // canvas: the page's <canvas>, given a 2D context here (a CPU-backed one unless accelerated:
  // putImageData is then a copy into the canvas's bitmap).
  constructor(canvas, accelerated = false) {
    this.canvas = canvas;
    this.ctx = canvas.getContext('2d', { alpha: false, willReadFrequently: !accelerated });
    if (!this.ctx) throw new Error('this browser gives the page no 2D canvas');
    this.placed = null;
    this.scratch = null;  // a canvas of the whole image, for a close-up's enlargement
  }

  // image: {pixels: ImageData of the window, crop: {x, y, w, h}, background: [r, g, b], size};
  // canvasSize: the canvas's side; box: the part of the image shown (0-1, rows top first).
  show(image, canvasSize, box = [0, 0, 1, 1]) {
    const whole = canvasSize === image.size && box[0] === 0 && box[1] === 0 && box[2] === 1 && box[3] === 1;
    if (whole) {
      this.put(this.ctx, image, this.placed);
      this.placed = { ...image.crop, bg: image.background.join(), size: canvasSize };
      return;
    }
    // a close-up: the image whole on a scratch canvas, its box drawn enlarged (bilinear, as the GL pass samples)
    if (!this.scratch || this.scratch.canvas.width !== image.size) {
      const c = document.createElement('canvas');
      c.width = c.height = image.size;
      this.scratch = { canvas: c, ctx: c.getContext('2d', { alpha: false }), placed: null };
    }
    this.put(this.scratch.ctx, image, this.scratch.placed);
    this.scratch.placed = { ...image.crop, bg: image.background.join(), size: image.size };
    const s = image.size;
    this.ctx.imageSmoothingEnabled = true;
    this.ctx.drawImage(this.scratch.canvas, box[0] * s, box[1] * s, box[2] * s, box[3] * s, 0, 0, canvasSize, canvasSize);
    this.placed = null;  // the whole canvas was drawn: the next frame fills what its window leaves
  }

  // The window's pixels, after the background where the last window (or anything else) was outside this one.
  put(ctx, image, placed) {
    const c = image.crop, bg = image.background.join();
    const inside = placed && placed.bg === bg && placed.size === image.size && c.x <= placed.x && c.y <= placed.y
      && c.x + c.w >= placed.x + placed.w && c.y + c.h >= placed.y + placed.h;
    if (!inside && !(c.w === image.size && c.h === image.size)) {
      ctx.fillStyle = `rgb(${bg})`;
      if (placed && placed.bg === bg && placed.size === image.size) ctx.fillRect(placed.x, placed.y, placed.w, placed.h);
      else ctx.fillRect(0, 0, image.size, image.size);
    }
    ctx.putImageData(image.pixels, c.x, c.y);
  }
}
