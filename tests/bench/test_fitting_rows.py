"""``morf bench fitting``'s rows: fitting.json's keys, in their order."""

from dataclasses import replace

import numpy as np

from morf.bench.fitting import ConfigRow, FitQuality, root_error_deg


def test_a_row_keeps_its_keys_in_order():
    q = FitQuality(vertex_error_mm=90.0, vertex_error_mm_all_frames=95.0, root_error_deg=4.0, keypoint_error_px=1.5,
                   silhouette_iou=0.75, silhouette_iou_body=0.7, offset_mean_mm=None, offset_max_mm=None, jitter=250.0,
                   filter_precision=1.0, filter_recall=0.5, rejected=1)
    row = ConfigRow(q, frames_per_second=12.0, seconds=1.0)
    assert list(row.measured()) == ["vertex_error_mm", "vertex_error_mm_all_frames", "root_error_deg",
                                    "keypoint_error_px", "silhouette_iou", "silhouette_iou_body", "offset_mean_mm",
                                    "offset_max_mm", "jitter", "filter_precision", "filter_recall", "rejected",
                                    "frames_per_second", "seconds"]
    d = replace(row, jitter_reduction=0.25).to_dict()
    assert list(d) == list(row.measured()) + ["jitter_reduction"]
    assert d["jitter_reduction"] == 0.25 and d["vertex_error_mm"] == 90.0 and d["offset_mean_mm"] is None


def test_root_error_is_the_angle_between_the_root_orientations():
    from morf.motion.so3 import axis_rotation, matrix_to_rotvec

    true = np.zeros((3, 4, 3))
    true[:, 0] = matrix_to_rotvec(np.stack([axis_rotation("z", a) for a in (0.0, 90.0, -170.0)]))
    fit = true.copy()
    fit[:, 0] = matrix_to_rotvec(np.stack([axis_rotation("z", a) @ axis_rotation("x", t)
                                           for a, t in ((0.0, 10.0), (90.0, -25.0), (-170.0, 0.0))]))
    fit[:, 1:] = 0.3  # the other joints do not count
    assert np.allclose(root_error_deg(fit, true), [10.0, 25.0, 0.0], atol=1e-6)
    # a turn about the vertical axis that crosses +-180 degrees is still its own small angle
    fit[2, 0] = matrix_to_rotvec(axis_rotation("z", 175.0))
    assert np.isclose(root_error_deg(fit, true)[2], 15.0, atol=1e-6)
