"""The one place distributions of microfacet normals are registered and dispatched.

Adding a distribution is a new module in ``vcavity/microfacet/`` with the interface below
plus one line in :data:`DISTRIBUTION_MODULES`; nothing else in the package changes. The
kernel, the analytic models, config validation, reports and ``--help`` all reach the
distributions through this module, whose lookup, parsing and dispatch are one
:class:`vcavity._numba.registry.Registry` (:data:`REGISTRY`).

Interface of a distribution module
----------------------------------
``NAME`` (str), ``DESCRIPTION`` (one line for reports and ``--help``),
``PARAMETERS`` (tuple of :mod:`vcavity.parameters` specs: config keys, ranges, defaults),
``SMITH`` (``"exact"``, ``"approximate"``, or ``"infinite"`` when the Smith Lambda
diverges and only V-cavity masking applies),
``EXAMPLES`` (a dict of named parameter sets, each a dict of config keys as a user writes
them in ``[material]``, e.g. ``{"typical": {"alpha": 0.6}, "anisotropic": {"alpha_x": 0.2,
"alpha_y": 0.6}, ...}``; the first is the typical one, which stands for the module where one
set is enough; checked at import: at least one, identifier-like names, only the module's own
keys, each accepted by :func:`parse`. tests/microfacet/test_conformance.py runs every generic
check of the interface on every registered module and example: no test file lists the
distributions), and

- ``params_from(values) -> ndarray``: the float64 parameter array from the canonical
  values (plain Python, may precompute tables);
- ``lobe_width(values) -> float``: angular roughness scale in radians of ``theta_m``,
  which quadratures use to resolve the specular lobe;
- jitted scalars, all with pdf ``D(m)(m.n)`` for the samplers (physics.md sec. 2):
  ``sample(u1, u2, params) -> (tan_theta_m, cos_phi_m, sin_phi_m)``;
  ``sample_disk(a, b, s, params)``, the same map with ``u1 = 1 - s`` and azimuth
  ``(a, b)/sqrt(s)`` for a uniform disk point (the kernel's trig-free sampler);
  ``sample_normal(u1, u2, params) -> (mx, my, mz)``, derived from ``sample`` as
  ``sample_normal = common.normal_sampler(sample)``;
  ``D(mx, my, mz, params)``, ``pdf(mx, my, mz, params)``;
  ``smith_lambda(vx, vy, vz, params)`` (physics.md sec. 3; documented fallback where
  not exact).

Optional: ``sample_visible(vx, vy, vz, u1, u2, params) -> (mx, my, mz)``, a normal with the
density of the normals visible from ``v``, ``<v, m>+ D(m)`` normalised (physics.md sec. 14):
the Smith random walk's facet sampling; :func:`has_visible_sampler` says which distributions
offer it. Every distribution with a finite Smith ``Lambda`` does; one whose ``SMITH`` is
``"infinite"`` (the Gaussian) cannot be walked and need not. Optional beside it:
``sample_visible_stream(state, vx, vy, vz, lam, params) -> (state, mx, my, mz)``, the same
density drawn from a random stream (:mod:`vcavity.rng`) given ``lam = Lambda(v)`` (for
``vz > 0``), for samplers that are faster by rejection or with ``Lambda`` known (Beckmann's);
:func:`sample_visible_stream` falls back to ``sample_visible`` on two uniforms of the stream.
Optional too: ``smith_lambda_bound(vx, vy, vz, params)``, an upper bound of ``smith_lambda``
cheaper than it, which lets the walk decide most escapes without the exact ``Lambda``
(Beckmann's needs no ``erfc``); :func:`smith_lambda_bound` falls back to ``smith_lambda``.

Arguments and results of the jitted scalars, the same in every module (each module's
docstrings add only what is its own): ``mx, my, mz`` a unit microfacet normal; ``vx, vy,
vz`` a unit direction; ``u1, u2`` uniforms in ``[0, 1)`` (``u1 >= 1`` is clamped to the
largest float below 1); ``(a, b)`` a point of the open unit disk other than the centre and
``s = a*a + b*b`` in (0, 1): ``s`` is uniform and independent of the direction
``(a, b)/sqrt(s)`` (Marsaglia's polar method), so ``sample_disk`` samples ``D(m)(m.n)``
exactly as ``sample`` does, without cos and sin; ``params`` the float64 array of the
module's ``params_from``. The samplers return a finite ``tan_theta_m >= 0`` and a unit
azimuth pair ``(cos_phi_m, sin_phi_m)``; ``D`` is in 1/sr and ``pdf`` per steradian, both 0
for ``mz <= 0``; ``smith_lambda >= 0`` is 0 for ``vz >= 1`` and ``inf`` for ``vz <= 0``.

Dispatch
--------
``kind`` is a distribution's position in :data:`DISTRIBUTION_MODULES`. In jitted code
the operations below resolve a compile-time constant ``kind`` (a closure integer, as
the kernel factory uses) to the module's own function with no branch, and a run-time
``kind`` to a branch over the registered modules (see :mod:`vcavity._numba.dispatch`). From
Python they call the module directly.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from vcavity._numba.jit import njit
from vcavity._numba.registry import Registry
from vcavity.parameters import ParameterError
from vcavity.rng import next_uniform

#: Registered distributions, by module name under ``vcavity.microfacet``: one line each.
DISTRIBUTION_MODULES = (
    "beckmann",
    "ggx",
    "phong",
    "gaussian",
    "student_t",
)

REGISTRY = Registry(
    "vcavity.microfacet", DISTRIBUTION_MODULES, noun="distribution", title="microfacet distribution",
    interface=("NAME", "DESCRIPTION", "PARAMETERS", "SMITH", "EXAMPLES", "params_from", "lobe_width", "sample",
               "sample_disk", "sample_normal", "D", "pdf", "smith_lambda"),
    owner="vcavity.microfacet.registry")


def _check_examples(module) -> None:
    """``ImportError`` unless ``module.EXAMPLES`` is a non-empty dict of named ``[material]``
    parameter sets, each with only the module's own keys and accepted by :func:`parse`."""
    examples = module.EXAMPLES
    if not isinstance(examples, dict) or not examples:
        raise ImportError(f"{module.__name__}.EXAMPLES: a non-empty dict of named parameter sets")
    keys = set(REGISTRY.config_keys(module.NAME))
    for label, raw in examples.items():
        where = f"{module.__name__}.EXAMPLES[{label!r}]"
        if not (isinstance(label, str) and label.isidentifier() and label.islower()):
            raise ImportError(f"{where}: names are lower-case identifiers")
        if not isinstance(raw, dict) or set(raw) - keys:
            raise ImportError(f"{where} = {raw!r}: a dict of the module's keys ({', '.join(sorted(keys))})")
        try:
            REGISTRY.parse(module.NAME, raw, table=where)
        except ParameterError as error:
            raise ImportError(str(error)) from None


