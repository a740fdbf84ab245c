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


# The skeletons known by their joint names, one column each: the joint that drives each Anny
# bone, ">" the joint its rest direction points to (the spine's; the limbs' follow from
# limb_anchors), "-" none. Each spine bone's direction ends at the next anchored bone, the last
# one's at the head; the joint on neck01 is the map's ``up``, the thighs are its ``hips``. Limb
# names are templates: {side} "left" / "right", {Side} "Left" / "Right", {s} "L" / "R", {l} "l" / "r".
# cmu: the 31-joint CMU conversion (fairmotion / Bruderlin names; Spine1 and LeftHand own no
# segment); cmu-old: the older one (LeftHip / LeftKnee, lowerback / Chest / Chest2 / lowerneck).
_NAMED_SKELETONS = """
Anny        smpl               cmu                  cmu-old
root        pelvis             Hips                 Hips
spine04     -                  LowerBack>Spine      lowerback>Chest
spine03     spine1>spine2      -                    -
spine02     spine2>spine3      Spine>Spine1         Chest>Chest2
spine01     spine3>neck        Neck>Neck1           lowerneck>Neck
neck01      neck>head          Neck1>Head           Neck>Head
head        head               Head                 Head
clavicle    {side}_collar      {Side}Shoulder       {Side}Collar
upperarm    {side}_shoulder    {Side}Arm            {Side}Shoulder
lowerarm    {side}_elbow       {Side}ForeArm        {Side}Elbow
hand        {side}_wrist       {Side}FingerBase     {l}hand
hand_tip    {side}_hand        {s}Fingers           {s}Fingers
thigh       {side}_hip         {Side}UpLeg          {Side}Hip
shin        {side}_knee        {Side}Leg            {Side}Knee
foot        {side}_ankle       {Side}Foot           {Side}Ankle
toe         {side}_foot        {Side}ToeBase        {Side}Toe
toe_tip     {side}_foot_end    {Side}ToeBase_end    {Side}Toe_end
"""
_SPINE_ROWS = ("spine04", "spine03", "spine02", "spine01", "neck01")
_LIMB_ROWS = ("clavicle", "upperarm", "lowerarm", "hand", "hand_tip", "thigh", "shin", "foot", "toe", "toe_tip")


def _named_joint_map(name: str) -> JointMap:
    """The :class:`JointMap` of the skeleton ``name``, a column of the table above: the root, the
    spine chain, the head, then each side's limbs."""
    rows = [line.split() for line in _NAMED_SKELETONS.strip().splitlines()]
    column = {row[0]: row[rows[0].index(name)] for row in rows[1:]}
    spine = [(bone, *column[bone].split(">")) for bone in _SPINE_ROWS if column[bone] != "-"]
    bones = [bone for bone, _, _ in spine] + ["head"]
    anchors = [Anchor("root", column["root"])]
    anchors += [Anchor(bone, joint, bones[k + 1], tip) for k, (bone, joint, tip) in enumerate(spine)]
    anchors.append(Anchor("head", column["head"]))
    hips = []
    for s, side in (("L", "left"), ("R", "right")):
        joints = [column[r].format(side=side, Side=side.title(), s=s, l=s.lower()) for r in _LIMB_ROWS]
        anchors += limb_anchors(s, *joints)
        hips.append(joints[_LIMB_ROWS.index("thigh")])
    return JointMap(name, tuple(anchors), (hips[0], hips[1]), column["neck01"].split(">")[0])


def _smpl_detail() -> JointMap:
    # SMPL-H / SMPL-X with fingers and eyes (morf.motion.smpl_hands): the body as SMPL, and one
    # anchor per finger bone and eye with no rest direction, so it turns from Anny's own rest.
    from morf.motion.smpl_hands import detail_bones

    base = _named_joint_map("smpl")
    extra = tuple(Anchor(bone, joint) for bone, joint in detail_bones())
    return JointMap("smpl-hands", base.anchors + extra, base.hips, base.up)


SMPL_MAP = _named_joint_map("smpl")
SMPL_DETAIL_MAP = _smpl_detail()
CMU_MAP = _named_joint_map("cmu")
CMU_OLD_MAP = _named_joint_map("cmu-old")
# Most joints first: a skeleton with SMPL-X hands takes the map that drives them.
KNOWN_MAPS = (SMPL_DETAIL_MAP, SMPL_MAP, CMU_MAP, CMU_OLD_MAP)

