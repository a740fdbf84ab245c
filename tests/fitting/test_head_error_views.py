"""``morf bench fitting``'s split of the head's error: by view and about the camera's axes."""

import dataclasses

import numpy as np

from morf.bench.fitting import head_error_parts
from morf.camera import PinholeCamera
from morf.motion.so3 import axis_rotation, matrix_to_rotvec

Poses = dataclasses.make_dataclass("Poses", ["rotvecs", "transl", "shape"])


def test_a_head_nodded_about_the_cameras_horizontal_axis(body_model):
    # facing the camera, turned sideways, facing away; the fitted head turned 10 degrees more about
    # the world x axis, which the camera (looking along +y) sees as its horizontal axis
    yaws = (0.0, 90.0, 180.0)
    n, J = len(yaws), len(body_model.bone_names)
    true = np.zeros((n, J, 3), np.float32)
    true[:, 0] = matrix_to_rotvec(np.stack([axis_rotation("z", y) for y in yaws]))
    fit = true.copy()
    head = body_model.bone_index("head")
    # local-ref rotations are in the rest pose's axes, composed after the root's: turn the head's own
    # rotation so that its world orientation gains 10 degrees about world x
    for i, y in enumerate(yaws):
        fit[i, head] = matrix_to_rotvec(axis_rotation("z", -y) @ axis_rotation("x", 10.0) @ axis_rotation("z", y))
    shape = body_model.default_shape().numpy()
    camera = PinholeCamera.look_at(256, 256, 40.0, eye=(0.0, -3.4, 0.6), target=(0.0, 0.0, 0.6))
    parts = head_error_parts(body_model, Poses(fit, np.zeros((n, 3)), shape), Poses(true, np.zeros((n, 3)), shape),
                             camera, np.ones(n, bool))
    views = parts["head_error_by_view"]
    assert [views[v]["frames"] for v in ("front", "side", "back")] == [1, 1, 1]
    assert all(abs(views[v]["head_error_deg"] - 10.0) < 0.5 for v in views)
    axes = parts["head_error_camera_deg"]
    assert abs(axes["pitch"] - 10.0) < 0.5 and axes["yaw"] < 0.5 and axes["roll"] < 0.5, axes
