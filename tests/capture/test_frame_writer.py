"""FrameWriter: the frames and masks a new project's stage writes, and the progress it reports."""

import numpy as np
import pytest

from morf.capture.frame_writer import FrameWriter
from morf.capture.project import CaptureProject
from morf.pipeline.control import StageControl, StopRequested


def test_writes_what_a_project_reads_and_reports_each_frame(tmp_path):
    seen = []
    control = StageControl(seen.append)
    rgb = np.random.default_rng(0).integers(0, 256, (3, 8, 6, 3), dtype=np.uint8)
    masks = rgb[..., 0] > 128
    with FrameWriter(tmp_path, ".png", "import", "importing", 3, control) as out:
        for n, (image, mask) in out.numbered(zip(rgb, masks)):
            out.write(n, image, mask)
    project = CaptureProject(tmp_path, {"num_frames": 3, "frame_ext": ".png"})
    for n in range(3):
        np.testing.assert_array_equal(project.load_frame(n), rgb[n])
        np.testing.assert_array_equal(project.load_mask(n) > 0, masks[n])
    assert [(p.stage, p.step, p.total, p.message, p.frame) for p in seen] == [
        ("import", n + 1, 3, f"importing frame {n + 1}", n) for n in range(3)]


def test_a_stop_is_honoured_before_the_next_frame(tmp_path):
    control = StageControl()
    handed = []
    with pytest.raises(StopRequested):
        with FrameWriter(tmp_path, ".png", "ingest", "ingesting", None, control) as out:
            for n, item in out.numbered(range(5)):
                handed.append(item)
                control.stop()
    assert handed == [0]
