"""Which source joint drives which Anny bone, per source skeleton.

An :class:`Anchor` says: Anny bone ``bone`` takes the world rotation of source joint ``joint``.
Its rest alignment matches the rest direction ``joint -> joint_tip`` of the source with
``bone -> bone_tip`` of Anny (on the spine, ``bone_tip`` is the next anchored bone, so the
direction spans the Anny bones the source segment is spread over) (both tips None: no direction to match, the bone keeps the
alignment of its nearest anchored ancestor, as the head does).

A source joint drives the segment from its head to its child's head, so where a source has a
zero-length joint (CMU ``Spine1`` -> ``Neck`` at the same point, ``LeftHand`` ->
``LeftFingerBase``) the anchor is the joint that owns the segment with a length.

Anny bones that no anchor names either follow their parent (pelvis, shoulder01, the twist bones
upperarm02 / lowerarm02 / upperleg02 / lowerleg02, metacarpals; fingers and eyes unless the source
has them, as SMPL-H / SMPL-X do: :mod:`morf.motion.smpl_hands`) or, on the spine and neck,
share the rotation between their nearest anchored ancestor and descendant (see
:data:`SPREAD_BONES`). Spine anchors were chosen by matching the height of each source spine
segment (as a fraction of the hips-to-head length) with Anny's spine05..spine01, neck01..03.
"""

from __future__ import annotations

from dataclasses import dataclass

# Anny bones whose rotation is spread between anchored neighbours along the spine and neck.
SPREAD_BONES = ("spine05", "spine04", "spine03", "spine02", "spine01", "neck01", "neck02", "neck03", "head")

# Anny's five toes; each toe's first bone takes the source toe rotation.
ANNY_TOES = ("toe1", "toe2", "toe3", "toe4", "toe5")


@dataclass(frozen=True)
class Anchor:
    """One Anny bone driven by one source joint (see the module docstring)."""

    bone: str
    joint: str
    bone_tip: str | None = None
    joint_tip: str | None = None


@dataclass(frozen=True)
class JointMap:
    """A named set of anchors; ``root`` anchors Anny's root (global orientation + translation).

    Fields:
        name: e.g. "smpl", "cmu", "cmu-old", "fuzzy".
        anchors: one per driven Anny bone (the root included).
        hips: (left, right) source joints at the hip sockets, for the body frame and leg length.
        up: source joint above the hips on the spine (neck base), for the body frame.
    """

    name: str
    anchors: tuple[Anchor, ...]
    hips: tuple[str, str]
    up: str

    def joint_for(self, bone: str) -> str | None:
        return next((a.joint for a in self.anchors if a.bone == bone), None)

    def source_joints(self) -> set[str]:
        return {a.joint for a in self.anchors} | {a.joint_tip for a in self.anchors if a.joint_tip}


def limb_anchors(side: str, clavicle: str | None, upper: str, fore: str, hand: str, hand_tip: str | None,
                 thigh: str, shin: str, foot: str, toe: str | None, toe_tip: str | None) -> list[Anchor]:
    """Anchors of one side (``side`` "L" or "R") from the source joints that own each segment."""
    s = side
    out = []
    if clavicle:
        out.append(Anchor(f"clavicle.{s}", clavicle, f"upperarm01.{s}", upper))
    out += [
        Anchor(f"upperarm01.{s}", upper, f"lowerarm01.{s}", fore),
        Anchor(f"lowerarm01.{s}", fore, f"wrist.{s}", hand),
        Anchor(f"wrist.{s}", hand, f"finger3-1.{s}" if hand_tip else None, hand_tip),
        Anchor(f"upperleg01.{s}", thigh, f"lowerleg01.{s}", shin),
        Anchor(f"lowerleg01.{s}", shin, f"foot.{s}", foot),
        Anchor(f"foot.{s}", foot, f"toe3-1.{s}" if toe else None, toe),
    ]
    if toe:
        out += [Anchor(f"{t}-1.{s}", toe, f"{t}-2.{s}" if toe_tip else None, toe_tip) for t in ANNY_TOES]
    return out


