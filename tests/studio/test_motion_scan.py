"""The motion folder listing: header checks, project internals left out, limits, unreadable
folders, recent folders (no window needed)."""

from __future__ import annotations

import json
import os
import time

import numpy as np
import pytest

from morf.io import save_npz
from studio.motion_browser import MotionBrowser
from studio.motion_scan import check_motion_file, npz_headers, scan_motions

# a person's skeleton, (joint, parent, offset in cm); the retargeting finds its hands, feet and head by name
SKELETON = (("Hips", None, (0, 95, 0)), ("Spine", "Hips", (0, 10, 0)), ("Neck", "Spine", (0, 30, 0)),
            ("Head", "Neck", (0, 8, 0)), ("LeftShoulder", "Spine", (4, 25, 0)), ("LeftArm", "LeftShoulder", (10, 0, 0)),
            ("LeftForeArm", "LeftArm", (25, 0, 0)), ("LeftHand", "LeftForeArm", (25, 0, 0)),
            ("RightShoulder", "Spine", (-4, 25, 0)), ("RightArm", "RightShoulder", (-10, 0, 0)),
            ("RightForeArm", "RightArm", (-25, 0, 0)), ("RightHand", "RightForeArm", (-25, 0, 0)),
            ("LeftUpLeg", "Hips", (9, 0, 0)), ("LeftLeg", "LeftUpLeg", (0, -42, 0)), ("LeftFoot", "LeftLeg", (0, -40, 0)),
            ("RightUpLeg", "Hips", (-9, 0, 0)), ("RightLeg", "RightUpLeg", (0, -42, 0)),
            ("RightFoot", "RightLeg", (0, -40, 0)))


def bvh_text(skeleton=SKELETON, frames: int = 3) -> str:
    """A small BVH of ``skeleton``: the root turns a little each frame."""
    children: dict = {}
    for name, parent, offset in skeleton:
        children.setdefault(parent, []).append((name, offset))
    lines = ["HIERARCHY"]

    def joint(name, offset, depth):
        pad, root = "  " * depth, depth == 0
        lines.extend([f"{pad}{'ROOT' if root else 'JOINT'} {name}", pad + "{", f"{pad}  OFFSET {' '.join(map(str, offset))}",
                      f"{pad}  CHANNELS " + ("6 Xposition Yposition Zposition " if root else "3 ") + "Zrotation Xrotation Yrotation"])
        for child, child_offset in children.get(name, []):
            joint(child, child_offset, depth + 1)
        if name not in children:
            lines.extend([f"{pad}  End Site", pad + "  {", f"{pad}    OFFSET 0 5 0", pad + "  }"])
        lines.append(pad + "}")

    joint(*children[None][0], 0)
    n = 6 + 3 * (len(skeleton) - 1)
    lines += ["MOTION", f"Frames: {frames}", "Frame Time: 0.033333"]
    lines += [" ".join(["0", "95", "0", "0", "0", str(10 * t)] + ["0"] * (n - 6)) for t in range(frames)]
    return "\n".join(lines) + "\n"


BVH = bvh_text()


def write_motion_folder(root):
    """Motions of four kinds, files that are no motions, and a project and an avatar whose
    internal .npz files must not be listed."""
    from tests.studio.conftest import make_tiny_project

    root.mkdir(parents=True, exist_ok=True)
    save_npz(root / "turn.npz", rotvecs=np.zeros((8, 104, 3), np.float32), transl=np.zeros((8, 3), np.float32),
             fps=np.float32(30))
    save_npz(root / "dance" / "amass_walk.npz", poses=np.zeros((5, 156), np.float32),
             trans=np.zeros((5, 3), np.float32), mocap_framerate=np.float32(60))
    (root / "walk.bvh").write_text(BVH)
    (root / "notes.bvh").write_text("just some text\n")
    (root / "stick.bvh").write_text(bvh_text((("Pole", None, (0, 0, 0)), ("Tip", "Pole", (0, 10, 0)))))
    (root / "empty.bvh").write_text("HIERARCHY\nROOT Hips\n{\n  OFFSET 0 0 0\n}\nMOTION\nFrames: 1\nFrame Time: 0.033\n0 0 0\n")
    (root / "text.npz").write_text("not a zip")
    save_npz(root / "weights.npz", w=np.zeros(4, np.float32))
    save_npz(root / "bent.npz", rotvecs=np.zeros((8, 3), np.float32), transl=np.zeros((8, 3), np.float32))
    project = make_tiny_project(root / "capture")  # fits/fits.npz, keypoints.npz, ...
    (project.root / "runs" / ".cache").mkdir(parents=True)
    save_npz(project.root / "runs" / ".cache" / "frames-0.npz", rotvecs=np.zeros((2, 1, 3)), transl=np.zeros((2, 3)))
    avatar = root / "exported"
    avatar.mkdir()
    (avatar / "manifest.json").write_text("{}")
    save_npz(avatar / "mesh.npz", vertices=np.zeros((3, 3), np.float32))
    (root / ".hidden").mkdir()
    (root / ".hidden" / "x.bvh").write_text(BVH)
    return root


