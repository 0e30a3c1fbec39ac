"""``vcavity warmup``: compile kernel variants and the estimators' analytic models into the
cache ahead of the runs that need them.

Exit status: 0 everything named ready; 2 an unknown name, no usable cache or nothing to
cache it with, or ``--device cuda`` without numba-cuda or a GPU (one line); 130
interrupted (what finished so far stays cached).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
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

Each flag names values of one axis (as in a run config; `vcavity run --help` lists them;
a flag given twice adds its values, a value named twice counts once); an axis not named
takes every registered value, except the walk, which is v-cavity unless --microsurface
says otherwise (the smith walk only for the distributions it takes; the others are
skipped). --models compiles the analytic models of the estimators exact (every order)
and exact-f1 (the single-bounce cell model, for each walk): runs with those estimators
need them besides their kernel, and compile them for a minute or more on a cold cache;
one compile serves every distribution and facet. --all is every variant of every walk
and the models.

The cache is NUMBA_CACHE_DIR when set, else ~/.cache/vcavity/<version>/numba (the
XDG_CACHE_HOME rule; the summary line prints the folder). Running warmup again loads what
is cached and compiles only what is missing or stale (after an upgrade); several warmups
at once, on one machine or on nodes sharing the folder, leave a working cache (each
compile is written atomically). Ctrl-C keeps the variants finished so far.

--device cuda compiles the variants' CUDA kernels instead (numba-cuda and a GPU needed,
docs/gpu.md), into the same cache, for the GPU model of this machine: run it on each
machine whose GPUs run the walks (each Dask worker's, docs/distributed.md). The paper
estimator's weighted walk has no CUDA kernel and is no variant here. The models run on
the CPU whatever the device: warm them with --models (or --all) without --device cuda."""

EPILOG = """\
examples:
  vcavity warmup --distribution beckmann --facet interfaced_lambertian   # the default run: 3 IL variants
  vcavity warmup --distribution ggx beckmann --microsurface smith
  vcavity warmup --models                                               # exact and exact-f1 runs' models
  vcavity warmup --all --list                                           # what --all would compile
  NUMBA_CACHE_DIR=/shared/nc vcavity warmup --all                       # a cluster image or shared cache
  vcavity warmup --all --device cuda                                    # the GPU kernels (on a GPU machine)"""


