"""Run names are single folder names."""

import pytest

from morf.errors import InputError
from morf.io.names import check_name


@pytest.mark.parametrize("name", ["morf-cpu", "a.b", "run_1", "Ünïcode"])
def test_plain_names_pass(name):
    assert check_name(name) == name


@pytest.mark.parametrize("name", ["", " ", ".", "..", "../x", "a/b", "a\\b", ".cache", "x\0y", " lead", "a" * 101,
                                  "tab\tname"])
def test_paths_and_reserved_names_are_refused(name):
    with pytest.raises(InputError, match="run name"):
        check_name(name)
