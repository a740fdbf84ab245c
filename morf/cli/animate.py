"""``morf animate PROJECT --motion FILE --out video.mp4``: play a motion (BVH, AMASS, AIST++ / SMPL,
another capture's fits, MoRF clips; see docs/formats.md) on the project's exported avatar
(``PROJECT/avatar``, written by ``morf export``), retargeted to the project's fitted body shape."""

from __future__ import annotations

from morf.cli.play import add_playback_options, check_args
from morf.cli.play import run as play


def add_parser(sub):
    p = sub.add_parser("animate", help="retarget a motion onto the project's avatar and render it to video")
    p.add_argument("project", help="capture project folder with an exported avatar")
    p.add_argument("--avatar", default=None, help="avatar folder (default: PROJECT/avatar)")
    add_playback_options(p)
    return p


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.errors import ProjectError
    from morf.export.avatar_folder import is_avatar_folder

    project = CaptureProject.open(args.project)
    avatar = args.avatar or project.avatar_dir
    if not is_avatar_folder(project.avatar_dir) and args.avatar is None:
        raise ProjectError(f"{project.root} has no exported avatar yet; run 'morf export {project.root}' first")
    args.avatar = str(avatar)
    checked = check_args(args)

    def shape():  # loaded only for a motion that is retargeted (torch and the body model: seconds)
        from morf.motion.capture_fits import project_shape

        return project_shape(project)

    return play(args, shape, checked)

