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


# The body model's points the face and hand landmarks see (morf.capture.landmarks_face_hands):
# the face anchors in FACE_ANCHORS order, and the 21 hand points (wrist, then thumb, index,
# middle, ring, little finger from base to tip). Anny's finger1 is the thumb, finger5 the little.
HAND_CHAIN = ("finger1-1", "finger1-2", "finger1-3", "finger2-1", "finger2-2", "finger2-3", "finger3-1",
              "finger3-2", "finger3-3", "finger4-1", "finger4-2", "finger4-3", "finger5-1", "finger5-2", "finger5-3")


def _rest(model) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rest-pose vertices (V, 3), bone heads (J, 3) at the default shape, and each vertex's heaviest bone."""
    import torch

    with torch.no_grad():
        out = model(model.zero_pose(), model.default_shape())
    return out.vertices[0].cpu().numpy(), out.joints[0].cpu().numpy(), model.dense_weights.argmax(1).cpu().numpy()


def face_anchor_vertices(model) -> tuple[tuple[int, ...], ...]:
    """Per face anchor (right eye, left eye, nose tip, mouth, chin), the model vertices whose mean
    it is, found on the rest mesh (Anny faces -Y, +X is the person's left):

    * eyes: the front-most vertex of each eyeball (``eye.R`` / ``eye.L``: the cornea, where the
      pupil is seen);
    * nose tip: the front-most head vertex on the midline;
    * chin: the lowest midline head vertex within 3 cm of the nose tip's depth (the menton, not
      the jaw's underside);
    * mouth: the front-most midline vertex of the upper lip band and of the lower lip band,
      averaged: the lips' meeting line, where MediaPipe's inner-lip points 13 and 14 and the
      iBUG inner-lip points 62 and 66 sit. The bands are fractions of the nose-to-chin height: on
      Anny's rest face the nose's underside reaches 10 %, the philtrum dips at 15-25 %, the
      upper lip bulges at 30-35 % and the lower lip at 50-57 %; bands of 5-25 % and 25-50 %
      took the nose's underside and the upper lip, 1.3 cm above the meeting line.
    """
    v, _, dominant = _rest(model)
    labels = vertex_parts(model)
    mid = (labels == PARTS["head"]) & (np.abs(v[:, 0]) < 0.004)

    def front_most(sel):
        ids = np.nonzero(sel)[0]
        return int(ids[np.argmin(v[ids, 1])])

    eyes = tuple(front_most(dominant == model.bone_index(b)) for b in ("eye.R", "eye.L"))
    nose = front_most(mid)
    ids = np.nonzero(mid & (v[:, 1] < v[nose, 1] + 0.03))[0]
    chin = int(ids[np.argmin(v[ids, 2])])
    zn, span = v[nose, 2], v[nose, 2] - v[chin, 2]
    upper = front_most(mid & (v[:, 2] < zn - 0.2 * span) & (v[:, 2] >= zn - 0.4 * span))
    lower = front_most(mid & (v[:, 2] < zn - 0.45 * span) & (v[:, 2] >= zn - 0.6 * span))
    return (eyes[0],), (eyes[1],), (nose,), (upper, lower), (chin,)


def hand_points(model, side: str) -> tuple[list[int], list[tuple[int, int]]]:
    """The 21 hand points of the ``side`` ("L" | "R") hand: ``joints`` = bone indices for the
    points that are bone heads (the wrist and the 15 finger joints), ``tips`` = (position in the
    21, vertex) for the 5 finger tips (the vertex of each last phalanx farthest from its head)."""
    v, J, dominant = _rest(model)
    joints, tips = [model.bone_index(f"wrist.{side}")], []
    for f in range(5):
        bones = [model.bone_index(f"{HAND_CHAIN[3 * f + k]}.{side}") for k in range(3)]
        joints += bones
        ids = np.nonzero(dominant == bones[-1])[0]
        tips.append((4 + 4 * f, int(ids[np.argmax(np.linalg.norm(v[ids] - J[bones[-1]], axis=1))])))
    return joints, tips
