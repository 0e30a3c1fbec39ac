"""The scenes and walk calls the CUDA loop's tests run (tests/kernels/test_cuda_loop.py).

A case is a plain dict (JSON, so that the simulator's child process,
tests/kernels/cuda_sim_child.py, gets it on its command line): the walk, the
distribution and facet model by name with their ``[material]`` values, the incident
direction and the call's sizes. :func:`scene` turns it into kinds and arrays through the
registries, :func:`walk_call` into a :class:`vcavity.kernels.walks.WalkCall` with the
walk's ``setup`` filled in, as :class:`vcavity.kernels.walks.Walk` fills it. Nothing here
imports numba-cuda.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from vcavity.facet import registry as facets
from vcavity.kernels import registry as walk_registry
from vcavity.microfacet import registry as distributions
from vcavity.rng import BLOCK_SIZE, direction_key

#: Three blocks, the last one short: the split, the grid-stride and the short block all occur.
SIM_PATHS = 2 * BLOCK_SIZE + 300


def case(walk, distribution, dist_values, facet, facet_values, *, theta=0.3, phi=0.2, n_paths=SIM_PATHS,
         max_bounces=100, max_order=4, resolution=17, first_binned_order=1, seed=1):
    """One case (module doc); the label names the scene."""
    variant = facets.variant_name(facet, facets.parse(facet, facet_values))
    return {"label": f"{walk}/{distribution}/{facet}/{variant}".replace(" ", "_"), "walk": walk,
            "distribution": distribution, "dist_values": dict(dist_values), "facet": facet,
            "facet_values": dict(facet_values), "theta": theta, "phi": phi, "n_paths": n_paths,
            "max_bounces": max_bounces, "max_order": max_order, "resolution": resolution,
            "first_binned_order": first_binned_order, "seed": seed}


#: The default suite's cases: fig. 7(b) on the V-groove walk, Smith's walk with GGX mirrors
#: (some paths truncated at 3 bounces), a conductor with the first order unbinned and
#: orders beyond 2 in slot 0. Their CPU variants are among those the suite compiles anyway.
DEFAULT_CASES = [
    case("v-cavity", "beckmann", {"alpha": 0.6}, "interfaced_lambertian", {"kd": 0.9, "eta": 1.5}),
    case("smith", "ggx", {"alpha": 0.3}, "mirror", {}, theta=1.2, max_bounces=3),
    case("v-cavity", "beckmann", {"alpha": 0.6}, "conductor", {"eta": 0.43, "k": 2.455}, theta=0.9,
         max_order=2, first_binned_order=2),
]


def all_cases(**sizes) -> list[dict]:
    """Every walk x distribution x facet variant the CUDA loop serves (the unweighted walks,
    Smith's only where it walks the distribution), each with the distribution's first
    example and the first facet example of that variant (the registries' ``EXAMPLES``)."""
    out = []
    for walk in walk_registry.MODULES:
        if walk.WEIGHTED:
            continue
        for dist in distributions.MODULES:
            if walk.walkable(dist.NAME) is not None:
                continue
            for facet in facets.MODULES:
                for variant in facet.VARIANTS:
                    values = next(raw for raw in facet.EXAMPLES.values()
                                  if facets.variant_name(facet.NAME, facets.parse(facet.NAME, raw)) == variant)
                    out.append(case(walk.NAME, dist.NAME, next(iter(dist.EXAMPLES.values())), facet.NAME, values,
                                    **sizes))
    return out


def scene(spec: dict) -> tuple:
    """``(walk_kind, dist_kind, facet_kind, facet_variant, params, facet_data)`` of a case."""
    dist_kind, params = distributions.params_from(spec["distribution"],
                                                  distributions.parse(spec["distribution"], spec["dist_values"]))
    facet_kind, variant, data = facets.prepare(spec["facet"], facets.parse(spec["facet"], spec["facet_values"]))
    return walk_registry.kind_of(spec["walk"]), dist_kind, facet_kind, variant, params, data


def walk_call(spec: dict, first_block: int = 0, n_blocks: int | None = None, key_seed: int | None = None,
              n_slots: int = 2):
    """The case's :class:`vcavity.kernels.walks.WalkCall` over blocks ``first_block ..``
    (default: all of the direction's), ``setup`` computed as a Walk computes it; ``key_seed``
    another seed than the case's, ``n_slots`` the CPU walk's threads."""
    from vcavity.kernels.walks import WalkCall

    walk_kind, dist_kind, _, _, params, data = scene(spec)
    theta, phi = spec["theta"], spec["phi"]
    incident = np.array([math.sin(theta) * math.cos(phi), math.sin(theta) * math.sin(phi), math.cos(theta)])
    total = -(-spec["n_paths"] // BLOCK_SIZE)
    call = WalkCall(incident=incident, direction_key=direction_key(spec["seed"] if key_seed is None else key_seed,
                                                                   theta, phi),
                    first_block=first_block, n_blocks=total - first_block if n_blocks is None else n_blocks,
                    n_paths=spec["n_paths"], params=params, facet_data=data, max_bounces=spec["max_bounces"],
                    max_order=spec["max_order"], resolution=spec["resolution"], n_slots=n_slots,
                    first_binned_order=spec["first_binned_order"])
    module = walk_registry.get(spec["walk"])
    ix, iy, iz = (float(v) for v in incident)
    return dataclasses.replace(call, setup=float(module.prepare_direction(ix, iy, iz, params, dist_kind)))


def cpu_tables(spec: dict, **call_args) -> tuple[np.ndarray, np.ndarray]:
    """The CPU walk's ``(counts [max_order + 1, N^2], stats [5])`` of a case (summed over its slots)."""
    from vcavity.kernels import walks

    walk_kind, dist_kind, facet_kind, variant, _, _ = scene(spec)
    walk = walks.get(spec["walk"], dist_kind, facet_kind, variant)
    tallies, stats = walk(walk_call(spec, **call_args))
    return tallies["counts"], np.array([stats[name] for name in walk.stats], np.int64)


def merged(parts) -> tuple[np.ndarray, np.ndarray]:
    """``(counts, stats)`` of several calls' ``(counts[1, ...], stats[1, 5])`` as one table:
    sums, ``max_bounces`` (column 3) the maximum."""
    counts = sum(part[0][0] for part in parts)
    stats = np.sum([part[1][0] for part in parts], axis=0)
    stats[3] = max(part[1][0][3] for part in parts)
    return counts, stats


__all__ = ["DEFAULT_CASES", "SIM_PATHS", "all_cases", "case", "cpu_tables", "merged", "scene", "walk_call"]
