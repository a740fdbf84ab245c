"""The head's colour by the head's own orientation (morf.avatar.head_colour): the chain's rotation is
the skinning skeleton's, the head share falls from the face to the neck, the colour is laid over
by that share in floats and in bytes alike, and damaged arrays are refused."""

import numpy as np
import pytest

from morf.avatar.head_colour import HeadChain, HeadColourBytes, HeadColours, head_orientation, head_share
from morf.export.skeleton import SkinningSkeleton
from morf.rotations import rotvec_to_matrix_rodrigues


def _skeleton(rng) -> SkinningSkeleton:
    parents = np.array([-1, 0, 1, 2, 1, 3], np.int32)  # a chain 0-1-2-3-5 with a branch at 1
    rots = lambda: rotvec_to_matrix_rodrigues(rng.normal(size=(6, 3)) * 0.7)  # noqa: E731
    return SkinningSkeleton(names=np.array([f"b{i}" for i in range(6)]), parents=parents, rest_rotations=rots(),
                            rest_heads=rng.normal(size=(6, 3)), reference_rotations=rots())


def test_the_chain_gives_the_skeletons_skinning_rotation():
    rng = np.random.default_rng(0)
    sk = _skeleton(rng)
    chain = HeadChain.along(sk.parents, sk.reference_rotations, sk.rest_rotations, 5)
    assert chain.bones.tolist() == [0, 1, 2, 3, 5]
    for _ in range(5):
        pose = rng.normal(size=(6, 3)) * 0.8
        want = sk.bone_transforms(pose, rng.normal(size=3))[5, :3, :3]
        np.testing.assert_allclose(chain.rotation(pose), want, atol=2e-6)
    # a bone off the chain (4) does not turn the head
    pose = rng.normal(size=(6, 3))
    moved = pose.copy()
    moved[4] += 1.0
    np.testing.assert_allclose(chain.rotation(pose), chain.rotation(moved), atol=1e-12)


def _head(rng, share, k=3, size=4) -> HeadColours:
    sk = _skeleton(rng)
    chain = HeadChain.along(sk.parents, sk.reference_rotations, sk.rest_rotations, 5)
    texels = np.array([0, 5, 6, 15], np.int32)
    anchors = rotvec_to_matrix_rodrigues(np.array([[0, 0, 0], [0, 1.5, 0], [0, -1.5, 0]], float)[:k])
    colours = np.stack([np.full((len(texels), 3), 40 + 80 * i, np.uint8) for i in range(k)])
    return HeadColours(anchors.astype(np.float32), texels, np.asarray(share, np.uint8), colours, 2, chain)


def test_the_head_is_laid_over_by_its_share_in_floats_and_bytes():
    rng = np.random.default_rng(1)
    head = _head(rng, [255, 0, 128, 255])
    rgb = np.full((3, 4, 4), 200 / 255, np.float32)
    pose = np.zeros((6, 3))
    idx, w = head.weights(pose, np.eye(3))
    blend = float(np.dot(w, [40 + 80 * i for i in idx])) / 255
    out = head.apply(rgb, pose, np.eye(3))
    flat = out.reshape(3, -1)
    np.testing.assert_allclose(flat[:, 0], blend, atol=1e-6)  # share 1: the head's colour
    np.testing.assert_allclose(flat[:, 5], 200 / 255, atol=1e-6)  # share 0: the body's
    np.testing.assert_allclose(flat[:, 6], (128 * blend + 127 * 200 / 255) / 255, atol=1e-6)
    untouched = np.setdiff1d(np.arange(16), head.texels)
    assert np.array_equal(flat[:, untouched], rgb.reshape(3, -1)[:, untouched])
    # the bytes the player lays over: the same to one step
    b = HeadColourBytes(head.anchors, 5, head.texels, head.share, head.colours)
    o = head_orientation(np.eye(3), head.chain.rotation(pose))
    got = b.lay_over(np.full((4, 4, 3), 200, np.uint8), b.blend_weights(o)).reshape(-1, 3)
    assert np.abs(got.astype(float) - flat.T * 255).max() <= 1.0
    assert got[untouched].min() == 200 == got[untouched].max()


def test_the_blend_follows_the_heads_orientation_not_the_roots():
    rng = np.random.default_rng(2)
    head = _head(rng, [255] * 4)
    pose = np.zeros((6, 3))
    turned = pose.copy()
    turned[5] = (0, 1.5, 0)  # the head bone alone turned
    a, b = head.weights(pose, np.eye(3)), head.weights(turned, np.eye(3))
    assert a[0][0] != b[0][0]


def test_round_trip_and_damaged_arrays():
    rng = np.random.default_rng(3)
    head = _head(rng, [255, 10, 128, 255])
    back = HeadColours.from_dict(head.to_dict(), 16)
    for f in ("anchors", "texels", "share", "colours"):
        assert np.array_equal(getattr(back, f), getattr(head, f))
    np.testing.assert_array_equal(back.chain.reference, head.chain.reference)
    d = head.to_dict()
    with pytest.raises(ValueError, match="outside"):
        HeadColours.from_dict(d, 8)  # texel 15 of a texture of 8
    with pytest.raises(ValueError, match="do not match"):
        HeadColours.from_dict({**d, "colours": d["colours"][:, :2]}, 16)


def test_head_share_falls_from_the_face_down_the_neck(body_model):
    from morf.body.parts import PARTS, part_atlas

    share = head_share(body_model, 128)
    parts = part_atlas(body_model, 128)
    assert share.min() >= 0.0 and share.max() <= 1.0 + 1e-6
    assert np.median(share[parts == PARTS["head"]]) > 0.99
    hands = parts == PARTS["hand.L"]
    assert share[hands].max() < 1e-3
    between = (share > 0.05) & (share < 0.95)
    assert between.sum() > 50  # a band, not a step
