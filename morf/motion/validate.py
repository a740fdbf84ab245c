"""How well a retargeted motion follows its source: bone directions compared on the posed body."""

from __future__ import annotations

import numpy as np
import torch

from morf.body.model import BodyPose
from morf.motion.retargeting import Retargeted

# (label, Anny bone at the segment start, Anny bone at its end); the source segment runs between
# the joints the joint map assigns to the same two bones.
SEGMENTS = (
    ("upper arm L", "upperarm01.L", "lowerarm01.L"), ("upper arm R", "upperarm01.R", "lowerarm01.R"),
    ("forearm L", "lowerarm01.L", "wrist.L"), ("forearm R", "lowerarm01.R", "wrist.R"),
    ("thigh L", "upperleg01.L", "lowerleg01.L"), ("thigh R", "upperleg01.R", "lowerleg01.R"),
    ("shin L", "lowerleg01.L", "foot.L"), ("shin R", "lowerleg01.R", "foot.R"),
    ("spine", "root", "neck"),  # "neck": the lowest anchored bone of neck01..03, head
)


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


@torch.no_grad()
def direction_errors(r: Retargeted, source_names: tuple[str, ...], model, shape: torch.Tensor | None = None,
                     frames: np.ndarray | None = None, batch_size: int = 64) -> dict[str, float]:
    """Mean angle (degrees) between source and Anny segment directions, per segment of
    :data:`SEGMENTS` (labels as keys) plus ``"mean"`` over all of them.

    Args:
        r: retargeted rotations with the source joints in the same world (``r.source_positions``).
        source_names: the source skeleton's joint names (indexing ``r.source_positions``).
        frames: which frames to compare (default: all).
    """
    shape = model.default_shape() if shape is None else shape[:1]
    frames = np.arange(r.rotvecs.shape[0]) if frames is None else np.asarray(frames)
    names = list(model.bone_names)
    joints = []
    for s in range(0, len(frames), batch_size):
        f = frames[s:s + batch_size]
        pose = BodyPose(torch.as_tensor(r.rotvecs[f], dtype=torch.float32),
                        torch.as_tensor(r.transl[f], dtype=torch.float32))
        joints.append(model(pose, shape).joints.double().cpu().numpy())
    joints = np.concatenate(joints)
    src = r.source_positions[frames]
    out = {}
    for label, a, b in SEGMENTS:
        if b == "neck":
            b = next((n for n in ("neck01", "neck02", "neck03", "head") if r.joint_map.joint_for(n)), "head")
        ja, jb = r.joint_map.joint_for(a), r.joint_map.joint_for(b)
        if ja is None or jb is None:
            continue
        d_src = _unit(src[:, source_names.index(jb)] - src[:, source_names.index(ja)])
        d_anny = _unit(joints[:, names.index(b)] - joints[:, names.index(a)])
        cos = np.clip((d_src * d_anny).sum(-1), -1.0, 1.0)
        out[label] = float(np.degrees(np.arccos(cos)).mean())
    out["mean"] = float(np.mean(list(out.values())))
    return out


def main(argv: list[str] | None = None) -> int:
    """``python -m morf.motion.validate FILE [--step N]``: direction errors, foot contact and sliding."""
    import argparse

    from morf.body import load_body_model
    from morf.motion.anny_rest import target_rest
    from morf.motion.convert import RetargetConfig, retarget
    from morf.motion.ground import GroundConfig, foot_points, foot_skate
    from morf.motion.retargeting import retarget_rotations

    ap = argparse.ArgumentParser(description="Check how a retargeted motion follows its source.")
    ap.add_argument("file", help=".bvh or AMASS .npz")
    ap.add_argument("--step", type=int, default=4, help="compare every N-th source frame")
    args = ap.parse_args(argv)
    from morf.errors import MorfError

    try:
        if args.file.lower().endswith(".bvh"):
            from morf.motion.bvh import read_bvh

            source = read_bvh(args.file)
        else:
            from morf.motion.amass import read_amass

            source = read_amass(args.file)
    except MorfError as e:
        print(f"error: {e}")
        return 2
    model = load_body_model("anny")
    r = retarget_rotations(source, target_rest(model))
    errors = direction_errors(r, source.skeleton.names, model, frames=np.arange(0, source.num_frames, args.step))
    print(f"{source.source}: {source.num_frames} frames at {source.fps:g} fps, map {r.joint_map.name}, scale {r.scale:.3f}")
    print("direction error (deg): " + ", ".join(f"{k} {v:.4f}" for k, v in errors.items()))
    clip = retarget(source, model)
    plain = retarget(source, model, config=RetargetConfig(ground=GroundConfig(reduce_sliding=False)))
    low = foot_points(clip, model)[..., 2].min(axis=1)
    print(f"lowest foot point (m): median {np.median(low):.4f}, min {low.min():.4f}, max {low.max():.4f}; "
          f"within 5 mm in {np.mean(low < 0.005) * 100:.0f}% of frames")
    print(f"foot sliding (m/s): {foot_skate(clip, model):.3f} with the correction, {foot_skate(plain, model):.3f} without")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
