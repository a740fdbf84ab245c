"""How a trained avatar scores on a FrameSet (:func:`morf.train.project_run.evaluate_frames`), as a
typed result."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class FrameScores:
    """Scores of a TrainedAvatar's renders against the frames, both over one flat colour.

    Fields:
        psnr, ssim: over the whole image; psnr_person, ssim_person: over the person only (the ground
            truth mask); each the mean over the frames of its finite values, None if there are none.
        temporal: flicker of the frames in order (NaN with fewer than two frames).
        background: the flat colour (r, g, b) both were composited over; frames: the frame count.
        warp_flicker: (render, real) temporal warping errors of the frames in order
            (:mod:`morf.avatar.warp_flicker`; None: not scored).
    """

    psnr: float | None
    ssim: float | None
    psnr_person: float | None
    ssim_person: float | None
    temporal: float
    background: tuple[float, ...]
    frames: int
    warp_flicker: tuple[float, float] | None = None

    def to_dict(self) -> dict:
        return {"psnr": self.psnr, "ssim": self.ssim, "psnr_person": self.psnr_person,
                "ssim_person": self.ssim_person, "temporal": self.temporal, "background": list(self.background),
                "frames": self.frames, **({} if self.warp_flicker is None else {"warp_flicker": list(self.warp_flicker)})}
