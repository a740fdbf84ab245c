"""A joint map for BVH skeletons with unfamiliar names: sides and body parts from the names,
the segments between them from the hierarchy.

Only a few joints are found by name (per side: the hand and the foot; the head); the rest come
from structure: walking up from the hand gives the forearm, upper arm and clavicle segments,
walking up from the foot the shin and thigh, and the path from the hips to the head the spine
and neck, whose segments go to the Anny spine bone at the nearest height.
"""

from __future__ import annotations

import re

import numpy as np

from morf.errors import InputError
from morf.motion.joint_maps import KNOWN_MAPS, Anchor, JointMap, limb_anchors
from morf.motion.skeleton import SourceSkeleton

_TOKENS = re.compile(r"[A-Z]+(?=[A-Z][a-z])|[A-Z]?[a-z]+|[A-Z]+|\d+")
_PARTS = ("hand", "wrist", "foot", "ankle", "toe", "head", "neck", "finger", "thumb", "index", "middle",
          "ring", "pinky", "twist", "roll", "end", "hips", "hip", "pelvis", "arm", "leg", "collar", "shoulder",
          "clavicle", "knee", "elbow")

# Anny spine/neck bones and the path-length fraction (hips = 0, head = 1) of the middle of
# each bone's segment, measured on the default phenotype's zero pose.
ANNY_SPINE_MIDS = (("spine05", 0.058), ("spine04", 0.173), ("spine03", 0.288), ("spine02", 0.458),
                   ("spine01", 0.701), ("neck01", 0.860), ("neck02", 0.918), ("neck03", 0.975))


def name_tokens(name: str) -> tuple[str | None, set[str]]:
    """(side "L"/"R"/None, lower-case word set) of a joint name such as ``mixamorig:LeftUpLeg``,
    ``LHipJoint``, ``lhand``, ``upperarm_l`` or ``Bip01 R Forearm``."""
    base = re.split(r"[:|]", name)[-1]
    words = [w.lower() for w in _TOKENS.findall(base)]
    side = None
    out: set[str] = set()
    for w in words:
        if w in ("left", "l"):
            side = "L"
        elif w in ("right", "r"):
            side = "R"
        elif len(w) > 1 and w[0] in "lr" and any(w[1:].startswith(p) for p in _PARTS):
            side = "L" if w[0] == "l" else "R"  # "lhand", "rfoot"
            out.add(w[1:])
        else:
            out.add(w)
    # "upleg", "forearm", "lowerback" arrive as one word: keep their parts findable.
    joined = "".join(sorted(out))
    for p in _PARTS:
        if p in joined:
            out.add(p)
    return side, out


def _find(names, side, parts, exclude=()) -> list[int]:
    hits = []
    for i, n in enumerate(names):
        s, w = name_tokens(n)
        if s == side and w & set(parts) and not w & set(exclude):
            hits.append(i)
    return hits


def body_part_joints(names) -> tuple[list[int], list[int]]:
    """(head-like joints, foot-like joints) by name, for telling which way is up."""
    heads = _find(names, None, ("head", "neck"), ("end",))
    feet = [i for s in "LR" for i in _find(names, s, ("foot", "ankle", "toe"), ("end",))]
    return heads, feet


def _top(sk: SourceSkeleton, idx: list[int]) -> int | None:
    """The joint of ``idx`` nearest the root (fewest ancestors)."""
    return min(idx, key=lambda i: len(sk.ancestors(i))) if idx else None


def _segments_to(sk: SourceSkeleton, rest: np.ndarray, start: int, end: int) -> list[tuple[int, int]]:
    """Segments with a length on the path ``start`` -> ``end`` (``start`` an ancestor of ``end``), each as
    (owner joint, joint at its far end); the owner is the last joint at the segment's near point."""
    path = [end] + sk.ancestors(end)
    path = path[: path.index(start) + 1][::-1]
    segs, owner = [], path[0]
    for j in path[1:]:
        if np.linalg.norm(rest[j] - rest[owner]) > 1e-6:
            segs.append((owner, j))
        owner = j
    return segs


def _tip(sk: SourceSkeleton, rest: np.ndarray, j: int, prefer=("middle",), avoid=("thumb",)) -> int | None:
    """A descendant of ``j`` at another point, along the preferred child chain."""
    frontier = sk.children(j)
    while frontier:
        def rank(c):
            _, w = name_tokens(sk.names[c])
            return (0 if w & set(prefer) else 1 if not w & set(avoid) else 2, c)
        c = min(frontier, key=rank)
        if np.linalg.norm(rest[c] - rest[j]) > 1e-6:
            return c
        frontier = sk.children(c)
    return None


def _lca(sk: SourceSkeleton, a: int, b: int) -> int:
    up_a = [a] + sk.ancestors(a)
    return next(j for j in [b] + sk.ancestors(b) if j in up_a)


