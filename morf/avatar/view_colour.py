"""View-dependent colour: the texture's colour channels (0-2) chosen by the direction the body is
seen from.

One colour texture projected from every training frame averages each texel over frames whose
fits disagree by a pixel or two and whose light, folds and gaze differ, so the face's small
detail (the eyes, the mouth's line) blurs. The frames that see the body from about the same
direction agree far better. So besides the one colour texture an avatar keeps K more, each
projected from the few training frames whose root orientation (the body's rotation in camera
coordinates, bone 0 of the pose) is nearest one of K anchor orientations spread over the ones
the capture showed; at render time the colour channels are the blend of the anchors nearest the
pose's own root orientation (:meth:`ViewColours.weights`). Texels those frames did not see keep
the one texture's colour. The renderer and the 13 neural channels are unchanged.

The classic form is view-dependent texture mapping (Debevec et al. 1996), here in texture space
and keyed by the body's orientation rather than the camera's, since the camera of a capture stays
where it is and the person turns.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.rotations import rotvec_to_matrix_rodrigues

BLEND = 3  # anchors blended at a time; the next one's distance fades the last in and out


def angles_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Geodesic angles (radians) between rotation matrices ``a`` (N, 3, 3) and ``b`` (M, 3, 3): (N, M)."""
    tr = np.einsum("nij,mij->nm", a, b)  # trace(a^T b)
    return np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0))


def spread_anchors(rot: np.ndarray, k: int) -> np.ndarray:
    """Indices of ``k`` of the rotations ``rot`` (N, 3, 3) spread over them: farthest-point sampling
    from the one nearest all the others, by geodesic angle."""
    n = len(rot)
    if k >= n:
        return np.arange(n)
    d = angles_between(rot, rot)
    chosen = [int(np.argmin(d.sum(1)))]
    nearest = d[chosen[0]].copy()
    while len(chosen) < k:
        nxt = int(np.argmax(nearest))
        chosen.append(nxt)
        nearest = np.minimum(nearest, d[nxt])
    return np.asarray(chosen)


def anchor_weights(anchors: np.ndarray, orientation: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(indices, weights) of the ``anchors`` (K, 3, 3) blended for a root orientation matrix (3, 3):
    the ``BLEND`` nearest, each weighted by the square of how much nearer it is than the next one,
    so a weight reaches zero exactly when its anchor stops being among the nearest (no jump as the
    body turns) and the nearest anchor leads the blend. As many anchors as ``BLEND`` or fewer: all,
    alike.

    Squared, not linear: with linear weights the other anchors' colours ghosted the eyes of
    People-Snapshot's held-out frames; squared, its head SSIM+-shift rose 0.897 -> 0.900 and person
    PSNR +0.15 dB, tennis +0.002 and +0.05 dB, the outdoor clip and the demo's capture within
    0.001 and 0.04 dB (docs/avatar.md, "The face's finest detail")."""
    ang = angles_between(np.asarray(orientation, np.float64)[None], np.asarray(anchors, np.float64))[0]
    if len(ang) <= BLEND:
        order = np.argsort(ang)
        return order, np.full(len(order), 1.0 / len(order))
    order = np.argsort(ang, kind="stable")[:BLEND + 1]
    w = (ang[order[BLEND]] - ang[order[:BLEND]]) ** 2
    total = w.sum()
    w = np.full(BLEND, 1.0 / BLEND) if total <= 1e-12 else w / total
    return order[:BLEND], w


def view_orientation(camera_R: np.ndarray, root_frame: np.ndarray, root_rotvec: np.ndarray) -> np.ndarray:
    """(3, 3) the body's orientation relative to a camera: the root bone's world rotation
    ``root_frame^T R(rotvec) root_frame`` (:meth:`morf.export.skeleton.SkinningSkeleton.bone_transforms`:
    a pose's bone 0 turns about the skeleton's reference frame ``root_frame``) seen through the
    world-to-camera rotation ``camera_R``."""
    U = np.asarray(root_frame, np.float64)
    return np.asarray(camera_R, np.float64) @ U.T @ rotvec_to_matrix_rodrigues(root_rotvec) @ U


@dataclass(frozen=True)
class ViewColours:
    """The colour channels by view.

    Fields:
        anchors: (K, 3, 3) float32 body orientations relative to the capture camera
            (:func:`view_orientation`) the colours were projected for;
        colours: (K, 3, S, S) uint8 colour channels, texture layout (row 0 = v 1), 0-255 for 0-1;
        frames: how many training frames nearest each anchor were projected into it;
        root_frame: (3, 3) the skeleton's reference rotation of bone 0; camera_R: (3, 3) the
            capture camera's world-to-camera rotation (poses of that capture are turned into
            orientations through both).
    """

    anchors: np.ndarray
    colours: np.ndarray
    frames: int
    root_frame: np.ndarray
    camera_R: np.ndarray

    @property
    def count(self) -> int:
        return int(self.anchors.shape[0])

    def weights(self, root_rotvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(indices, weights) of the anchors blended for a root orientation (3,) axis-angle
        (:func:`anchor_weights`)."""
        return anchor_weights(self.anchors, view_orientation(self.camera_R, self.root_frame, root_rotvec))

    def colour(self, root_rotvec: np.ndarray) -> np.ndarray:
        """(3, S, S) float32 colour channels (0-1) for a root orientation."""
        idx, w = self.weights(root_rotvec)
        out = np.zeros(self.colours.shape[1:], np.float32)
        for i, wi in zip(idx, w):
            out += np.float32(wi / 255.0) * self.colours[i].astype(np.float32)
        return out

    def texture_for(self, texture, root_rotvec: np.ndarray):
        """``texture`` (C, S, S) torch tensor with channels 0-2 replaced by the colour for ``root_rotvec``."""
        import torch

        out = texture.clone()
        out[:3] = torch.from_numpy(self.colour(root_rotvec)).to(texture.dtype)
        return out

    def to_dict(self) -> dict:
        """Tensors for avatar.pt (loaded with weights_only)."""
        import torch

        return {"anchors": torch.from_numpy(np.ascontiguousarray(self.anchors, np.float32)),
                "colours": torch.from_numpy(np.ascontiguousarray(self.colours, np.uint8)), "frames": int(self.frames),
                "root_frame": torch.from_numpy(np.ascontiguousarray(self.root_frame, np.float64)),
                "camera_R": torch.from_numpy(np.ascontiguousarray(self.camera_R, np.float64))}

    @staticmethod
    def from_dict(d: dict) -> "ViewColours":
        anchors = np.asarray(d["anchors"], np.float32)
        colours = np.asarray(d["colours"], np.uint8)
        if anchors.ndim != 3 or anchors.shape[1:] != (3, 3) or colours.ndim != 4 or colours.shape[:2] != (
                anchors.shape[0], 3):
            raise ValueError(f"view colours of shapes {anchors.shape} and {colours.shape} do not match")
        frames_R = [np.asarray(d[k], np.float64) for k in ("root_frame", "camera_R")]
        if any(m.shape != (3, 3) for m in frames_R):
            raise ValueError("view colours' root_frame and camera_R must be 3 x 3")
        return ViewColours(anchors, colours, int(d.get("frames", 0)), *frames_R)


