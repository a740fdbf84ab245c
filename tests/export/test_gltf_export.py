"""``morf export --gltf``: the .glb read back by libraries we did not write (pygltflib, trimesh), posed
with the file's own skin data and compared with our skinning; the baked colour against the renders.

The skinning check poses the file like a glTF viewer does: node TRS -> joint globals ->
``sum_j w_j G_j B_j v`` with JOINTS_0 / WEIGHTS_0 / inverseBindMatrices, all in numpy here.
"""

from __future__ import annotations

import io

import numpy as np
import pytest
import torch

from tests.conftest import require

pygltflib = require("pygltflib")

from scipy.spatial.transform import Rotation  # noqa: E402

from morf.export.gltf_rig import Y_UP, pose_nodes  # noqa: E402

pytestmark = pytest.mark.gl

# Tolerances. The file must reproduce our own skinning with the same top-4 weights to float32
# precision (EXACT_M). Against the model's full skinning (Anny: up to 9 influences a vertex, 2.5 on
# average) the only difference is the truncation, whose error at a vertex is exactly
# |sum_j (w_j - w4_j) T_j v| <= sum_j |w_j - w4_j| |T_j v - x| for any x (the weight differences sum
# to 0): the test checks that bound per vertex, and absolute limits for the seeded test poses
# (0.3 rad per bone and axis: measured about 2 mm max at the zero pose, 16 mm max, 0.13 mm mean).
EXACT_M = 2e-5
TRUNCATION_MAX_M = 0.025
TRUNCATION_MEAN_M = 5e-4


def read(gltf, index: int) -> np.ndarray:
    """An accessor as a numpy array (tightly packed, as our writer and most others lay them out)."""
    acc = gltf.accessors[index]
    view = gltf.bufferViews[acc.bufferView]
    dtype = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}[acc.componentType]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[acc.type]
    data = gltf.binary_blob()[view.byteOffset + (acc.byteOffset or 0):][:acc.count * width * np.dtype(dtype).itemsize]
    a = np.frombuffer(data, dtype).reshape(acc.count, width)
    if acc.type == "MAT4":
        return a.reshape(-1, 4, 4).transpose(0, 2, 1)  # glTF stores matrices column-major
    return a[:, 0] if width == 1 else a


def node_globals(gltf, joints: list[int], rotations=None, translations=None) -> np.ndarray:
    """(J, 4, 4) joint globals from the file's node hierarchy and TRS (optionally overridden)."""
    parent = {c: i for i, n in enumerate(gltf.nodes) for c in (n.children or [])}
    local = {}
    for k, j in enumerate(joints):
        n = gltf.nodes[j]
        M = np.eye(4)
        M[:3, :3] = Rotation.from_quat(n.rotation if rotations is None else rotations[k]).as_matrix()
        M[:3, 3] = n.translation if translations is None else translations[k]
        local[j] = M

    def world(j):
        return local[j] if j not in parent else world(parent[j]) @ local[j]

    return np.stack([world(j) for j in joints])


def skin(gltf, globals_: np.ndarray) -> np.ndarray:
    """(V, 3) vertices skinned with the file's own JOINTS_0, WEIGHTS_0 and inverse bind matrices."""
    prim = gltf.meshes[0].primitives[0]
    v = read(gltf, prim.attributes.POSITION).astype(np.float64)
    j = read(gltf, prim.attributes.JOINTS_0).astype(np.int64)
    w = read(gltf, prim.attributes.WEIGHTS_0).astype(np.float64)
    ibm = read(gltf, gltf.skins[0].inverseBindMatrices).astype(np.float64)
    mats = globals_ @ ibm  # (J, 4, 4)
    blended = np.einsum("vk,vkab->vab", w, mats[j])
    return np.einsum("vab,vb->va", blended[:, :3, :3], v) + blended[:, :3, 3]


