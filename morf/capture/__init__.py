"""Capture ingestion: frames, 2D keypoints and person masks into a project folder."""

from morf.capture.project import CaptureProject, FrameDecision, Keypoints2D

__all__ = ["CaptureProject", "FrameDecision", "Keypoints2D"]
