"""BVH motion files: any joint names, any rotation order per joint, 3- or 6-channel joints,
Y-up or Z-up, lengths in any unit (detected from the skeleton's height)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.motion.skeleton import SourceMotion, SourceSkeleton, UNITS, detect_unit
from morf.motion.so3 import euler_to_matrix

_AXES = {"xrotation": "X", "yrotation": "Y", "zrotation": "Z"}
_POS = {"xposition": 0, "yposition": 1, "zposition": 2}


class _Parsed:
    def __init__(self):
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[list[str]] = []


def _parse_hierarchy(lines: list[str], path: Path) -> tuple[_Parsed, int]:
    """Joints in file order (parents first); returns the index of the MOTION line."""
    out = _Parsed()
    stack: list[int] = []
    pending: int | None = None  # joint declared, its "{" not yet seen
    for i, raw in enumerate(lines):
        tok = raw.split()
        if not tok:
            continue
        key = tok[0].upper()
        if key == "HIERARCHY":
            continue
        if key in ("ROOT", "JOINT"):
            name = " ".join(tok[1:]) or f"joint{len(out.names)}"
            pending = _add(out, name, stack[-1] if stack else -1)
        elif key == "END":
            parent = stack[-1] if stack else -1
            pending = _add(out, f"{out.names[parent]}_end" if parent >= 0 else "end", parent)
        elif key == "{":
            if pending is None:
                raise InputError(f"{path}: line {i + 1}: '{{' without a joint")
            stack.append(pending)
            pending = None
        elif key == "}":
            if not stack:
                raise InputError(f"{path}: line {i + 1}: unbalanced '}}'")
            stack.pop()
        elif key == "OFFSET":
            if not stack or len(tok) < 4:
                raise InputError(f"{path}: line {i + 1}: bad OFFSET")
            out.offsets[stack[-1]] = [float(v) for v in tok[1:4]]
        elif key == "CHANNELS":
            n = int(tok[1])
            names = [t.lower() for t in tok[2:2 + n]]
            if len(names) != n or any(c not in _AXES and c not in _POS for c in names):
                raise InputError(f"{path}: line {i + 1}: bad CHANNELS {' '.join(tok[2:])}")
            out.channels[stack[-1]] = names
        elif key == "MOTION":
            if stack:
                raise InputError(f"{path}: hierarchy not closed before MOTION")
            return out, i
        else:
            raise InputError(f"{path}: line {i + 1}: unexpected {tok[0]!r}")
    raise InputError(f"{path}: no MOTION section")


def _add(out: _Parsed, name: str, parent: int) -> int:
    out.names.append(name)
    out.parents.append(parent)
    out.offsets.append([0.0, 0.0, 0.0])
    out.channels.append([])
    return len(out.names) - 1


def read_bvh(path: str | os.PathLike, up_axis: str = "auto", unit: str = "auto") -> SourceMotion:
    """Read a BVH file into a :class:`SourceMotion` in metres.

    Args:
        up_axis: "y", "z" or "auto" (from where the head is relative to the feet).
        unit: a key of :data:`morf.motion.skeleton.UNITS` or "auto" (from the skeleton height).
    Raises:
        InputError: the file is missing or not a readable BVH.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None
    lines = text.splitlines()
    if not lines or lines[0].strip().upper() != "HIERARCHY":
        raise InputError(f"{path}: not a BVH file (no HIERARCHY header)")
    try:
        parsed, motion_line = _parse_hierarchy(lines, path)
        frames, frame_time, data = _parse_motion(lines[motion_line + 1:], path)
    except ValueError as e:
        raise InputError(f"{path}: malformed number: {e}") from None
    if not parsed.names:
        raise InputError(f"{path}: no joints")
    n_channels = sum(len(c) for c in parsed.channels)
    if data.size != frames * n_channels:
        raise InputError(f"{path}: {data.size} values for {frames} frames x {n_channels} channels")
    data = data.reshape(frames, n_channels)

    offsets = np.asarray(parsed.offsets, dtype=np.float64)
    names = tuple(parsed.names)
    raw = SourceSkeleton(names, tuple(parsed.parents), offsets, "y")
    if up_axis == "auto":
        up_axis = guess_up_axis(raw)
    if unit == "auto":
        unit, scale = detect_unit(raw.rest_positions(), up_axis)
    elif unit in UNITS:
        scale = UNITS[unit]
    else:
        raise InputError(f"unknown length unit {unit!r}; known: {', '.join(UNITS)}")

    J = len(names)
    local = np.broadcast_to(np.eye(3), (frames, J, 3, 3)).copy()
    root_pos = np.broadcast_to(offsets[0], (frames, 3)).copy()
    col = 0
    orders = []
    for j, chans in enumerate(parsed.channels):
        block = data[:, col:col + len(chans)]
        col += len(chans)
        rot = [(c, k) for k, c in enumerate(chans) if c in _AXES]
        orders.append("".join(_AXES[c] for c, _ in rot))
        if rot:
            order = "".join(_AXES[c] for c, _ in rot)
            angles = block[:, [k for _, k in rot]]
            if len(rot) < 3:  # pad to three axes with zero angles
                missing = [a for a in "XYZ" if a not in order]
                order += "".join(missing[: 3 - len(rot)])
                angles = np.concatenate([angles, np.zeros((frames, 3 - len(rot)))], axis=1)
            local[:, j] = euler_to_matrix(angles, order)
        if j == 0:
            for c, k in ((c, k) for k, c in enumerate(chans) if c in _POS):
                root_pos[:, _POS[c]] = block[:, k]
        # Position channels of other joints would stretch bones; Anny's bones have fixed
        # lengths, so only their rotations are used and the rest offsets stay.
    skeleton = SourceSkeleton(names, tuple(parsed.parents), offsets * scale, up_axis)
    fps = 1.0 / frame_time if frame_time > 0 else 30.0
    if abs(fps - round(fps)) < 0.01:  # "Frame Time: .0083333" means 120 fps
        fps = float(round(fps))
    return SourceMotion(skeleton, local, root_pos * scale, fps, up_axis=up_axis, name=path.stem,
                        source=f"bvh:{path.name} ({unit}, {up_axis}-up)", kind="bvh", channel_orders=tuple(orders))


