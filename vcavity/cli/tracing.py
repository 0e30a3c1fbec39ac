"""What ``vcavity run`` and ``vcavity sweep`` share: their flags, declared once, and the progress bar.

Both commands trace paths into a file: :func:`add_run_flags` declares their common flags
(the output, ``--overwrite``, ``--resume``, the flags that override the config's budget,
estimator and device, ``--threads``, ``--chunk-blocks``, ``--dask``, ``-q``) with the help each command gives
them; :class:`ProgressBar` is how they show the paths traced (a tqdm bar on stderr, the
run's relative error beside it when it has a target).
"""

from __future__ import annotations

import argparse
import math
import sys

from vcavity.cli.common import PATHS_MAX, count_arg, fraction_arg, seed_arg

#: Per command, the help of the flags whose meaning differs between ``run`` and ``sweep``.
HELP = {
    "run": {
        "output": "output table (default: [output].path, else CONFIG with .h5, else ./vcavity-default.h5)",
        "overwrite": "replace an existing table (atomically, only when the run completes); without it an "
                     "existing output is refused before anything runs",
        "resume": "continue the interrupted run of OUT.h5 from its checkpoint OUT.h5.checkpoint (same config "
                  "and seed; the table equals an uninterrupted run's, bit for bit); a file at OUT.h5 is replaced "
                  "only if it is this run's own table, else only with --overwrite",
        "chunk_blocks": "RNG blocks of 4096 paths per kernel call (default: sized to about 0.5 s of work per "
                        "call, 1 s on a GPU or a Dask worker, so Ctrl-C is answered within that; does not "
                        "change results)",
        "dask": "run the work units on a Dask cluster: a scheduler address (tcp://host:8786) or local:N for N "
                "local worker processes (needs vcavity[distributed]; docs/distributed.md); the table is the "
                "local run's, bit for bit",
    },
    "sweep": {
        "output": "output file (default: [output].path, else SWEEP with .h5)",
        "overwrite": "replace an existing output",
        "resume": "continue the sweep in the existing output: run only the points not done (refused if it "
                  "holds another sweep)",
        "chunk_blocks": "RNG blocks of 4096 paths per kernel call (default: sized to about 0.5 s of work per "
                          "call; does not change results)",
        "dask": "run each point's work units on a Dask cluster: a scheduler address (tcp://host:8786) or "
                "local:N (a LocalCluster of N workers); same file as a local run",
    },
}


def add_run_flags(parser: argparse.ArgumentParser, command: str) -> None:
    """Add the flags ``run`` and ``sweep`` share, with ``command``'s help (:data:`HELP`).

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The sub-parser of ``command`` (``"run"`` or ``"sweep"``).
    command : str
    """
    texts = HELP[command]
    parser.add_argument("-o", "--output", metavar="OUT.h5", help=texts["output"])
    parser.add_argument("--overwrite", action="store_true", help=texts["overwrite"])
    parser.add_argument("--resume", action="store_true", help=texts["resume"])
    add_budget_flags(parser)
    parser.add_argument("--threads", type=count_arg(1, 4096), metavar="T", help="worker threads (default: all cores)")
    parser.add_argument("--chunk-blocks", type=count_arg(1, 2**40), metavar="B", help=texts["chunk_blocks"])
    parser.add_argument("--dask", metavar="ADDRESS", help=texts["dask"])
    parser.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


class ProgressBar:
    """A tqdm bar of paths on stderr (:class:`vcavity.simulate.service.Progress`); with a
    target error, the direction's current error beside it.

    Parameters
    ----------
    total, initial : int
        Paths planned and already done (a resumed run, a sweep's finished points).
    label : str
        The bar's description (``"tracing"``, ``"sweeping"``).
    unit : str, default "path"
        What it counts (``"point"``: a sweep whose estimator traces no path).
    """

    def __init__(self, total: int, initial: int, label: str, unit: str = "path"):
        from tqdm import tqdm

        self.bar = tqdm(total=total, initial=initial, unit=unit, unit_scale=unit == "path", dynamic_ncols=True,
                        desc=label, file=sys.stderr)

    def advance(self, paths: int, error: float) -> None:
        """``paths`` more traced; ``error`` shown unless NaN (no target)."""
        if not math.isnan(error):
            self.bar.set_postfix_str(f"error {error:.2e}", refresh=False)
        self.bar.update(paths)

    def close(self) -> None:
        """The bar ends its line (before anything else is printed)."""
        self.bar.close()


