"""A procedural clothing texture painted in the body model's UV atlas.

Every texel learns, by rasterizing the mesh in texture space, the rest-pose 3D point it covers
and its region weights (:mod:`morf.synth.regions`). Patterns are functions of the rest-pose
position, so stripes run round the body and a print sits flat on the chest, whatever the UV
layout. The shirt carries high-frequency detail (pinstripes or checks plus a text-like
print), because the detail a neural avatar keeps sharp is what the paper is about.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from morf.body.render_mesh import RenderMesh
from morf.raster.gl_atlas import bake_vertex_attributes, dilate_charts
from morf.synth.regions import HAIR, REGIONS, SHIRT, SHOES, SKIN, TROUSERS

_SKIN_TONES = ((236, 196, 170), (214, 170, 135), (176, 122, 88), (120, 80, 56), (245, 214, 190))
_HAIR = ((40, 28, 20), (90, 60, 35), (20, 20, 22), (170, 130, 80), (110, 40, 25))
_SHIRT = ((200, 40, 45), (35, 90, 170), (240, 235, 225), (40, 140, 90), (235, 180, 40), (60, 60, 70))
_TROUSERS = ((40, 55, 90), (30, 30, 34), (150, 130, 95), (85, 90, 95))
_SHOES = ((25, 25, 28), (150, 40, 35), (120, 70, 40))
_WORDS = ("MORF", "AVATAR", "HELLO", "STUDIO", "NEURAL", "WACV 24", "TEXEL")


@dataclass(frozen=True)
class ClothingTexture:
    """The painted atlas and what each texel is.

    Fields:
        image: (S, S, 3) uint8 RGB atlas, row 0 = v 1, charts dilated into the empty space.
        region: (S, S) int8 region index (:data:`morf.synth.regions.REGIONS`), -1 off the charts.
        coverage: (S, S) bool texels covered by the mesh.
        pattern: name of the shirt pattern ("stripes" or "checks").
    """

    image: np.ndarray
    region: np.ndarray
    coverage: np.ndarray
    pattern: str


def paint_clothing(mesh: RenderMesh, rest_vertices: np.ndarray, vertex_regions: np.ndarray,
                   rest_keypoints: np.ndarray, size: int, rng: np.random.Generator,
                   style: str = "print") -> ClothingTexture:
    """Paint shirt, trousers, shoes, skin and hair colours into a ``size`` x ``size`` atlas.

    Args:
        mesh: render mesh; rest_vertices: (V, 3) model-topology rest-pose vertices;
        vertex_regions: (V, 5) region weights per model vertex; rest_keypoints: (23, 3).
        rng: colours, pattern and print text are drawn from it.
        style: "print" (patterned shirt with a chest print, twill trousers) or "plain" (flat colours).
            Both draw the same random numbers, so a plain scene differs from its printed twin only in
            the clothing detail.
    """
    attrs = np.concatenate([rest_vertices[mesh.vertex_map], vertex_regions[mesh.vertex_map]], axis=1)
    baked, coverage = bake_vertex_attributes(mesh, attrs, size)
    pos, weights = baked[..., :3], baked[..., 3:]
    region = np.where(coverage, weights.argmax(-1), -1).astype(np.int8)
    x, y, z = pos[..., 0], pos[..., 1], pos[..., 2]
    kp = rest_keypoints

    def pick(palette):
        return np.asarray(palette[rng.integers(len(palette))], np.float32)

    skin, hair, shirt, trousers, shoes = (pick(p) for p in (_SKIN_TONES, _HAIR, _SHIRT, _TROUSERS, _SHOES))
    accent = np.float32(255) - shirt if rng.random() < 0.5 else pick(_SHIRT)
    if np.abs(accent - shirt).sum() < 120:  # keep the print visible on the shirt
        accent = np.where(shirt.mean() > 128, 20.0, 235.0).astype(np.float32) * np.ones(3, np.float32)
    img = np.zeros((size, size, 3), np.float32)

    # Skin: low-frequency blotches, and a simple face so a pose detector sees one.
    noise = _smooth_noise(size, rng, scale=size // 32)
    img[:] = skin * (0.95 + 0.08 * noise[..., None])
    _paint_face(img, pos, kp, skin)

    # Shirt: pinstripes or checks around the body, plus a text print on the chest.
    pattern = "stripes" if rng.random() < 0.5 else "checks"
    period = rng.uniform(0.025, 0.045)
    angle = np.arctan2(x, -y)  # 0 at the front, +-pi at the back
    around = angle * 0.16  # about the torso's radius: metres around the body
    if pattern == "stripes":
        stripe = (np.mod(z / period, 1.0) < 0.35).astype(np.float32)
        fine = (np.mod(z / (period / 4), 1.0) < 0.2).astype(np.float32)
        shirt_img = shirt * (1 - 0.55 * stripe[..., None]) * (1 - 0.25 * fine[..., None]) + accent * 0.55 * stripe[..., None]
    else:
        cx = np.mod(around / period, 1.0) < 0.5
        cz = np.mod(z / period, 1.0) < 0.5
        check = (cx ^ cz).astype(np.float32)
        grid = ((np.mod(around / (period / 2), 1.0) < 0.12) | (np.mod(z / (period / 2), 1.0) < 0.12)).astype(np.float32)
        shirt_img = shirt * (1 - 0.45 * check[..., None]) + accent * 0.45 * check[..., None]
        shirt_img = shirt_img * (1 - 0.35 * grid[..., None]) + accent * 0.35 * grid[..., None]
    print_mask = _chest_print(pos, kp, rng)
    shirt_img = shirt_img * (1 - print_mask[..., None]) + accent * print_mask[..., None]
    if style == "plain":
        shirt_img = np.broadcast_to(shirt, shirt_img.shape)
    sel = region == SHIRT
    img[sel] = shirt_img[sel]

    # Trousers: a fine diagonal twill and darker side seams.
    twill = np.sin((z + around) * 2 * np.pi / 0.006)
    seam = np.exp(-((np.abs(angle) - np.pi / 2) / 0.05) ** 2)
    trouser_img = trousers * (1 + 0.07 * twill[..., None]) * (1 - 0.3 * seam[..., None])
    if style == "plain":
        trouser_img = np.broadcast_to(trousers, trouser_img.shape)
    sel = region == TROUSERS
    img[sel] = trouser_img[sel]

    # Shoes with a light sole; hair with strands along the head.
    sole = z < z[region == SHOES].min() + 0.012 if (region == SHOES).any() else np.zeros_like(z, bool)
    shoe_img = np.where(sole[..., None], np.float32(230), shoes)
    sel = region == SHOES
    img[sel] = shoe_img[sel]
    strands = _smooth_noise(size, rng, scale=2)
    sel = region == HAIR
    img[sel] = (hair * (0.85 + 0.3 * strands[..., None]))[sel]

    img = np.clip(img, 0, 255)
    img[~coverage] = 0
    image = dilate_charts(img.astype(np.uint8), coverage, iterations=max(4, size // 48))
    return ClothingTexture(image=image, region=region, coverage=coverage, pattern=pattern)


def _smooth_noise(size: int, rng: np.random.Generator, scale: int) -> np.ndarray:
    """(size, size) noise in [-1, 1] with features about ``scale`` texels across."""
    n = rng.standard_normal((size, size)).astype(np.float32)
    k = max(1, scale) | 1
    n = cv2.GaussianBlur(n, (0, 0), sigmaX=k / 2)
    return n / max(float(np.abs(n).max()), 1e-6)


def _chest_print(pos: np.ndarray, kp: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """(S, S) float mask of a word printed on the shirt front, by rest-pose (x, z)."""
    word = _WORDS[rng.integers(len(_WORDS))]
    shoulders_z = kp[5:7, 2].mean()
    hips_z = kp[11:13, 2].mean()
    width = 0.8 * abs(kp[5, 0] - kp[6, 0])
    top = shoulders_z - 0.25 * (shoulders_z - hips_z)
    height = 0.22 * (shoulders_z - hips_z)
    W, H = 400, int(400 * height / width)
    canvas = np.zeros((H, W), np.uint8)
    scale = 1.0
    (tw, th), _ = cv2.getTextSize(word, cv2.FONT_HERSHEY_DUPLEX, scale, 2)
    scale = min(0.9 * W / tw, 0.6 * H / th)
    (tw, th), _ = cv2.getTextSize(word, cv2.FONT_HERSHEY_DUPLEX, scale, max(1, int(2 * scale)))
    cv2.putText(canvas, word, ((W - tw) // 2, (H + th) // 2), cv2.FONT_HERSHEY_DUPLEX, scale, 255,
                max(1, int(2 * scale)), cv2.LINE_AA)
    cv2.rectangle(canvas, (2, 2), (W - 3, H - 3), 255, 3)
    x, y, z = pos[..., 0], pos[..., 1], pos[..., 2]
    # Seen from the front (from -Y) the person's left, +X, is on the viewer's right: text runs along +X.
    u = ((x + width / 2) / width * W)
    v = ((top - z) / height * H)
    front = y < kp[5:7, 1].mean()
    inside = front & (u >= 0) & (u < W - 1) & (v >= 0) & (v < H - 1)
    out = np.zeros(x.shape, np.float32)
    vals = cv2.remap(canvas.astype(np.float32), u.astype(np.float32), v.astype(np.float32), cv2.INTER_LINEAR)
    out[inside] = vals[inside] / 255.0
    return out


def _paint_face(img: np.ndarray, pos: np.ndarray, kp: np.ndarray, skin: np.ndarray) -> None:
    """Eyes, brows and lips as soft spots around the rest-pose face keypoints."""
    def spot(center, rx, rz, colour, strength):
        d = ((pos[..., 0] - center[0]) / rx) ** 2 + ((pos[..., 2] - center[2]) / rz) ** 2
        front = pos[..., 1] < center[1] + 0.03
        a = (np.exp(-d * 2.0) * front * strength)[..., None]
        img[:] = img * (1 - a) + np.asarray(colour, np.float32) * a

    nose = kp[0]
    for eye in (kp[1], kp[2]):
        spot(eye, 0.012, 0.006, (250, 250, 250), 0.9)
        spot(eye, 0.005, 0.005, (40, 30, 25), 1.0)
        spot(eye + np.array([0, 0, 0.018]), 0.018, 0.004, skin * 0.35, 0.9)
    mouth = nose - np.array([0, 0, 0.045])
    spot(mouth, 0.02, 0.006, (170, 70, 70), 0.8)


__all__ = ["ClothingTexture", "paint_clothing", "REGIONS", "SKIN"]
