"""``morf info PROJECT``: what a project holds and which frames are used for training."""

from __future__ import annotations

import json


def add_parser(sub):
    p = sub.add_parser("info", help="summarise a capture project")
    p.add_argument("project", help="project folder")
    p.add_argument("--json", action="store_true", help="print machine-readable JSON")
    return p


def run(args) -> int:
    from morf.capture.project import CaptureProject
    from morf.export.avatar_folder import is_avatar_folder

    project = CaptureProject.open(args.project)
    decisions = project.frame_decisions()
    dropped = [{"frame": d.index, "reason": d.reason} for d in decisions if not d.used]
    summary = {
        "project": str(project.root),
        "frames": project.num_frames,
        "size": list(project.image_size),
        "fps": project.fps,
        "source": project.manifest.get("source"),
        "synthetic": project.is_synthetic,
        "has_fits": project.fits_path.is_file(),
        "runs": run_names(project.runs_dir),
        "has_avatar": is_avatar_folder(project.avatar_dir),
        "training_frames": len(decisions) - len(dropped),
        "excluded": dropped,
    }
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        for k, v in summary.items():
            if k == "excluded":
                print(f"excluded frames: {len(v)}")
                for row in v[:20]:
                    print(f"  {row['frame']:6d}  {row['reason']}")
                if len(v) > 20:
                    print(f"  ... and {len(v) - 20} more")
            else:
                print(f"{k}: {v}")
    return 0


def run_names(runs_dir) -> list[str]:
    """The training runs in ``runs_dir``: its folders, without the project's own (``.cache`` and
    any other name starting with a dot) and without stray files."""
    if not runs_dir.is_dir():
        return []
    return sorted(p.name for p in runs_dir.iterdir() if p.is_dir() and not p.name.startswith("."))