def our_skinning(body_model, shape, rotvecs, transl, weights=None) -> np.ndarray:
    """(Vr, 3) render-mesh vertices posed by morf.body, glTF axes: the model's own skinning (all
    influences), or morf.body's LBS with the given (Vr, J) per-render-vertex weights."""
    from morf.body import BodyPose
    from morf.body.lbs import linear_blend_skinning
    from morf.body.render_mesh import render_mesh_for

    rm = render_mesh_for(body_model)
    with torch.no_grad():
        out = body_model(BodyPose(torch.tensor(rotvecs[None], dtype=torch.float32),
                                  torch.tensor(transl[None], dtype=torch.float32)), shape)
        if weights is None:
            verts = rm.gather(out.vertices)
        else:
            verts = linear_blend_skinning(rm.gather(out.rest_vertices).double(), torch.from_numpy(weights).double(),
                                          out.bone_transforms.double())
    return verts[0].double().numpy() @ Y_UP.T


def truncation_bound(body_model, shape, rotvecs, transl, truncated, full) -> np.ndarray:
    """(Vr,) sum_j |w_j - w4_j| |T_j v - x| with x the fully skinned vertex (see the tolerances)."""
    from morf.body import BodyPose
    from morf.body.render_mesh import render_mesh_for

    rm = render_mesh_for(body_model)
    with torch.no_grad():
        out = body_model(BodyPose(torch.tensor(rotvecs[None], dtype=torch.float32),
                                  torch.tensor(transl[None], dtype=torch.float32)), shape)
    T = out.bone_transforms[0].double().numpy()
    v = rm.gather(out.rest_vertices)[0].double().numpy()
    per_bone = (np.einsum("jab,vb->vja", T[:, :3, :3], v) + T[:, :3, 3]) @ Y_UP.T  # (Vr, J, 3)
    dw = np.abs(body_model.dense_weights.double().numpy()[rm.vertex_map] - truncated)
    return (dw * np.linalg.norm(per_bone - full[:, None], axis=2)).sum(1)


def test_accessors_read_back_with_libraries_we_did_not_write(exported, body_model):
    import trimesh

    result, gltf, _, _ = exported
    prim = gltf.meshes[0].primitives[0]
    a = prim.attributes
    V = result.vertices
    pos, nrm, uv = read(gltf, a.POSITION), read(gltf, a.NORMAL), read(gltf, a.TEXCOORD_0)
    joints, weights = read(gltf, a.JOINTS_0), read(gltf, a.WEIGHTS_0)
    idx = read(gltf, prim.indices)
    assert len(pos) == len(nrm) == len(uv) == len(joints) == len(weights) == V
    acc = gltf.accessors[a.POSITION]
    assert np.allclose(acc.min, pos.min(0)) and np.allclose(acc.max, pos.max(0))
    assert 1.4 < acc.max[1] - acc.min[1] < 2.1  # Y up: the body's height is along Y
    assert len(idx) % 3 == 0 and idx.max() < V
    assert np.allclose(np.linalg.norm(nrm, axis=1), 1, atol=1e-5)
    assert uv.min() >= 0 and uv.max() <= 1
    assert np.abs(weights.astype(np.float64).sum(1) - 1).max() < 1e-6 and weights.min() >= 0
    J = len(gltf.skins[0].joints)
    assert J == len(body_model.bone_names) == result.joints and joints.max() < J
    assert gltf.accessors[gltf.skins[0].inverseBindMatrices].count == J
    # Counter-clockwise triangles enclose the body (positive volume) and the normals agree with them.
    tm = trimesh.Trimesh(pos.astype(np.float64), idx.reshape(-1, 3), process=False)
    assert tm.volume > 0.03
    assert (np.einsum("va,va->v", tm.vertex_normals, nrm) > 0.5).mean() > 0.99
    scene = trimesh.load(str(result.path))
    meshes = list(scene.geometry.values()) if isinstance(scene, trimesh.Scene) else [scene]
    assert sum(len(m.faces) for m in meshes) == len(idx) // 3
    # Vertices split per UV as the raster does: each vertex has one UV and the avatar folder's order.
    from morf.body.render_mesh import render_mesh_for

    rm = render_mesh_for(body_model)
    assert np.allclose(uv[:, 0], rm.uvs[:, 0]) and np.allclose(uv[:, 1], 1 - rm.uvs[:, 1])