def test_lists_motions_by_header_greys_the_rest_and_leaves_out_internals(tmp_path):
    scan = scan_motions(write_motion_folder(tmp_path / "library"))
    assert scan.error is None
    kinds = {e.name: e.kind for e in scan.motions}
    assert kinds == {"dance/amass_walk.npz": "amass", "turn.npz": "player", "walk.bvh": "bvh"}
    greyed = {e.name: e.reason for e in scan.entries if not e.is_motion}
    assert set(greyed) == {"bent.npz", "notes.bvh", "text.npz", "weights.npz", "stick.bvh", "empty.bvh"}
    assert "HIERARCHY" in greyed["notes.bvh"] and "not an .npz" in greyed["text.npz"]
    assert "no joint named like left hand" in greyed["stick.bvh"] and "no channels" in greyed["empty.bvh"]
    assert "arrays: w" in greyed["weights.npz"] and "(T, J, 3)" in greyed["bent.npz"]
    assert [e.is_motion for e in scan.entries] == sorted((e.is_motion for e in scan.entries), reverse=True)
    names = " ".join(e.name for e in scan.entries)
    for internal in ("capture", "exported", "mesh", "fits", "frames-0", "keypoints", ".hidden"):
        assert internal not in names
    assert any("2 project / avatar folder(s) left out" in n for n in scan.notes)


def test_a_project_or_avatar_folder_itself_is_refused_with_the_fix(tmp_path):
    from tests.studio.conftest import make_tiny_project

    make_tiny_project(tmp_path / "capture")
    scan = scan_motions(tmp_path / "capture")
    assert not scan.entries and "is a capture project" in scan.error and "choose a folder" in scan.error
    assert "folder not found" in scan_motions(tmp_path / "missing").error
    assert scan_motions("").error == "no folder given"


def test_headers_only_no_array_data_is_read(tmp_path, monkeypatch):
    path = tmp_path / "big.npz"
    save_npz(path, rotvecs=np.zeros((2000, 104, 3), np.float32), transl=np.zeros((2000, 3), np.float32))
    monkeypatch.setattr(np, "load", lambda *a, **k: pytest.fail("np.load was called"))
    monkeypatch.setattr(np.lib.format, "read_array", lambda *a, **k: pytest.fail("array data was read"))
    assert {k: v.shape for k, v in npz_headers(path).items()} == {"rotvecs": (2000, 104, 3), "transl": (2000, 3)}
    assert check_motion_file(path) == ("player", None)


def test_pickled_object_arrays_are_greyed(tmp_path):
    path = tmp_path / "obj.npz"
    np.savez(path, rotvecs=np.array([None, 1], dtype=object), transl=np.zeros((2, 3)))
    kind, reason = check_motion_file(path)
    assert kind is None and "pickled" in reason