def match_joint_map(sk: SourceSkeleton) -> JointMap:
    """Build a :class:`JointMap` for an unfamiliar skeleton; InputError if no body can be found."""
    names, rest = sk.names, sk.rest_positions()
    hands = {s: _top(sk, _find(names, s, ("hand", "wrist"), ("finger", "thumb", "end"))) for s in "LR"}
    feet = {s: _top(sk, _find(names, s, ("foot", "ankle"), ("toe", "end"))) for s in "LR"}
    head = _top(sk, _find(names, None, ("head",), ("end", "top")))
    missing = [k for k, v in (("left hand", hands["L"]), ("right hand", hands["R"]), ("left foot", feet["L"]),
                              ("right foot", feet["R"]), ("head", head)) if v is None]
    if missing:
        raise InputError(f"cannot match this skeleton to a body: no joint named like {', '.join(missing)}")
    hips_idx = _lca(sk, feet["L"], feet["R"])
    chest = _lca(sk, hands["L"], hands["R"])
    hip_joint = _top(sk, _find(names, None, ("hips", "pelvis")))
    root = hip_joint if hip_joint is not None and hip_joint in [hips_idx] + sk.ancestors(hips_idx) else hips_idx

    anchors = [Anchor("root", names[root])]
    sides = {}
    for s in "LR":
        arm = [seg for seg in _segments_to(sk, rest, chest, hands[s])
               if not name_tokens(names[seg[0]])[1] & {"twist", "roll"}]
        if len(arm) < 2:
            raise InputError(f"cannot match this skeleton: too few arm joints above {names[hands[s]]}")
        clav = arm[-3][0] if len(arm) >= 3 and name_tokens(names[arm[-3][0]])[0] == s else None
        leg = _segments_to(sk, rest, hips_idx, feet[s])
        if len(leg) < 2:
            raise InputError(f"cannot match this skeleton: too few leg joints above {names[feet[s]]}")
        hand_owner = _owner_at(sk, rest, hands[s])
        hand_tip = _tip(sk, rest, hand_owner)
        toe = _tip(sk, rest, feet[s], prefer=("toe",), avoid=())
        toe_owner = _owner_at(sk, rest, toe) if toe is not None else None
        toe_tip = _tip(sk, rest, toe_owner, prefer=(), avoid=()) if toe_owner is not None else None
        nm = lambda i: names[i] if i is not None else None  # noqa: E731
        anchors += limb_anchors(s, nm(clav), names[arm[-2][0]], names[arm[-1][0]], names[hand_owner], nm(hand_tip),
                                names[leg[-2][0]], names[leg[-1][0]], names[_owner_at(sk, rest, feet[s])],
                                nm(toe_owner), nm(toe_tip))
        sides[s] = names[leg[-2][0]]
    anchors += _spine_anchors(sk, rest, root, head)
    neck_base = next((a.joint for a in anchors if a.bone == "neck01"), names[head])
    return JointMap("fuzzy", tuple(anchors), (sides["L"], sides["R"]), neck_base)


def _owner_at(sk: SourceSkeleton, rest: np.ndarray, j: int) -> int:
    """The joint that owns the segment starting at ``j``'s point (``j`` or a zero-offset descendant)."""
    while True:
        same = [c for c in sk.children(j) if np.linalg.norm(rest[c] - rest[j]) <= 1e-6
                and _tip(sk, rest, c) is not None and not name_tokens(sk.names[c])[1] & {"thumb"}]
        if not same:
            return j
        j = same[0]


def _spine_anchors(sk: SourceSkeleton, rest: np.ndarray, root: int, head: int) -> list[Anchor]:
    """Spine and neck segments from the hips to the head onto Anny's spine bones by height."""
    segs = _segments_to(sk, rest, root, head)
    lengths = np.array([np.linalg.norm(rest[b] - rest[a]) for a, b in segs])
    cum = np.concatenate([[0.0], np.cumsum(lengths)]) / max(lengths.sum(), 1e-9)
    out, last = [], -1
    for k, (owner, end) in enumerate(segs):
        if owner == root:
            continue  # the hips' own segment moves with Anny's root
        mid = 0.5 * (cum[k] + cum[k + 1])
        choices = [(abs(f - mid), i) for i, (_, f) in enumerate(ANNY_SPINE_MIDS) if i > last]
        if not choices:
            break
        _, i = min(choices)
        last = i
        out.append((ANNY_SPINE_MIDS[i][0], sk.names[owner], sk.names[end]))
    # Each anchor's Anny direction runs to the next anchored bone: the span its source segment covers.
    nxt = [b for b, _, _ in out[1:]] + ["head"]
    return [Anchor(b, j, t, e) for (b, j, e), t in zip(out, nxt)] + [Anchor("head", sk.names[head])]


def map_for(skeleton) -> JointMap:
    """The documented map whose joints a :class:`~morf.motion.skeleton.SourceSkeleton` has; otherwise
    the fuzzy name matcher's (:func:`match_joint_map`)."""
    have = set(skeleton.names)
    for jm in KNOWN_MAPS:
        if jm.source_joints() <= have:
            return jm
    return match_joint_map(skeleton)
