"""``morf export --gltf`` in a renderer we did not write: three.js's GLTFLoader in headless Chromium
(``scripts/gltf_in_browser.sh``, ``tools/gltf-check/``), on the tiny capture of test_gltf_export.py.

three.js poses the file (its animation at keyframe and in-between times, and a pose set on the
bones) and reports every vertex's skinned world position, from its CPU skinning and from its
skinning shader on the GPU (SwiftShader); both are compared with morf.body's skinning of the same
pose. Skipped where Chromium or three (tools/gltf-check/fetch_three.py, run by scripts/test.sh) are missing.
"""

from __future__ import annotations

import importlib.util
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import require

REPO = Path(__file__).resolve().parents[2]


def _driver():
    """tools/gltf-check/gltf_in_browser.py as a module (its folder name is not importable)."""
    path = REPO / "tools" / "gltf-check" / "gltf_in_browser.py"
    spec = importlib.util.spec_from_file_location("gltf_in_browser", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


_why = _driver().missing_tools()
if _why:
    pytest.skip(f"three.js in Chromium: {_why}", allow_module_level=True)
require("pygltflib")

from scipy.spatial.transform import Rotation, Slerp  # noqa: E402

from morf.export.gltf_rig import pose_nodes  # noqa: E402
from test_gltf_export import TRUNCATION_MAX_M, node_globals, our_skinning, read, skin  # noqa: E402

pytestmark = pytest.mark.gl

# three.js must put every vertex where our own skinning with the same 4 weights does, to 1e-3 of
# the body's height (1.5 mm on the tiny capture; measured: under 0.001 mm, float32 rounding).
TOL_OF_HEIGHT = 1e-3
KEYFRAME_TIMES = {0.0: 0, 0.1: 1, 0.3: 3, 0.4: 4}  # seconds -> frame of the 10 fps clip
BETWEEN = 0.25  # halfway between frames 2 and 3: glTF's slerp / lerp


@pytest.fixture(scope="module")
def browser(exported, body_model, tmp_path_factory):
    """The .glb through scripts/gltf_in_browser.sh: report.json, positions.npz (a dict), the explicit
    pose (rotvecs (J, 3), transl (3,)) and the output folder."""
    from morf.export.skeleton import skeleton_from_body_model
    from morf.train.trained_avatar import load_trained_avatar

    result, _, project, _ = exported
    out = tmp_path_factory.mktemp("browser")
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    J = len(body_model.bone_names)
    rng = np.random.default_rng(7)
    rotvecs, transl = rng.normal(0, 0.3, (J, 3)), np.array([0.2, -0.1, 0.05])
    q, t = pose_nodes(skeleton_from_body_model(body_model, shape), rotvecs, transl)
    pose = out / "pose.json"
    pose.write_text(json.dumps({"name": "random 0.3 rad", "rotations": q.tolist(), "translations": t.tolist()}))
    times = ",".join(str(x) for x in sorted([*KEYFRAME_TIMES, BETWEEN]))
    cmd = ["bash", str(REPO / "scripts" / "gltf_in_browser.sh"), str(result.path), str(out / "check"),
           "--times", times, "--pose", str(pose)]
    proc = subprocess.run(cmd, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHON": sys.executable})
    print(proc.stdout)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    report = json.loads((out / "check" / "report.json").read_text())
    return report, dict(np.load(out / "check" / "positions.npz")), (rotvecs, transl), out / "check"


def truncated_weights(body_model) -> np.ndarray:
    """(Vr, J) the file's top-4 skinning weights as a dense matrix."""
    from morf.body.render_mesh import render_mesh_for
    from morf.export.gltf_rig import top_influences

    rm = render_mesh_for(body_model)
    idx, w4 = top_influences(body_model.dense_weights.numpy()[rm.vertex_map])
    out = np.zeros((len(rm.vertex_map), len(body_model.bone_names)))
    np.put_along_axis(out, idx.astype(np.int64), w4.astype(np.float64), axis=1)
    return out


def test_three_reads_what_we_wrote(browser, exported, body_model):
    report, pos, _, _ = browser
    result, gltf, _, _ = exported
    assert report["passed"], report["checks"]
    assert report["meshes"] == report["skinned_meshes"] == 1
    assert report["vertices"] == result.vertices == len(pos["rest"])
    assert report["triangles"] == len(read(gltf, gltf.meshes[0].primitives[0].indices)) // 3
    assert report["joints"] == result.joints == len(body_model.bone_names)
    # three.js drops "." from node names (PropertyBinding.sanitizeNodeName): "pelvis.L" -> "pelvisL".
    assert report["joint_names"] == [re.sub(r"[\[\].:/]", "", re.sub(r"\s", "_", n)) for n in body_model.bone_names]
    assert report["animations"] == [{"name": "clip", "duration": pytest.approx(0.4), "tracks": result.joints + 1}]
    assert report["texture"] == {"width": result.texture_size, "height": result.texture_size}
    assert report["messages"] == []  # no loader or WebGL warnings on the page
    assert np.array_equal(pos["rest"], read(gltf, gltf.meshes[0].primitives[0].attributes.POSITION))


def test_three_skins_the_motion_and_a_pose_as_we_do(browser, exported, body_model):
    from morf.train.trained_avatar import load_trained_avatar

    report, pos, (rotvecs, transl), _ = browser
    _, gltf, project, clip = exported
    shape = load_trained_avatar(project.runs_dir / "morf-tiny").shape
    tol = TOL_OF_HEIGHT * report["height_m"]
    w4 = truncated_weights(body_model)
    names, times = list(pos["names"]), pos["times"]
    expected = {names[0]: pos["rest"].astype(np.float64)}  # the bind pose
    full = {}
    for k in range(1, len(names) - 1):
        frame = KEYFRAME_TIMES.get(round(float(times[k]), 6))
        if frame is not None:
            args = (body_model, shape, clip["rotvecs"][frame], clip["transl"][frame])
            expected[names[k]], full[names[k]] = our_skinning(*args, w4), our_skinning(*args)
    expected[names[-1]] = our_skinning(body_model, shape, rotvecs, transl, w4)
    full[names[-1]] = our_skinning(body_model, shape, rotvecs, transl)
    # Between keyframes: the file's own keyframes slerped / lerped as glTF says, skinned in numpy.
    anim, joints = gltf.animations[0], gltf.skins[0].joints
    rot = {c.target.node: read(gltf, anim.samplers[c.sampler].output)
           for c in anim.channels if c.target.path == "rotation"}
    root_t = [read(gltf, anim.samplers[c.sampler].output) for c in anim.channels if c.target.path == "translation"][0]
    a = (BETWEEN - 0.2) / 0.1
    q = [Slerp([0, 1], Rotation.from_quat(rot[j][2:4].astype(np.float64)))(a).as_quat() for j in joints]
    t = np.array([gltf.nodes[j].translation for j in joints])
    t[0] = (1 - a) * root_t[2] + a * root_t[3]
    between = names[int(np.flatnonzero(np.isclose(times, BETWEEN))[0])]
    expected[between] = skin(gltf, node_globals(gltf, joints, q, t))

    assert set(expected) == set(names)
    lines = []
    for k, name in enumerate(names):
        cpu = np.linalg.norm(pos["cpu"][k] - expected[name], axis=1).max()
        gpu = np.linalg.norm(pos["gpu"][k] - expected[name], axis=1).max()
        line = f"{name:<16} three CPU {cpu * 1e3:.4f} mm, GPU {gpu * 1e3:.4f} mm"
        if name in full:  # against all of Anny's weights only the 4-weight truncation is left
            trunc = np.linalg.norm(pos["cpu"][k] - full[name], axis=1).max()
            line += f"; vs all weights {trunc * 1e3:.2f} mm"
            assert trunc < TRUNCATION_MAX_M, line
        lines.append(line)
        assert cpu < tol and gpu < tol, line
    print(f"\nthree.js skin vs ours (same top-4 weights; tolerance {tol * 1e3:.2f} mm):\n  " + "\n  ".join(lines))


def test_screenshot_shows_a_textured_body_in_every_panel(browser):
    from PIL import Image

    report, pos, _, out = browser
    rgb = np.asarray(Image.open(out / "screenshot.png").convert("RGB"), np.float64) / 255
    W, H = report["panel"]
    assert rgb.shape == (H, W * len(pos["names"]), 3)
    background = np.asarray(report["background"]) / 255
    for k, panel in enumerate(np.array_split(rgb, len(pos["names"]), axis=1)):
        body = np.abs(panel - background).max(-1) > 8 / 255
        assert 0.03 < body.mean() < 0.8, (k, body.mean())  # a body, framed, not a blank or a flooded panel
        assert panel[body].std(0).mean() > 0.03  # shaded and textured, not one flat colour


def test_the_check_fails_on_a_broken_file(exported, tmp_path):
    result = exported[0]
    glb = tmp_path / "broken.glb"
    data = result.path.read_bytes()
    glb.write_bytes(data[:len(data) // 2])  # the binary chunk cut short: GLTFLoader throws
    proc = subprocess.run(["bash", str(REPO / "scripts" / "gltf_in_browser.sh"), str(glb), str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=600, env={**os.environ, "PYTHON": sys.executable})
    assert proc.returncode == 1 and "the page failed" in proc.stderr, proc.stdout + proc.stderr
    assert json.loads((tmp_path / "out" / "report.json").read_text())["passed"] is False
