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


def test_the_mouth_anchor_is_the_lips_meeting_line(body_model):
    # MediaPipe's mouth (inner-lip points 13 and 14) and iBUG's (62, 66) mark where the lips meet:
    # the model's mouth must sit there, between the upper and the lower lip's bulges, not on the
    # nose's underside (which a band starting just below the nose tip picks)
    import numpy as np

    from morf.body.parts import _rest, face_anchor_vertices

    v, _, _ = _rest(body_model)
    _, _, (nose,), (upper, lower), (chin,) = face_anchor_vertices(body_model)
    zn, span = v[nose, 2], v[nose, 2] - v[chin, 2]
    depth = [(zn - v[i, 2]) / span for i in (upper, lower)]
    assert 0.25 < depth[0] < 0.4 and 0.45 < depth[1] < 0.6, depth  # upper lip, lower lip
    assert 0.38 < np.mean(depth) < 0.5  # the meeting line: 2.9 cm below the nose tip on Anny's rest face
    assert v[upper, 1] < v[nose, 1] + 0.02 and v[lower, 1] < v[nose, 1] + 0.02  # on the face's front
