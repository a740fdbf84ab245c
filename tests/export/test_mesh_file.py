"""``morf export --mesh``: the fitted body as PLY / OBJ, read back by trimesh as another tool would."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from morf.errors import InputError
from morf.export.avatar_folder import load_exported_avatar
from morf.export.mesh_file import check_mesh_path, write_body_mesh

trimesh = pytest.importorskip("trimesh")  # declared: tests/conftest.py's strict install fails instead


@pytest.mark.parametrize("suffix", [".ply", ".obj"])
def test_the_body_reads_back_vertex_for_vertex(tiny_avatar, tmp_path, suffix):
    mesh = load_exported_avatar(tiny_avatar).mesh
    written = write_body_mesh(mesh, tmp_path / f"body{suffix}")
    back = trimesh.load(written.path, process=False)
    assert (written.vertices, written.faces) == (mesh.num_vertices, len(mesh.faces))
    assert np.allclose(back.vertices, mesh.rest_vertices, atol=1e-6)
    assert np.array_equal(back.faces, mesh.faces)
    assert np.allclose(back.visual.uv, mesh.uvs, atol=1e-6)
    height = back.vertices[:, 2].max() - back.vertices[:, 2].min()
    assert 1.3 < height < 2.1  # a person standing in metres, Z up
    assert list(tmp_path.iterdir()) == [written.path]  # no material file, no temporary left behind


def test_the_obj_names_no_material_file_it_does_not_write(tiny_avatar, tmp_path):
    path = write_body_mesh(load_exported_avatar(tiny_avatar).mesh, tmp_path / "body.obj").path
    text = path.read_text()
    assert "mtllib" not in text and "\nvt " in text and "\nf " in text


def test_an_unknown_suffix_is_one_line():
    with pytest.raises(InputError, match=r"--mesh body\.stl: the file must end in \.ply or \.obj"):
        check_mesh_path("body.stl")


def test_the_command_refuses_a_bad_mesh_path_before_opening_the_project(tmp_path):
    existing = tmp_path / "body.ply"
    existing.write_text("keep")
    for arg, said in ((str(tmp_path / "body.stl"), "must end in .ply or .obj"), (str(existing), "already exists")):
        r = subprocess.run([sys.executable, "-m", "morf.cli.main", "export", str(tmp_path / "no-project"), "--mesh", arg],
                           capture_output=True, text=True, timeout=120)
        assert r.returncode == 2 and said in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
    assert existing.read_text() == "keep"
