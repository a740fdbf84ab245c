"""Clothing regions on the body, from the skinning weights of each vertex.

A vertex belongs to the shirt, the trousers, the shoes or bare skin according to which bones
move it (spine and upper arms: shirt; pelvis and legs: trousers; feet: shoes); hair is the
part of the head above the brow and behind the ears, found from the rest-pose keypoints.
Weights are soft, so the boundaries stay smooth when interpolated over the UV atlas.
"""

from __future__ import annotations

import numpy as np

REGIONS = ("skin", "shirt", "trousers", "shoes", "hair")
SKIN, SHIRT, TROUSERS, SHOES, HAIR = range(len(REGIONS))


_TRUNK = -1  # spine, pelvis, thighs: shirt above the hem line, trousers below


def _bone_region(name: str) -> int:
    """The region a bone's skin belongs to (trunk and hair are split geometrically afterwards)."""
    if name.startswith(("foot", "toe")):
        return SHOES
    if name.startswith("lowerleg"):
        return TROUSERS
    if name.startswith(("pelvis", "upperleg", "spine")) or name == "root":
        return _TRUNK
    if name.startswith(("clavicle", "shoulder", "upperarm")):
        return SHIRT
    return SKIN  # neck, head, eyes, forearms, hands


def region_weights(dense_weights: np.ndarray, bone_names: list[str], rest_vertices: np.ndarray,
                   rest_keypoints: np.ndarray) -> np.ndarray:
    """Soft region membership per model vertex.

    Args:
        dense_weights: (V, J) skinning weights.
        bone_names: J bone names (Anny's).
        rest_vertices: (V, 3) shaped rest-pose vertices (Z up, facing -Y).
        rest_keypoints: (23, 3) rest-pose keypoints (COCO order: 0 nose, 1/2 eyes, 3/4 ears).
    Returns:
        (V, 5) float32 weights over :data:`REGIONS`, rows summing to 1.
    """
    W = np.asarray(dense_weights, np.float64)
    groups = np.array([_bone_region(n) for n in bone_names])
    out = np.zeros((W.shape[0], len(REGIONS)))
    for r in range(len(REGIONS)):
        out[:, r] = W[:, groups == r].sum(1)
    z, y = rest_vertices[:, 2], rest_vertices[:, 1]
    # The shirt hangs a little below the hip joints; the spine's weights alone would end it at
    # the waist and leave the pelvis to a leotard-like cut.
    hem = rest_keypoints[11:13, 2].mean() + 0.02
    trunk = W[:, groups == _TRUNK].sum(1)
    above = smooth_ramp(z, hem - 0.008, hem + 0.008)
    out[:, SHIRT] += trunk * above
    out[:, TROUSERS] += trunk * (1 - above)
    # Sleeves end half-way down the upper arm: forearm weight already counts as skin, and the
    # upper-arm weight blends into it near the elbow, which gives a soft sleeve hem.
    head = W[:, [i for i, n in enumerate(bone_names) if n in ("head", "neck03")]].sum(1)
    eyes_z = rest_keypoints[1:3, 2].mean()
    ears_y = rest_keypoints[3:5, 1].mean()
    # Hair: above the brow line, or behind the ears down to the nape; a smooth ramp, not a step.
    above_brow = smooth_ramp(z, eyes_z + 0.025, eyes_z + 0.045)
    behind = smooth_ramp(y, ears_y - 0.005, ears_y + 0.015) * smooth_ramp(z, eyes_z - 0.09, eyes_z - 0.06)
    hair = np.clip(head * np.maximum(above_brow, behind), 0, 1)
    out *= (1 - hair)[:, None]
    out[:, HAIR] += hair
    out /= np.clip(out.sum(1, keepdims=True), 1e-8, None)
    return out.astype(np.float32)


def smooth_ramp(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """0 below ``lo``, 1 above ``hi``, smoothstep in between."""
    t = np.clip((x - lo) / (hi - lo), 0, 1)
    return t * t * (3 - 2 * t)
