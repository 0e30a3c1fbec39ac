"""``vcavity warmup``: compile kernel variants into the cache ahead of the runs that need them.

Exit status: 0 every named variant ready; 2 an unknown name, no writable cache, or
``--device cuda`` without numba-cuda or a GPU (one line); 130 interrupted (the variants
finished so far stay cached).
"""

from __future__ import annotations

import argparse
import sys

from vcavity.cli.common import EXIT_OK, Interrupted, error

NAME = "warmup"

DESCRIPTION = """\
Compile kernel variants into the on-disk cache, so that later runs (and every Dask worker
or cluster job sharing the cache) load them in well under a second instead of compiling
each for tens of seconds on first use. A variant is one walk (--microsurface) for one
distribution and one facet model's compiled variant (interfaced_lambertian has three:
specular dielectric for kd = 0, lambertian for eta = 1, and the full model; mirror and
conductor have one each); parameter values do not matter.

Each flag names values of one axis (as in a run config; `vcavity run --help` lists them);
an axis not named takes every registered value, except the walk, which is v-cavity unless
--microsurface says otherwise (the smith walk only for the distributions it takes; the
others are skipped). --all is every variant of every walk.

The cache is NUMBA_CACHE_DIR when set, else ~/.cache/vcavity/<version>/numba (the
XDG_CACHE_HOME rule; the summary line prints the folder). Running warmup again loads what
is cached and compiles only what is missing or stale (after an upgrade); several warmups
at once, on one machine or on nodes sharing the folder, leave a working cache (each
compile is written atomically). Ctrl-C keeps the variants finished so far.

--device cuda compiles the variants' CUDA kernels instead (numba-cuda and a GPU needed,
docs/gpu.md), into the same cache, for the GPU model of this machine: run it on each
machine whose GPUs run the walks (each Dask worker's, docs/distributed.md). The paper
estimator's weighted walk has no CUDA kernel and is no variant here."""

EPILOG = """\
examples:
  vcavity warmup --distribution beckmann --facet interfaced_lambertian   # the default run: 3 IL variants
  vcavity warmup --distribution ggx beckmann --microsurface smith
  vcavity warmup --all --list                                           # what --all would compile
  NUMBA_CACHE_DIR=/shared/nc vcavity warmup --all                       # a cluster image or shared cache
  vcavity warmup --all --device cuda                                    # the GPU kernels (on a GPU machine)"""


def add_parser(subparsers) -> None:
    """Add the ``warmup`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    warmup = subparsers.add_parser(NAME, help="compile kernel variants into the cache (for clusters, Dask workers)",
                                   description=DESCRIPTION, epilog=EPILOG,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    warmup.set_defaults(handler=command)
    warmup.add_argument("--distribution", nargs="+", metavar="D", help="distributions (default: all)")
    warmup.add_argument("--facet", nargs="+", metavar="F", help="facet models, each with all its variants "
                        "(default: all)")
    warmup.add_argument("--microsurface", nargs="+", metavar="M", help="walks: v-cavity, smith (default: v-cavity)")
    warmup.add_argument("--all", action="store_true", help="every variant of every walk")
    warmup.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                        help="compile the CPU's kernels (default) or the CUDA kernels (a GPU needed)")
    warmup.add_argument("--list", action="store_true", help="print the selected variants and compile nothing")
    warmup.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _selection(args):
    """The selected variants, or a one-line error message."""
    from vcavity.simulate.warmup import variants

    named = [flag for flag in ("distribution", "facet", "microsurface") if getattr(args, flag)]
    if args.all and named:
        return f"--all = every variant: it takes no --{named[0]}"
    if not args.all and not named:
        return "name what to compile: --distribution, --facet, --microsurface, or --all"
    keyword = {"--microsurface": "microsurfaces", "--distribution": "distribution_names", "--facet": "facet_names"}
    for flag, values in (("--microsurface", args.microsurface), ("--distribution", args.distribution),
                         ("--facet", args.facet)):
        for value in values or ():
            try:
                variants(**{keyword[flag]: [value]})
            except KeyError as exc:  # "unknown ... 'x'; registered: a, b"
                return f"{flag} = {value!r}: must be one of {exc.args[0].split(': ', 1)[-1]}"
    walks = None if args.all else (args.microsurface or ["v-cavity"])
    selected = variants(walks, args.distribution, args.facet)
    if not selected:
        return f"--distribution = {' '.join(args.distribution)}: the Smith walk takes none of them"
    return selected


def command(args: argparse.Namespace) -> int:
    """``vcavity warmup``: compile the selected variants into the cache; returns the exit status."""
    import time

    selected = _selection(args)
    if isinstance(selected, str):
        return error(selected)
    if args.list:
        for variant in selected:
            print(variant.label)
        return EXIT_OK
    from tqdm import tqdm

    from vcavity._numba.jit import CACHE_ENABLED, CACHE_LOCATION, NAMED_CACHE_REFUSED
    from vcavity.simulate.warmup import compile_variant

    if args.device == "cuda":  # before the cache's refusals: without a GPU nothing is compiled anyway
        from vcavity.simulate.plan import cuda_unavailable

        reason = cuda_unavailable()
        if reason is not None:
            return error(f"--device = 'cuda': {reason}")
    if NAMED_CACHE_REFUSED:  # filling another folder would leave the named one cold
        return error(f"{NAMED_CACHE_REFUSED}; warmup fills the cache that runs with this NUMBA_CACHE_DIR "
                     "read: name a writable folder, or unset it for the per-user cache")
    if not CACHE_ENABLED:
        return error("no writable Numba cache directory here: nothing can be kept (set NUMBA_CACHE_DIR to one)")
    start = time.perf_counter()
    compiled = loaded = 0
    bar = tqdm(selected, unit="variant", file=sys.stderr, disable=args.quiet, dynamic_ncols=True)
    try:
        for variant in bar:
            bar.set_description(f"compiling {variant.label}")
            _, from_cache = compile_variant(variant, args.device)
            loaded += from_cache
            compiled += not from_cache
    except KeyboardInterrupt:
        bar.close()
        raise Interrupted(f"{compiled + loaded} of {len(selected)} variant(s) ready in {CACHE_LOCATION}") from None
    bar.close()
    if args.device == "cuda" and _simulated():
        print(f"vcavity: {len(selected)} variant(s) run under numba's CUDA simulator in "
              f"{time.perf_counter() - start:.1f} s: it compiles and caches nothing", file=sys.stderr)
        return EXIT_OK
    kind = "CUDA kernel(s) of the variant(s)" if args.device == "cuda" else "variant(s)"
    print(f"vcavity: {len(selected)} {kind} ready in {time.perf_counter() - start:.1f} s ({compiled} compiled, "
          f"{loaded} loaded from the cache) in {CACHE_LOCATION}", file=sys.stderr)
    return EXIT_OK


def _simulated() -> bool:
    """Whether the CUDA kernels ran under numba's simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
    from vcavity.kernels import cuda_loop

    return cuda_loop.SIMULATED
