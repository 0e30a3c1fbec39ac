"""Pieces of the walk (vcavity/kernels/trace.py, vcavity/kernels/scaffold.py): one compiled
kernel per (distribution, facet model, variant) with the documented output layout, and the
kernels' source tag. Deterministic (no false-positive rate).

(The groove sampler the kernels inline is checked against each distribution's ``sample`` on
every registered module and example in tests/microfacet/test_conformance.py; the Fresnel
bracketing table the IL facet event uses is tested with the facet, in
tests/facet/test_interfaced_lambertian.py.)
"""

import dataclasses
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from vcavity.facet import registry as facets
from vcavity.kernels import scaffold, trace, walks
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE


def test_one_kernel_per_scene_and_its_output_layout():
    dist_kind = distributions.kind_of("beckmann")
    facet_kind, variant, facet_data = facets.prepare("mirror", {})
    walk = walks.get("v-cavity", dist_kind, facet_kind, variant)
    assert walks.get("v-cavity", dist_kind, facet_kind, variant).kernel is walk.kernel  # built once
    il_kind, il_variant, _ = facets.prepare("interfaced_lambertian", {"kd": 0.5, "eta": 1.5})
    assert walks.get("v-cavity", dist_kind, il_kind, il_variant).kernel is not walk.kernel
    assert walks.get("smith", dist_kind, facet_kind, variant).kernel is not walk.kernel
    _, params = distributions.params_from("beckmann", {"alpha_x": 0.4, "alpha_y": 0.4})
    incident = np.array([math.sin(0.5), 0.0, math.cos(0.5)])
    n_paths, max_order, resolution, n_slots = BLOCK_SIZE + 100, 2, 5, 2
    call = walks.WalkCall(incident=incident, direction_key=np.uint64(99), first_block=0, n_blocks=2, n_paths=n_paths,
                          params=params, facet_data=facet_data, max_bounces=50, max_order=max_order,
                          resolution=resolution, n_slots=n_slots)
    counts, stat = walk.kernel(call)  # per slot: the counts plane and the statistics columns
    assert counts.shape == (n_slots, max_order + 1, resolution * resolution) and counts.dtype == np.int64
    assert stat.shape == (n_slots, len(trace.STATS)) and stat.dtype == np.int64
    tallies, stats = walk(call)  # by name, summed over the slots
    assert list(tallies) == ["counts"] and np.array_equal(tallies["counts"], counts.sum(axis=0))
    assert stats["absorbed"] == 0  # mirror facets
    assert tallies["counts"].sum() + stats["truncated"] + stats["degenerate"] == n_paths
    assert stats["max_bounces"] == stat[:, trace.STATS.index("max_bounces")].max() <= 50
    # no block, no path
    tallies, stats = walk(dataclasses.replace(call, n_blocks=0, n_paths=0))
    assert tallies["counts"].sum() == 0 and sum(stats.values()) == 0


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
