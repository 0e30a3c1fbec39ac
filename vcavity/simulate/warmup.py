"""Compiled kernel variants by name: list them, compile them into the cache, announce a compile.

A kernel variant is one walk (``v-cavity`` or ``smith``) for one distribution, facet model
and facet variant (:func:`vcavity.kernels.trace.variants`); Numba compiles each on first
use (docs/performance.md: compile time) and caches it on disk (:mod:`vcavity._numba.jit`). ``vcavity warmup``
compiles named variants ahead of time, for cluster images and Dask workers
(:func:`compile_variant`); ``vcavity run`` says what it is compiling while it does
(:class:`CompileNotice`) instead of staying silent.

A variant is compiled through :meth:`vcavity.simulate.pipeline.Simulation.compile`, with the
argument types of a run: what warmup puts in the cache is what a run loads.
"""

from __future__ import annotations

import sys
import threading
import time
from dataclasses import dataclass

from numba.core import event

from vcavity import config as config_mod
from vcavity._numba import cache_lock
from vcavity._numba.jit import CACHE_ENABLED
from vcavity.estimators import registry as estimators
from vcavity.facet import registry as facets
from vcavity.kernels import walks
from vcavity.microfacet import registry as distributions
from vcavity.sensor.grid import EqualAreaSensor
from vcavity.simulate.pipeline import Scene, Simulation

#: The walks ``microsurface`` selects, in the order warmup compiles them.
MICROSURFACES = ("v-cavity", "smith")


@dataclass(frozen=True)
class Variant:
    """One compiled kernel: a walk, a distribution, a facet model and one of its variants (names)."""

    microsurface: str
    distribution: str
    facet: str
    facet_variant: str

    @property
    def label(self) -> str:
        """``beckmann x interfaced_lambertian``, with the facet variant where it is not the facet's
        only one or its full model, and the walk where it is not the V-groove walk."""
        module = facets.get(self.facet)
        full = module.VARIANTS[-1]
        variant = "" if self.facet_variant == full else f" ({self.facet_variant})"
        walk = "" if self.microsurface == "v-cavity" else f" ({self.microsurface} walk)"
        return f"{self.distribution} x {self.facet}{variant}{walk}"

    @classmethod
    def of_material(cls, material) -> "Variant":
        """The variant a run of ``material`` (a :class:`vcavity.material.Material`) compiles."""
        return cls(material.microsurface, material.distribution, material.facet,
                   facets.variant_name(material.facet, material.facet_params))


def _smith_walkable(distribution: str) -> bool:
    return distributions.smith_walk_refusal(distribution) is None


def variants(microsurfaces=None, distribution_names=None, facet_names=None) -> list[Variant]:
    """Every variant of the given walks, distributions and facets (None: all registered).

    The Smith walk only for the distributions it takes. Registry order; a name given twice
    (or two names of one registry entry) counts once.

    Parameters
    ----------
    microsurfaces, distribution_names, facet_names : iterable of str, optional
        Names as in a run config; unknown ones are a ``KeyError`` naming what is registered.

    Returns
    -------
    list of Variant
    """
    walks = tuple(dict.fromkeys(microsurfaces)) if microsurfaces else MICROSURFACES
    for walk in walks:
        if walk not in MICROSURFACES:
            raise KeyError(f"unknown microsurface {walk!r}; accepted: {', '.join(MICROSURFACES)}")
    dists = list(dict.fromkeys(distributions.get(name).NAME for name in distribution_names)) if distribution_names \
        else list(distributions.NAMES)
    facet_modules = list(dict.fromkeys(facets.get(name) for name in facet_names)) if facet_names \
        else list(facets.MODULES)
    return [Variant(walk, dist, facet.NAME, name) for walk in walks for dist in dists for facet in facet_modules
            for name in facet.VARIANTS if walk == "v-cavity" or _smith_walkable(dist)]


def _example_values(module) -> dict:
    """Canonical parameter values of a registry module from its ``--help`` examples."""
    return {spec.keys[0]: spec.example for spec in module.PARAMETERS}


