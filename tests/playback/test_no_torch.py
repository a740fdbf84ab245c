"""An exported avatar loads and plays with numpy, onnxruntime and moderngl only (no torch, and no
onnx package, whose import costs half a second)."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import sys
    sys.modules["torch"] = None  # any import of torch now fails
    sys.modules["onnx"] = None  # and of onnx
    import numpy as np
    from morf.export.avatar_folder import load_exported_avatar
    from morf.playback.player import Player
    from morf.raster.camera_paths import front_camera

    av = load_exported_avatar(sys.argv[1], verify=True)
    with Player(av, size=64, background=(0, 0, 0)) as p:
        img = p.render(np.zeros((av.skeleton.num_bones, 3)), np.zeros(3), front_camera(64))
    assert "torch" not in [m for m in sys.modules if sys.modules[m] is not None]
    print("person pixels", int((img.sum(-1) > 30).sum()))
""")


def test_loads_and_plays_without_torch(tiny_avatar):
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(tiny_avatar)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert int(r.stdout.split()[-1]) > 200


def test_motion_clips_import_without_torch():
    """The player's motions are MotionClips, whose module (and the player's) imports no torch."""
    script = textwrap.dedent("""
        import sys
        import morf.motion.clip, morf.playback.motion_input, morf.playback.player
        assert "torch" not in sys.modules, "torch was imported"
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]


def test_the_command_line_is_built_without_torch():
    """Every ``morf`` command builds the whole parser (the preset registry, each benchmark's options):
    none of that may import torch, so a command that needs none starts without it."""
    script = textwrap.dedent("""
        import sys
        sys.modules["torch"] = None  # any import of torch now fails
        from morf.cli.main import build_parser
        args = build_parser().parse_args(["play", "avatar", "--motion", "walk.npz", "--out", "walk.mp4"])
        assert args.command == "play", args
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]


def test_manifest_describes_the_folder(tiny_avatar):
    import json

    from morf.export.avatar_folder import load_exported_avatar

    m = json.loads((tiny_avatar / "manifest.json").read_text())
    assert m["format"] == "morf-avatar" and m["texture"]["channels"] == 16 and len(m["texture"]["channel_scales"]) == 16
    assert set(m["files"]) == {"texture.npz", "mesh.npz", "skeleton.npz", "renderer.onnx", "renderer_int8.onnx"}
    assert all(len(f["sha256"]) == 64 and f["bytes"] > 0 for f in m["files"].values())
    assert m["int8_quality"]["psnr_db"] > 30
    av = load_exported_avatar(tiny_avatar)
    assert av.texture.data.shape[2] == 16 and av.mesh.bone_indices.shape[1] == 8


def test_damaged_file_is_reported(tiny_avatar, tmp_path):
    import shutil

    import pytest

    from morf.errors import InputError
    from morf.export.avatar_folder import load_exported_avatar

    copy = tmp_path / "a"
    shutil.copytree(tiny_avatar, copy)
    with open(copy / "texture.npz", "r+b") as f:
        f.seek(100)
        f.write(b"\\x00\\x01\\x02")
    with pytest.raises(InputError):
        load_exported_avatar(copy, verify=True)


def test_playback_cameras_need_no_torch():
    """PinholeCamera itself imports torch lazily, so playback cameras work without it."""
    script = textwrap.dedent("""
        import sys
        sys.modules["torch"] = None
        from morf.raster.camera_paths import front_camera
        cam = front_camera(96, yaw_deg=33)
        assert cam.position[1] < 0  # in front of the person (Anny faces -Y)
        print(cam.gl_projection().shape)
    """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr[-2000:]
