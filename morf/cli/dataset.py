"""``morf dataset people-snapshot|zju-mocap SRC_DIR PROJECT``: a standard dataset's sequence
into a capture project (frames, masks, camera, split; 2D keypoints from MediaPipe)."""

from __future__ import annotations

import sys
from pathlib import Path

from morf.cli.options import add_force_option


def _common(p) -> None:
    p.add_argument("src", type=Path, metavar="SRC_DIR", help="the dataset folder (see docs/datasets.md)")
    p.add_argument("project", type=Path, metavar="PROJECT", help="project folder (created, or replaced if a MoRF project)")
    p.add_argument("--max-frames", type=int, metavar="N", help="keep at most N frames (after --every)")
    p.add_argument("--every", type=int, default=1, metavar="K", help="keep every K-th frame of the split (default 1)")
    p.add_argument("--no-detect", action="store_true",
                   help="skip MediaPipe; frames get no 2D keypoints (marked undetected)")
    p.add_argument("--frame-format", choices=("auto", "png", "jpg"), default="auto",
                   help="frame image format (auto: PNG up to 300 frames, JPEG beyond)")
    add_force_option(p, "replace a project that already has fits, runs or an avatar")


def add_parser(sub):
    p = sub.add_parser("dataset", help="People-Snapshot / ZJU-MoCap -> capture project",
                       description="Import a sequence of a standard dataset into a capture project, with the "
                                   "split the paper's comparisons use. Pickled files are read plain-data-only.")
    kinds = p.add_subparsers(dest="dataset", metavar="DATASET", required=True)
    ps = kinds.add_parser("people-snapshot", help="a People-Snapshot subject (InstantAvatar split)")
    _common(ps)
    ps.add_argument("--subject", metavar="NAME", help="subject folder under SRC_DIR (default: SRC_DIR is the subject)")
    ps.add_argument("--split", choices=("train", "test", "all"), default="train",
                    help="frames to import: InstantAvatar's train or test frames, or all (default train)")
    zju = kinds.add_parser("zju-mocap", help="a ZJU-MoCap sequence (HumanNeRF protocol)")
    _common(zju)
    zju.add_argument("--camera", type=int, default=1, help="training camera, 1-based (default 1, as HumanNeRF)")
    zju.add_argument("--split", choices=("humannerf", "all"), default="humannerf",
                     help="humannerf: HumanNeRF's training frames of the camera; all: every frame")
    zju.add_argument("--view-every", type=int, default=30, metavar="K",
                     help="store the other cameras' images of every K-th project frame for novel-view "
                          "evaluation (0: none; default 30)")
    return p


def run(args) -> int:
    if args.dataset == "people-snapshot":
        from morf.datasets import PeopleSnapshotConfig, import_people_snapshot

        cfg = PeopleSnapshotConfig(subject=args.subject, split=args.split, max_frames=args.max_frames,
                                   every=args.every, detect=not args.no_detect, force=args.force,
                                   frame_format=args.frame_format)
        result = import_people_snapshot(args.src, args.project, cfg)
    else:
        from morf.datasets import ZjuMocapConfig, import_zju_mocap

        cfg = ZjuMocapConfig(camera=args.camera, split=args.split, max_frames=args.max_frames, every=args.every,
                             view_every=args.view_every, detect=not args.no_detect, force=args.force,
                             frame_format=args.frame_format)
        result = import_zju_mocap(args.src, args.project, cfg)
    for w in result.warnings:
        print(f"morf dataset: warning: {w}", file=sys.stderr)
    what = "replaced" if result.replaced else "created"
    splits = ", ".join(f"{n} {s or 'unsplit'}" for s, n in result.splits.items())
    print(f"{what} {result.root}: {result.num_frames} frames ({splits}), {result.width}x{result.height}")
    if args.no_detect:
        print("no keypoints detected (--no-detect): every frame is marked undetected")
    else:
        print(f"person found in {result.detected} of {result.num_frames} frames")
    if result.extras.get("views"):
        print(f"novel views: {result.extras['views']} cameras x {result.extras['view_frames']} frames in "
              f"{result.root / 'dataset' / 'views'}")
    return 0
