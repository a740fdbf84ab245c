import pytest

from morf.motion.joint_maps import CMU_MAP, CMU_OLD_MAP, SMPL_MAP
from morf.motion.name_matching import map_for
from morf.motion.name_matching import match_joint_map, name_tokens
from motion_helpers import tpose_skeleton


@pytest.mark.parametrize("name,side,word", [
    ("LHipJoint", "L", "hip"), ("lhand", "L", "hand"), ("rfoot", "R", "foot"),
    ("mixamorig:RightForeArm", "R", "arm"), ("upperarm_l", "L", "arm"), ("Bip01 R Forearm", "R", "arm"),
    ("LeftUpLeg", "L", "leg"), ("Head", None, "head"), ("lowerback", None, "lowerback"), ("Spine1", None, "spine"),
])
def test_name_tokens(name, side, word):
    s, words = name_tokens(name)
    assert s == side and word in words


def test_fuzzy_matcher_on_mixamo_like_names():
    jm = match_joint_map(tpose_skeleton())
    a = {x.bone: x for x in jm.anchors}
    assert a["root"].joint == "Hips"
    assert (a["clavicle.L"].joint, a["upperarm01.L"].joint, a["lowerarm01.L"].joint) == ("LeftShoulder", "LeftArm", "LeftForeArm")
    assert (a["wrist.R"].joint, a["wrist.R"].joint_tip) == ("RightHand", "RightHandMiddle1")
    assert (a["upperleg01.R"].joint, a["lowerleg01.R"].joint, a["foot.R"].joint) == ("RightUpLeg", "RightLeg", "RightFoot")
    assert a["toe3-1.L"].joint == "LeftToeBase" and a["head"].joint == "Head"
    spine = [x.bone for x in jm.anchors if x.bone.startswith(("spine", "neck"))]
    assert spine == sorted(spine, key=lambda b: ("spine05", "spine04", "spine03", "spine02", "spine01", "neck01",
                                                 "neck02", "neck03").index(b))
    assert jm.hips == ("LeftUpLeg", "RightUpLeg")
    assert map_for(tpose_skeleton()).name == "fuzzy"


def test_documented_maps_are_symmetric():
    for jm in (SMPL_MAP, CMU_MAP, CMU_OLD_MAP):
        bones = {a.bone for a in jm.anchors}
        for b in bones:
            if b.endswith(".L"):
                assert b[:-2] + ".R" in bones


def test_fuzzy_matcher_reproduces_the_cmu_maps(shared_data):
    from morf.motion.bvh import read_bvh

    for name, expected in (("01_01", CMU_MAP), ("131_01", CMU_OLD_MAP)):
        sk = read_bvh(shared_data / f"motion/cmu/{name}.bvh").skeleton
        assert map_for(sk) is expected
        fuzzy = match_joint_map(sk)
        assert set(fuzzy.anchors) == set(expected.anchors)
