// The output size the page plays at: smaller when the device cannot hold the target rate, larger
// again when it has headroom. Hysteresis keeps it from see-sawing between two sizes: a size is
// grown to only when the measured rate predicts the target there with a margin to spare, after a
// longer stretch of frames than a shrink needs, and a size the device just failed at is not tried
// again for a while (twice as long after each failure there).
// The cost of a frame is taken to follow its pixel count (the person's window scales with it).

export const SHRINK_FRAMES = 20;  // frames measured at a size before shrinking from it
export const GROW_FRAMES = 60;    // frames measured at a size before growing from it (about 2 s at 30 fps)
export const GROW_MARGIN = 1.2;   // the predicted rate at the larger size must beat the target by this factor
export const RETRY_MS = 5000;     // a size the device failed at is not grown back to for this long, doubled per failure

export class OutputSize {
  // sizes: the sizes offered, largest first; size: the one to start at; target: fps
  constructor(sizes, size, target) {
    this.sizes = sizes;
    this.size = size;
    this.target = target;
    this.blocked = new Map();  // size -> {until (ms), wait (ms)}: failed there, not retried before `until`
  }

  // fps: the rate measured over the last frames at the current size; frames: how many frames the
  // current size has been shown; now: ms. Returns null (keep the size) or {to, fps, from, why}.
  observe(fps, frames, now) {
    if (fps === null || !Number.isFinite(fps)) return null;
    const from = this.size;
    if (fps < this.target && frames >= SHRINK_FRAMES) {
      const want = from * Math.sqrt(fps / this.target);
      const smaller = this.sizes.filter((s) => s < from);
      const to = smaller.find((s) => s <= want) || smaller.pop();
      if (!to) return null;
      const b = this.blocked.get(from);
      const wait = b ? Math.min(2 * b.wait, 16 * RETRY_MS) : RETRY_MS;
      this.blocked.set(from, { until: now + wait, wait });
      this.size = to;
      return { from, to, fps, why: 'slow' };
    }
    if (fps >= this.target && frames >= GROW_FRAMES) {
      const to = this.sizes.filter((s) => s > from).pop();  // one step up
      if (!to) return null;
      const predicted = fps * (from / to) ** 2;
      const b = this.blocked.get(to);
      if (predicted < GROW_MARGIN * this.target || (b && now < b.until)) return null;
      this.size = to;
      return { from, to, fps, why: 'headroom' };
    }
    return null;
  }

  // Why observe() keeps the current size for this rate (a sentence: what `morf bench web` reports).
  why(fps, now) {
    const from = this.size, t = this.target;
    if (fps < t) {
      return this.sizes.some((s) => s < from) ? `${fps.toFixed(1)} fps, under ${t}, not yet measured over ${SHRINK_FRAMES} frames`
        : `the smallest size offered; ${fps.toFixed(1)} fps there`;
    }
    const to = this.sizes.filter((s) => s > from).pop();
    if (!to) return `the largest size, at ${fps.toFixed(1)} fps (target ${t})`;
    const predicted = fps * (from / to) ** 2, b = this.blocked.get(to);
    if (predicted < GROW_MARGIN * t) {
      return `${fps.toFixed(1)} fps here; ${to} px would run about ${predicted.toFixed(1)} fps, under the ${(GROW_MARGIN * t).toFixed(0)} fps ` +
        `(target + ${Math.round(100 * (GROW_MARGIN - 1))} %) a larger size needs`;
    }
    if (b && now < b.until) return `${to} px ran under ${t} fps before; not retried for ${((b.until - now) / 1000).toFixed(1)} s more`;
    return `${fps.toFixed(1)} fps; room for ${to} px once measured over ${GROW_FRAMES} frames`;
  }
}
