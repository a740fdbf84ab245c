"""Adapters that turn standard research datasets into capture projects.

* :func:`import_people_snapshot` -- People-Snapshot subjects (video, masks, camera), with
  InstantAvatar's train/test split.
* :func:`import_zju_mocap` -- ZJU-MoCap sequences: one camera as a monocular capture (HumanNeRF's
  protocol), the other cameras kept for novel-view evaluation.

Their pickled files are read by a plain-data-only unpickler (:mod:`morf.datasets.safe_pickle`).
"""

from morf.datasets.people_snapshot import PeopleSnapshotConfig, import_people_snapshot
from morf.datasets.safe_pickle import load_npy, load_plain_pickle, loads_plain
from morf.datasets.writer import DATASET_DIR, DatasetImportResult
from morf.datasets.zju_mocap import ZjuMocapConfig, import_zju_mocap

__all__ = [
    "DATASET_DIR",
    "DatasetImportResult",
    "PeopleSnapshotConfig",
    "ZjuMocapConfig",
    "import_people_snapshot",
    "import_zju_mocap",
    "load_npy",
    "load_plain_pickle",
    "loads_plain",
]
