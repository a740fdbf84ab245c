"""The suite's schedule: the slowest files named in tests/conftest.py exist, so a renamed file is
noticed instead of silently starting last."""

from tests.conftest import REPO, SLOWEST_FILES


def test_the_slowest_files_exist():
    missing = [p for p in SLOWEST_FILES if not (REPO / p).is_file()]
    assert not missing, f"tests/conftest.py SLOWEST_FILES names files that do not exist: {missing}"
    assert len(set(SLOWEST_FILES)) == len(SLOWEST_FILES)
