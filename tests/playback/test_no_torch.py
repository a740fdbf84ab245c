"""An exported avatar loads and plays with numpy, onnxruntime and moderngl only."""

import subprocess
import sys
import textwrap

SCRIPT = textwrap.dedent("""
    import sys
    sys.modules["torch"] = None  # any import of torch now fails
    import numpy as np
    from morf.export.avatar_folder import load_exported_avatar
    from morf.playback.player import Player

    class Camera:  # the PinholeCamera interface the player uses
        width = height = 64
        def view_matrix(self):
            V = np.eye(4); V[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]; V[:3, 3] = [0, 0, 3.4]; return V
        def gl_projection(self, near, far):
            P = np.zeros((4, 4)); P[0, 0] = P[1, 1] = 2 * 90 / 64
            P[2, 2] = (far + near) / (far - near); P[2, 3] = -2 * far * near / (far - near); P[3, 2] = 1; return P

    av = load_exported_avatar(sys.argv[1], verify=True)
    with Player(av, size=64, background=(0, 0, 0)) as p:
        img = p.render(np.zeros((av.skeleton.num_bones, 3)), np.zeros(3), Camera())
    assert "torch" not in [m for m in sys.modules if sys.modules[m] is not None]
    print("person pixels", int((img.sum(-1) > 30).sum()))
""")


def test_loads_and_plays_without_torch(tiny_avatar):
    r = subprocess.run([sys.executable, "-c", SCRIPT, str(tiny_avatar)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert int(r.stdout.split()[-1]) > 200


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


def test_torch_free_camera_matches_pinhole():
    import numpy as np

    import morf.playback.camera_paths as cp

    cam = cp.front_camera(96, yaw_deg=33)
    eye = cam.position
    alt = cp._TorchFreeCamera(cam.fx, 96, cam.R, cam.t)
    np.testing.assert_allclose(alt.gl_projection(), cam.gl_projection())
    np.testing.assert_allclose(alt.view_matrix(), cam.view_matrix())
    assert eye[1] < 0  # in front of the person (Anny faces -Y)
