"""The head's colour by the head's own orientation.

View colours (:mod:`morf.avatar.view_colour`) are keyed by the body's root orientation. A person
who plays, talks or looks about turns the head on its own: the frames nearest in body orientation
then show the face turned another way, and their mean ghosts it. So an avatar can also keep K
colours of the head's texels alone, each projected from the few training frames whose head bone
(its skinning rotation seen through the camera) is turned most like one anchor orientation; at
render time they are blended (:func:`morf.avatar.view_colour.anchor_weights`) by the pose's own
head orientation and laid over the body's view colour by each texel's head share: the head bones'
skinning weight at that point of the surface, 1 on the face and the skull, falling to 0 down the
neck, so there is no seam where the two colours meet (both sides of a UV seam share the weight).

Only the texels with a share are stored: (K, n, 3) bytes for n texels, n about a fifth of the
atlas at 256^2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from morf.avatar.anchor_blend import anchor_weights, integer_weights
from morf.rotations import rotvec_to_matrix_rodrigues

MIN_SHARE = 1.0 / 255.0  # texels whose head share rounds to zero bytes are not stored


@dataclass(frozen=True)
class HeadChain:
    """The rotations that turn a pose ("local-ref" axis-angle per bone, bone 0 the root) into the
    head bone's skinning rotation, as :meth:`morf.export.skeleton.SkinningSkeleton.bone_transforms`
    computes it along the bones from the root to the head.

    Fields: bones (m,) int bone indices root first; reference (m, 3, 3) their reference rotations
    U; rest_end (3, 3) the head bone's rest rotation R."""

    bones: np.ndarray
    reference: np.ndarray
    rest_end: np.ndarray

    def rotation(self, rotvecs: np.ndarray) -> np.ndarray:
        """(3, 3) the head bone's skinning rotation for a pose (J, 3)."""
        rotvecs = np.asarray(rotvecs, np.float64)
        U = self.reference
        D = rotvec_to_matrix_rodrigues(rotvecs[self.bones])
        W = U[0].T @ D[0] @ U[0]
        for i in range(1, len(self.bones)):
            W = W @ U[i - 1].T @ D[i] @ U[i]
        return W @ self.rest_end.T

    @staticmethod
    def along(parents, reference_rotations, rest_rotations, bone: int) -> "HeadChain":
        """The chain from the root to ``bone`` of a skeleton given by its parents (J,) (-1 for the
        root), reference rotations U (J, 3, 3) and rest rotations R (J, 3, 3)."""
        chain, b = [], int(bone)
        while b >= 0:
            chain.append(b)
            b = int(parents[b])
        chain = np.asarray(chain[::-1], np.int32)
        return HeadChain(chain, np.asarray(reference_rotations, np.float64)[chain],
                         np.asarray(rest_rotations, np.float64)[int(bone)])


def head_orientation(camera_R: np.ndarray, skinning_rotation: np.ndarray) -> np.ndarray:
    """(3, 3) the head's orientation relative to a camera: the head bone's skinning rotation seen
    through the world-to-camera rotation ``camera_R``."""
    return np.asarray(camera_R, np.float64) @ np.asarray(skinning_rotation, np.float64)


