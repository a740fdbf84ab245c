"""The capture ``morf bench quality`` trains on, with the body fits it asks for.

``--project`` names an existing synthetic capture (it needs the hold-out sequence); otherwise one
is made in ``OUT/capture`` (the tiny synthetic preset with ``--preset tiny``, else the default)
and reused on a re-run. Training on fitted bodies (``--fits fits``, the default) needs
``fits/fits.npz``: when the capture has none, the fitting stage runs first, as ``morf fit`` and
``morf demo`` run it (the ``fast`` fit preset for the tiny benchmark, else ``default``), and
resumes if it was interrupted.
"""

from __future__ import annotations

from pathlib import Path

FIT_PRESETS = {"tiny": "fast"}  # training preset -> fit preset; the others fit with "default"


def bench_capture(out: Path, preset: str, project_path: str | None, fits: str, model):
    """The benchmark's CaptureProject, fitted when ``fits`` is "fits" and no fits exist yet."""
    project = _synthetic_capture(out, preset, project_path, model)
    if fits == "fits" and not project.fits_path.is_file():
        from morf.fitting.config import preset as fit_preset
        from morf.fitting.project_fit import fit_project

        name = FIT_PRESETS.get(preset, "default")
        print(f"fitting the body to {project.num_frames} frames of {project.root} (fit preset {name}) ...")
        report = fit_project(project, fit_preset(name), model=model)
        print(f"fitted in {report.seconds:.1f} s; the frame filter rejected {len(report.rejected)} frames")
    return project


def _synthetic_capture(out: Path, preset: str, project_path: str | None, model):
    from morf.capture.project import CaptureProject
    from morf.errors import InputError
    from morf.synth.ground_truth import has_holdout

    if project_path:
        project = CaptureProject.open(project_path)
        if not has_holdout(project):
            raise InputError(f"{project.root} has no hold-out sequence (a synthetic capture is needed)")
        return project
    root = out / "capture"
    if CaptureProject.is_project(root):
        return CaptureProject.open(root)
    from morf.synth.capture import make_synthetic_capture
    from morf.synth.config import synth_config

    print(f"making a synthetic capture in {root} ...")
    return make_synthetic_capture(root, synth_config("tiny" if preset == "tiny" else "default"), model=model,
                                  overwrite=True)
