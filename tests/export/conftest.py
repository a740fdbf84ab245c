"""Fixtures shared by the export tests."""

from __future__ import annotations

import numpy as np
import pytest
from tests.conftest import copy_capture, require

# Enough tiny-preset steps for the renderer's mask to cover the body: after the preset's own 30 the
# mask was still at its initial 0.13 on an Intel Xeon with AMX (Dice 0.87) and the bake views
# showed no person; after 150 (3 s) Dice was 0.26.
STEPS = 150


@pytest.fixture(scope="module")
def exported(tmp_path_factory, tiny_capture_source, body_model, gl, one_torch_thread):
    """A tiny synthetic capture, trained with the tiny preset for ``STEPS`` steps (its renderer's
    mask then covers the body), exported with a 5-frame motion clip."""
    from morf.export.gltf_project import export_gltf
    from morf.export.project_export import ProjectExportConfig
    from morf.train.config import preset
    from morf.train.project_run import train_project

    root = tmp_path_factory.mktemp("gltf")
    project = copy_capture(tiny_capture_source, root / "tiny")
    train_project(project, preset("tiny", inpaint_steps=0, steps=STEPS), model=body_model)
    J = len(body_model.bone_names)
    rng = np.random.default_rng(1)
    clip = {"rotvecs": rng.normal(0, 0.2, (5, J, 3)).astype(np.float32),
            "transl": rng.normal(0, 0.1, (5, 3)).astype(np.float32), "fps": np.float32(10)}
    np.savez(root / "clip.npz", **clip)
    glb = root / "out" / "avatar.glb"
    result = export_gltf(project, glb, ProjectExportConfig(calibration_views=4), motion=str(root / "clip.npz"),
                         body_model=body_model)
    return result, require("pygltflib").GLTF2().load(str(glb)), project, clip
