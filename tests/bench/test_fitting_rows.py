"""``morf bench fitting``'s rows: fitting.json's keys, in their order."""

from dataclasses import replace

from morf.bench.fitting import ConfigRow, FitQuality


def test_a_row_keeps_its_keys_in_order():
    q = FitQuality(vertex_error_mm=90.0, vertex_error_mm_all_frames=95.0, keypoint_error_px=1.5, silhouette_iou=0.75,
                   silhouette_iou_body=0.7, offset_mean_mm=None, offset_max_mm=None, jitter=250.0,
                   filter_precision=1.0, filter_recall=0.5, rejected=1)
    row = ConfigRow(q, frames_per_second=12.0, seconds=1.0)
    assert list(row.measured()) == ["vertex_error_mm", "vertex_error_mm_all_frames", "keypoint_error_px",
                                    "silhouette_iou", "silhouette_iou_body", "offset_mean_mm", "offset_max_mm",
                                    "jitter", "filter_precision", "filter_recall", "rejected", "frames_per_second",
                                    "seconds"]
    d = replace(row, jitter_reduction=0.25).to_dict()
    assert list(d) == list(row.measured()) + ["jitter_reduction"]
    assert d["jitter_reduction"] == 0.25 and d["vertex_error_mm"] == 90.0 and d["offset_mean_mm"] is None
