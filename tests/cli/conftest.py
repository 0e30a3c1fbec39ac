"""Fixtures of the command-line tests: numba-cuda or the GPU taken away (``--device cuda``)."""

import sys

import pytest

from tests.cli.device_support import HAVE_NUMBA_CUDA


@pytest.fixture
def no_numba_cuda(monkeypatch):
    """numba-cuda as if not installed: importing the CUDA loop fails (``None`` in sys.modules)."""
    import vcavity.kernels

    monkeypatch.setitem(sys.modules, "vcavity.kernels.cuda_loop", None)
    monkeypatch.delattr(vcavity.kernels, "cuda_loop", raising=False)


@pytest.fixture
def no_gpu(monkeypatch):
    """numba-cuda installed, but no CUDA device or driver (as on this project's CI), even
    where there is one or the simulator is on."""
    if not HAVE_NUMBA_CUDA:  # (importorskip would error: the module raises ImportError, not ModuleNotFoundError)
        pytest.skip("numba-cuda is not installed")
    from vcavity.kernels import cuda_loop

    monkeypatch.setattr(cuda_loop, "SIMULATED", False)
    monkeypatch.setattr(cuda_loop.cuda, "is_available", lambda: False)
