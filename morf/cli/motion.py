"""``morf motion export MOTION_FILE --out clip.bvh [--project P]``: any motion file MoRF reads
(BVH, AMASS, AIST++ / SMPL, a capture's fits, MoRF clips), retargeted onto Anny, written as BVH on
Anny's skeleton (the project's fitted body shape with ``--project``, else Anny's default body)."""

from __future__ import annotations

from morf.cli.options import add_force_option, add_motion_fps_option


def add_parser(sub):
    p = sub.add_parser("motion", help="motion files: convert to BVH on Anny's skeleton")
    actions = p.add_subparsers(dest="action", metavar="ACTION", required=True)
    e = actions.add_parser("export", help="retarget a motion onto Anny and write it as BVH (opens in Blender)")
    e.add_argument("motion", help="motion file (BVH, AMASS / AIST++ / SMPL .npz, fits/fits.npz, MoRF clip); "
                                  "see docs/formats.md")
    e.add_argument("--out", required=True, help="output .bvh file")
    add_force_option(e, "replace an existing --out file")
    e.add_argument("--project", default=None,
                   help="capture project whose fitted body shape sets the skeleton (default: Anny's default body)")
    e.add_argument("--fps", type=float, default=30.0, help="output frame rate (the motion is resampled)")
    add_motion_fps_option(e, "frame rate of a motion file that stores none (AIST++ / SMPL .npz, fits.npz outside "
                             "its project); default 60 for AIST++ (smpl_poses), else 30; a rate stored in the file "
                             "wins")
    e.add_argument("--rotation-order", default="ZYX", type=str.upper,
                   choices=("ZYX", "ZXY", "YXZ", "YZX", "XYZ", "XZY"),
                   help="Euler channel order of every joint (ZYX: Zrotation Yrotation Xrotation)")
    return p


def run(args) -> int:
    from pathlib import Path

    import sys

    from morf.errors import InputError
    from morf.cli.play import check_rates
    from morf.io.outputs import claim_output_file

    check_rates(args)
    out = Path(args.out)
    if out.suffix.lower() != ".bvh":
        raise InputError(f"--out must be a .bvh file, got {out}")
    claim_output_file(out, "morf motion export", args.force)

    from morf.motion import RetargetConfig, load_motion, resample
    from morf.motion.bvh_export import write_clip_bvh
    from morf.motion.library import shared_body_model

    shape = None
    if args.project is not None:
        from morf.capture.project import CaptureProject
        from morf.errors import ProjectError
        from morf.motion.capture_fits import project_shape

        project = CaptureProject.open(args.project)
        shape = project_shape(project)
        if shape is None:
            raise ProjectError(f"{project.root} has no body fits; run 'morf fit {project.root}' first")
    model = shared_body_model()
    clip = load_motion(args.motion, model, shape, RetargetConfig(fps=args.fps), source_fps=args.motion_fps)
    for note in clip.notes:
        print(f"morf motion export: note: {note}", file=sys.stderr)
    if abs(clip.fps - args.fps) > 1e-6:  # clips and Anny poses load at their own rate
        clip = resample(clip, args.fps)
    if clip.rotvecs.shape[1] != len(model.bone_names):
        raise InputError(f"{args.motion}: motion has {clip.rotvecs.shape[1]} bones; Anny has {len(model.bone_names)}")
    out.parent.mkdir(parents=True, exist_ok=True)
    skeleton = write_clip_bvh(clip, out, model, shape, args.rotation_order)
    print(f"wrote {out}: {skeleton.num_joints} joints, {clip.num_frames} frames at {clip.fps:g} fps "
          f"({args.rotation_order} rotations, metres, Y up) from {clip.source or args.motion}")
    return 0
