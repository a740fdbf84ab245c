"""Two exported avatar folders compared file by file (``morf bench resume``): the same file list,
the arrays of every .npz and the initializers of every .onnx graph within a tolerance, the graphs'
operators in the same order, the JSON files (the manifest) with the same keys apart from those
that record a time, a size, a checksum or a path. Other files must match byte for byte.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

# manifest keys that record when, how long, how large or where, not what was exported
VOLATILE_KEYS = frozenset({"created", "export_seconds", "project", "sha256", "bytes", "seconds", "written", "finished"})


@dataclass(frozen=True)
class AvatarDiff:
    """How an avatar folder differs from a reference one (:func:`compare_avatars`).

    Fields:
        missing, extra: files the reference has and this folder lacks, and the other way round;
        max_abs_diff: the largest absolute difference of any array or initializer (inf when two
            cannot be compared: another shape, dtype kind, or a name only one of them has);
        worst: "file:array" where it is; key_diff: JSON keys only one side has ("file:a.b.c");
        value_diff: JSON values (not times or paths) that differ, for information; tolerance:
            what ``max_abs_diff`` had to stay within.
    """

    missing: tuple[str, ...]
    extra: tuple[str, ...]
    max_abs_diff: float
    worst: str
    key_diff: tuple[str, ...]
    value_diff: tuple[str, ...]
    tolerance: float

    @property
    def passed(self) -> bool:
        return not self.missing and not self.extra and not self.key_diff and self.max_abs_diff <= self.tolerance

    def to_dict(self) -> dict:
        return {**asdict(self), "passed": self.passed}


def _files(folder: Path) -> set[str]:
    return {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()}


def _array_diff(a: np.ndarray, b: np.ndarray) -> float:
    """Largest absolute difference of two arrays; inf when they cannot be compared."""
    if a.shape != b.shape:
        return float("inf")
    if a.dtype.kind in "US" or b.dtype.kind in "US":
        return 0.0 if a.dtype.kind == b.dtype.kind and np.array_equal(a, b) else float("inf")
    if a.dtype.kind not in "biuf" or b.dtype.kind not in "biuf":
        return 0.0 if np.array_equal(a, b) else float("inf")
    if a.size == 0:
        return 0.0
    d = np.abs(a.astype(np.float64) - b.astype(np.float64))
    nan_a, nan_b = np.isnan(a.astype(np.float64)), np.isnan(b.astype(np.float64))
    if (nan_a != nan_b).any():
        return float("inf")
    return float(np.nanmax(np.where(nan_a, 0.0, d)))


def npz_arrays(path: Path) -> dict[str, np.ndarray]:
    from morf.io import load_npz

    return load_npz(path)


def onnx_arrays(path: Path) -> dict[str, np.ndarray]:
    """The graph's initializers by name, plus its operator sequence as one string array (so two
    graphs with other nodes but the same weights do not pass)."""
    import onnx
    from onnx import numpy_helper

    model = onnx.load(str(path))
    out = {f"init:{t.name}": numpy_helper.to_array(t) for t in model.graph.initializer}
    out["graph:ops"] = np.array(" ".join(n.op_type for n in model.graph.node))
    return out


def _json_diff(a, b, where: str, keys: list[str], values: list[str], tol: float) -> None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in sorted(set(a) | set(b), key=str):
            here = f"{where}.{k}" if where else str(k)
            if k in VOLATILE_KEYS:
                if (k in a) != (k in b):
                    keys.append(here)
                continue
            if k not in a or k not in b:
                keys.append(here)
            else:
                _json_diff(a[k], b[k], here, keys, values, tol)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            _json_diff(x, y, f"{where}[{i}]", keys, values, tol)
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        if not abs(float(a) - float(b)) <= tol * max(1.0, abs(float(a))):
            values.append(f"{where}: {a} != {b}")
    elif a != b:
        values.append(f"{where}: {a!r} != {b!r}")


def compare_avatars(reference: str | Path, other: str | Path, tolerance: float = 1e-5) -> AvatarDiff:
    """Compare avatar folder ``other`` with ``reference`` (see the module docstring for what counts)."""
    reference, other = Path(reference), Path(other)
    ref_files, other_files = _files(reference), _files(other)
    worst, worst_name = 0.0, ""
    keys: list[str] = []
    values: list[str] = []
    for name in sorted(ref_files & other_files):
        suffix = Path(name).suffix
        if suffix in (".npz", ".onnx"):
            read = npz_arrays if suffix == ".npz" else onnx_arrays
            a, b = read(reference / name), read(other / name)
            for key in sorted(set(a) | set(b)):
                d = _array_diff(a[key], b[key]) if key in a and key in b else float("inf")
                if d > worst or (d == worst and not worst_name and d > 0):
                    worst, worst_name = d, f"{name}:{key}"
        elif suffix == ".json":
            found: list[str] = []
            _json_diff(json.loads((reference / name).read_text()), json.loads((other / name).read_text()),
                       "", found, values, tolerance)
            keys += [f"{name}:{k}" for k in found]
        elif (reference / name).read_bytes() != (other / name).read_bytes():
            worst, worst_name = float("inf"), name
    return AvatarDiff(tuple(sorted(ref_files - other_files)), tuple(sorted(other_files - ref_files)), worst,
                      worst_name, tuple(keys), tuple(values), tolerance)