for _module in REGISTRY.modules:
    if _module.SMITH not in ("exact", "approximate", "infinite"):
        raise ImportError(f"{_module.__name__}.SMITH = {_module.SMITH!r}: exact, approximate or infinite")
    _check_examples(_module)

MODULES = REGISTRY.modules
NAMES = REGISTRY.names
get = REGISTRY.get
kind_of = REGISTRY.kind_of
parse = REGISTRY.parse
config_keys = REGISTRY.config_keys
value_keys = REGISTRY.value_keys
help_lines = REGISTRY.help_lines


def is_isotropic(name: str, values: Mapping[str, float]) -> bool:
    """True when the distribution is invariant under rotation about the macro normal."""
    return all(spec.is_isotropic(values) for spec in get(name).PARAMETERS)


def params_from(name: str, values: Mapping[str, float]) -> tuple[int, np.ndarray]:
    """``(kind, params)``: dispatch index and contiguous float64 parameter array."""
    kind = kind_of(name)
    return kind, np.ascontiguousarray(REGISTRY.modules[kind].params_from(values), dtype=np.float64)


def lobe_width(name: str, values: Mapping[str, float]) -> float:
    """Angular roughness scale (radians of theta_m) for quadrature resolution."""
    return float(get(name).lobe_width(values))


