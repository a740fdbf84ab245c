"""``morf export PROJECT --gltf avatar.glb``: the project's trained avatar as a rigged glTF 2.0 binary,
with the avatar folder (neural texture, ONNX renderers) beside it for players that run the network.

The avatar folder is written first by :func:`morf.export.project_export.export_project` (to
``--out`` if given, else beside the .glb and named after it: ``avatar.glb`` + ``avatar/``); the
.glb's ``extras.morf`` points at its files with paths relative to the .glb.
"""

from __future__ import annotations

import dataclasses
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from morf.errors import InputError
from morf.export.gltf_bake import BakeConfig
from morf.export.project_export import ProjectExportConfig
from morf.pipeline.control import Progress, StageControl


@dataclass(frozen=True)
class GltfExport:
    """What ``export_gltf`` wrote.

    Fields:
        path: the .glb; bytes: its size; avatar_dir: the avatar folder beside it.
        manifest: the avatar folder's manifest; joints, vertices: skin and mesh sizes.
        texture_size: side of the baked base colour; seen_share: share of its atlas texels a bake view saw.
        animation_frames: keyframes of the motion (0 without one).
    """

    path: Path
    bytes: int
    avatar_dir: Path
    manifest: dict
    joints: int
    vertices: int
    texture_size: int
    seen_share: float
    animation_frames: int


def avatar_dir_for(glb: Path, out: str | None) -> Path:
    """The avatar folder of a .glb: ``out`` if given, else ``<glb folder>/<glb stem>``."""
    return Path(out) if out else glb.with_suffix("")


def relative_ref(target: Path, glb: Path) -> str:
    """``target``'s path relative to the .glb's folder, with forward slashes (glTF URIs use them)."""
    return Path(os.path.relpath(target.resolve(), glb.parent.resolve())).as_posix()


def gltf_extras(glb: Path, avatar_dir: Path, manifest: dict, bake_info: dict) -> dict:
    """The ``extras.morf`` block: where our own player finds the neural avatar, and how the glTF was made."""
    from morf.export.avatar_folder import MANIFEST, RENDERERS

    ref = lambda name: relative_ref(avatar_dir / name, glb)  # noqa: E731
    return {"format": "morf-avatar", "avatar_folder": relative_ref(avatar_dir, glb), "manifest": ref(MANIFEST),
            "neural_texture": ref("texture.npz"), "renderer_int8": ref(RENDERERS["int8"]),
            "renderer_fp32": ref(RENDERERS["fp32"]), "vertex_order": "as the avatar folder's mesh.npz",
            "axes": "glTF Y up; the body model's world is Z up facing -Y: (x, y, z) -> (x, z, -y)",
            "body": manifest.get("body", {}), "source": manifest.get("source", {}), "base_colour": bake_info}


def export_gltf(project, glb: str | Path, cfg: ProjectExportConfig = ProjectExportConfig(), motion: str | None = None,
                bake: BakeConfig = BakeConfig(), control: StageControl | None = None, body_model=None,
                motion_fps: float | None = None) -> GltfExport:
    """Write the trained avatar as ``glb`` and its avatar folder (see the module docstring).

    Args:
        project: a CaptureProject with a finished training run.
        glb: the .glb path; cfg: run, avatar folder (``out``) and int8 choices, as for the folder export.
        motion: optional motion file (.npz clip, BVH, AMASS, ...) added as a glTF animation.
        motion_fps: the frame rate of a motion file that stores none (as ``morf play --motion-fps``).
        bake: views and size of the baked base-colour texture.
    """
    from morf.export.gltf_animation import joint_animation
    from morf.export.gltf_avatar import gltf_mesh, write_gltf_avatar
    from morf.export.gltf_bake import bake_base_colour
    from morf.export.gltf_rig import gltf_rig
    from morf.export.project_export import avatar_offsets, export_project, pick_run
    from morf.export.skeleton import skeleton_from_body_model
    from morf.train.trained_avatar import load_trained_avatar

    from morf.export.project_export import claim_export_folder
    from morf.io.outputs import claim_output_file

    glb = Path(glb)
    if glb.suffix.lower() != ".glb":
        raise InputError(f"the glTF export writes a binary .glb; got {glb.name!r}")
    # both outputs checked before any work: the .glb, and its avatar folder beside it
    claim_output_file(glb, "morf export", cfg.force)
    claim_export_folder(project, dataclasses.replace(cfg, out=str(avatar_dir_for(glb, cfg.out))))
    control = control or StageControl()
    if body_model is None:
        from morf.body import load_body_model

        body_model = load_body_model("anny")
    run_dir = pick_run(project, cfg.run)
    trained = load_trained_avatar(run_dir)
    clip = None
    if motion:  # read (and retargeted onto this body) before the long folder export: a bad file fails at once
        from morf.motion import load_motion

        clip = load_motion(motion, model=body_model, shape=trained.shape, source_fps=motion_fps)
        for note in clip.notes:
            print(f"morf export: note: {note}", file=sys.stderr)
        if clip.rotvecs.shape[1] != len(body_model.bone_names) or clip.num_frames == 0:
            raise InputError(f"{motion}: a motion of {clip.num_frames} frames of {clip.rotvecs.shape[1]} bones; "
                             f"the body has {len(body_model.bone_names)}")
    avatar_dir = avatar_dir_for(glb, cfg.out)
    manifest = export_project(project, dataclasses.replace(cfg, out=str(avatar_dir), run=run_dir.name), control,
                              body_model)
    skeleton = skeleton_from_body_model(body_model, trained.shape)
    animation = None
    if clip is not None:
        animation = joint_animation(skeleton, clip.rotvecs, clip.transl, clip.fps, Path(motion).stem)
    # the body the avatar folder's mesh.npz holds: dressed by the clothing offsets the run trained with
    offsets = avatar_offsets(project, trained, run_dir)
    step = lambda i, msg: control.report(Progress("export", i, 2, f"glTF: {msg}"))  # noqa: E731
    step(0, "baking the base colour from the renderer")
    baked = bake_base_colour(trained, body_model, bake, offsets)
    control.check()
    step(1, "writing the rigged mesh")
    mesh = gltf_mesh(body_model, trained.shape, offsets)
    bake_info = {"from": "the trained renderer (fp32) in the neutral A-pose"
                 + (", body dressed by the clothing offsets" if offsets is not None else "")
                 + ", projected into the UV atlas",
                 "views": len(baked.cameras), "render_size": int(baked.views.resolution),
                 "texture_size": int(baked.rgb.shape[0]), "seen_share": round(baked.seen_share, 4)}
    extras = gltf_extras(glb, avatar_dir, manifest, bake_info)
    size = write_gltf_avatar(glb, mesh, gltf_rig(skeleton), baked.rgb, extras, animation)
    step(2, "done")
    return GltfExport(path=glb, bytes=size, avatar_dir=avatar_dir, manifest=manifest, joints=skeleton.num_bones,
                      vertices=mesh.num_vertices, texture_size=int(baked.rgb.shape[0]), seen_share=baked.seen_share,
                      animation_frames=0 if animation is None else animation.num_frames)
