"""Overlay images of a fit: translucent body silhouette and outline, detected keypoints (green)
and fitted keypoints (red) on the frame, plus the filter's verdict."""

from __future__ import annotations

import cv2
import numpy as np

from morf.capture.keypoint_layout import SKELETON


def draw_overlay(frame: np.ndarray, silhouette: np.ndarray, detected: np.ndarray, fitted: np.ndarray,
                 reason: str | None = None, min_confidence: float = 0.3) -> np.ndarray:
    """Compose one overlay.

    Args:
        frame: (H, W, 3) uint8 RGB; silhouette: (H, W) bool body coverage;
        detected: (23, 3) x, y, confidence; fitted: (23, 2) pixels;
        reason: the filter's rejection reason, written on the image.
    Returns:
        (H, W, 3) uint8 RGB.
    """
    out = frame.copy()
    tint = np.array([80, 140, 255], np.float32)
    out[silhouette] = (0.55 * out[silhouette] + 0.45 * tint).astype(np.uint8)
    contours, _ = cv2.findContours(silhouette.astype(np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cv2.drawContours(out, contours, -1, (40, 90, 255), 1, cv2.LINE_AA)
    H = frame.shape[0]
    r = max(2, H // 200)
    ok = detected[:, 2] > min_confidence
    for a, b in SKELETON:
        if ok[a] and ok[b]:
            cv2.line(out, _pt(detected[a]), _pt(detected[b]), (0, 200, 0), 1, cv2.LINE_AA)
        cv2.line(out, _pt(fitted[a]), _pt(fitted[b]), (230, 30, 30), 1, cv2.LINE_AA)
    for k in range(len(fitted)):
        if ok[k]:
            cv2.circle(out, _pt(detected[k]), r, (0, 220, 0), -1, cv2.LINE_AA)
        cv2.circle(out, _pt(fitted[k]), r, (240, 30, 30), 1, cv2.LINE_AA)
    if reason:
        scale = max(0.4, H / 1000)
        cv2.putText(out, f"rejected: {reason}", (8, int(24 * scale + 6)), cv2.FONT_HERSHEY_SIMPLEX, scale,
                    (255, 60, 60), max(1, int(scale * 2)), cv2.LINE_AA)
    return out


def _pt(p) -> tuple[int, int]:
    x = float(np.clip(p[0], -1e4, 1e4))
    y = float(np.clip(p[1], -1e4, 1e4))
    return int(round(x - 0.5)), int(round(y - 0.5))
