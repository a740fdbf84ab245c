"""Capture ingestion: frames, 2D keypoints and person masks into a project folder.

``ingest``, ``IngestConfig``, ``MediaPipeDetector`` and ``Detection`` are loaded on first use, so
importing this package stays cheap (MediaPipe is imported only when a detector is created).
"""

import importlib

from morf.capture.project import CaptureProject, FrameDecision, Keypoints2D

__all__ = ["CaptureProject", "FrameDecision", "Keypoints2D", "IngestConfig", "MediaPipeDetector", "Detection",
           "run_ingest"]

_LAZY = {"IngestConfig": "morf.capture.ingest", "MediaPipeDetector": "morf.capture.detect_mediapipe",
         "Detection": "morf.capture.detect_mediapipe"}


def __getattr__(name):
    if name == "run_ingest":
        return importlib.import_module("morf.capture.ingest").ingest
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'morf.capture' has no attribute {name!r}")
