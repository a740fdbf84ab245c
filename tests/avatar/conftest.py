"""Fixtures for the avatar tests."""

import pytest
import torch


@pytest.fixture(autouse=True, scope="module")
def _one_torch_thread():
    """Tiny tensors gain nothing from a second thread; on a loaded 2-core machine OpenMP barrier
    waits made tiny-tensor tests many times slower."""
    prev = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(prev)
