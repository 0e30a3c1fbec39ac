"""What the ``--device cuda`` tests share: whether numba-cuda is here, the run they trace,
the refusals' reasons (the fixtures that take numba-cuda or the GPU away are in conftest.py)."""

import importlib.util

HAVE_NUMBA_CUDA = importlib.util.find_spec("numba_cuda") is not None

#: Two directions of three RNG blocks (the last one short), a small sensor: the default
#: material (IL paper fig. 7b), the CUDA loop tests' first scene (tests/kernels/cuda_cases.py).
CONFIG = """\
[material]
distribution = "beckmann"
alpha = 0.6
kd = 0.9
eta = 1.5
[incidence]
theta_i_deg = [20, 70]
paths = 8492
[simulation]
seed = 3
max_order = 4
max_bounces = 100
sensor_resolution = 9
{simulation}"""

NOT_INSTALLED = "numba-cuda is not installed: pip install 'vcavity[cuda]'"
NO_DEVICE = "numba-cuda finds no CUDA device or driver here"
