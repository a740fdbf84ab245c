"""``morf export --gltf`` of an avatar trained on the dressed body: the .glb carries the same
dressed rest vertices as the avatar folder's mesh.npz, so a viewer draws the loose clothes the
renderer learned instead of cutting them away, and the base colour is baked on that body.

The capture is the tiny synthetic one with loose garments (``morf synth --loose 0.08``); its body
fits are the ground truth's poses and shape with the garments' own offsets as clothing offsets
(what a perfect ``morf fit`` would find), so the dressed body matches the person masks.
"""

from __future__ import annotations

import numpy as np
import pytest

from morf.cli.main import main
from tests.conftest import require

pygltflib = require("pygltflib")

from test_gltf_export import node_globals, read  # noqa: E402

pytestmark = pytest.mark.gl

LOOSE = 0.08  # metres at hems and cuffs: a few pixels each side at the tiny capture's 128 px


@pytest.fixture(scope="module")
def loose_export(tmp_path_factory, body_model, gl, one_torch_thread):
    """(project, fits, glb path, parsed glTF, avatar folder) of a 2-step run on the loose capture."""
    from morf.synth import make_synthetic_capture, synth_config
    from morf.synth.ground_truth import load_ground_truth
    from tests.train.dressed_fits import write_dressed_fits

    root = tmp_path_factory.mktemp("loose")
    project = make_synthetic_capture(root / "cap", synth_config("tiny", loose=LOOSE), model=body_model)
    fits = write_dressed_fits(project, body_model, load_ground_truth(project).loose_offset)
    assert main(["train", str(project.root), "--preset", "tiny", "--steps", "2", "--set", "inpaint_steps=0"]) == 0
    glb = root / "out" / "avatar.glb"
    assert main(["export", str(project.root), "--gltf", str(glb), "--calibration-views", "2"]) == 0
    return project, fits, glb, pygltflib.GLTF2().load(str(glb)), root / "out" / "avatar"


def _rest_positions(gltf) -> np.ndarray:
    """(V, 3) the file's rest POSITION in the body model's axes (Z up, facing -Y)."""
    from morf.export.gltf_rig import Y_UP

    return read(gltf, gltf.meshes[0].primitives[0].attributes.POSITION).astype(np.float64) @ Y_UP


def test_rest_positions_are_the_avatar_folders_dressed_vertices(loose_export, body_model):
    from morf.export.avatar_folder import load_exported_avatar
    from morf.export.export_avatar import skinned_mesh_from_body_model
    from morf.train.trained_avatar import load_trained_avatar

    project, fits, _, gltf, folder = loose_export
    avatar = load_exported_avatar(folder)
    assert avatar.manifest["body"]["clothing"]["dressed"]
    assert gltf.asset.extras["morf"]["body"]["clothing"]["dressed"]
    positions = _rest_positions(gltf)
    np.testing.assert_array_equal(positions.astype(np.float32), avatar.mesh.rest_vertices)
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    naked = skinned_mesh_from_body_model(body_model, shape).rest_vertices
    moved = np.linalg.norm(positions - naked, axis=1)
    assert moved.max() == pytest.approx(float(fits.offsets.max()), abs=1e-4)  # the hems moved out, by the offsets


def _file_coverage(gltf, rest: np.ndarray, rotvecs, transl, body_model, shape, camera) -> np.ndarray:
    """(H, W) bool pixels our rasterizer covers with ``rest`` (V, 3) (glTF axes, the file's vertex
    order) skinned as a viewer does with the file's own joints, weights and inverse bind matrices,
    in the body model's pose (rotvecs (J, 3), transl (3,))."""
    from morf.body.render_mesh import render_mesh_for
    from morf.export.gltf_rig import Y_UP, pose_nodes
    from morf.export.skeleton import skeleton_from_body_model
    from morf.raster import rasterize_uv

    prim = gltf.meshes[0].primitives[0]
    q, t = pose_nodes(skeleton_from_body_model(body_model, shape), rotvecs, transl)
    mats = node_globals(gltf, gltf.skins[0].joints, q, t) @ read(gltf, gltf.skins[0].inverseBindMatrices)
    w = read(gltf, prim.attributes.WEIGHTS_0).astype(np.float64)
    blended = np.einsum("vk,vkab->vab", w, mats[read(gltf, prim.attributes.JOINTS_0).astype(np.int64)])
    posed = np.einsum("vab,vb->va", blended[:, :3, :3], rest) + blended[:, :3, 3]
    return rasterize_uv((posed @ Y_UP).astype(np.float32), render_mesh_for(body_model), camera).mask


def test_the_file_posed_in_a_capture_frame_covers_the_loose_clothes(loose_export, body_model):
    """Skinned with its own joints and weights, the file covers the person's mask as the dressed
    body does; the naked body of the same file leaves the loose hems out."""
    from morf.export.gltf_avatar import gltf_mesh
    from morf.train.trained_avatar import load_trained_avatar

    project, fits, _, gltf, _ = loose_export
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    naked = gltf_mesh(body_model, shape).positions.astype(np.float64)
    dressed = read(gltf, gltf.meshes[0].primitives[0].attributes.POSITION).astype(np.float64)
    camera = project.camera()
    ious = []
    for i in (0, len(fits.rotvecs) // 2):
        mask = project.load_mask(i)
        cover_d, cover_n = (_file_coverage(gltf, rest, fits.rotvecs[i], fits.transl[i], body_model, shape, camera)
                            for rest in (dressed, naked))
        assert cover_d.sum() > 1.05 * cover_n.sum(), i
        extra = cover_d & ~cover_n
        assert (mask & extra).sum() > 0.8 * extra.sum(), i  # what the dressed body adds is the person's
        ious.append([(c & mask).sum() / (c | mask).sum() for c in (cover_d, cover_n)])
    print(f"\nmask IoU of the file posed in capture frames (dressed, naked): {np.round(ious, 3).tolist()}")
    assert all(d > 0.85 and d > n + 0.02 for d, n in ious), ious


def test_the_colour_is_baked_on_the_dressed_body(loose_export, body_model):
    from morf.export.avatar_folder import load_exported_avatar
    from morf.export.export_avatar import skinned_mesh_from_body_model
    from morf.export.gltf_bake import neutral_vertices
    from morf.train.trained_avatar import load_trained_avatar

    project, fits, _, gltf, folder = loose_export
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    # The bake's A-pose body is moved out by the file's own dressing: as far at every vertex, in
    # about the same direction (the zero pose turns some bones a few degrees off the rest pose:
    # measured at most 5.6 degrees and 0.1 mm in length on this capture).
    moved = neutral_vertices(body_model, shape, fits.offsets) - neutral_vertices(body_model, shape)
    dressing = load_exported_avatar(folder).mesh.rest_vertices - skinned_mesh_from_body_model(body_model, shape).rest_vertices
    length, dressed_length = np.linalg.norm(moved, axis=1), np.linalg.norm(dressing, axis=1)
    assert dressed_length.max() > 0.05
    np.testing.assert_allclose(length, dressed_length, atol=2e-4)
    far = dressed_length > 1e-3
    assert ((moved[far] * dressing[far]).sum(1) / length[far] / dressed_length[far]).min() > 0.99
    assert "dressed" in gltf.asset.extras["morf"]["base_colour"]["from"]
