"""Body-model fitting: keypoints + masks of every frame -> body fits, and the frame filter.

``fit_project(project, FitConfig())`` writes PROJECT/fits/; ``load_fits(project)`` reads them.

Every name below is loaded from its submodule on first use, so importing a torch-free submodule
(``morf.fitting.fits_io``, which the torch-free player reaches through ``morf.motion.formats``)
does not bring in the optimizer and torch.
"""

from morf.lazy import lazy_attributes

# name -> the submodule that defines it
_LAZY = {
    "PRESETS": "morf.fitting.config", "FilterConfig": "morf.fitting.config", "FitConfig": "morf.fitting.config",
    "StageConfig": "morf.fitting.config", "preset": "morf.fitting.config",
    "FitState": "morf.fitting.fit", "finalize": "morf.fitting.fit", "fit_sequence": "morf.fitting.fit",
    "BodyFits": "morf.fitting.fits_io", "load_fits": "morf.fitting.fits_io", "read_fits": "morf.fitting.fits_io",
    "FitInputs": "morf.fitting.inputs", "load_fit_inputs": "morf.fitting.inputs",
    "FitReport": "morf.fitting.project_fit", "fit_project": "morf.fitting.project_fit",
}

__all__ = [
    "PRESETS", "BodyFits", "FilterConfig", "FitConfig", "FitInputs", "FitReport", "FitState", "StageConfig",
    "finalize", "fit_project", "fit_sequence", "load_fit_inputs", "load_fits", "preset", "read_fits",
]
__getattr__, __dir__ = lazy_attributes(__name__, _LAZY)
