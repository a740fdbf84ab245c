"""A rigged, textured glTF 2.0 binary (.glb) of the avatar's body.

What the file holds (one scene):
    nodes 0..J-1   the body's joints (Anny bone names), in the shaped rest (bind) pose
    node J         the skinned body mesh (skin 0), at the scene root as glTF asks
    mesh 0         POSITION (shaped rest vertices, dressed by the fit's clothing offsets as the
                   avatar folder's mesh.npz: the surface the renderer trained on), NORMAL, TEXCOORD_0 (top-left origin:
                   t = 1 - v), JOINTS_0 / WEIGHTS_0 (the 4 largest skinning weights, summing to 1),
                   triangle indices; vertices on UV seams are split exactly as the rasterizer's
                   render mesh (:mod:`morf.body.render_mesh`), in the same order as the avatar
                   folder's mesh.npz
    skin 0         the joints and their inverse bind matrices
    material 0     base colour = an embedded PNG baked from the neural renderer (:mod:`morf.export.gltf_bake`)
    animation 0    optional: a motion, one rotation sampler per joint plus the root's translation
    extras         on the asset and on the mesh: ``morf`` -> relative paths of the avatar folder
                   (neural texture, fp32 and int8 ONNX renderers, manifest) written beside the .glb

Axes and skinning conventions: :mod:`morf.export.gltf_rig`.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from morf.export.glb import ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER, GlbBuilder
from morf.export.gltf_animation import JointAnimation, moving_joints
from morf.export.gltf_rig import Y_UP, GltfRig, top_influences
from morf.records import length_of

# glTF sampler enums
LINEAR, LINEAR_MIPMAP_LINEAR, CLAMP_TO_EDGE = 9729, 9987, 33071


@dataclass(frozen=True)
class GltfMesh:
    """The skinned body mesh in glTF axes.

    Fields:
        positions: (V, 3) float32 shaped (and dressed) rest vertices (metres, Y up, facing +Z).
        normals: (V, 3) float32 unit vertex normals (area-weighted, shared across UV seams).
        texcoords: (V, 2) float32 (s, t) with t = 1 - v: glTF's origin is the image's top-left.
        indices: (F, 3) uint16 or uint32 counter-clockwise triangles.
        joints: (V, 4) uint8 / uint16 joint indices; weights: (V, 4) float32, rows sum to 1.
    """

    positions: np.ndarray
    normals: np.ndarray
    texcoords: np.ndarray
    indices: np.ndarray
    joints: np.ndarray
    weights: np.ndarray

    num_vertices = length_of("positions")


def gltf_mesh(model, shape, offsets=None, influences: int = 4) -> GltfMesh:
    """The shaped rest body of ``model`` as a glTF mesh (needs torch).

    Args:
        model: the body model (:class:`morf.body.anny_model.AnnyBodyModel`); shape: (1, S) tensor.
        offsets: (V,) clothing offsets the avatar trained with (None: the naked body); the rest
            vertices are then the dressed ones of the avatar folder's mesh.npz
            (:func:`morf.fitting.offsets.dressed_rest_vertices`), so loose clothes the renderer
            learned are not cut away in a viewer.
        influences: skinning weights kept per vertex (glTF's JOINTS_0 / WEIGHTS_0 hold 4).
    """
    from morf.body.normals import vertex_normals
    from morf.body.render_mesh import render_mesh_for
    from morf.fitting.offsets import dressed_rest_vertices

    rm = render_mesh_for(model)
    rest = dressed_rest_vertices(model, shape, offsets)[0].double().cpu().numpy()
    # Normals on the model's own topology, so the two copies of a seam vertex agree.
    normals = vertex_normals(rest, model.faces.cpu().numpy())[rm.vertex_map]
    joints, weights = top_influences(model.dense_weights.cpu().numpy()[rm.vertex_map], influences)
    uv = rm.uvs.astype(np.float32)
    index_type = np.uint16 if rm.num_vertices < 65536 else np.uint32
    return GltfMesh(positions=(rest[rm.vertex_map] @ Y_UP.T).astype(np.float32),
                    normals=(normals @ Y_UP.T).astype(np.float32),
                    texcoords=np.stack([uv[:, 0], 1 - uv[:, 1]], 1).astype(np.float32),
                    indices=rm.faces.astype(index_type), joints=joints, weights=weights)


def png_bytes(rgb: np.ndarray) -> bytes:
    """(H, W, 3) uint8 -> PNG file bytes."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(rgb, np.uint8), "RGB").save(buf, format="PNG", optimize=True)
    return buf.getvalue()


def build_gltf(mesh: GltfMesh, rig: GltfRig, base_colour: np.ndarray, extras: dict,
               animation: JointAnimation | None = None, name: str = "avatar") -> GlbBuilder:
    """Assemble the document (layout in the module docstring).

    Args:
        base_colour: (S, S, 3) uint8 texture, row 0 = top; extras: JSON-able dict stored as
            ``extras.morf`` on the asset and the mesh.
    """
    from morf import __version__

    g = GlbBuilder(f"MoRF Studio {__version__}")
    g.doc["asset"]["extras"] = {"morf": extras}
    J = rig.num_joints
    children: list[list[int]] = [[] for _ in range(J)]
    for j, p in enumerate(rig.parents):
        if p >= 0:
            children[p].append(j)
    for j in range(J):
        node = {"name": str(rig.names[j]), "rotation": [float(x) for x in rig.rotations[j]],
                "translation": [float(x) for x in rig.translations[j]]}
        if children[j]:
            node["children"] = children[j]
        g.append("nodes", node)

    attributes = {"POSITION": g.add_accessor(mesh.positions, ARRAY_BUFFER, min_max=True),
                  "NORMAL": g.add_accessor(mesh.normals, ARRAY_BUFFER),
                  "TEXCOORD_0": g.add_accessor(mesh.texcoords, ARRAY_BUFFER),
                  "JOINTS_0": g.add_accessor(mesh.joints, ARRAY_BUFFER),
                  "WEIGHTS_0": g.add_accessor(mesh.weights, ARRAY_BUFFER)}
    indices = g.add_accessor(mesh.indices.reshape(-1), ELEMENT_ARRAY_BUFFER)
    image = g.add_image(png_bytes(base_colour), "base colour")
    sampler = g.append("samplers", {"magFilter": LINEAR, "minFilter": LINEAR_MIPMAP_LINEAR,
                                    "wrapS": CLAMP_TO_EDGE, "wrapT": CLAMP_TO_EDGE})
    texture = g.append("textures", {"source": image, "sampler": sampler})
    material = g.append("materials", {"name": "avatar", "pbrMetallicRoughness": {
        "baseColorTexture": {"index": texture, "texCoord": 0}, "metallicFactor": 0.0, "roughnessFactor": 0.9}})
    g.append("meshes", {"name": "body", "extras": {"morf": extras}, "primitives": [
        {"attributes": attributes, "indices": indices, "material": material, "mode": 4}]})
    ibm = g.add_accessor(rig.inverse_bind.astype(np.float32))
    skin = g.append("skins", {"name": "anny", "joints": list(range(J)), "inverseBindMatrices": ibm, "skeleton": 0})
    body = g.append("nodes", {"name": name, "mesh": 0, "skin": skin})
    g.append("scenes", {"name": name, "nodes": [0, body]})
    g.doc["scene"] = 0
    if animation is not None:
        add_animation(g, animation, rig)
    return g


def add_animation(g: GlbBuilder, animation: JointAnimation, rig: GltfRig) -> int:
    """Append ``animation`` (joints = nodes 0..J-1) as a glTF animation: a rotation channel per
    joint, a translation channel per joint that moves (the root); returns its index."""
    times = g.add_accessor(animation.times.astype(np.float32), min_max=True)
    samplers, channels = [], []

    def channel(node: int, path: str, values: np.ndarray) -> None:
        out = g.add_accessor(np.ascontiguousarray(values, np.float32))
        samplers.append({"input": times, "output": out, "interpolation": "LINEAR"})
        channels.append({"sampler": len(samplers) - 1, "target": {"node": node, "path": path}})

    for j in range(rig.num_joints):
        channel(j, "rotation", animation.rotations[:, j])
    for j in moving_joints(animation, rig.translations):
        channel(j, "translation", animation.translations[:, j])
    return g.append("animations", {"name": animation.name, "samplers": samplers, "channels": channels})


def write_gltf_avatar(path: str | Path, mesh: GltfMesh, rig: GltfRig, base_colour: np.ndarray, extras: dict,
                      animation: JointAnimation | None = None) -> int:
    """Write the .glb atomically; returns its size in bytes."""
    path = Path(path)
    return build_gltf(mesh, rig, base_colour, extras, animation, path.stem or "avatar").write(path)
