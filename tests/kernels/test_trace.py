"""Pieces of the walk (vcavity/kernels/trace.py, vcavity/kernels/scaffold.py): one compiled
kernel per (distribution, facet model, variant) with the documented output layout, and the
kernels' source tag. Deterministic (no false-positive rate).

(The groove sampler the kernels inline is checked against each distribution's ``sample`` on
every registered module and example in tests/microfacet/test_conformance.py; the Fresnel
bracketing table the IL facet event uses is tested with the facet, in
tests/facet/test_interfaced_lambertian.py.)
"""

import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from vcavity.facet import registry as facets
from vcavity.kernels import scaffold, trace
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE


def test_one_kernel_per_scene_and_its_output_layout():
    dist_kind = distributions.kind_of("beckmann")
    facet_kind, variant, facet_data = facets.prepare("mirror", {})
    kernel = trace.get_kernel(dist_kind, facet_kind, variant)
    assert trace.get_kernel(dist_kind, facet_kind, variant) is kernel
    il_kind, il_variant, _ = facets.prepare("interfaced_lambertian", {"kd": 0.5, "eta": 1.5})
    assert trace.get_kernel(dist_kind, il_kind, il_variant) is not kernel
    _, params = distributions.params_from("beckmann", {"alpha_x": 0.4, "alpha_y": 0.4})
    incident = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    n_paths, max_order, resolution, n_slots = BLOCK_SIZE + 100, 2, 5, 2
    counts, stat = kernel(incident, np.uint64(99), 0, 2, n_paths, params, facet_data, 50, max_order,
                          resolution, n_slots, 1)
    assert counts.shape == (n_slots, max_order + 1, resolution * resolution) and counts.dtype == np.int64
    assert stat.shape == (n_slots, trace.N_STATS) and stat.dtype == np.int64
    assert stat[:, trace.STAT_ABSORBED].sum() == 0  # mirror facets
    exits = counts.sum()
    assert exits + stat[:, [trace.STAT_TRUNCATED, trace.STAT_DEGENERATE]].sum() == n_paths
    assert stat[:, trace.STAT_MAX_BOUNCES].max() <= 50
    # no block, no path
    counts, stat = kernel(incident, np.uint64(99), 0, 0, 0, params, facet_data, 50, max_order, resolution, n_slots,
                          1)
    assert counts.sum() == 0 and stat.sum() == 0


def test_the_source_tag_covers_every_jitted_file_the_kernels_are_built_from():
    """Numba's cache does not see edits to inlined code in other files: the kernels' tag
    must hash each file of jitted code or overloads that the two walks import (in a fresh
    process, so that only their own imports count)."""
    script = ("import sys, vcavity.kernels.paper, vcavity.kernels.trace\n"
              "for name, module in sorted(sys.modules.items()):\n"
              "    if name.startswith('vcavity.') and getattr(module, '__file__', None):\n"
              "        print(module.__file__)\n")
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300, check=True)
    imported = {Path(line).resolve() for line in out.stdout.splitlines()}
    tagged = {path.resolve() for path in scaffold.source_files()}
    compiled = [str(path) for path in imported - tagged if "njit" in path.read_text() or "overload" in path.read_text()]
    assert not compiled  # jitted code, or Numba overloads (the registries' dispatch), left out of the tag
    assert {Path(scaffold.__file__).resolve(), Path(trace.__file__).resolve()} <= tagged
    assert len(tagged) == len(scaffold.source_files())  # no file twice