#: The flags ``run`` and ``sweep`` share to override a config's budget (and its estimator
#: and device): argparse dest -> (flag, the config field it overrides).
BUDGET_FLAGS = {"paths": ("--paths", "incidence.paths"), "seed": ("--seed", "simulation.seed"),
                "estimator": ("--estimator", "simulation.estimator"),
                "target_error": ("--target-error", "simulation.target_error"),
                "max_paths": ("--max-paths", "simulation.max_paths"),
                "device": ("--device", "simulation.device")}


def add_budget_flags(parser: argparse.ArgumentParser) -> None:
    """Add ``--paths``, ``--seed``, ``--estimator``, ``--target-error``, ``--max-paths`` and ``--device``.

    Parameters
    ----------
    parser : argparse.ArgumentParser
        The sub-parser of ``run`` or ``sweep``; each flag overrides the config field
        :data:`BUDGET_FLAGS` names (in a sweep: at every point).
    """
    parser.add_argument("--paths", type=count_arg(1, PATHS_MAX), metavar="N",
                        help="paths per incident direction, e.g. 1e6 (overrides incidence.paths)")
    parser.add_argument("--seed", type=seed_arg, metavar="S",
                        help="random seed, 0 .. 2**64-1 (overrides simulation.seed)")
    from vcavity.estimators import registry as estimators

    parser.add_argument("--estimator", choices=estimators.names(),
                        help="; ".join(f"{module.NAME}: {module.DESCRIPTION}" for module in estimators.MODULES)
                        + " (overrides simulation.estimator)")
    parser.add_argument("--target-error", type=fraction_arg, metavar="E",
                        help="run each direction until the energy-weighted mean relative standard error of "
                        "f_inf is at most E (e.g. 0.002), checked every 64 blocks of 4096 paths; with "
                        "--estimator exact: the model's tolerance (relative L1 error of all orders, default "
                        "0.001) (overrides simulation.target_error)")
    parser.add_argument("--max-paths", type=count_arg(1, PATHS_MAX), metavar="N",
                        help="with --target-error: the most paths per direction (default: the config's "
                        "paths) (overrides simulation.max_paths)")
    # the choices spelled here, not read from vcavity.config: --help loads no registry
    parser.add_argument("--device", choices=("cpu", "cuda"),
                        help="where the walk runs: cpu (default), or cuda: an NVIDIA GPU (needs vcavity[cuda]; "
                        "the unweighted walks only; with --dask, one worker per GPU; tables agree with the CPU's in distribution, "
                        "not bit for bit: docs/gpu.md) (overrides simulation.device)")


def budget_overrides(args: argparse.Namespace) -> dict:
    """The budget flags given, as ``{config field: value}`` (``{"incidence.paths": 20000}``).

    Parameters
    ----------
    args : argparse.Namespace
        Parsed by a parser with :func:`add_budget_flags`.
    """
    return {field: getattr(args, dest) for dest, (_, field) in BUDGET_FLAGS.items()
            if getattr(args, dest, None) is not None}


def name_the_flag(message: str, overrides: dict) -> str:
    """A config error caused by an overridden field, naming the flag the value came from.

    Parameters
    ----------
    message : str
        ``"simulation.estimator = 'exact': ..."``: a config error starting with its field.
    overrides : dict
        :func:`budget_overrides` of the command.

    Returns
    -------
    str
        ``"--estimator = 'exact': ..."`` when that field was overridden, else ``message``.
    """
    field = message.split(" ", 1)[0]
    for flag, name in BUDGET_FLAGS.values():
        if field == name and name in overrides:
            return flag + message[len(field):]
    return message


__all__ = ["BUDGET_FLAGS", "HELP", "ProgressBar", "add_budget_flags", "add_run_flags", "budget_overrides",
           "name_the_flag"]
