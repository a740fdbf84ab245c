"""Right-sized avatars: the automatic size choice of ``--preset auto`` and the named sizes it picks from.

``morf.sizing.choose.choose_train_config(project, base_preset)`` -> (TrainConfig, reasons) is
what ``--preset auto`` calls; it measures the capture (:mod:`morf.sizing.features`) and picks from
the renderer sizes of :mod:`morf.sizing.sweep`, whose points ``morf bench pareto`` trains. A
training feature: nothing here imports the benchmarks (``morf.bench`` measures these choices).

Nothing is imported eagerly, so ``import morf.sizing`` pulls in neither torch nor the body model.
"""

from morf.lazy import lazy_attributes

__all__ = ["SizingRule", "choose_from_features", "choose_train_config", "CaptureFeatures", "capture_features"]
__getattr__, __dir__ = lazy_attributes(__name__, {
    "SizingRule": "morf.sizing.choose", "choose_from_features": "morf.sizing.choose",
    "choose_train_config": "morf.sizing.choose", "CaptureFeatures": "morf.sizing.features",
    "capture_features": "morf.sizing.features"})