def add_parser(subparsers) -> None:
    """Add the ``warmup`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    warmup = subparsers.add_parser(NAME, help="compile kernel variants into the cache (for clusters, Dask workers)",
                                   description=DESCRIPTION, epilog=EPILOG,
                                   formatter_class=argparse.RawDescriptionHelpFormatter)
    warmup.set_defaults(handler=command)
    # "extend": a flag given twice adds its values (argparse's default keeps the last only)
    warmup.add_argument("--distribution", nargs="+", action="extend", metavar="D",
                        help="distributions (default: all)")
    warmup.add_argument("--facet", nargs="+", action="extend", metavar="F",
                        help="facet models, each with all its variants (default: all)")
    warmup.add_argument("--microsurface", nargs="+", action="extend", metavar="M",
                        help="walks: v-cavity, smith (default: v-cavity)")
    warmup.add_argument("--models", action="store_true", help="the analytic models of the estimators exact and "
                        "exact-f1 (alone: no kernel variant)")
    warmup.add_argument("--all", action="store_true", help="every variant of every walk, and the models (with "
                        "--device cuda: the variants' CUDA kernels only)")
    warmup.add_argument("--device", choices=("cpu", "cuda"), default="cpu",
                        help="compile the CPU's kernels (default) or the CUDA kernels (a GPU needed)")
    warmup.add_argument("--list", action="store_true", help="print the selected variants and compile nothing")
    warmup.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


def _selection(args):
    """The selected kernel variants and model codes (one list), or a one-line error message."""
    from vcavity.simulate.warmup import MODELS, variants

    named = [flag for flag in ("distribution", "facet", "microsurface") if getattr(args, flag)]
    if args.all and named:
        return f"--all = every variant: it takes no --{named[0]}"
    if not args.all and not named and not args.models:
        return "name what to compile: --distribution, --facet, --microsurface, --models, or --all"
    if args.models and args.device == "cuda":
        return ("--models with --device = 'cuda': the models run on the CPU whatever the device; warm them with "
                "--models alone")
    models = list(MODELS) if (args.all or args.models) and args.device == "cpu" else []
    if not args.all and not named:
        return models
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
    return selected + models


def _cache():
    """``vcavity._numba.jit`` (where compiled code goes), imported with its note on stderr
    held back: warmup says what is wrong with the cache in its own single line."""
    held = io.StringIO()
    with contextlib.redirect_stderr(held):
        from vcavity._numba import jit
    return jit, held.getvalue()


def _cache_refusal(jit) -> str | None:
    """Why warmup cannot fill a cache here (one line naming the folders tried), or None."""
    import numba

    if numba.config.DISABLE_JIT:
        return (f"NUMBA_DISABLE_JIT = {os.environ.get('NUMBA_DISABLE_JIT', '1')!r}: nothing is compiled, so "
                "nothing can be cached; unset it to fill the cache")
    if jit.NAMED_CACHE_REFUSED:  # filling another folder would leave the named one cold
        return (f"{jit.NAMED_CACHE_REFUSED}; warmup fills the cache that runs with this NUMBA_CACHE_DIR read: "
                "name a writable folder, or unset it for the per-user cache")
    if not jit.CACHE_ENABLED:
        uid = os.getuid() if hasattr(os, "getuid") else 0
        tried = [jit.user_cache_dir(), os.path.join(jit._temporary_directory(), f"vcavity-numba-cache-{uid}")]
        shown = [f"{folder!r} ({jit._unwritable_because(folder) or 'not a private folder of this user'})"
                 for folder in tried if folder]
        return (f"no writable Numba cache folder: tried {' and '.join(shown) or 'no folder (no home)'}; "
                "set NUMBA_CACHE_DIR to a writable folder")
    return None


def command(args: argparse.Namespace) -> int:
    """``vcavity warmup``: compile the selected variants and models into the cache; returns the exit status."""
    import time

    jit, note = _cache()
    selected = _selection(args)
    if isinstance(selected, str):
        return error(selected)
    if args.list:
        for item in selected:
            print(item.label)
        return EXIT_OK
    from tqdm import tqdm

    from vcavity._numba import cache_lock
    from vcavity.simulate.warmup import Variant, compile_models, compile_variant

    if args.device == "cuda":  # before the cache's refusals: without a GPU nothing is compiled anyway
        from vcavity.simulate.plan import cuda_unavailable

        reason = cuda_unavailable()
        if reason is not None:
            return error(f"--device = 'cuda': {reason}")
    refusal = _cache_refusal(jit)
    if refusal:
        return error(refusal)
    if note:
        sys.stderr.write(note)
    n_variants = sum(isinstance(item, Variant) for item in selected)
    kind = "CUDA kernel(s) of the variant(s)" if args.device == "cuda" else "variant(s)"
    what = " and ".join(part for part in (f"{n_variants} {kind}" if n_variants else "",
                                          f"{len(selected) - n_variants} model code(s)"
                                          if len(selected) > n_variants else "") if part)
    start = time.perf_counter()
    compiled = loaded = 0
    bar = tqdm(selected, unit="item", file=sys.stderr, disable=args.quiet, dynamic_ncols=True)
    try:
        # a disk that refuses the saves (full, read-only) is warmup's failure, said once below
        with cache_lock.notes_held(say=False):
            for item in bar:
                bar.set_description(f"compiling {item.label}")
                _, from_cache = (compile_variant(item, args.device) if isinstance(item, Variant)
                                 else compile_models(item))
                if cache_lock.SAVE_FAILURES:
                    break
                loaded += from_cache
                compiled += not from_cache
    except KeyboardInterrupt:
        bar.close()
        raise Interrupted(f"{compiled + loaded} of {what} ready in {jit.CACHE_LOCATION}") from None
    bar.close()
    if cache_lock.SAVE_FAILURES:
        folder, reason = cache_lock.SAVE_FAILURES[0]
        return error(f"the Numba cache folder {folder!r} cannot take compiled code ({reason}): {item.label} was "
                     f"compiled but not cached, {compiled + loaded} of {what} are; free space there, or set "
                     f"NUMBA_CACHE_DIR to a folder that can")
    if args.device == "cuda" and _simulated():  # no model is selected with cuda
        print(f"vcavity: {len(selected)} variant(s) run under numba's CUDA simulator in "
              f"{time.perf_counter() - start:.1f} s: it compiles and caches nothing", file=sys.stderr)
        return EXIT_OK
    print(f"vcavity: {what} ready in {time.perf_counter() - start:.1f} s ({compiled} compiled, "
          f"{loaded} loaded from the cache) in {jit.CACHE_LOCATION}", file=sys.stderr)
    return EXIT_OK


def _simulated() -> bool:
    """Whether the CUDA kernels ran under numba's simulator (``NUMBA_ENABLE_CUDASIM=1``)."""
    from vcavity.kernels import cuda_loop

    return cuda_loop.SIMULATED