def test_inverse_bind_matrices_invert_the_joints_rest_globals(exported):
    _, gltf, _, _ = exported
    joints = gltf.skins[0].joints
    G = node_globals(gltf, joints)
    ibm = read(gltf, gltf.skins[0].inverseBindMatrices).astype(np.float64)
    assert np.abs(G @ ibm - np.eye(4)).max() < 1e-5
    # In the bind pose the file's skin leaves the mesh where it is.
    pos = read(gltf, gltf.meshes[0].primitives[0].attributes.POSITION)
    assert np.abs(skin(gltf, G) - pos).max() < 1e-5


def test_posing_the_file_matches_our_skinning(exported, body_model):
    from morf.body.render_mesh import render_mesh_for
    from morf.export.gltf_rig import top_influences
    from morf.export.skeleton import skeleton_from_body_model
    from morf.train.trained_avatar import load_trained_avatar

    _, gltf, project, _ = exported
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    sk = skeleton_from_body_model(body_model, shape)
    joints = gltf.skins[0].joints
    rest_t = np.array([gltf.nodes[j].translation for j in joints])
    rm = render_mesh_for(body_model)
    idx, w4 = top_influences(body_model.dense_weights.numpy()[rm.vertex_map])
    truncated = np.zeros((len(rm.vertex_map), len(joints)))
    np.put_along_axis(truncated, idx.astype(np.int64), w4.astype(np.float64), axis=1)
    rng = np.random.default_rng(0)
    J = len(joints)
    poses = [(np.zeros((J, 3)), np.zeros(3)), (rng.normal(0, 0.3, (J, 3)), np.array([0.2, -0.1, 0.05])),
             (rng.normal(0, 0.3, (J, 3)), np.array([-0.3, 0.4, 0.0]))]
    exact, full_max, full_mean = [], [], []
    for rotvecs, transl in poses:
        q, t = pose_nodes(sk, rotvecs, transl)
        assert np.abs(t[1:] - rest_t[1:]).max() < 1e-5  # a pose is rotations + the root's translation
        for k, j in enumerate(joints):  # set the pose on the file's nodes, as an animation would
            gltf.nodes[j].rotation = [float(x) for x in q[k]]
        gltf.nodes[joints[0]].translation = [float(x) for x in t[0]]
        posed = skin(gltf, node_globals(gltf, joints))
        exact.append(np.abs(posed - our_skinning(body_model, shape, rotvecs, transl, truncated)).max())
        full = our_skinning(body_model, shape, rotvecs, transl)
        err = np.linalg.norm(posed - full, axis=1)
        assert (err <= truncation_bound(body_model, shape, rotvecs, transl, truncated, full) + 1e-6).all()
        full_max.append(err.max())
        full_mean.append(err.mean())
    for k, j in enumerate(joints):  # leave the shared file as it was
        gltf.nodes[j].translation = [float(x) for x in rest_t[k]]
    print(f"\nglTF skin vs morf.body: same top-4 weights max {max(exact) * 1e3:.4f} mm; all weights "
          f"max {max(full_max) * 1e3:.2f} mm, mean {np.mean(full_mean) * 1e3:.3f} mm "
          f"(per pose max {[round(float(x) * 1e3, 2) for x in full_max]} mm)")
    assert max(exact) < EXACT_M
    assert full_max[0] < TRUNCATION_MAX_M and max(full_max) < TRUNCATION_MAX_M
    assert np.mean(full_mean) < TRUNCATION_MEAN_M


