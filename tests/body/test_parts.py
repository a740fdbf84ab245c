"""Body parts: the head and the hands are the right vertices, and the atlas finds them from UVs."""

import numpy as np

from morf.body.parts import PARTS, part_atlas, part_bones, pixel_parts, subtree, vertex_parts


def test_subtree_follows_parents():
    parents = [-1, 0, 1, 1, 0, 4]
    assert subtree(parents, 1) == [1, 2, 3] and subtree(parents, 0) == list(range(6)) and subtree(parents, 5) == [5]


def test_parts_are_the_head_and_the_hands_of_the_rest_pose(body_model):
    bones = part_bones(body_model)
    names = [body_model.bone_names[j] for j in bones["head"]]
    assert names[0] == "head" and "eye.L" in names and "neck01" not in names
    assert {body_model.bone_names[j] for j in bones["hand.L"]} >= {"wrist.L", "finger1-3.L", "finger5-3.L"}
    out = body_model(body_model.zero_pose(), body_model.default_shape())
    v = out.vertices[0].numpy()
    labels = vertex_parts(body_model)
    head, left, right = (v[labels == PARTS[p]] for p in ("head", "hand.L", "hand.R"))
    assert len(head) > 1000 and len(left) == len(right) > 500
    assert head[:, 2].min() > v[labels == 0][:, 2].mean() + 0.5  # the head sits above the rest of the body
    assert np.percentile(v[labels == 0][:, 2], 99) < head[:, 2].max()
    assert left[:, 0].min() > 0.1 and right[:, 0].max() < -0.1  # Anny's left is +X
    assert abs(np.abs(left[:, 0]).mean() - np.abs(right[:, 0]).mean()) < 0.01  # mirrored


def test_atlas_gives_each_vertex_its_part(body_model):
    atlas = part_atlas(body_model, 512)
    assert part_atlas(body_model, 512) is atlas  # cached
    labels = vertex_parts(body_model)
    faces, face_uvs = body_model.faces.numpy(), body_model.face_uvs.numpy()
    uv = body_model.uvs.numpy()
    # the centroid of every face whose corners share one part, looked up in the atlas
    same = (labels[faces[:, 0]] == labels[faces[:, 1]]) & (labels[faces[:, 1]] == labels[faces[:, 2]])
    centre = uv[face_uvs[same]].mean(1)
    got = pixel_parts(centre[None], np.ones((1, len(centre)), bool), atlas)[0]
    want = labels[faces[same, 0]]
    for code in PARTS.values():
        assert (got[want == code] == code).mean() > 0.98, code
    assert (got[want == 0] == 0).mean() > 0.98
    off = pixel_parts(centre[None], np.zeros((1, len(centre)), bool), atlas)
    assert not off.any()  # no mesh, no part