def compile_variant(variant: Variant, device: str = "cpu") -> tuple[float, bool]:
    """Compile ``variant`` into the cache, or load it from there.

    Parameters
    ----------
    variant : Variant
    device : str
        ``"cpu"`` (the slot loop) or ``"cuda"`` (the CUDA kernel, :mod:`vcavity.kernels.cuda_loop`:
        the caller checks first that this process can run it,
        :func:`vcavity.simulate.plan.cuda_unavailable`).

    Returns
    -------
    seconds : float
        Time the compile (or cache load) took.
    loaded : bool
        True when it came from the cache (nothing compiled).
    """
    simulation = Simulation(config_mod.default_config(), threads=1)
    dist_kind, params = distributions.params_from(
        variant.distribution, distributions.REGISTRY.parse(variant.distribution,
                                                           _example_values(distributions.get(variant.distribution))))
    facet_module = facets.get(variant.facet)
    facet_kind, _, data = facets.prepare(variant.facet, facets.REGISTRY.parse(variant.facet,
                                                                              _example_values(facet_module)))
    index = facet_module.VARIANTS.index(variant.facet_variant)
    # the run's own call (Simulation.compile), with this variant's walk and scene: the
    # cached signature is the one a run asks for
    simulation.scene = Scene(dist_kind, params, facet_kind, index, data)
    simulation.walk = walks.get(variant.microsurface, dist_kind, facet_kind, index, device=device)
    misses = _compiles(simulation.kernel)  # the dispatcher is shared per process
    seconds = simulation.compile()
    return seconds, _compiles(simulation.kernel) == misses


def _compiles(kernel) -> int:
    """Compiles so far of a walk's kernel in this process (a cache load is none)."""
    if hasattr(kernel, "compiles"):  # the CUDA kernel (cuda_loop.CudaKernel)
        return kernel.compiles
    return sum(kernel.walk.stats.cache_misses.values())


@dataclass(frozen=True)
class ModelCode:
    """The compiled code of one estimator's analytic models, for one microsurface.

    The models dispatch on the distribution and the facet at run time
    (:mod:`vcavity._numba.dispatch`), so one compile serves every material of the
    microsurface; it is made for :attr:`material` (a facet with every part the models
    compute), through the estimator's own :meth:`compile
    <vcavity.estimators.models.DirectionModels.compile>`, as a run makes it.
    """

    estimator: str
    microsurface: str
    material: tuple  # (key, value) pairs of a [material] table

    @property
    def label(self) -> str:
        """``exact estimator's models``, with the walk where it is not the V-groove walk
        (as :attr:`Variant.label`)."""
        walk = "" if self.microsurface == "v-cavity" else f" ({self.microsurface} walk)"
        return f"{self.estimator} estimator's models{walk}"


#: Every model code ``--models`` compiles: the every-order model (specular facets; a
#: conductor also needs the facet's reflectance table, which a mirror skips) and the exact
#: f1 model of each microsurface (a facet with both a specular and a body term).
MODELS = (
    ModelCode("exact", "v-cavity", (("distribution", "ggx"), ("alpha", 0.5), ("facet", "conductor"))),
    ModelCode("exact-f1", "v-cavity", (("distribution", "beckmann"), ("alpha", 0.5),
                                       ("facet", "interfaced_lambertian"), ("kd", 0.8), ("eta", 1.5))),
    ModelCode("exact-f1", "smith", (("microsurface", "smith"), ("distribution", "beckmann"), ("alpha", 0.5),
                                    ("facet", "interfaced_lambertian"), ("kd", 0.8), ("eta", 1.5))),
)


def compile_models(code: ModelCode) -> tuple[float, bool]:
    """Compile ``code`` into the cache, or load it from there (as :func:`compile_variant`).

    Returns
    -------
    seconds : float
    loaded : bool
        True when nothing was compiled (every function came from the cache, or was
        compiled earlier in this process).
    """
    config = config_mod.validate({"material": dict(code.material), "incidence": {"theta_i_deg": [30.0]},
                                  "simulation": {"estimator": code.estimator, "sensor_resolution": 3}},
                                 source="vcavity warmup")
    models = estimators.get(code.estimator).models(config, EqualAreaSensor(config.sensor_resolution))
    compiled = threading.Event()
    with event.install_listener("numba:compile", _CompileStarted(compiled)):
        seconds = models.compile()
    return seconds, not compiled.is_set()


