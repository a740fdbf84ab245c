"""BVH motion files: any joint names, any rotation order per joint, 3- or 6-channel joints,
Y-up or Z-up, lengths in any unit (detected from the skeleton's height)."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.io.arrays import first_outside
from morf.motion.checks import (MAX_ANGLE_DEG, MAX_TRANSLATION_M, check_degrees, check_duration, check_fps,
                                check_range, check_translations, number_text)
from morf.motion.skeleton import SourceMotion, SourceSkeleton, UNITS, detect_unit
from morf.motion.so3 import euler_to_matrix

_AXES = {"xrotation": "X", "yrotation": "Y", "zrotation": "Z"}
_POS = {"xposition": 0, "yposition": 1, "zposition": 2}


class BvhHierarchy:
    """A BVH's joints in file order (parents first): names, parent indices, offsets, channels.
    Public so that a header check (the studio's motion browser) reads a file as the reader does."""

    def __init__(self):
        self.names: list[str] = []
        self.parents: list[int] = []
        self.offsets: list[list[float]] = []
        self.channels: list[list[str]] = []


# A BVH of this size holds hours of mocap at 120 fps; more is not a motion clip.
MAX_BVH_BYTES = 256 * 2**20

def parse_hierarchy(lines: list[str], path: Path) -> tuple[BvhHierarchy, int]:
    """Joints in file order (parents first) and the index of the MOTION line. Reads only the
    hierarchy, so a header check costs no frame data; a malformed hierarchy is an InputError."""
    out = BvhHierarchy()
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
            out.offsets[stack[-1]] = [_number(v, path, i + 1, "OFFSET") for v in tok[1:4]]
        elif key == "CHANNELS":
            n = int(_number(tok[1], path, i + 1, "CHANNELS count")) if len(tok) > 1 else -1
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


def _number(token: str, path: Path, line: int, what: str) -> float:
    try:
        return float(token)
    except ValueError:
        raise InputError(f"{path}: line {line}: {what} value {token!r} is not a number") from None


def _add(out: BvhHierarchy, name: str, parent: int) -> int:
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
        size = path.stat().st_size
        if size > MAX_BVH_BYTES:  # the text and its numbers take several times the file in memory
            raise InputError(f"{path} is {size / 2**20:.0f} MiB, more than the {MAX_BVH_BYTES // 2**20} MiB a BVH "
                             "motion may take here; cut the clip into shorter files")
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as e:
        raise InputError(f"cannot read {path}: {e.strerror or e}") from None
    lines = text.splitlines()
    if not lines or lines[0].strip().upper() != "HIERARCHY":
        raise InputError(f"{path}: not a BVH file (no HIERARCHY header)")
    parsed, motion_line = parse_hierarchy(lines, path)
    if not parsed.names:
        raise InputError(f"{path}: no joints")
    n_channels = sum(len(c) for c in parsed.channels)
    frames, frame_time, data = _parse_motion(lines, motion_line + 1, n_channels, path)

    offsets = np.asarray(parsed.offsets, dtype=np.float64)
    names = tuple(parsed.names)
    for j in np.nonzero(~np.isfinite(offsets).all(axis=1))[0]:  # before the up axis and unit are guessed from them
        _check_offset(offsets[j], names[j], path)
    raw = SourceSkeleton(names, tuple(parsed.parents), offsets, "y")
    if up_axis == "auto":
        up_axis = guess_up_axis(raw)
    if unit == "auto":
        unit, scale = detect_unit(raw.rest_positions(), up_axis)
    elif unit in UNITS:
        scale = UNITS[unit]
    else:
        raise InputError(f"unknown length unit {unit!r}; known: {', '.join(UNITS)}")
    _check_numbers(parsed, offsets, data, scale, path)
    fps = _frame_rate(frame_time, path)
    check_duration(frames, fps, str(path))

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
    return SourceMotion(skeleton, local, root_pos * scale, fps, up_axis=up_axis, name=path.stem,
                        source=f"bvh:{path.name} ({unit}, {up_axis}-up)", kind="bvh", channel_orders=tuple(orders))


def _parse_motion(lines: list[str], start: int, n_channels: int, path: Path) -> tuple[int, float, np.ndarray]:
    """(frames, frame time in seconds as written, (frames, n_channels) values) of the MOTION
    section starting at line index ``start``. A frame may be wrapped over several lines as long
    as the values add up."""
    frames = frame_time = None
    i = start
    while i < len(lines) and frame_time is None:
        s = lines[i].strip()
        low = s.lower()
        if not s:
            pass
        elif low.startswith("frames:"):
            value = s.split(":", 1)[1].strip()
            if not value.isdigit():
                raise InputError(f"{path}: line {i + 1}: 'Frames: {value}' is not a frame count")
            frames = int(value)
        elif low.startswith("frame time:"):
            frame_time = _number(s.split(":", 1)[1].strip(), path, i + 1, "Frame Time")
        else:
            raise InputError(f"{path}: line {i + 1}: expected 'Frames:' and 'Frame Time:' after MOTION")
        i += 1
    if frames is None or frame_time is None:
        raise InputError(f"{path}: missing 'Frames:' or 'Frame Time:' after MOTION")
    if frames <= 0:
        raise InputError(f"{path}: no frames ('Frames: {frames}')")
    rows = [(k + 1, line.split()) for k, line in enumerate(lines[i:], start=i) if line.strip()]
    counts = [len(tok) for _, tok in rows]
    if sum(counts) != frames * n_channels:
        wrong = next(((n, c) for (n, _), c in zip(rows, counts) if c != n_channels), None)
        if wrong is not None:
            raise InputError(f"{path}: line {wrong[0]} has {wrong[1]} values, but the hierarchy's CHANNELS "
                             f"declare {n_channels} per frame")
        raise InputError(f"{path}: 'Frames: {frames}' but {len(rows)} frames of data follow"
                         + ("; the file may be cut short" if len(rows) < frames else "")
                         + "; correct the Frames: line")
    try:
        data = np.array([v for _, tok in rows for v in tok], dtype=np.float64)
    except ValueError:
        line, token = next((n, v) for n, tok in rows for v in tok if not _is_number(v))
        raise InputError(f"{path}: line {line}: {token!r} is not a number") from None
    return frames, frame_time, data.reshape(frames, n_channels)


def _is_number(token: str) -> bool:
    try:
        float(token)
    except ValueError:
        return False
    return True


def _frame_rate(frame_time: float, path: Path) -> float:
    """Frames per second from the file's 'Frame Time:' (seconds per frame); 120.0 for .0083333."""
    if not np.isfinite(frame_time) or frame_time <= 0:
        raise InputError(f"{path}: 'Frame Time: {number_text(frame_time)}' is not a time between frames; write the "
                         "seconds per frame there (0.0333333 for 30 fps)")
    fps = 1.0 / frame_time
    if abs(fps - round(fps)) < 0.01 and round(fps) > 0:  # "Frame Time: .0083333" means 120 fps
        fps = float(round(fps))
    return check_fps(fps, str(path), f"the frame rate of 'Frame Time: {frame_time:g}'")


def _check_numbers(parsed: BvhHierarchy, offsets: np.ndarray, data: np.ndarray, scale: float, path: Path) -> None:
    """Offsets and channel values finite and in range (lengths in metres once scaled by ``scale``);
    the message names the joint, the channel and the first bad frame."""
    for j, name in enumerate(parsed.names):
        _check_offset(offsets[j] * scale, name, path)
    columns = [(name, c) for name, chans in zip(parsed.names, parsed.channels) for c in chans]
    if not columns:
        return
    is_pos = np.array([c in _POS for _, c in columns])
    limit = np.where(is_pos, MAX_TRANSLATION_M / scale, MAX_ANGLE_DEG)
    bad = first_outside(data, -limit, limit)
    if bad is None:
        return
    col = bad[0][1]
    name, chan = columns[col]
    field = f"{chan.capitalize()} of joint {name!r}"
    if is_pos[col]:
        check_translations(data[:, col] * scale, str(path), field)
    else:
        check_degrees(data[:, col], str(path), field)


def _check_offset(offset: np.ndarray, name: str, path: Path) -> None:
    check_range(offset, str(path), f"the OFFSET of joint {name!r}", MAX_TRANSLATION_M, "m", "bone offset",
                frame_axis=False)


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
