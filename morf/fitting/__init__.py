"""Body-model fitting: keypoints + masks of every frame -> body fits, and the frame filter.

``fit_project(project, FitConfig())`` writes PROJECT/fits/; ``load_fits(project)`` reads them.
"""

from morf.fitting.config import PRESETS, FilterConfig, FitConfig, StageConfig, preset
from morf.fitting.fit import FitState, finalize, fit_sequence
from morf.fitting.fits_io import BodyFits, load_fits, read_fits
from morf.fitting.inputs import FitInputs, load_fit_inputs
from morf.fitting.project_fit import FitReport, fit_project

__all__ = [
    "PRESETS", "BodyFits", "FilterConfig", "FitConfig", "FitInputs", "FitReport", "FitState", "StageConfig",
    "finalize", "fit_project", "fit_sequence", "load_fit_inputs", "load_fits", "preset", "read_fits",
]
