"""Right-sized avatars: the speed/accuracy sweep's building blocks and the automatic size choice.

``morf.sizing.choose.choose_train_config(project, base_preset)`` -> (TrainConfig, reasons) is
what ``--preset auto`` calls; :mod:`morf.sizing.sweep`, :mod:`morf.sizing.evaluate` and
:mod:`morf.sizing.charts` are shared by ``morf bench pareto`` and ``morf bench stability``.

Nothing is imported eagerly: the torch-free playback timing child imports
:mod:`morf.sizing.evaluate` and must not pull in torch.
"""

_LAZY = {"SizingRule": "choose", "choose_from_features": "choose", "choose_train_config": "choose",
         "CaptureFeatures": "features", "capture_features": "features", "near_front": "front",
         "pareto_front": "front"}


def __getattr__(name):
    if name in _LAZY:
        import importlib

        return getattr(importlib.import_module(f"morf.sizing.{_LAZY[name]}"), name)
    raise AttributeError(name)


__all__ = list(_LAZY)
