"""A lighter render mesh for the page: the body with fewer triangles, the same texture mapping.

Software WebGL (SwiftShader, what a browser without a GPU runs) spends its raster time per
triangle it is given, not per pixel: halving the triangles halved the raster's best time, and the
raster is the largest stage of a 640 x 640 frame after the renderer (docs/web.md). Most of the
body's 27,420 triangles are far under a pixel at the sizes the page plays: the page can draw a
mesh with a fraction of them and show the same image.

How (quadric error half-edge collapses, Garland and Heckbert 1998, in position + texture
coordinates): a vertex is merged into one of its neighbours, which keeps its own position, texture
coordinates and bone weights, so every vertex left is one of the original mesh and nothing is
interpolated or re-fitted. A collapse's cost is how far the merged fan moves from the planes of the
faces it replaced, measured in the five dimensions (x, y, z, and u, v scaled to metres by the
mesh's own ratio of surface to atlas area), so sliding the texture across the surface costs as
much as moving the surface itself. A collapse is refused when it would

- move a vertex on a texture seam or an open edge (the split copies of a seam stay where they
  are, so the two sides still meet without a crack);
- merge vertices whose bone weights differ by more than ``max_weight_change`` (the L1 distance of
  their weights over every bone: posed, the two sides of a joint would bend the merged triangles);
- change the surface's topology (the link condition), flip or crush a face in space or in the
  atlas.

A collapse on the head or a hand costs ``1 + detail_weight`` times more, so their error stays
within the bound over the square root of that (2.3 mm of the default 4 mm): they are what people
look at. They are also where the body model is densest (55 % of its triangles), so they still
lose about half of theirs; closer views, where that would show, draw the full mesh (the page's
level of detail, resources/web/player.js).
"""

from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass

import numpy as np

from morf.raster.neural_raster import SkinnedMesh

DETAIL_BONES = ("head", "wrist.L", "wrist.R")  # their subtrees: the face and eyes, the hands and fingers
LEVELS_M = (4e-3, 8e-3)  # the error bounds of the levels a web folder carries
_REMEMBERED: dict[str, tuple] = {}
_LOCK = threading.Lock()


@dataclass(frozen=True)
class LightMesh:
    """The lighter mesh and what it cost.

    Fields:
        mesh: the decimated mesh (only the vertices its faces use, in their original order).
        kept: (Vl,) indices of those vertices in the original mesh.
        faces_before: the original's triangle count.
        max_error_m: the largest collapse's error (the square root of its quadric cost), metres.
    """

    mesh: SkinnedMesh
    kept: np.ndarray
    faces_before: int
    max_error_m: float

    def describe(self) -> str:
        f = self.mesh.faces.shape[0]
        return (f"{f:,} triangles of {self.faces_before:,} ({f / self.faces_before:.0%}), {len(self.kept):,} vertices, "
                f"largest collapse error {self.max_error_m * 1000:.2f} mm")


def face_quadrics(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(F, 6, 6) homogeneous quadrics of the faces' planes in the points' dimension (here 5: position
    and scaled texture coordinates): x^T Q x is the squared distance of x from the face's plane."""
    p, q, r = (points[faces[:, k]].astype(np.float64) for k in range(3))
    e1 = q - p
    e1 /= np.maximum(np.linalg.norm(e1, axis=1, keepdims=True), 1e-12)
    e2 = r - p
    e2 -= np.sum(e2 * e1, axis=1, keepdims=True) * e1
    e2 /= np.maximum(np.linalg.norm(e2, axis=1, keepdims=True), 1e-12)
    d = points.shape[1]
    a = np.eye(d)[None] - e1[:, :, None] * e1[:, None] - e2[:, :, None] * e2[:, None]
    pe1, pe2 = np.sum(p * e1, axis=1), np.sum(p * e2, axis=1)
    b = pe1[:, None] * e1 + pe2[:, None] * e2 - p
    c = np.sum(p * p, axis=1) - pe1 ** 2 - pe2 ** 2
    out = np.zeros((len(faces), d + 1, d + 1))
    out[:, :d, :d] = a
    out[:, :d, d] = out[:, d, :d] = b
    out[:, d, d] = c
    return out


def uv_scale(mesh: SkinnedMesh) -> float:
    """Metres per atlas unit: the square root of the surface's area over the atlas area its faces cover."""
    v, t, f = mesh.rest_vertices.astype(np.float64), mesh.uvs.astype(np.float64), mesh.faces
    area3 = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1).sum()
    e1, e2 = t[f[:, 1]] - t[f[:, 0]], t[f[:, 2]] - t[f[:, 0]]
    area2 = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]).sum()
    return float(np.sqrt(area3 / max(area2, 1e-12)))


