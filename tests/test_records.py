"""``morf.records.length_of``: the count property of the array records."""

from dataclasses import FrozenInstanceError, dataclass, fields

import numpy as np
import pytest

from morf.records import length_of


@dataclass(frozen=True)
class _Mesh:
    positions: np.ndarray
    faces: np.ndarray
    num_vertices = length_of("positions")
    num_faces = length_of("faces")


def test_counts_the_named_arrays_first_axis():
    mesh = _Mesh(np.zeros((7, 3)), np.zeros((2, 3), np.int32))
    assert (mesh.num_vertices, mesh.num_faces) == (7, 2)
    assert type(mesh.num_vertices) is int
    assert [f.name for f in fields(_Mesh)] == ["positions", "faces"]  # not a field of the record


def test_is_read_only():
    mesh = _Mesh(np.zeros((1, 3)), np.zeros((0, 3)))
    with pytest.raises((AttributeError, FrozenInstanceError)):
        mesh.num_vertices = 3
