"""The synthetic person and studio: body shape, clothing, garment looseness and the camera."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator

import numpy as np
import torch

from morf.body import BodyPose, load_body_model
from morf.body.normals import vertex_normals
from morf.body.render_mesh import RenderMesh, render_mesh_for
from morf.camera import PinholeCamera
from morf.synth.config import SynthConfig
from morf.synth.nuisance import garment_weight, loose_offsets
from morf.synth.regions import region_weights
from morf.synth.texture import ClothingTexture, paint_clothing

# Independent random streams, so that e.g. more frames do not change the clothes.
STREAMS = ("shape", "clothing", "motion", "holdout", "slide", "noise", "corrupt")


def rng_streams(seed: int) -> dict[str, np.random.Generator]:
    children = np.random.SeedSequence(int(seed)).spawn(len(STREAMS))
    return {name: np.random.default_rng(s) for name, s in zip(STREAMS, children)}


@dataclass(frozen=True)
class SynthScene:
    """Everything that stays fixed over a synthetic capture.

    Fields:
        model: the body model (Anny).
        mesh: its render mesh.
        shape: (1, 6) float32 phenotype.
        camera: the static camera (looks at the person from -Y).
        clothing: the painted clothing atlas.
        vertex_regions: (V, 5) region weights per model vertex.
        loose_offset: (V,) float32 outward garment offset per model vertex, metres.
        slide_weight: (Vr,) float32 how much each render vertex's texture slides (0..1).
    """

    model: torch.nn.Module
    mesh: RenderMesh
    shape: torch.Tensor
    camera: PinholeCamera
    clothing: ClothingTexture
    vertex_regions: np.ndarray
    loose_offset: np.ndarray
    slide_weight: np.ndarray


def draw_shape(rng: np.random.Generator) -> np.ndarray:
    """(1, 6) phenotype drawn around the middle of Anny's range (adult, not extreme)."""
    return rng.uniform(0.35, 0.65, size=(1, 6)).astype(np.float32)


def build_scene(config: SynthConfig, streams: dict[str, np.random.Generator], model=None) -> SynthScene:
    """Shape the body, dress it and place the camera."""
    model = model if model is not None else load_body_model("anny")
    mesh = render_mesh_for(model)
    shape_np = np.asarray([config.shape], np.float32) if config.shape is not None else draw_shape(streams["shape"])
    shape = torch.as_tensor(shape_np)
    with torch.no_grad():
        rest = model(model.zero_pose(1), shape)
    rest_v = rest.vertices[0].numpy()
    rest_kp = rest.keypoints3d[0].numpy()
    regions = region_weights(model.dense_weights.cpu().numpy(), model.bone_names, rest_v, rest_kp)
    clothing = paint_clothing(mesh, rest_v, regions, rest_kp, config.texture_size, streams["clothing"],
                              config.clothing)
    offset = loose_offsets(rest_v, regions, rest_kp, config.loose)

    # Level camera at mid-body height on -Y, far enough for the person to fill the asked share.
    zmin, zmax = float(rest_v[:, 2].min()), float(rest_v[:, 2].max())
    height = zmax - zmin
    visible = height / config.person_height_frac
    distance = visible / (2 * np.tan(np.deg2rad(config.fov_deg) / 2))
    centre = 0.5 * (zmin + zmax)
    camera = PinholeCamera.look_at(config.size, config.size, config.fov_deg, eye=(0.0, -distance, centre),
                                   target=(0.0, 0.0, centre))
    return SynthScene(model=model, mesh=mesh, shape=shape, camera=camera, clothing=clothing,
                      vertex_regions=regions, loose_offset=offset,
                      slide_weight=garment_weight(regions)[mesh.vertex_map].astype(np.float32))


@dataclass(frozen=True)
class PosedFrame:
    """One posed frame.

    Fields:
        body: (Vr, 3) float32 render-mesh vertices of the body itself.
        dressed: (Vr, 3) float32 render-mesh vertices with the garments pushed out.
        keypoints3d: (23, 3) float32 world keypoints of the body.
    """

    body: np.ndarray
    dressed: np.ndarray
    keypoints3d: np.ndarray


def posed_frames(scene: SynthScene, rotvecs: np.ndarray, transl: np.ndarray, batch: int = 16) -> Iterator[PosedFrame]:
    """Pose the body frame by frame (in batches through the model)."""
    faces = scene.model.faces.cpu().numpy()
    vmap = scene.mesh.vertex_map
    for start in range(0, len(rotvecs), batch):
        pose = BodyPose(torch.as_tensor(rotvecs[start:start + batch]), torch.as_tensor(transl[start:start + batch]))
        with torch.no_grad():
            out = scene.model(pose, scene.shape)
        v = out.vertices.numpy()
        dressed = v + vertex_normals(v, faces) * scene.loose_offset[None, :, None]
        for b in range(v.shape[0]):
            yield PosedFrame(body=np.ascontiguousarray(v[b, vmap], np.float32),
                             dressed=np.ascontiguousarray(dressed[b, vmap], np.float32),
                             keypoints3d=out.keypoints3d[b].numpy().astype(np.float32))