def detail_share(mesh: SkinnedMesh, names, parents) -> np.ndarray:
    """(Vr,) each vertex's bone weight on the head's and the hands' subtrees (0..1)."""
    names = [str(n) for n in names]
    children: dict[int, list[int]] = {}
    for j, p in enumerate(parents):
        children.setdefault(int(p), []).append(j)
    bones, todo = set(), [names.index(n) for n in DETAIL_BONES if n in names]
    while todo:
        j = todo.pop()
        bones.add(j)
        todo.extend(children.get(j, []))
    hit = np.isin(mesh.bone_indices, sorted(bones))
    return np.clip((mesh.bone_weights * hit).sum(axis=1), 0.0, 1.0)


def seam_vertices(faces: np.ndarray, count: int) -> np.ndarray:
    """(count,) bool: vertices on an edge used by one face only (texture seams, open edges)."""
    edges = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    unique, n = np.unique(edges, axis=0, return_counts=True)
    out = np.zeros(count, bool)
    out[unique[n == 1].ravel()] = True
    return out


def light_meshes(mesh: SkinnedMesh, names, parents, bounds_m=LEVELS_M, keep: float = 0.3,
                 detail_weight: float = 2.0, max_weight_change: float = 0.35) -> tuple[LightMesh, ...]:
    """``mesh`` decimated to each error bound of ``bounds_m`` in turn (metres, rising: each level goes
    on from the one before), never under ``keep`` of its triangles. ``names``, ``parents``: the
    skeleton's bones, for the head's and the hands' share (:func:`detail_share`).

    The page draws the coarsest level whose error stays under a pixel and a half at the scale the
    body is drawn (resources/web/player.js). The default levels, 4 and 8 mm: on the demo avatar
    55 % and about 45 % of the triangles; the page's frames with the first 35.7-38.1 dB from the
    Python player's over the body at 640 px (docs/web.md, "A lighter mesh for software WebGL").
    The last few results are remembered (seconds each)."""
    if not 0.0 < keep <= 1.0:
        raise ValueError(f"keep must be in (0, 1], got {keep}")
    if not len(bounds_m) or any(b <= a for a, b in zip(bounds_m, bounds_m[1:])) or bounds_m[0] <= 0:
        raise ValueError(f"error bounds must be positive and rising, got {bounds_m}")
    key = hashlib.sha1(b"".join(np.ascontiguousarray(a).tobytes() for a in (
        mesh.rest_vertices, mesh.uvs, mesh.faces, mesh.bone_indices, mesh.bone_weights)))
    key.update(repr((list(map(str, names)), list(map(int, parents)), tuple(bounds_m), keep, detail_weight,
                     max_weight_change)).encode())
    with _LOCK:
        if key.hexdigest() in _REMEMBERED:
            return _REMEMBERED[key.hexdigest()]
    levels = _decimated(mesh, names, parents, bounds_m, keep, detail_weight, max_weight_change)
    with _LOCK:
        _REMEMBERED[key.hexdigest()] = levels
        while len(_REMEMBERED) > 4:
            _REMEMBERED.pop(next(iter(_REMEMBERED)))
    return levels


def light_mesh(mesh: SkinnedMesh, names, parents, max_error_m: float = LEVELS_M[0], keep: float = 0.3,
               **kwargs) -> LightMesh:
    """One level of :func:`light_meshes`."""
    return light_meshes(mesh, names, parents, (max_error_m,), keep, **kwargs)[0]


def _decimated(mesh, names, parents, bounds_m, keep, detail_weight, max_weight_change) -> tuple[LightMesh, ...]:
    from morf.web.edge_collapse import EdgeCollapse

    n, faces = mesh.num_vertices, np.asarray(mesh.faces, np.int64)
    points = np.concatenate([mesh.rest_vertices, mesh.uvs * uv_scale(mesh)], axis=1).astype(np.float64)
    corners = face_quadrics(points, faces)
    quadrics = np.zeros((n, 6, 6))
    for k in range(3):
        np.add.at(quadrics, faces[:, k], corners)
    weights = np.zeros((n, len(parents)), np.float32)
    np.add.at(weights, (np.repeat(np.arange(n), mesh.bone_indices.shape[1]), mesh.bone_indices.ravel()),
              mesh.bone_weights.ravel())
    multiplier = 1.0 + detail_weight * detail_share(mesh, names, parents)
    collapse = EdgeCollapse(points, faces, quadrics, ~seam_vertices(faces, n), weights, max_weight_change, multiplier)
    levels, worst = [], 0.0
    for bound in bounds_m:
        worst = max(worst, collapse.run(int(np.ceil(keep * len(faces))), bound ** 2))
        levels.append(_compacted(mesh, collapse.faces[collapse.alive], len(faces), float(np.sqrt(worst))))
    return tuple(levels)


def _compacted(mesh: SkinnedMesh, faces: np.ndarray, before: int, error: float) -> LightMesh:
    kept = np.unique(faces)
    index = np.full(mesh.num_vertices, -1, np.int64)
    index[kept] = np.arange(len(kept))
    light = SkinnedMesh(rest_vertices=mesh.rest_vertices[kept], uvs=mesh.uvs[kept],
                        faces=index[faces].astype(np.int32), bone_indices=mesh.bone_indices[kept],
                        bone_weights=mesh.bone_weights[kept])
    return LightMesh(light, kept, before, error)