# ------------------------------------------------------------------ jitted dispatch


sample = REGISTRY.dispatcher("sample", ("u1", "u2", "params"))
sample_normal = REGISTRY.dispatcher("sample_normal", ("u1", "u2", "params"))
sample_disk = REGISTRY.dispatcher("sample_disk", ("a", "b", "s", "params"))
D = REGISTRY.dispatcher("D", ("mx", "my", "mz", "params"))
pdf = REGISTRY.dispatcher("pdf", ("mx", "my", "mz", "params"))
smith_lambda = REGISTRY.dispatcher("smith_lambda", ("vx", "vy", "vz", "params"))
#: Optional (see the module docstring): a distribution without it gives a NaN normal,
#: which the Smith walk counts as degenerate (it refuses such distributions before tracing).
sample_visible = REGISTRY.dispatcher("sample_visible", ("vx", "vy", "vz", "u1", "u2", "params"),
                                     missing="(math.nan, math.nan, math.nan)")


_own_stream_sampler = REGISTRY.dispatcher("sample_visible_stream", ("state", "vx", "vy", "vz", "lam", "params"),
                                         missing="(state, math.nan, math.nan, math.nan)")
#: Per kind: does the module define ``sample_visible_stream``?
_HAS_STREAM_SAMPLER = tuple(hasattr(module, "sample_visible_stream") for module in MODULES)


@njit(cache=True, inline="always")
def sample_visible_stream(kind, state, vx, vy, vz, lam, params):
    """A visible normal from ``v`` (physics.md sec. 14) drawn from the random stream ``state``.

    The distribution's own ``sample_visible_stream`` where it has one, else its
    ``sample_visible`` on the stream's next two uniforms. ``kind`` is a compile-time constant
    in the walk, so the choice costs nothing.

    Parameters
    ----------
    kind : int
        Dispatch index.
    state : uint64
        Random stream state (:mod:`vcavity.rng`).
    vx, vy, vz : float
        Unit direction seen from (``sample_visible``'s).
    lam : float
        ``Lambda(v)`` when ``vz > 0`` (the walk's, :func:`smith_lambda`); unused otherwise.
    params : ndarray
        The distribution's parameter array.

    Returns
    -------
    state, mx, my, mz
        The advanced state and a unit normal (NaN where the distribution has no sampler).
    """
    if _HAS_STREAM_SAMPLER[kind]:
        return _own_stream_sampler(kind, state, vx, vy, vz, lam, params)
    state, u1 = next_uniform(state)
    state, u2 = next_uniform(state)
    mx, my, mz = sample_visible(kind, vx, vy, vz, u1, u2, params)
    return state, mx, my, mz


_own_lambda_bound = REGISTRY.dispatcher("smith_lambda_bound", ("vx", "vy", "vz", "params"), missing="math.inf")
_HAS_LAMBDA_BOUND = tuple(hasattr(module, "smith_lambda_bound") for module in MODULES)


@njit(cache=True, inline="always")
def smith_lambda_bound(kind, vx, vy, vz, params):
    """An upper bound of ``smith_lambda(kind, v)``: the module's own where it has one, else Lambda itself.

    Parameters
    ----------
    kind : int
        Dispatch index (a compile-time constant in the walk).
    vx, vy, vz : float
        Unit direction.
    params : ndarray
        The distribution's parameter array.

    Returns
    -------
    float
        ``>= smith_lambda(kind, vx, vy, vz, params)``.
    """
    if _HAS_LAMBDA_BOUND[kind]:
        return _own_lambda_bound(kind, vx, vy, vz, params)
    return smith_lambda(kind, vx, vy, vz, params)


@njit(cache=True, inline="always")
def smith_lambda_past_bound(kind, bound, vx, vy, vz, params):
    """``smith_lambda(kind, v)`` once :func:`smith_lambda_bound` gave ``bound`` for the same ``v``:
    ``bound`` itself where it is Lambda (no bound of the module's own), so nothing is evaluated twice."""
    if _HAS_LAMBDA_BOUND[kind]:
        return smith_lambda(kind, vx, vy, vz, params)
    return bound


