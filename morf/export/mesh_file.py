"""The avatar's body as a plain mesh file (PLY or OBJ) for other tools: ``morf export PROJECT
--mesh FILE``.

The mesh is the exported render mesh: the body model in its rest pose with the project's fitted
shape, seams split so that every vertex has one texture coordinate (metres, Z up, the person
facing -Y, as the body model). It carries no colour: the avatar's look is a neural texture that
only its renderer turns into colour (``morf export --gltf`` bakes a colour texture instead).
trimesh writes the files, so what it reads back is what other tools read.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.errors import InputError
from morf.io import atomic_path
from morf.raster.neural_raster import SkinnedMesh

MESH_SUFFIXES = (".ply", ".obj")


@dataclass(frozen=True)
class MeshFile:
    """What :func:`write_body_mesh` wrote: the file, its vertex and triangle counts."""

    path: Path
    vertices: int
    faces: int


def check_mesh_path(path: str | Path) -> Path:
    """``path`` when its suffix names a format this writes; else a one-line error."""
    path = Path(path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise InputError(f"--mesh {path}: the file must end in {' or '.join(MESH_SUFFIXES)} (the format is taken "
                         "from the suffix)")
    return path


def body_trimesh(mesh: SkinnedMesh):
    """The render mesh as a ``trimesh.Trimesh`` with its texture coordinates, vertices in their
    own order (``process=False``: no merging, the seams stay split)."""
    import trimesh

    visual = trimesh.visual.TextureVisuals(uv=np.asarray(mesh.uvs, np.float64))
    return trimesh.Trimesh(np.asarray(mesh.rest_vertices, np.float64), np.asarray(mesh.faces, np.int64),
                           visual=visual, process=False)


def write_body_mesh(mesh: SkinnedMesh, path: str | Path) -> MeshFile:
    """Write ``mesh`` to ``path`` (.ply binary, or .obj with ``vt`` coordinates), atomically."""
    from trimesh.exchange.obj import export_obj

    path = check_mesh_path(path)
    tm = body_trimesh(mesh)
    if path.suffix.lower() == ".obj":
        text, _ = export_obj(tm, include_normals=False, include_texture=True, write_texture=False, return_texture=True,
                             header="the fitted body of a morf avatar: metres, Z up, facing -Y")
        # trimesh names a material file for the coordinates; there is no colour image to put in it
        data = "\n".join(line for line in text.splitlines() if not line.startswith(("mtllib ", "usemtl "))).encode()
    else:
        data = tm.export(file_type="ply")
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return MeshFile(path=path, vertices=int(tm.vertices.shape[0]), faces=int(tm.faces.shape[0]))
