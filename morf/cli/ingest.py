"""``morf ingest PROJECT --video FILE | --frames DIR_OR_IMAGE``: frames, 2D keypoints and person
masks into a capture project (created, or replaced whole)."""

from __future__ import annotations

import sys
from pathlib import Path

from morf.cli.options import add_force_option


def add_parser(sub):
    p = sub.add_parser("ingest", help="video or images -> capture project (frames, keypoints, masks)",
                       description="Decode a video or read images, detect the person's 2D keypoints and mask "
                                   "(MediaPipe) or import them (OpenPose JSON, mask images), and write a capture "
                                   "project. Re-running replaces the project's frames whole.")
    p.add_argument("project", help="project folder (created, or replaced if it is a MoRF project)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--video", type=Path, metavar="FILE", help="a video file")
    src.add_argument("--frames", type=Path, metavar="PATH", help="a folder of images, or one image")
    p.add_argument("--keypoints", type=Path, metavar="DIR",
                   help="OpenPose JSON per frame (BODY_25 or COCO-18; hands and face kept) instead of MediaPipe")
    p.add_argument("--masks", type=Path, metavar="DIR", help="person mask images (folder, or one file) instead of MediaPipe's")
    p.add_argument("--max-frames", type=int, metavar="N", help="keep at most N frames (after --every)")
    p.add_argument("--every", type=int, default=1, metavar="K", help="keep every K-th frame (default 1)")
    p.add_argument("--resize", type=int, metavar="PX", help="scale frames so the longest side is PX pixels")
    p.add_argument("--fps", type=float, help="source frame rate (overrides the video's; the project gets fps/K). Images given without it are "
                        "recorded as unordered views (a photo set: each fitted on its own, no smoothing between "
                        "neighbours); give it for images that are the frames of a clip")
    p.add_argument("--focal", type=float, metavar="PX",
                   help="focal length in source pixels (default: EXIF when present, else 1.2 x the longest side)")
    p.add_argument("--frame-format", choices=("auto", "png", "jpg"), default="auto",
                   help="frame image format (auto: PNG up to 300 frames, JPEG beyond)")
    add_force_option(p, "replace a project that already has fits, runs or an avatar")
    p.add_argument("--no-mirror-average", dest="mirror_average", action="store_false",
                   help="detect MediaPipe's keypoints on each frame once; by default they are detected on the "
                        "mirrored frame too and the two averaged where they agree (twice the detection time for "
                        "closer keypoints and fits, docs/formats.md)")
    p.add_argument("--no-face-hands", dest="face_hands", action="store_false",
                   help="skip the face and hand landmarks (MediaPipe face mesh and hands, about 0.1 s a frame) "
                        "that the fit turns the head, wrists and fingers to; OpenPose files with face and hand "
                        "points need none")
    return p


def run(args) -> int:
    from morf.capture.ingest import IngestConfig, ingest

    config = IngestConfig(video=args.video, frames=args.frames, keypoints=args.keypoints, masks=args.masks,
                          max_frames=args.max_frames, every=args.every, resize=args.resize, fps=args.fps,
                          focal=args.focal, frame_format=args.frame_format, force=args.force,
                          mirror_average=args.mirror_average, face_hands=args.face_hands)
    result = ingest(args.project, config)
    for w in result.warnings:
        print(f"morf ingest: warning: {w}", file=sys.stderr)
    what = "replaced" if result.replaced else "created"
    print(f"{what} {result.root}: {result.num_frames} frames, {result.width}x{result.height}")
    print(f"person found in {result.detected} of {result.num_frames} frames")  # never 0: ingest refuses that
    if result.unordered_views:
        print("frames recorded as unordered views (a photo set); give --fps if they are the frames of a clip")
    return 0
