"""The web folder's files, without a browser: what morf web writes is what the page reads, and the
commands' one-line errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import REPO


@pytest.fixture(scope="module")
def folder(tiny_avatar, tmp_path_factory):
    from morf.errors import InputError
    from morf.web.build import build_web_folder
    from morf.web.libraries import ort_dist

    try:
        ort_dist()
    except InputError as e:
        from tests.web.conftest import browser_or_skip

        browser_or_skip()  # skips (or fails in a strict install) with the reason
        pytest.skip(str(e))
    return build_web_folder(tiny_avatar, tmp_path_factory.mktemp("web") / "out")


def test_folder_holds_the_page_the_libraries_and_the_avatar(folder, tiny_avatar):
    from morf.export.avatar_folder import load_exported_avatar

    root = folder.path
    for name in ("index.html", "main.js", "player.js", "raster.js", "tail.js", "cpu_tail.js", "fill.js", "player.json",
                 "lib/ort.wasm.min.mjs", "lib/ort-wasm-simd-threaded.mjs", "lib/ort-wasm-simd-threaded.wasm.gz",
                 "avatar/avatar.json", "avatar/texture.bin", "avatar/mesh.bin", "avatar/renderer.onnx"):
        assert (root / name).is_file(), name
    doc = json.loads((root / "avatar" / "avatar.json").read_text())
    av = load_exported_avatar(tiny_avatar)
    mesh = (root / "avatar" / "mesh.bin").read_bytes()

    def array(name):
        a = doc["mesh"]["arrays"][name]
        n = int(np.prod(a["shape"]))
        return np.frombuffer(mesh, a["type"], n, a["offset"]).reshape(a["shape"])

    assert np.array_equal(array("rest_vertices"), av.mesh.rest_vertices.astype(np.float32))
    assert np.array_equal(array("faces"), av.mesh.faces)
    assert np.array_equal(array("bone_indices"), av.mesh.bone_indices)
    assert np.array_equal(array("bone_weights"), av.mesh.bone_weights.astype(np.float32))
    from morf.web.light_mesh import light_meshes

    levels = light_meshes(av.mesh, av.skeleton.names, av.skeleton.parents)
    assert [lv["name"] for lv in doc["mesh"]["levels"]] == ["light", "lighter"]
    for lv, want in zip(doc["mesh"]["levels"], levels):  # each level's faces over the full mesh's vertices
        assert np.array_equal(array(lv["array"]), want.kept[want.mesh.faces]) and lv["faces"] == len(want.mesh.faces)
        assert lv["max_error_mm"] == pytest.approx(want.max_error_m * 1000, abs=1e-3)
    tex = np.frombuffer((root / "avatar" / "texture.bin").read_bytes(), np.uint8)
    assert np.array_equal(tex.reshape(av.texture.data.shape), av.texture.data)
    assert doc["renderer"]["mode"] == "image"  # the coverage renderer has no tail
    names = [m["name"] for m in doc["motions"]]
    assert {"idle_sway", "walk_in_place", "walk_forward"} <= set(names)
    for m in doc["motions"]:
        data = np.frombuffer((root / m["file"]).read_bytes(), "<f4")
        assert data.size == m["frames"] * (3 * m["bones"] + 3) and np.isfinite(data).all()
    # every script the page loads is in the folder: no address of another host in the page's own files
    for f in ("index.html", "main.js", "player.js", "renderer.js", "harness.js"):
        assert "://" not in (root / f).read_text(), f
    assert folder.bytes < 10e6


def test_skeleton_in_the_folder_poses_as_the_player(folder, tiny_avatar):
    """The page's forward kinematics reads the skeleton from avatar.json: it must be the avatar's."""
    from morf.export.avatar_folder import load_exported_avatar
    from morf.export.skeleton import SkinningSkeleton

    doc = json.loads((folder.path / "avatar" / "avatar.json").read_text())["skeleton"]
    J = len(doc["parents"])
    sk = SkinningSkeleton(names=np.array(doc["names"]), parents=np.array(doc["parents"], np.int32),
                          rest_rotations=np.array(doc["rest_rotations"]).reshape(J, 3, 3),
                          rest_heads=np.array(doc["rest_heads"]).reshape(J, 3),
                          reference_rotations=np.array(doc["reference_rotations"]).reshape(J, 3, 3))
    rot = np.random.default_rng(0).normal(0, 0.4, (J, 3))
    want = load_exported_avatar(tiny_avatar).skeleton.bone_transforms(rot, np.array([0.1, 0.2, 0.3]))
    assert np.abs(sk.bone_transforms(rot, np.array([0.1, 0.2, 0.3])) - want).max() < 1e-5


def _morf(*args, env=None):
    return subprocess.run([sys.executable, "-m", "morf.cli.main", *args], capture_output=True, text=True,
                          timeout=300, cwd=REPO, env={**os.environ, **(env or {})})


def test_missing_libraries_are_one_line(tiny_avatar, tmp_path):
    p = _morf("web", str(tiny_avatar), str(tmp_path / "w"), env={"MORF_WEB_LIBS": str(tmp_path / "none")})
    assert p.returncode == 2
    lines = p.stderr.strip().splitlines()
    assert len(lines) == 1 and "onnxruntime-web" in lines[0] and "morf web --fetch-libs" in lines[0], p.stderr
    assert not (tmp_path / "w").exists()


def test_refusals_are_one_line(folder, tiny_avatar, tmp_path):
    p = _morf("web", str(tiny_avatar), str(folder.path))  # an earlier output, no --force
    assert p.returncode == 2 and "--force" in p.stderr and len(p.stderr.strip().splitlines()) == 1
    p = _morf("web", str(tmp_path / "nowhere"), str(tmp_path / "w"))
    assert p.returncode == 2 and "avatar folder not found" in p.stderr
    p = _morf("web", str(tiny_avatar), str(tmp_path / "w"), "--motion", str(tmp_path))
    assert p.returncode == 2 and "is a folder" in p.stderr
    p = _morf("serve", str(tmp_path))
    assert p.returncode == 2 and "not a web folder" in p.stderr


def test_force_replaces_only_its_own_files(folder, tiny_avatar):
    from morf.web.build import build_web_folder

    keep = folder.path / "notes.txt"
    keep.write_text("mine")
    again = build_web_folder(tiny_avatar, folder.path, force=True)
    assert keep.read_text() == "mine" and (again.path / "index.html").is_file()


def test_export_web_refuses_before_exporting(folder, tmp_path):
    """morf export --web checks its web folder (and the cached libraries) before the export's minutes."""
    p = _morf("export", str(tmp_path / "no-project"), "--web", str(folder.path))
    assert p.returncode == 2 and "--force" in p.stderr and len(p.stderr.strip().splitlines()) == 1, p.stderr
    p = _morf("export", str(tmp_path / "no-project"), "--webgpu")
    assert p.returncode == 2 and "--webgpu goes with --web" in p.stderr
