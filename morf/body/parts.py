"""Body parts of a skinned model: which bones, vertices, faces and texels belong to the head and
to each hand.

A part is a bone and all its descendants (Anny: ``head`` with the eyes; ``wrist.L`` / ``wrist.R``
with the metacarpals and fingers). A vertex belongs to the part of the bone that weighs most in
its skinning, a face to the part most of its corners belong to. The part atlas paints each
part's faces into texture space, so the part under any rasterized pixel is one look-up of its UV:
the rasterization of a frame's fit already says which pixels show the head, occlusion included,
with no second rasterization.
"""

from __future__ import annotations

import numpy as np

# part codes in the atlas; 0 is "none of these"
PARTS = {"head": 1, "hand.L": 2, "hand.R": 3}
# the bone that roots each part, in the body model's bone names
PART_ROOTS = {"head": "head", "hand.L": "wrist.L", "hand.R": "wrist.R"}


def subtree(parents, root: int) -> list[int]:
    """Bone ``root`` and every bone below it, given each bone's parent (-1 for the root)."""
    out, frontier = [root], [root]
    while frontier:
        frontier = [j for j, p in enumerate(parents) if p in frontier]
        out += frontier
    return sorted(out)


def part_bones(model) -> dict[str, list[int]]:
    """{part name: bone indices} for every part whose root bone the model has."""
    names = list(model.bone_names)
    return {part: subtree(list(model.bone_parents), names.index(root))
            for part, root in PART_ROOTS.items() if root in names}


def vertex_parts(model) -> np.ndarray:
    """(V,) uint8 part code per model vertex (0: none), from its heaviest skinning bone."""
    dominant = model.dense_weights.argmax(1).cpu().numpy()
    labels = np.zeros(dominant.shape[0], np.uint8)
    for part, bones in part_bones(model).items():
        labels[np.isin(dominant, bones)] = PARTS[part]
    return labels


def face_parts(model) -> np.ndarray:
    """(F,) uint8 part code per face: the code at least two of its corners carry (else 0)."""
    corner = vertex_parts(model)[model.faces.cpu().numpy()]  # (F, 3)
    a, b, c = corner[:, 0], corner[:, 1], corner[:, 2]
    return np.where((a == b) | (a == c), a, np.where(b == c, b, 0)).astype(np.uint8)


def part_atlas(model, size: int = 512) -> np.ndarray:
    """(size, size) uint8 part code per texel (row = (1 - v) * size), cached on the model.

    Each part face's UV triangle is filled, then grown by one texel so that UVs interpolated
    right at a chart's edge still find their part.
    """
    import cv2

    cache = getattr(model, "_part_atlas", None)
    if cache is not None and cache.shape[0] == size:
        return cache
    labels = face_parts(model)
    uv = model.uvs.cpu().numpy()[model.face_uvs.cpu().numpy()]  # (F, 3, 2)
    px = np.stack([uv[..., 0] * size, (1 - uv[..., 1]) * size], -1)
    atlas = np.zeros((size, size), np.uint8)
    for code in sorted(set(PARTS.values())):
        layer = np.zeros_like(atlas)
        for tri in px[labels == code]:
            cv2.fillConvexPoly(layer, np.round(tri * 16).astype(np.int32), 1, lineType=cv2.LINE_8, shift=4)
        layer = cv2.dilate(layer, np.ones((3, 3), np.uint8))
        atlas[(layer > 0) & (atlas == 0)] = code
    object.__setattr__(model, "_part_atlas", atlas)
    return atlas


def pixel_parts(uv: np.ndarray, uv_mask: np.ndarray, atlas: np.ndarray) -> np.ndarray:
    """(..., H, W) uint8 part code of each rasterized pixel (0 off the mesh or off every part).

    ``uv``: (..., H, W, 2) float UVs in [0, 1], v up; ``uv_mask``: (..., H, W) mesh coverage.
    """
    size = atlas.shape[0]
    col = np.clip((uv[..., 0] * size).astype(np.int64), 0, size - 1)
    row = np.clip(((1 - uv[..., 1]) * size).astype(np.int64), 0, size - 1)
    return np.where(uv_mask, atlas[row, col], 0).astype(np.uint8)