def has_visible_sampler(name: str) -> bool:
    """True when the distribution offers ``sample_visible`` (physics.md sec. 14)."""
    return hasattr(get(name), "sample_visible")


def smith_walk_refusal(name: str) -> str | None:
    """None when the Smith random walk can use the distribution ``name``, else why not (one line)."""
    if get(name).SMITH == "infinite":
        return f"the Smith walk needs a finite Smith Lambda; {name}'s diverges (V-cavity masking only)"
    if not has_visible_sampler(name):
        return (f"the Smith walk has no visible-normal sampler for {name} yet "
                f"(available: {', '.join(n for n in NAMES if has_visible_sampler(n))})")
    return None


# ------------------------------------------------------------------ vectorised path

_ROW_OPS = {"D": 0, "pdf": 1, "smith_lambda": 2}


@njit(cache=True)
def _rows(kind, op, v, params):
    """``op(kind, v[k, 0], v[k, 1], v[k, 2], params)`` per row; ``op`` 0 D, 1 pdf, 2 Lambda."""
    out = np.empty(v.shape[0])
    for k in range(v.shape[0]):
        if op == 0:
            out[k] = D(kind, v[k, 0], v[k, 1], v[k, 2], params)
        elif op == 1:
            out[k] = pdf(kind, v[k, 0], v[k, 1], v[k, 2], params)
        else:
            out[k] = smith_lambda(kind, v[k, 0], v[k, 1], v[k, 2], params)
    return out


@njit(cache=True)
def _sample_rows(kind, u1, u2, params):
    out = np.empty((u1.shape[0], 3))
    for k in range(u1.shape[0]):
        out[k, 0], out[k, 1], out[k, 2] = sample_normal(kind, u1[k], u2[k], params)
    return out


def evaluate(op: str, kind: int, vectors, params) -> np.ndarray:
    """``op`` (``"D"``, ``"pdf"`` or ``"smith_lambda"``) over the rows of an ``(N, 3)`` array.

    Parameters
    ----------
    op : str
        Which operation.
    kind : int
        Dispatch index (:func:`kind_of`).
    vectors : array_like, shape (N, 3)
        Unit normals (D, pdf) or directions (smith_lambda).
    params : ndarray
        The distribution's parameter array (:func:`params_from`).

    Returns
    -------
    ndarray, shape (N,)
    """
    if op not in _ROW_OPS:
        raise ValueError(f"op = {op!r}: accepted {', '.join(_ROW_OPS)}")
    v = np.ascontiguousarray(np.asarray(vectors, dtype=np.float64).reshape(-1, 3))
    kind = REGISTRY.check_kind(kind, "evaluate")
    return _rows(kind, _ROW_OPS[op], v, np.ascontiguousarray(params, dtype=np.float64))


def sample_normals(kind: int, u1, u2, params) -> np.ndarray:
    """Normals ``(N, 3)`` from arrays of uniforms through the distribution's ``sample_normal``."""
    u1 = np.ascontiguousarray(u1, dtype=np.float64).ravel()
    u2 = np.ascontiguousarray(u2, dtype=np.float64).ravel()
    kind = REGISTRY.check_kind(kind, "sample_normals")
    return _sample_rows(kind, u1, u2, np.ascontiguousarray(params, dtype=np.float64))


__all__ = ["DISTRIBUTION_MODULES", "REGISTRY", "MODULES", "NAMES", "ParameterError", "get", "kind_of", "parse",
           "config_keys", "value_keys", "is_isotropic", "params_from", "lobe_width", "help_lines",
           "sample", "sample_normal", "sample_disk", "D", "pdf", "smith_lambda", "sample_visible",
           "sample_visible_stream", "smith_lambda_bound", "smith_lambda_past_bound",
           "has_visible_sampler", "smith_walk_refusal", "evaluate",
           "sample_normals"]
