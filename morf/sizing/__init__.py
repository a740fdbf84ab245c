"""Right-sized avatars: the speed/accuracy sweep's building blocks and the automatic size choice.

``choose_train_config(project, base_preset)`` -> (TrainConfig, reasons) is what ``--preset auto``
calls; :mod:`morf.sizing.sweep`, :mod:`morf.sizing.evaluate` and :mod:`morf.sizing.charts` are
shared by ``morf bench pareto`` and ``morf bench stability``.
"""

from morf.sizing.choose import SizingRule, choose_from_features, choose_train_config
from morf.sizing.features import CaptureFeatures, capture_features
from morf.sizing.front import near_front, pareto_front

__all__ = ["SizingRule", "choose_from_features", "choose_train_config", "CaptureFeatures", "capture_features",
           "near_front", "pareto_front"]