@dataclass(frozen=True)
class HeadColours:
    """The head's colour channels by head orientation.

    Fields:
        anchors: (K, 3, 3) float32 head orientations relative to the capture camera;
        texels: (n,) int32 flat indices (row * S + column, texture layout) of the texels with a share;
        share: (n,) uint8 each texel's head share, 0-255 for 0-1;
        colours: (K, n, 3) uint8 their colours (0-255 for 0-1) per anchor;
        frames: how many training frames nearest each anchor were projected into it;
        chain: the pose-to-head rotations.

    The camera the anchors are relative to is the view colours' own (:class:`~morf.avatar.view_colour.ViewColours`
    holds these and passes its ``camera_R``).
    """

    anchors: np.ndarray
    texels: np.ndarray
    share: np.ndarray
    colours: np.ndarray
    frames: int
    chain: HeadChain

    @property
    def count(self) -> int:
        return int(self.anchors.shape[0])

    def weights(self, rotvecs: np.ndarray, camera_R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(indices, weights) of the anchors blended for a pose (J, 3) seen through the capture
        camera's rotation ``camera_R``."""
        return anchor_weights(self.anchors, head_orientation(camera_R, self.chain.rotation(rotvecs)))

    def apply(self, rgb: np.ndarray, rotvecs: np.ndarray, camera_R: np.ndarray) -> np.ndarray:
        """(3, S, S) float colour channels (0-1) with the head's texels laid over for a pose (J, 3)
        seen through ``camera_R``."""
        idx, w = self.weights(rotvecs, camera_R)
        head = np.tensordot(np.asarray(w, np.float32) / np.float32(255.0), self.colours[idx].astype(np.float32), axes=1)
        out = np.array(rgb, np.float32, copy=True)
        flat = out.reshape(3, -1)
        s = self.share.astype(np.float32) / np.float32(255.0)
        flat[:, self.texels] = s * head.T + (1 - s) * flat[:, self.texels]
        return out

    def to_dict(self) -> dict:
        """Tensors for avatar.pt (loaded with weights_only)."""
        import torch

        t = lambda a, dt: torch.from_numpy(np.ascontiguousarray(a, dt))  # noqa: E731
        return {"anchors": t(self.anchors, np.float32), "texels": t(self.texels, np.int32),
                "share": t(self.share, np.uint8), "colours": t(self.colours, np.uint8), "frames": int(self.frames),
                "chain_bones": t(self.chain.bones, np.int32), "chain_reference": t(self.chain.reference, np.float64),
                "chain_rest_end": t(self.chain.rest_end, np.float64)}

    @staticmethod
    def from_dict(d: dict, texel_count: int) -> "HeadColours":
        """Read :meth:`to_dict`'s tensors, checked against a texture of ``texel_count`` texels (a
        ``camera_R`` that earlier files also hold is the view colours' own and is not read)."""
        anchors = np.asarray(d["anchors"], np.float32)
        texels, share = np.asarray(d["texels"], np.int64), np.asarray(d["share"], np.uint8)
        colours = np.asarray(d["colours"], np.uint8)
        bones = np.asarray(d["chain_bones"], np.int32)
        reference = np.asarray(d["chain_reference"], np.float64)
        shapes_ok = (anchors.ndim == 3 and anchors.shape[1:] == (3, 3) and texels.ndim == 1
                     and share.shape == texels.shape and colours.shape == (len(anchors), len(texels), 3)
                     and reference.shape == (len(bones), 3, 3) and len(bones) > 0)
        if not shapes_ok:
            raise ValueError(f"head colours of shapes {anchors.shape}, {texels.shape}, {share.shape}, {colours.shape} "
                             "do not match")
        if texels.size and (texels.min() < 0 or texels.max() >= texel_count):
            raise ValueError(f"head colours name texels outside the texture's {texel_count}")
        chain = HeadChain(bones, reference, np.asarray(d["chain_rest_end"], np.float64).reshape(3, 3))
        return HeadColours(anchors, texels.astype(np.int32), share, colours, int(d.get("frames", 0)), chain)


def head_share(model, size: int) -> np.ndarray:
    """(size, size) float32 each texel's head share: the head bones' summed skinning weight
    interpolated over the render mesh's UV layout (0 off the atlas)."""
    from morf.avatar.spectral import body_uv_atlas
    from morf.body.parts import part_bones
    from morf.body.render_mesh import render_mesh_for

    bones = part_bones(model)["head"]
    w = model.dense_weights[:, bones].sum(1).detach().cpu().numpy().astype(np.float32)
    w = np.clip(w[render_mesh_for(model).vertex_map], 0.0, 1.0)
    return body_uv_atlas(model, size, size).interpolate(w[:, None])[..., 0]


@dataclass(frozen=True)
class HeadColourBytes:
    """Head colours as an exported avatar holds them: in the texture's own bytes (channels 0-2,
    quantised with the texture's scales), laid over the body's view-colour bytes.

    Fields: anchors (K, 3, 3) float32 head orientations relative to the camera; bone: the head
    bone's index (its skinning rotation keys the blend); texels (n,) int32 flat texel indices;
    share (n,) uint8; data (K, n, 3) uint8."""

    anchors: np.ndarray
    bone: int
    texels: np.ndarray
    share: np.ndarray
    data: np.ndarray

    def blend_weights(self, orientation: np.ndarray) -> tuple[tuple[int, ...], tuple[int, ...]]:
        """(anchor indices, integer weights summing to 256) for a head orientation (3, 3)."""
        return integer_weights(*anchor_weights(self.anchors, orientation))

    def lay_over(self, rgb: np.ndarray, weights) -> np.ndarray:
        """``rgb`` (Ht, Wt, 3) uint8 with the head's texels laid over by ``weights`` (from
        :meth:`blend_weights`), in integers: head = sum q_k data_k / 256, then
        (share * head + (255 - share) * rgb) / 255, both rounded."""
        idx, q = weights
        head = np.full(self.data.shape[1:], 128, np.uint32)
        for i, wi in zip(idx, q):
            head += self.data[i].astype(np.uint32) * np.uint32(wi)
        head >>= 8
        out = np.array(rgb, np.uint8, copy=True)
        flat = out.reshape(-1, 3)
        s = self.share.astype(np.uint32)[:, None]
        flat[self.texels] = ((s * head + (255 - s) * flat[self.texels].astype(np.uint32) + 127) // 255).astype(np.uint8)
        return out


def quantize_head_colours(head: HeadColours, scales: np.ndarray, zero_point: int) -> HeadColourBytes:
    """``head`` in texture bytes of channel ``scales`` (3,) (as :func:`morf.avatar.view_colour.quantize_view_colours`)."""
    from morf.raster.texture_quant import texture_bytes

    q = texture_bytes(head.colours.astype(np.float32) / 255.0, scales, zero_point)  # (K, n, 3)
    return HeadColourBytes(np.asarray(head.anchors, np.float32), int(head.chain.bones[-1]),
                           np.asarray(head.texels, np.int32), np.asarray(head.share, np.uint8), q)