@dataclass(frozen=True)
class ViewColourBytes:
    """View colours as an exported avatar holds them: in the texture's own bytes (channels 0-2,
    quantised with the texture's scales), so the player blends bytes.

    Fields: anchors (K, 3, 3) float32 root orientations relative to the camera; data (K, Ht, Wt, 3) uint8.
    """

    anchors: np.ndarray
    data: np.ndarray

    def blend_weights(self, orientation: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """(anchor indices, integer weights summing to 256) of the blend for a root orientation
        matrix (3, 3) relative to the camera: :func:`anchor_weights` in steps of 1/256, fine enough
        that a byte moves by at most one, coarse enough that a still body reuses its blend."""
        idx, w = anchor_weights(self.anchors, orientation)
        q = np.floor(w * 256.0).astype(np.int64)
        q[int(np.argmax(w))] += 256 - int(q.sum())
        keep = q > 0
        return tuple(int(i) for i in idx[keep]), tuple(int(v) for v in q[keep])

    def blend(self, orientation: np.ndarray, weights=None) -> np.ndarray:
        """(Ht, Wt, 3) uint8 colour bytes for a root orientation matrix (3, 3) relative to the camera
        (or for ``weights`` from :meth:`blend_weights`), blended in integers."""
        idx, q = self.blend_weights(orientation) if weights is None else weights
        if len(idx) == 1:
            return self.data[idx[0]]
        out = np.full(self.data.shape[1:], 128, np.uint16)  # rounding
        for i, wi in zip(idx, q):
            out += self.data[i].astype(np.uint16) * np.uint16(wi)
        return (out >> 8).astype(np.uint8)


def quantize_view_colours(views: ViewColours, scales: np.ndarray, zero_point: int) -> ViewColourBytes:
    """``views`` in texture bytes of channel ``scales`` (3,) (:func:`morf.raster.texture_quant.quantize_texture`)."""
    c = views.colours.astype(np.float32) / 255.0  # (K, 3, S, S)
    q = np.rint(c / np.asarray(scales, np.float32)[None, :, None, None]) + zero_point
    q = np.clip(q, zero_point - 127, zero_point + 127).astype(np.uint8)
    return ViewColourBytes(np.asarray(views.anchors, np.float32), np.ascontiguousarray(q.transpose(0, 2, 3, 1)))
