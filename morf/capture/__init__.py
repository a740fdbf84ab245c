"""Capture ingestion: frames, 2D keypoints and person masks into a project folder.

``IngestConfig``, ``MediaPipeDetector`` and ``Detection`` are loaded on first use, so importing
this package stays cheap (MediaPipe is imported only when a detector is created). The ingest itself
is ``morf.capture.ingest.ingest``: a package attribute ``ingest`` would be shadowed by that submodule.
"""

from morf.capture.project import CaptureProject, FrameDecision, Keypoints2D
from morf.lazy import lazy_attributes

__all__ = ["CaptureProject", "FrameDecision", "Keypoints2D", "IngestConfig", "MediaPipeDetector", "Detection"]
__getattr__, __dir__ = lazy_attributes(__name__, {
    "IngestConfig": "morf.capture.ingest", "MediaPipeDetector": "morf.capture.detect_mediapipe",
    "Detection": "morf.capture.detect_mediapipe"})
