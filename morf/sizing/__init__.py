"""Right-sized avatars: the automatic size choice of ``--preset auto`` and the named sizes it picks from.

``morf.sizing.choose.choose_train_config(project, base_preset)`` -> (TrainConfig, reasons) is
what ``--preset auto`` calls; it measures the capture (:mod:`morf.sizing.features`) and picks from
the renderer sizes of :mod:`morf.sizing.sweep`, whose points ``morf bench pareto`` trains. A
training feature: nothing here imports the benchmarks (``morf.bench`` measures these choices).

Nothing is imported eagerly, so ``import morf.sizing`` pulls in neither torch nor the body model.
"""

_LAZY = {"SizingRule": "choose", "choose_from_features": "choose", "choose_train_config": "choose",
         "CaptureFeatures": "features", "capture_features": "features"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"morf.sizing.{_LAZY[name]}"), name)
    raise AttributeError(name)


__all__ = list(_LAZY)
