"""The glTF rig on a small random skeleton: bind pose, poses against SkinningSkeleton.bone_transforms, weights,
animation keyframes, and the .glb container read back by pygltflib."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from morf.export.glb import ARRAY_BUFFER, GlbBuilder
from morf.export.gltf_animation import align_quaternion_signs, joint_animation, moving_joints
from morf.export.gltf_rig import Y_UP, global_transforms, gltf_rig, pose_nodes, to_gltf_axes, top_influences
from morf.export.skeleton import SkinningSkeleton
from tests.conftest import require


def random_skeleton(seed: int = 0) -> SkinningSkeleton:
    rng = np.random.default_rng(seed)
    parents = np.array([-1, 0, 1, 1, 3], np.int32)
    R = Rotation.random(5, random_state=seed).as_matrix()
    U = Rotation.random(5, random_state=seed + 1).as_matrix()
    return SkinningSkeleton(names=np.array(list("abcde")), parents=parents, rest_rotations=R,
                    rest_heads=rng.normal(0, 0.3, (5, 3)), reference_rotations=U)


def test_y_up_is_a_rotation_taking_anny_up_and_front_to_gltf_up_and_front():
    assert np.allclose(Y_UP @ Y_UP.T, np.eye(3)) and np.isclose(np.linalg.det(Y_UP), 1)
    assert np.allclose(Y_UP @ [0, 0, 1], [0, 1, 0])  # up
    assert np.allclose(Y_UP @ [0, -1, 0], [0, 0, 1])  # the body's front


def test_bind_pose_globals_are_the_rest_frames_and_inverse_bind_inverts_them():
    sk = random_skeleton()
    rig = gltf_rig(sk)
    G = global_transforms(rig.rotations, rig.translations, rig.parents)
    P = np.zeros((5, 4, 4))
    P[:, :3, :3], P[:, :3, 3], P[:, 3, 3] = sk.rest_rotations, sk.rest_heads, 1
    assert np.allclose(G, to_gltf_axes(P), atol=1e-10)
    assert np.allclose(G @ rig.inverse_bind, np.eye(4), atol=1e-10)
    assert np.allclose(np.linalg.norm(rig.rotations, axis=1), 1)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_posed_nodes_skin_like_our_bone_transforms(seed):
    sk = random_skeleton(seed)
    rig = gltf_rig(sk)
    rng = np.random.default_rng(seed + 10)
    rotvecs, transl = rng.normal(0, 0.7, (5, 3)), rng.normal(0, 0.5, 3)
    q, t = pose_nodes(sk, rotvecs, transl)
    q0, t0 = pose_nodes(sk, np.zeros((5, 3)), np.zeros(3))
    assert np.allclose(t[1:], t0[1:], atol=1e-6)  # bone offsets do not depend on the pose
    assert np.allclose(t[2:], rig.translations[2:], atol=1e-6)  # and below the root's children are the bind pose's
    skin = global_transforms(q, t, rig.parents) @ rig.inverse_bind
    ours = to_gltf_axes(sk.bone_transforms(rotvecs, transl).astype(np.float64))
    assert np.abs(skin - ours).max() < 1e-5  # bone_transforms is float32


def test_top_influences_keep_the_largest_weights_summing_to_one():
    w = np.array([[0.05, 0.5, 0.1, 0.2, 0.15, 0.0], [0, 0, 1.0, 0, 0, 0], [0.3, 0.3, 0.2, 0.1, 0.05, 0.05]])
    j, v = top_influences(w, 4)
    assert j.dtype == np.uint8 and v.dtype == np.float32
    assert j[0].tolist() == [1, 3, 4, 2] and np.allclose(v[0], np.array([0.5, 0.2, 0.15, 0.1]) / 0.95)
    assert j[1].tolist() == [2, 0, 0, 0] and v[1].tolist() == [1, 0, 0, 0]
    assert np.abs(v.astype(np.float64).sum(1) - 1).max() < 1e-7
    assert top_influences(np.ones((1, 300)) / 300)[0].dtype == np.uint16


def test_animation_quaternions_are_sign_aligned_and_timed():
    q = np.array([[[0, 0, 0, 1.0]], [[0, 0, 0, -1.0]], [[0, 0, 0.1, -0.995]]])
    a = align_quaternion_signs(q)
    assert (a[:, 0, 3] > 0).all()
    sk = random_skeleton()
    anim = joint_animation(sk, np.zeros((3, 5, 3)), np.zeros((3, 3)), 25.0)
    assert np.allclose(anim.times, [0, 0.04, 0.08]) and anim.rotations.shape == (3, 5, 4)
    # This skeleton's root reference and rest orientations differ, so the root's child moves too.
    assert moving_joints(anim, gltf_rig(sk).translations) == [0, 1]
    with pytest.raises(ValueError, match="rotvecs"):
        joint_animation(sk, np.zeros((3, 4, 3)), np.zeros((3, 3)), 25.0)


def test_glb_container_reads_back_with_pygltflib(tmp_path):
    pygltflib = require("pygltflib")
    g = GlbBuilder("test")
    pos = g.add_accessor(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), ARRAY_BUFFER, min_max=True)
    odd = g.add_accessor(np.array([1, 2, 3], np.uint8))  # 3 bytes: the next view must still start aligned
    mats = g.add_accessor(np.arange(32, dtype=np.float32).reshape(2, 4, 4))
    g.append("meshes", {"primitives": [{"attributes": {"POSITION": pos}}]})
    g.append("nodes", {"mesh": 0})
    g.append("scenes", {"nodes": [0]})
    size = g.write(tmp_path / "t.glb")
    assert size == (tmp_path / "t.glb").stat().st_size and size % 4 == 0
    gltf = pygltflib.GLTF2().load(str(tmp_path / "t.glb"))
    assert gltf.accessors[pos].max == [1.0, 1.0, 0.0] and gltf.accessors[odd].count == 3
    view = gltf.bufferViews[gltf.accessors[mats].bufferView]
    assert view.byteOffset % 4 == 0
    raw = np.frombuffer(gltf.binary_blob()[view.byteOffset:view.byteOffset + 128], np.float32)
    assert np.array_equal(raw.reshape(2, 4, 4).transpose(0, 2, 1), np.arange(32).reshape(2, 4, 4))  # column-major