def _smpl() -> JointMap:
    anchors = [
        Anchor("root", "pelvis"),
        Anchor("spine03", "spine1", "spine02", "spine2"),
        Anchor("spine02", "spine2", "spine01", "spine3"),
        Anchor("spine01", "spine3", "neck01", "neck"),
        Anchor("neck01", "neck", "head", "head"),
        Anchor("head", "head"),
    ]
    for s, w in (("L", "left"), ("R", "right")):
        anchors += limb_anchors(s, f"{w}_collar", f"{w}_shoulder", f"{w}_elbow", f"{w}_wrist", f"{w}_hand",
                                f"{w}_hip", f"{w}_knee", f"{w}_ankle", f"{w}_foot", f"{w}_foot_end")
    return JointMap("smpl", tuple(anchors), ("left_hip", "right_hip"), "neck")


def _cmu() -> JointMap:
    # 31-joint CMU conversion (fairmotion / Bruderlin names). Spine1 and LeftHand own no segment.
    anchors = [
        Anchor("root", "Hips"),
        Anchor("spine04", "LowerBack", "spine02", "Spine"),
        Anchor("spine02", "Spine", "spine01", "Spine1"),
        Anchor("spine01", "Neck", "neck01", "Neck1"),
        Anchor("neck01", "Neck1", "head", "Head"),
        Anchor("head", "Head"),
    ]
    for s, w in (("L", "Left"), ("R", "Right")):
        anchors += limb_anchors(s, f"{w}Shoulder", f"{w}Arm", f"{w}ForeArm", f"{w}FingerBase", f"{s}Fingers",
                                f"{w}UpLeg", f"{w}Leg", f"{w}Foot", f"{w}ToeBase", f"{w}ToeBase_end")
    return JointMap("cmu", tuple(anchors), ("LeftUpLeg", "RightUpLeg"), "Neck1")


def _cmu_old() -> JointMap:
    # Older CMU conversion (LeftHip/LeftKnee, lowerback/Chest/Chest2/lowerneck, LeftCollar, lhand).
    anchors = [
        Anchor("root", "Hips"),
        Anchor("spine04", "lowerback", "spine02", "Chest"),
        Anchor("spine02", "Chest", "spine01", "Chest2"),
        Anchor("spine01", "lowerneck", "neck01", "Neck"),
        Anchor("neck01", "Neck", "head", "Head"),
        Anchor("head", "Head"),
    ]
    for s, w in (("L", "Left"), ("R", "Right")):
        anchors += limb_anchors(s, f"{w}Collar", f"{w}Shoulder", f"{w}Elbow", f"{s.lower()}hand", f"{s}Fingers",
                                f"{w}Hip", f"{w}Knee", f"{w}Ankle", f"{w}Toe", f"{w}Toe_end")
    return JointMap("cmu-old", tuple(anchors), ("LeftHip", "RightHip"), "Neck")


def _smpl_detail() -> JointMap:
    # SMPL-H / SMPL-X with fingers and eyes (morf.motion.smpl_hands): the body as SMPL, and one
    # anchor per finger bone and eye with no rest direction, so it turns from Anny's own rest.
    from morf.motion.smpl_hands import detail_bones

    base = _smpl()
    extra = tuple(Anchor(bone, joint) for bone, joint in detail_bones())
    return JointMap("smpl-hands", base.anchors + extra, base.hips, base.up)


SMPL_MAP = _smpl()
SMPL_DETAIL_MAP = _smpl_detail()
CMU_MAP = _cmu()
CMU_OLD_MAP = _cmu_old()
# Most joints first: a skeleton with SMPL-X hands takes the map that drives them.
KNOWN_MAPS = (SMPL_DETAIL_MAP, SMPL_MAP, CMU_MAP, CMU_OLD_MAP)

