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
from typing import TYPE_CHECKING

import numpy as np

from morf.avatar.anchor_blend import BLEND, anchor_weights, angles_between, integer_weights, spread_anchors  # noqa: F401
from morf.rotations import rotvec_to_matrix_rodrigues

if TYPE_CHECKING:
    from morf.avatar.head_colour import HeadColourBytes, HeadColours


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
            orientations through both);
        head: the head's colour by the head's own orientation, laid over (:mod:`morf.avatar.head_colour`),
            or None.
    """

    anchors: np.ndarray
    colours: np.ndarray
    frames: int
    root_frame: np.ndarray
    camera_R: np.ndarray
    head: "HeadColours | None" = None

    @property
    def count(self) -> int:
        return int(self.anchors.shape[0])

    def weights(self, root_rotvec: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(indices, weights) of the anchors blended for a root orientation (3,) axis-angle
        (:func:`anchor_weights`)."""
        return anchor_weights(self.anchors, view_orientation(self.camera_R, self.root_frame, root_rotvec))

    def colour(self, pose: np.ndarray) -> np.ndarray:
        """(3, S, S) float32 colour channels (0-1) for a pose: (J, 3) axis-angle per bone, or (3,)
        the root's alone (then without the head's own colour)."""
        pose = np.asarray(pose, np.float64)
        idx, w = self.weights(pose.reshape(-1, 3)[0])
        out = np.zeros(self.colours.shape[1:], np.float32)
        for i, wi in zip(idx, w):
            out += np.float32(wi / 255.0) * self.colours[i].astype(np.float32)
        if self.head is not None and pose.ndim == 2:
            out = self.head.apply(out, pose, self.camera_R)
        return out

    def texture_for(self, texture, pose: np.ndarray):
        """``texture`` (C, S, S) torch tensor with channels 0-2 replaced by the colour for ``pose``
        (as :meth:`colour`)."""
        import torch

        out = texture.clone()
        out[:3] = torch.from_numpy(self.colour(pose)).to(texture.dtype)
        return out

    def to_dict(self) -> dict:
        """Tensors for avatar.pt (loaded with weights_only)."""
        import torch

        return {"anchors": torch.from_numpy(np.ascontiguousarray(self.anchors, np.float32)),
                "colours": torch.from_numpy(np.ascontiguousarray(self.colours, np.uint8)), "frames": int(self.frames),
                "root_frame": torch.from_numpy(np.ascontiguousarray(self.root_frame, np.float64)),
                "camera_R": torch.from_numpy(np.ascontiguousarray(self.camera_R, np.float64)),
                **({"head": self.head.to_dict()} if self.head is not None else {})}

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
        head = None
        if d.get("head") is not None:
            from morf.avatar.head_colour import HeadColours

            head = HeadColours.from_dict(d["head"], colours.shape[2] * colours.shape[3])
        return ViewColours(anchors, colours, int(d.get("frames", 0)), *frames_R, head=head)


@dataclass(frozen=True)
class ViewColourBytes:
    """View colours as an exported avatar holds them: in the texture's own bytes (channels 0-2,
    quantised with the texture's scales), so the player blends bytes.

    Fields: anchors (K, 3, 3) float32 root orientations relative to the camera; data (K, Ht, Wt, 3) uint8;
    head: the head's colours laid over by the head's orientation, or None.
    """

    anchors: np.ndarray
    data: np.ndarray
    head: "HeadColourBytes | None" = None

    def blend_weights(self, orientation: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """(anchor indices, integer weights summing to 256) of the blend for a root orientation
        matrix (3, 3) relative to the camera: :func:`anchor_weights` in steps of 1/256
        (:func:`integer_weights`)."""
        return integer_weights(*anchor_weights(self.anchors, orientation))

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
    from morf.raster.texture_quant import texture_bytes

    q = texture_bytes(views.colours.transpose(0, 2, 3, 1).astype(np.float32) / 255.0, scales, zero_point)
    head = None
    if views.head is not None:
        from morf.avatar.head_colour import quantize_head_colours

        head = quantize_head_colours(views.head, scales, zero_point)
    return ViewColourBytes(np.asarray(views.anchors, np.float32), q, head)