def test_depth_and_count_limits(tmp_path):
    deep = tmp_path / "a" / "b" / "c"
    deep.mkdir(parents=True)
    (deep / "deep.bvh").write_text(BVH)
    for i in range(12):
        (tmp_path / f"m{i:02d}.bvh").write_text(BVH)
    scan = scan_motions(tmp_path, max_depth=2, max_files=100)
    assert "a/b/c/deep.bvh" not in {e.name for e in scan.entries}
    assert any("more than 2 levels down" in n for n in scan.notes)
    assert "a/b/c/deep.bvh" in {e.name for e in scan_motions(tmp_path, max_depth=3).entries}
    scan = scan_motions(tmp_path, max_files=5)
    assert len(scan.entries) == 5 and any("stopped after 5 files" in n for n in scan.notes)


def test_unreadable_folders_are_skipped(tmp_path, monkeypatch):
    (tmp_path / "ok").mkdir()
    (tmp_path / "ok" / "walk.bvh").write_text(BVH)
    (tmp_path / "locked").mkdir()
    (tmp_path / "locked" / "x.bvh").write_text(BVH)
    real = os.scandir

    def scandir(path):  # what a folder of another user (or /proc/1/cwd) does; root reads all, so fake it
        if str(path).endswith("locked"):
            raise PermissionError(13, "Permission denied", str(path))
        return real(path)

    monkeypatch.setattr(os, "scandir", scandir)
    scan = scan_motions(tmp_path)
    assert [e.name for e in scan.entries] == ["ok/walk.bvh"]
    assert any("1 folder(s) could not be read" in n for n in scan.notes)


def _wait(browser, timeout=10.0):
    end = time.monotonic() + timeout
    while browser.scanning is not None and time.monotonic() < end:
        time.sleep(0.01)
    assert browser.scanning is None


def test_browser_lists_off_thread_newest_commit_wins_and_remembers_folders(tmp_path):
    settings = tmp_path / "cfg" / "studio.json"
    for name in ("one", "two"):
        (tmp_path / name).mkdir()
        (tmp_path / name / f"{name}.bvh").write_text(BVH)
    b = MotionBrowser(settings=settings)
    try:
        b.commit(str(tmp_path / "one"))
        b.commit(str(tmp_path / "two"))
        b.commit(str(tmp_path / "missing"))  # an error: shown, not remembered
        _wait(b)
        assert b.latest().error and b.latest().folder == str(tmp_path / "missing")
        b.commit(str(tmp_path / "two")).result(10)
        assert [e.name for e in b.latest().entries] == ["two.bvh"]
    finally:
        b.close()
    saved = json.loads(settings.read_text())["recent_motion_folders"]
    assert saved[0] == str(tmp_path / "two") and str(tmp_path / "missing") not in saved
    again = MotionBrowser(settings=settings)
    try:
        again.commit(str(tmp_path / "one")).result(10)
        assert again.recent[:2] == [str(tmp_path / "one"), str(tmp_path / "two")]
    finally:
        again.close()


def _listed_and_played(folder) -> list[str]:
    """Every motion the listing offers, loaded as the live panel loads it; the names of those that fail."""
    from studio.player import load_live_motion

    failed = []
    for e in scan_motions(folder).motions:
        clip, note = load_live_motion(e.path, 104)
        if clip is None or not len(clip):
            failed.append(f"{e.name}: {note}")
    return failed


def test_every_listed_motion_plays_and_every_greyed_one_would_not(tmp_path):
    from morf.motion.library import BUILTIN_MOTIONS
    from studio.player import load_live_motion

    library = write_motion_folder(tmp_path / "library")
    assert _listed_and_played(library) == []
    assert _listed_and_played(BUILTIN_MOTIONS) == []
    for e in scan_motions(library).entries:
        if not e.is_motion:
            assert load_live_motion(e.path, 104)[0] is None, e.name  # the header check greys no playable file


def test_the_shared_cmu_motions_are_listed_and_the_shortest_plays(shared_data):
    from studio.player import load_live_motion

    cmu = shared_data / "motion" / "cmu"
    if not cmu.is_dir():
        pytest.skip(f"no CMU motions in {shared_data}")
    listed = scan_motions(cmu).motions
    assert {e.name for e in listed} >= {"01_01.bvh", "131_01.bvh"}
    shortest = min(listed, key=lambda e: e.path.stat().st_size)  # retargeting them all takes half a minute
    clip, note = load_live_motion(shortest.path, 104)
    assert clip is not None and len(clip) > 100, note
