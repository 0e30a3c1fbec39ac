"""Numba plumbing every jitted module shares: the one njit decorator (cache location) and compile-time dispatch over a registry."""
