"""Numba plumbing every jitted module shares: the one njit decorator (cache location), compile-time dispatch over a registry, and the Registry both registries are."""
