"""What makes a synthetic capture as hard as a real one: cloth that slides over the body,
garments looser than the body, and keypoints that are noisy or plain wrong.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.synth.regions import SHIRT, TROUSERS, smooth_ramp


# ---- cloth sliding: a smooth texture-space displacement that drifts over time ---------------
@dataclass(frozen=True)
class SlideField:
    """d(uv, frame) = sum_k coeffs[frame, k] * sin(2 pi freqs[k] . uv + phases[k]), per uv axis.

    Frames render with ``uv + weight * d(uv, frame)``, ``weight`` the garment membership of the
    vertex, so the print drifts over the body the way a loose shirt slides.

    Fields:
        freqs: (K, 2) spatial frequencies in cycles per atlas side.
        phases: (K, 2) phase per component and uv axis.
        coeffs: (N, K, 2) amplitude per frame, component and uv axis (atlas units); the sum of
            absolute amplitudes never exceeds the configured maximum.
    """

    freqs: np.ndarray
    phases: np.ndarray
    coeffs: np.ndarray

    def displacement(self, uv: np.ndarray, frame: int) -> np.ndarray:
        """(M, 2) uv -> (M, 2) displacement in atlas units at ``frame``."""
        arg = 2 * np.pi * (uv @ self.freqs.T)  # (M, K)
        out = np.empty_like(uv, dtype=np.float64)
        for axis in range(2):
            out[:, axis] = np.sin(arg + self.phases[None, :, axis]) @ self.coeffs[frame, :, axis]
        return out

    def grid(self, frame: int, n: int = 32) -> np.ndarray:
        """(n, n, 2) displacement sampled on texel-centred atlas grid (row 0 = v 1)."""
        c = (np.arange(n) + 0.5) / n
        u, v = np.meshgrid(c, 1 - c)
        return self.displacement(np.stack([u.ravel(), v.ravel()], 1), frame).reshape(n, n, 2)


def make_slide_field(n_frames: int, amplitude: float, rng: np.random.Generator, components: int = 4) -> SlideField:
    """A random slowly varying field: a few cycles per atlas, one or two swings over the capture."""
    freqs = rng.uniform(1.0, 4.0, size=(components, 2)) * rng.choice([-1, 1], size=(components, 2))
    phases = rng.uniform(0, 2 * np.pi, size=(components, 2))
    t = np.linspace(0, 1, n_frames)[:, None, None]
    cycles = rng.uniform(0.5, 2.0, size=(1, components, 2))
    start = rng.uniform(0, 2 * np.pi, size=(1, components, 2))
    share = rng.dirichlet(np.ones(components), size=2).T[None]  # (1, K, 2), sums to 1 per axis
    coeffs = amplitude * share * np.sin(2 * np.pi * cycles * t + start)
    return SlideField(freqs=freqs, phases=phases, coeffs=coeffs)


def garment_weight(vertex_regions: np.ndarray) -> np.ndarray:
    """(V, 5) region weights -> (V,) how much a vertex's texture slides (shirt and trousers)."""
    return vertex_regions[:, SHIRT] + vertex_regions[:, TROUSERS]


# ---- loose garments: offsets along the normals -----------------------------------------------
def loose_offsets(rest_vertices: np.ndarray, vertex_regions: np.ndarray, rest_keypoints: np.ndarray,
                  amount: float) -> np.ndarray:
    """(V,) outward offset in metres: a shirt that flares towards its hem and wide trouser legs.

    Zero where the body is bare; at most ``amount`` at the hem and the ankles, a third of it at
    the chest and the hips, so the silhouette is wider than the body but still follows it.
    """
    z = rest_vertices[:, 2]
    shoulders = rest_keypoints[5:7, 2].mean()
    hips = rest_keypoints[11:13, 2].mean()
    ankles = rest_keypoints[15:17, 2].mean()
    shirt_flare = 1 - smooth_ramp(z, hips, shoulders - 0.1)  # 1 at the hem, 0 at the chest
    leg_flare = 1 - smooth_ramp(z, ankles, hips)  # 1 at the ankles, 0 at the hips
    shirt = vertex_regions[:, SHIRT] * (0.33 + 0.67 * shirt_flare)
    trousers = vertex_regions[:, TROUSERS] * (0.33 + 0.67 * leg_flare)
    return (amount * (shirt + trousers)).astype(np.float32)


# ---- keypoints from a wrong pose --------------------------------------------------------------
_ARM_CHAINS = {"left_arm": (5, (7, 9)), "right_arm": (6, (8, 10))}
_LEG_CHAINS = {"left_leg": (11, (13, 15, 17, 18, 19)), "right_leg": (12, (14, 16, 20, 21, 22))}
CORRUPTIONS = ("swap_arms", "rotate_arm", "rotate_leg")


def corrupt_keypoints(points: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, str]:
    """Keypoints of a wrong pose: arms swapped left for right, or one limb swung far away.

    Args:
        points: (23, 3) x, y, confidence of the true pose (confidences are kept, as a detector
            that confuses limbs is still confident).
    Returns:
        (23, 3) corrupted points and the kind of corruption (one of :data:`CORRUPTIONS`).
    """
    out = np.array(points, dtype=np.float32, copy=True)
    kind = CORRUPTIONS[rng.integers(len(CORRUPTIONS))]
    if kind == "swap_arms":
        for a, b in ((7, 8), (9, 10)):
            out[[a, b]] = out[[b, a]]
        # with the arms close to the body a swap can be small: push the elbows and wrists apart
        out[[7, 8, 9, 10], :2] += (out[[7, 8, 9, 10], :2] - out[[5, 6, 5, 6], :2]) * 0.5
        return out, kind
    chains = _ARM_CHAINS if kind == "rotate_arm" else _LEG_CHAINS
    root, chain = list(chains.values())[rng.integers(2)]
    lo, hi = (70, 140) if kind == "rotate_arm" else (45, 80)
    angle = np.deg2rad(rng.uniform(lo, hi)) * rng.choice([-1, 1])
    c, s = np.cos(angle), np.sin(angle)
    rel = out[list(chain), :2] - out[root, :2]
    out[list(chain), :2] = out[root, :2] + rel @ np.array([[c, s], [-s, c]], np.float32)
    return out, kind
