"""``morf play AVATAR_DIR --motion FILE --out video.mp4|video.webm|frames/``: render a motion with an
exported avatar."""

from __future__ import annotations

import sys
import time

import numpy as np

from morf.cli.options import add_force_option, add_motion_fps_option, check_frame_rate

# Below this PSNR (int8 against fp32 on held-out views, measured at export) int8 output is visibly
# wrong, so playback falls back to the fp32 renderer and says so.
INT8_MIN_PSNR_DB = 30.0


def _int8_psnr(avatar: str) -> float | None:
    """The export's int8 check (the lower of image and person PSNR), None when it cannot be read."""
    from morf.errors import InputError
    from morf.export.avatar_folder import int8_check_db, read_manifest

    try:
        return int8_check_db(read_manifest(avatar))
    except (InputError, OSError, ValueError, TypeError):
        return None  # the player reports a missing or damaged folder itself


def add_parser(sub):
    p = sub.add_parser("play", help="render a motion with an exported avatar to mp4 or PNG frames")
    p.add_argument("avatar", help="avatar folder written by `morf export`")
    add_playback_options(p)
    return p


def add_playback_options(p) -> None:
    """Options shared by ``morf play`` and ``morf animate``."""
    p.add_argument("--motion", required=True,
                   help="motion file, told by its content: BVH; AMASS SMPL-H / SMPL-X .npz; AIST++ or SMPL .npz "
                        "(poses (T,72)); a capture's fits/fits.npz; Anny poses .npz (rotvecs (T,104,3), transl "
                        "(T,3), fps) (docs/formats.md)")
    p.add_argument("--out", required=True,
                   help="output video (.mp4: H.264 with PyAV installed, else mp4v; .webm: VP9, needs PyAV) or a "
                        "folder for PNG frames")
    p.add_argument("--fps", type=float, default=30.0, help="output frame rate (the motion is resampled)")
    add_motion_fps_option(p, "frame rate of a motion file that stores none (AIST++ / SMPL .npz, fits.npz outside "
                             "its project, Anny poses without fps); default 60 for AIST++ (smpl_poses), else 30; a "
                             "rate stored in the file wins")
    p.add_argument("--camera", choices=("follow", "orbit", "front"), default="follow")
    p.add_argument("--size", type=int, default=640, help="square output size in pixels")
    p.add_argument("--precision", choices=("int8", "fp32"), default="int8")
    p.add_argument("--background", default="255,255,255", help="R,G,B background colour")
    p.add_argument("--max-frames", type=int, default=0, help="stop after this many frames (0: all)")
    add_force_option(p, "replace an existing video, or write into a folder that holds files, replacing only the "
                           "frames this command writes (other files there are kept)")
    p.add_argument("--force-int8", action="store_true",
                   help="play int8 even when the export measured it far from fp32")


def check_args(args):
    """The options' checks and the output's claim (:mod:`morf.io.outputs`), before anything heavy is
    loaded: a bad option or a refused output costs a fraction of a second. Returns (background, claim)."""
    from morf.errors import InputError
    from morf.playback.video_sink import claim_sink

    try:
        bg = tuple(int(v) for v in args.background.split(","))
        assert len(bg) == 3 and all(0 <= v <= 255 for v in bg)
    except (ValueError, AssertionError):
        raise InputError(f"--background must be R,G,B with each from 0 to 255, got {args.background!r}") from None
    check_rates(args)
    if args.max_frames < 0:
        raise InputError(f"--max-frames must be 0 (all frames) or a positive count, got {args.max_frames}")
    if args.size < 32 or args.size > 8192:
        raise InputError(f"--size must be between 32 and 8192 pixels, got {args.size}")
    return bg, claim_sink(args.out, command_name(args), args.force)


def check_rates(args) -> None:
    """``--fps`` and ``--motion-fps`` (when given): positive frame rates of at most 1000 (nan refused too)."""
    check_frame_rate("--fps", args.fps)
    check_frame_rate("--motion-fps", args.motion_fps)


def command_name(args) -> str:
    return f"morf {getattr(args, 'command', None) or 'play'}"


def run(args, shape=None, checked=None) -> int:
    """Render ``args.motion``; ``shape`` (1, 6) is the body the motion is retargeted to (default
    Anny's); ``checked``: what :func:`check_args` returned, when the caller ran it already."""
    from morf.motion.clip import resample
    from morf.raster.camera_paths import front_camera, orbit_camera
    from morf.playback.motion_input import load_playback_motion
    from morf.playback.player import load_avatar, open_player
    from morf.playback.video_sink import VideoSink
    from morf.progress import progress

    bg, claim = checked or check_args(args)
    command = command_name(args)
    precision, notice = args.precision, None
    quality = _int8_psnr(args.avatar)
    if precision == "int8" and not args.force_int8 and quality is not None and quality < INT8_MIN_PSNR_DB:
        notice = (f"{command}: this avatar's int8 renderer is only {quality:.1f} dB from fp32 over the image or the "
                  f"person (below {INT8_MIN_PSNR_DB:.0f} dB); playing fp32 instead (--force-int8 to override)")
        precision = "fp32"
    avatar = load_avatar(args.avatar)  # the folder checked, and the motion read, before GL and the renderer start
    clip = load_playback_motion(args.motion, avatar.skeleton.num_bones, shape, args.motion_fps)
    with open_player(avatar, size=args.size, precision=precision, background=bg) as player:
        if notice:  # said once the input is known to be good: a bad motion stays a one-line error
            print(notice, file=sys.stderr)
        for note in clip.notes:  # what the file holds that the body cannot show (a jaw, an expression)
            print(f"{command}: note: {note}", file=sys.stderr)
        clip = resample(clip, args.fps)
        rotvecs, transl = clip.rotvecs, clip.transl
        if args.max_frames > 0:
            rotvecs, transl = rotvecs[:args.max_frames], transl[:args.max_frames]
        size = args.size
        # Motions are grounded (feet on z = 0), so aim at the root's typical height, not the origin.
        mid = np.median(transl, axis=0)
        centre = (float(mid[0]), float(mid[1]), float(mid[2]))

        def camera(i):
            if args.camera == "orbit":
                return orbit_camera(size, i / args.fps, center=centre)
            if args.camera == "follow":
                return front_camera(size, center=(float(transl[i, 0]), float(transl[i, 1]), centre[2]))
            return front_camera(size, center=centre)

        sink = VideoSink(args.out, args.fps, (size, size), command, claim)
        ok = False
        t0 = time.perf_counter()
        try:
            frames = ((rotvecs[i], transl[i], camera(i)) for i in range(len(rotvecs)))
            for img in progress(player.render_sequence(frames), total=len(rotvecs), desc="play", unit="frame"):
                sink.write(img)
            ok = True
        finally:
            sink.close(ok)
        dt = time.perf_counter() - t0
    codec = f"{sink.codec.label}, " if sink.codec else ""
    print(f"wrote {sink.count} frames to {args.out} ({codec}{sink.count / max(dt, 1e-9):.1f} fps)")
    return 0