def test_animation_keyframes_pose_the_motion(exported, body_model):
    from morf.train.trained_avatar import load_trained_avatar

    _, gltf, project, clip = exported

    anim = gltf.animations[0]
    joints = gltf.skins[0].joints
    assert len(anim.channels) == len(joints) + 1  # on Anny only the root translates
    assert [c.target.node for c in anim.channels if c.target.path == "translation"] == [joints[0]]
    times = read(gltf, anim.samplers[0].input)
    assert np.allclose(times, np.arange(5) / 10) and gltf.accessors[anim.samplers[0].input].max[0] == pytest.approx(0.4)
    frame = 3
    rot = {c.target.node: read(gltf, anim.samplers[c.sampler].output)[frame]
           for c in anim.channels if c.target.path == "rotation"}
    tr = [read(gltf, anim.samplers[c.sampler].output)[frame] for c in anim.channels if c.target.path == "translation"]
    rest_t = np.array([gltf.nodes[j].translation for j in joints])
    rest_t[0] = tr[0]
    posed = skin(gltf, node_globals(gltf, joints, [rot[j] for j in joints], rest_t))
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    ours = our_skinning(body_model, shape, clip["rotvecs"][frame], clip["transl"][frame])
    assert np.linalg.norm(posed - ours, axis=1).max() < TRUNCATION_MAX_M
    q = np.stack([read(gltf, anim.samplers[c.sampler].output) for c in anim.channels if c.target.path == "rotation"])
    assert ((q[:, 1:] * q[:, :-1]).sum(-1) >= 0).all()  # sign-aligned for slerp


def test_baked_texture_matches_the_renders_in_colour(exported, body_model):
    from PIL import Image

    from morf.body.render_mesh import render_mesh_for
    from morf.export.gltf_bake import BakeConfig, framed_camera, neutral_vertices, render_bake_views
    from morf.train.trained_avatar import load_trained_avatar

    result, gltf, project, _ = exported
    tex = gltf.textures[gltf.materials[0].pbrMetallicRoughness.baseColorTexture.index]
    view = gltf.bufferViews[gltf.images[tex.source].bufferView]
    png = gltf.binary_blob()[view.byteOffset:view.byteOffset + view.byteLength]
    rgb = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), np.float64) / 255
    S = rgb.shape[0]
    assert rgb.shape == (S, S, 3) and S == result.texture_size
    # Views between the bake's own (other azimuths and elevations).
    trained = load_trained_avatar(project.runs_dir / "morf-tiny")
    verts = neutral_vertices(body_model, trained.shape)
    res = trained.config.resolution
    cams = [framed_camera(verts, a, e, res, BakeConfig()) for a, e in ((20, 10), (200, -10), (110, 20))]
    views = render_bake_views(trained, render_mesh_for(body_model), verts, cams)
    ok = views.masks & views.uv_mask & (views.facing >= 77)
    uv = views.uv[ok].astype(np.float64) / 65535
    col = np.clip((uv[:, 0] * S).astype(int), 0, S - 1)
    row = np.clip(((1 - uv[:, 1]) * S).astype(int), 0, S - 1)  # glTF t = 1 - v: image row 0 is the top
    baked = rgb[row, col]
    shown = views.images[ok].astype(np.float64) / 255
    err = np.abs(baked - shown).mean()
    flat = np.abs(shown.mean(0) - shown).mean()  # a single flat colour, for scale
    print(f"\nbaked texture vs renders: mean |colour error| {err:.4f} (a flat colour: {flat:.4f}) over {ok.sum()} px")
    assert ok.sum() > 500
    assert err < 0.06 and err < 0.5 * flat


def test_extras_point_at_the_neural_avatar_beside_the_glb(exported):
    from morf.export.avatar_folder import load_exported_avatar

    result, gltf, _, _ = exported
    morf = gltf.asset.extras["morf"]
    assert gltf.meshes[0].extras["morf"] == morf
    base = result.path.parent
    for key in ("manifest", "neural_texture", "renderer_int8", "renderer_fp32"):
        assert not morf[key].startswith("/") and (base / morf[key]).is_file(), key
    avatar = load_exported_avatar(base / morf["avatar_folder"])
    assert avatar.mesh.num_vertices == result.vertices
    assert morf["base_colour"]["texture_size"] == result.texture_size


def test_cli_refuses_motion_without_gltf_and_other_suffixes(exported, capsys):
    from morf.cli.main import main

    _, _, project, _ = exported
    assert main(["export", str(project.root), "--motion", "clip.npz"]) == 2
    assert "--gltf" in capsys.readouterr().err
    assert main(["export", str(project.root), "--gltf", "avatar.gltf"]) == 2
    assert ".glb" in capsys.readouterr().err
