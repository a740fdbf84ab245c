"""``morf export PROJECT [--run NAME] [--out DIR] [--gltf FILE.glb [--motion FILE]] [--mesh FILE]``:
the trained avatar as a portable folder (uint8 neural texture, shaped render mesh, skeleton, fp32 +
int8 ONNX renderers, manifest); with ``--gltf`` also as a rigged glTF 2.0 binary whose folder sits
beside it; with ``--mesh`` also the fitted body as a PLY / OBJ file
(:mod:`morf.export.mesh_file`).

A thin wrapper over :func:`morf.export.project_export.export_project` (which the studio calls too)
and :func:`morf.export.gltf_project.export_gltf`.
"""

from __future__ import annotations

import signal
import sys
from pathlib import Path

from morf.cli.options import add_fits_option, add_force_option, add_motion_fps_option


def add_parser(sub):
    p = sub.add_parser("export", help="export a trained avatar for real-time playback (int8 ONNX + GL data)")
    p.add_argument("project", help="capture project folder")
    p.add_argument("--run", default=None, help="training run name under PROJECT/runs (default: the newest finished)")
    p.add_argument("--out", default=None, help="output folder (default: PROJECT/avatar)")
    p.add_argument("--layout", choices=("nhwc", "nchw", "planes"), default="nhwc",
                   help="renderer input layout (nhwc: the GL read-back as it is, the fastest)")
    p.add_argument("--calibration-views", type=int, default=32, help="training views used to calibrate int8")
    add_fits_option(p, "body fits that pose the calibration views (as for 'morf train')")
    p.add_argument("--gltf", default=None, metavar="FILE.glb",
                   help="also write a rigged glTF 2.0 binary (mesh, skeleton, skin weights, colour texture baked "
                        "from the renderer); the avatar folder goes beside it (FILE/) unless --out is given")
    add_force_option(p, "write into an existing non-empty --out folder (or over an existing .glb), replacing only "
                        "the files morf export writes; other files there are kept")
    p.add_argument("--motion", default=None, metavar="FILE",
                   help="with --gltf: add this motion (BVH, AMASS or clip .npz) to the .glb as an animation; with "
                        "--web: add it to the web folder's motions")
    p.add_argument("--web", default=None, metavar="OUT",
                   help="also write a static web folder that plays the avatar live in a browser (morf serve OUT; "
                        "docs/web.md)")
    p.add_argument("--webgpu", action="store_true", help="with --web: also carry onnxruntime-web's WebGPU build")
    p.add_argument("--mesh", default=None, metavar="FILE.ply|FILE.obj",
                   help="also write the fitted body (rest pose, the project's fitted shape, texture coordinates; metres, "
                        "Z up) as a PLY or OBJ mesh for other tools")
    add_motion_fps_option(p, "with --motion: the frame rate of a motion file that stores none (split SMPL, "
                             "AIST++ / SMPL .npz); a rate stored in the file wins")
    return p


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.errors import InputError
    from morf.io.names import check_name
    from morf.export.project_export import ProjectExportConfig, export_project
    from morf.pipeline.control import StageControl, StopRequested

    if args.motion and not (args.gltf or args.web):
        raise InputError("--motion goes into the glTF file or the web folder: give --gltf FILE.glb or --web OUT too")
    if args.webgpu and not args.web:
        raise InputError("--webgpu goes with --web OUT")
    if args.web:  # refused before the export's minutes, not after
        from morf.cli.web import check_web

        check_web(args.web, args.force, [args.motion] if args.motion else None, "morf export --web")
    if args.motion_fps is not None and not (args.motion and 0 < args.motion_fps <= 1000):
        raise InputError(f"--motion-fps goes with --motion and must be a frame rate from 0 to 1000, got {args.motion_fps}")
    if args.run is not None:
        check_name(args.run, "run name")
    if args.mesh:
        from morf.export.mesh_file import check_mesh_path
        from morf.io.outputs import claim_output_file

        claim_output_file(check_mesh_path(args.mesh), "morf export", args.force)  # refused before the long export
    project = CaptureProject.open(args.project)
    cfg = ProjectExportConfig(run=args.run, out=args.out, input_layout=args.layout,
                              calibration_views=args.calibration_views, fits=args.fits,
                              force=args.force)
    control = StageControl()
    previous = signal.signal(signal.SIGINT, lambda *_: control.stop())
    try:
        if args.gltf:
            from morf.export.gltf_project import export_gltf

            result = export_gltf(project, args.gltf, cfg, motion=args.motion, control=control, motion_fps=args.motion_fps)
            manifest = result.manifest
        else:
            manifest = export_project(project, cfg, control)
    except StopRequested:
        what = ".glb" if args.gltf else "avatar folder"
        print(f"morf export: stopped; the previous {what} (if any) is unchanged", file=sys.stderr)
        return 130
    finally:
        signal.signal(signal.SIGINT, previous)
    if args.gltf:
        anim = f", animation of {result.animation_frames} frames" if result.animation_frames else ""
        print(f"wrote {result.path} ({result.bytes / 1e6:.1f} MB): {result.vertices} vertices, {result.joints} joints, "
              f"{result.texture_size}x{result.texture_size} colour texture{anim}")
    out = Path(args.out) if args.out else (result.avatar_dir if args.gltf else project.avatar_dir)
    q = manifest["int8_quality"]
    size = sum(f["bytes"] for f in manifest["files"].values()) / 1e6
    print(f"exported {out} ({size:.1f} MB) from run {manifest['source']['run']}; int8 vs fp32 on "
          f"{q['views']} {q['on']} views: PSNR {q['psnr_db']:.1f} dB (person {q['psnr_person_db']:.1f}), "
          f"SSIM {q['ssim']:.4f}" + _closer_check(q))
    if args.mesh:
        _write_mesh(out, args.mesh)
    if args.web:
        from morf.cli.web import report
        from morf.web.build import build_web_folder

        report(build_web_folder(out, args.web, motions=[args.motion] if args.motion else None, force=args.force,
                                webgpu=args.webgpu, command="morf export --web", motion_fps=args.motion_fps))
    return 0


def _write_mesh(avatar_dir: Path, path: str) -> None:
    from morf.export.avatar_folder import load_exported_avatar
    from morf.export.mesh_file import write_body_mesh

    written = write_body_mesh(load_exported_avatar(avatar_dir, verify=False).mesh, path)
    print(f"wrote {written.path}: the fitted body, {written.vertices} vertices, {written.faces} triangles")


def _closer_check(q: dict) -> str:
    c = q.get("playback_scale")
    if not isinstance(c, dict):
        return ""
    return f"; {c['zoom']:.2f}x closer, as the player draws: {c['psnr_db']:.1f} dB (person {c['psnr_person_db']:.1f})"