def _parse_motion(lines: list[str], path: Path) -> tuple[int, float, np.ndarray]:
    frames, frame_time, start = None, None, None
    for i, raw in enumerate(lines):
        s = raw.strip()
        if not s:
            continue
        low = s.lower()
        if low.startswith("frames:"):
            frames = int(s.split(":", 1)[1])
        elif low.startswith("frame time:"):
            frame_time = float(s.split(":", 1)[1])
            start = i + 1
            break
        else:
            raise InputError(f"{path}: expected 'Frames:' and 'Frame Time:' after MOTION")
    if frames is None or frame_time is None:
        raise InputError(f"{path}: missing 'Frames:' or 'Frame Time:'")
    if frames <= 0:
        raise InputError(f"{path}: no frames")
    data = np.array(" ".join(lines[start:]).split(), dtype=np.float64)
    return frames, frame_time, data


def guess_up_axis(skeleton: SourceSkeleton) -> str:
    """"y" or "z": the axis along which the head-like joints sit farthest above the feet."""
    from morf.motion.name_matching import body_part_joints

    rest = skeleton.rest_positions()
    heads, feet = body_part_joints(skeleton.names)
    if heads and feet:
        up = rest[heads].mean(0) - rest[feet].mean(0)
    else:  # no telling names: the skeleton is usually taller than it is deep
        up = np.ptp(rest, axis=0) * np.array([0.0, 1.0, 0.999])
    return "y" if abs(up[1]) >= abs(up[2]) else "z"