class CompileNotice:
    """Context manager: a line on stderr while Numba compiles for longer than ``delay`` seconds.

    Numba announces each real compile (a cache miss) with a ``numba:compile`` event; a
    kernel loaded from the cache raises none and prints nothing, however long the load
    takes on a busy machine. A cold compile prints ``vcavity: compiling the kernel for beckmann x interfaced_lambertian
    (first use; cached afterwards) ...`` and, when it ends, the seconds it took (on a
    terminal the line counts the seconds as they pass). The compile itself stays in the
    calling thread, so Ctrl-C reaches it as before; a thread only writes the line, and an
    interrupted compile ends the line before the interrupt's own message.

    Where nothing can be cached (:data:`vcavity._numba.jit.CACHE_ENABLED` false) the line
    says ``(not cached: compiled in every process)`` instead of promising a cache.

    Parameters
    ----------
    label : str
        For what it is compiled (:attr:`Variant.label`).
    stream : file, optional
        Default ``sys.stderr``.
    delay : float
        Seconds before the line appears.
    code : str, keyword-only
        What is compiled: ``"kernel"`` (the walk), or an estimator's models
        (:attr:`vcavity.estimators.models.DirectionModels.CODE`).
    cached : bool, keyword-only
        Whether the compiled code is kept (default: whether this process caches).
    """

    def __init__(self, label: str, stream=None, delay: float = 1.0, *, code: str = "kernel",
                 cached: bool | None = None):
        cached = CACHE_ENABLED if cached is None else cached
        kept = "first use; cached afterwards" if cached else "not cached: compiled in every process"
        self.text = f"vcavity: compiling the {code} for {label} ({kept}) ..."
        self.stream = stream if stream is not None else sys.stderr
        self.delay = delay
        self._done = threading.Event()
        self._lock = threading.Lock()
        self._shown = False
        self._start = 0.0
        self._compiling = threading.Event()
        self._listening = None
        self._thread = threading.Thread(target=self._tick, name="vcavity-compile-notice", daemon=True)

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()

    def _tick(self) -> None:
        if self._done.wait(self.delay):
            return
        while not self._compiling.wait(0.1):  # a cache load: nothing to say
            if self._done.is_set():
                return
        live = getattr(self.stream, "isatty", lambda: False)()
        with self._lock:
            if self._done.is_set():
                return
            self._shown = True
            _OPEN_NOTICES.add(self)
            self._write(self.text)
        while live and not self._done.wait(1.0):
            with self._lock:
                if not self._done.is_set():
                    self._write(f"\r{self.text} {time.perf_counter() - self._start:.0f} s")

    def __enter__(self) -> "CompileNotice":
        self._start = time.perf_counter()
        # a cache that refuses the save says so after this line ends, on a line of its own
        self._held = cache_lock.notes_held()
        self._held.__enter__()
        self._listening = event.install_listener("numba:compile", _CompileStarted(self._compiling))
        self._listening.__enter__()
        self._thread.start()
        return self

    def _end(self, end: str) -> None:
        """End the notice's line with ``end`` (once; the lock held)."""
        self._done.set()
        if self._shown and self in _OPEN_NOTICES:
            _OPEN_NOTICES.discard(self)
            self._write(f"\r{self.text}{end}\n" if getattr(self.stream, "isatty", lambda: False)()
                        else f"{end}\n")

    def __exit__(self, exc_type, exc, tb) -> bool:
        with self._lock:
            self._end(f" {time.perf_counter() - self._start:.0f} s" if exc_type is None else " stopped")
        self._thread.join()
        self._listening.__exit__(None, None, None)
        self._held.__exit__(None, None, None)
        return False


#: The notices whose line is written and not ended yet.
_OPEN_NOTICES: set = set()


def end_open_notices() -> None:
    """End the line of a compile notice that an interrupt cut short (`` stopped``), before
    the interrupt's own line is printed: a Ctrl-C can strike inside the notice's exit,
    between the compile's end and the line's."""
    for notice in list(_OPEN_NOTICES):
        if notice._lock.acquire(timeout=1.0):
            try:
                notice._end(" stopped")
            finally:
                notice._lock.release()


class _CompileStarted(event.Listener):
    """Sets ``flag`` when Numba starts compiling anything (not when it loads from the cache)."""

    def __init__(self, flag: threading.Event):
        self.flag = flag

    def on_start(self, ev) -> None:
        self.flag.set()

    def on_end(self, ev) -> None:
        pass


__all__ = ["MICROSURFACES", "MODELS", "ModelCode", "Variant", "variants", "compile_models", "compile_variant",
           "CompileNotice"]
