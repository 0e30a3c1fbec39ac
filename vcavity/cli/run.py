"""``vcavity run``: simulate a run config and write its BRDF table to HDF5.

Exit status: 0 written; 2 bad input (config, flags, output path, not enough memory or
disk, model not applicable, a write that failed), one line and no output file; 130
interrupted (the checkpoint keeps the run; ``--resume`` continues it).

The command is a pipeline of steps, each of which either returns what the next needs or
raises :class:`~vcavity.cli.common.BadInput`: :func:`read_config` (config and flag
overrides), :func:`preflight` (every check that can fail, before compiling),
:func:`prepare` (the simulation, a resumed state, the compiled kernel and models),
:func:`trace_and_write` (progress, checkpoints, Ctrl-C) and :func:`report`.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, NamedTuple

from vcavity.cli.common import (
    EXIT_INTERRUPTED,
    EXIT_OK,
    BadInput,
    Interrupted,
    add_budget_flags,
    budget_overrides,
    count_arg,
    error,
    first_line,
    name_the_flag,
    run_epilog,
    seconds_arg,
)

if TYPE_CHECKING:
    from pathlib import Path

    from vcavity.config import RunConfig
    from vcavity.io.schema import TableValue

NAME = "run"


def add_parser(subparsers) -> None:
    """Add the ``run`` sub-parser (handler :func:`command`; the interface: :mod:`vcavity.cli`)."""
    run = subparsers.add_parser(
        NAME,
        help="simulate a run config and write an HDF5 table",
        description="Simulate light paths in V-cavities for each incident direction of a run "
        "config and write the BRDF table per bounce order to HDF5.",
        epilog_factory=run_epilog,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run.set_defaults(handler=command)
    run.add_argument("config", nargs="?", metavar="CONFIG.toml", help="run config (default: built-in figure 7 run)")
    run.add_argument("-o", "--output", metavar="OUT.h5",
                     help="output table (default: [output].path, else CONFIG with .h5, else ./vcavity-default.h5)")
    run.add_argument("--overwrite", action="store_true",
                     help="replace an existing table (atomically, only when the run completes); without it an "
                     "existing output is refused before anything runs")
    add_budget_flags(run)
    run.add_argument("--threads", type=count_arg(1, 4096), metavar="T", help="worker threads (default: all cores)")
    run.add_argument("--chunk-blocks", type=count_arg(1, 2**40), metavar="B",
                     help="RNG blocks of 4096 paths per kernel call (default 512; does not change results)")
    run.add_argument("--resume", action="store_true",
                     help="continue the interrupted run of OUT.h5 from its checkpoint OUT.h5.checkpoint (same "
                     "config and seed; the table equals an uninterrupted run's, bit for bit); a file at OUT.h5 is "
                     "replaced only if it is this run's own table, else only with --overwrite")
    run.add_argument("--checkpoint-every", type=seconds_arg, default=60.0, metavar="S",
                     help="save the run's progress to OUT.h5.checkpoint every S seconds (default 60); Ctrl-C "
                     "saves it too and exits 130; removed once the table is written")
    run.add_argument("--dask", metavar="ADDRESS",
                     help="run the work units on a Dask cluster: a scheduler address (tcp://host:8786) or "
                     "local:N for N local worker processes (needs vcavity[distributed]; docs/distributed.md); "
                     "the table is the local run's, bit for bit")
    run.add_argument("-q", "--quiet", action="store_true", help="no progress bar")


class Written(NamedTuple):
    """A finished run: the table's path, the table it holds and the config it ran."""

    path: Path
    table: TableValue
    config: RunConfig


def command(args: argparse.Namespace) -> int:
    """``vcavity run [CONFIG.toml] [-o OUT.h5] ...``: simulate, write the table, summarise it.

    Returns the exit status (:mod:`vcavity.cli.common`).

    Raises
    ------
    Interrupted
        On Ctrl-C, saying whether the table was written (``main`` reports it).
    """
    from vcavity.simulate import interrupts

    written = None
    try:
        try:
            status, written = simulate(args)
        except BadInput as exc:
            status = error(exc)
        if written is not None:
            report(written)
        if status != EXIT_INTERRUPTED:
            interrupts.raise_if_pending()  # a Ctrl-C something swallowed: reported below
        return status
    except BaseException as exc:
        # after a swallowed SIGINT, what fails next is a consequence of the interrupt
        if not (interrupts.is_interrupt(exc) or interrupts.pending()):
            raise
        outcome = f"the table was written: {written.path}" if written is not None else "no table written"
        raise Interrupted(outcome) from exc


def simulate(args: argparse.Namespace) -> tuple[int, Written | None]:
    """Every step of the run up to the written table.

    Returns
    -------
    tuple of (int, Written or None)
        The exit status and, when the table was written, what :func:`report` prints.

    Raises
    ------
    BadInput
        The first check that failed, as its one-line error.
    """
    import dataclasses

    cfg = read_config(args)
    output = preflight(args, cfg)
    cfg = dataclasses.replace(cfg, output=output.path.resolve())  # the table records where it was written
    sim, state = prepare(args, cfg, output.path)
    status, table = trace_and_write(args, sim, cfg, output, state)
    return status, Written(output.path, table, cfg) if status == EXIT_OK else None


def read_config(args: argparse.Namespace) -> RunConfig:
    """The run config: CONFIG (or the built-in run) with the flags that override it.

    Returns
    -------
    RunConfig
        The validated config.

    Raises
    ------
    BadInput
        A config error; one caused by a flag names the flag, not the config field.
    """
    import dataclasses

    import vcavity.config as config_mod

    try:
        cfg = config_mod.load(args.config) if args.config else config_mod.default_config()
        if args.paths is not None:
            cfg = dataclasses.replace(
                cfg, incidence=tuple(dataclasses.replace(d, paths=args.paths) for d in cfg.incidence)
            )
        if args.seed is not None:
            cfg = dataclasses.replace(cfg, seed=args.seed)
        overrides = {name: value for name, value in (("estimator", args.estimator),
                     ("target_error", args.target_error), ("max_paths", args.max_paths)) if value is not None}
        if args.max_paths is not None and args.target_error is None and cfg.target_error is None:
            raise BadInput(f"--max-paths = {args.max_paths}: applies only with --target-error "
                           "(otherwise --paths is the number of paths)")
        if overrides:
            try:
                cfg = cfg.replace(**overrides)
            except config_mod.ConfigError as exc:  # name the flag the value came from
                raise config_mod.ConfigError(name_the_flag(str(exc), budget_overrides(args))) from None
    except config_mod.ConfigError as exc:
        raise BadInput(str(exc)) from None
    return cfg


def preflight(args: argparse.Namespace, cfg):
    """Every check of a run that can fail, before compiling or tracing (vcavity/io/preflight.py).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``run`` flags.
    cfg : RunConfig
        The run config.

    Returns
    -------
    vcavity.io.preflight.Output
        Where the table goes, and the flag or field that named it.

    Raises
    ------
    BadInput
        The first failed check (output path, threads, memory, disk space).
    """
    import numba

    from vcavity.estimators import registry as estimators
    from vcavity.io import preflight as checks
    from vcavity.io.checkpoint import checkpoint_path, foreign_output
    from vcavity.sensor.grid import EqualAreaSensor

    try:
        out = checks.resolve_output(args.output, cfg.output, args.config)
        resuming = bool(getattr(args, "resume", False)) and checkpoint_path(out.path).exists()
        checks.check_output(out, args.config, args.overwrite or resuming)
        # without --overwrite, resume replaces only its own run's table (say, written just
        # before a kill that left the checkpoint): never what was put there meanwhile
        what = (foreign_output(out.path, cfg.to_dict()) if resuming and not args.overwrite
                and out.path.is_file() else None)
        if what is not None:
            raise out.fail(f"exists and is {what}; --resume replaces only the table of this run: "
                           "pass --overwrite to replace it")
        if args.threads is not None and args.threads > numba.config.NUMBA_NUM_THREADS:
            raise checks.PreflightError(f"--threads = {args.threads}: must be between 1 and "
                                        f"{numba.config.NUMBA_NUM_THREADS} (cores here)")
        if getattr(args, "dask", None) is not None:  # the address's form, before anything compiles
            from vcavity.simulate.dask import parse_address

            try:
                parse_address(args.dask)
            except ValueError as exc:
                raise checks.PreflightError(f"--dask = {args.dask!r}: {exc}") from None
        n_cells = EqualAreaSensor(cfg.sensor_resolution).n_cells
        checks.check_memory(cfg, args.threads or numba.config.NUMBA_NUM_THREADS, n_cells,
                            len(estimators.get(cfg.estimator).TALLIES))
        removed = checks.probe_output(out)  # creates and removes a file: /proc, /sys, read-only
        checks.check_disk_space(out, checks.table_bytes(len(cfg.incidence), len(cfg.orders), n_cells))
    except checks.PreflightError as exc:
        raise BadInput(str(exc)) from None
    if removed:
        print(f"vcavity: removed {len(removed)} stale temporary file(s) of interrupted writes: "
              f"{', '.join(p.name for p in removed)}", file=sys.stderr)
    return out


def prepare(args: argparse.Namespace, cfg, out):
    """The simulation, ready to trace: a resumed state, the compiled kernel, the f1 models.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``run`` flags.
    cfg : RunConfig
        The run config.
    out : pathlib.Path
        The table's path (its checkpoint is ``out`` + ``.checkpoint``).

    Returns
    -------
    tuple of (Simulation, state or None)
        The simulation and the checkpointed state to continue from (None: from the start).

    Raises
    ------
    BadInput
        An unusable checkpoint, or exact-f1 on a material its model does not cover.
    """
    from vcavity.analytic.single_bounce import ModelNotApplicable
    from vcavity.io import checkpoint
    from vcavity.simulate import driver
    from vcavity.simulate.interrupts import raise_if_pending
    from vcavity.simulate.pipeline import Simulation
    from vcavity.simulate.warmup import CompileNotice, Variant

    sim = Simulation(cfg, threads=args.threads, chunk_blocks=args.chunk_blocks)
    work = f"no path ({cfg.estimator} estimator)" if sim.walk is None else f"{sim.total_paths:,} paths"
    print(f"vcavity: {cfg.source}: {len(cfg.incidence)} incident direction(s), {work}, {sim.threads} thread(s)",
          file=sys.stderr)
    try:
        state = driver.load_state(sim, out, args.resume or False)
    except checkpoint.CheckpointError as exc:
        if not (args.overwrite and not args.resume and "unfinished run exists" in str(exc)):
            raise BadInput(str(exc)) from None
        state = None  # --overwrite: start afresh; the old checkpoint is replaced by the first save
    with CompileNotice(Variant.of_material(cfg.material).label):  # a line only when it takes a while
        compile_s = sim.compile()
    raise_if_pending()  # a Ctrl-C that the compiler's callbacks swallowed
    if sim.kernel is not None:
        print(f"vcavity: kernel ready in {compile_s:.2f} s (compile or cache load, not counted as run time)",
              file=sys.stderr)
    try:
        model_s = sim.prepare_models()
    except ModelNotApplicable as exc:
        raise BadInput(f"--estimator = {cfg.estimator}: {first_line(exc)}") from None
    if sim.models is not None:
        print(f"vcavity: {sim.models.ready_line(model_s)}", file=sys.stderr)
    return sim, state


def trace_and_write(args: argparse.Namespace, sim, cfg, output, state):
    """Trace the paths (progress bar, checkpoints, deferred Ctrl-C) and write the table.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed ``run`` flags.
    sim : Simulation
        The prepared simulation.
    cfg : RunConfig
        The run config.
    output : vcavity.io.preflight.Output
        Where the table goes.
    state : optional
        The checkpointed state to continue from.

    Returns
    -------
    tuple of (int, TableValue or None)
        ``EXIT_OK`` and the table written, or ``EXIT_INTERRUPTED`` (the driver said what it kept).

    Raises
    ------
    BadInput
        An unusable ``--dask`` address, or a table or checkpoint write that failed.
    """
    from vcavity.io.checkpoint import CheckpointWriteError
    from vcavity.io.writer import write_table
    from vcavity.simulate import driver

    if args.dask and sim.walk is None:
        raise BadInput(f"--dask = {args.dask!r}: the {cfg.estimator} estimator traces no path, there is nothing "
                       "to distribute")
    executor = _executor(args.dask) if args.dask else None
    out = output.path

    def write(table, cancelled):
        write_table(out, table, cancelled=cancelled)

    try:
        result = driver.run_to_table(sim, out, write, state=state, checkpoint_every_s=args.checkpoint_every,
                                     quiet=args.quiet, executor=executor)
        return (EXIT_INTERRUPTED, None) if result is None else (EXIT_OK, result)
    except CheckpointWriteError as exc:
        kept = ("the previous checkpoint is unchanged" if exc.previous else "no checkpoint was kept")
        raise BadInput(f"{output.field} = {output.shown!r}: {exc}; no table written, an existing file is "
                       f"unchanged; {kept}") from None
    except OSError as exc:
        reason = exc.strerror or first_line(exc)
        raise BadInput(f"{output.field} = {output.shown!r}: writing the table failed ({reason}); "
                       "nothing was written and an existing file is unchanged; the checkpoint keeps the run") from None
    finally:
        if executor is not None:
            executor.close()


def _executor(address: str):
    """The Dask executor of ``--dask ADDRESS``; raises BadInput when it cannot connect."""
    from vcavity.simulate.dask import DaskExecutor, parse_address

    try:
        parse_address(address)
        return DaskExecutor(address)
    except (ValueError, ImportError, OSError) as exc:
        raise BadInput(f"--dask = {address!r}: {first_line(exc)}") from None


def report(written: Written) -> None:
    """Print where the table went, the run's speed and the table's summary (stdout).

    Parameters
    ----------
    written : Written
        The finished run.
    """
    import numpy as np

    from vcavity.io.summary import format_summary
    from vcavity.io.table import open_table

    cfg, table = written.config, written.table
    traced = int(table["paths"].sum())
    compute_time_s = table.attrs["compute_time_s"]
    rate = traced / compute_time_s if compute_time_s > 0 else float("inf")
    if cfg.target_error is not None and np.all(table["target_reached"] >= 0):  # a model's: its tolerance
        for d, paths, rel_error, reached in zip(cfg.incidence, table["paths"], table["relative_error"],
                                                table["target_reached"]):
            state = "reached" if reached == 1 else "NOT reached: path cap hit"
            print(f"theta_i = {d.theta_i_deg:g} deg: target error {cfg.target_error:g} {state} "
                  f"(error {rel_error:.3g} after {int(paths):,} paths)")
    print(f"wrote {written.path}")
    if table.attrs["deterministic"]:
        print(f"model time {table.attrs['model_time_s']:.2f} s (deterministic table: no path traced)")
    else:
        print(f"run time {compute_time_s:.2f} s ({rate / 1e6:.2f} M paths/s), "
              f"kernel compile/load {table.attrs['compile_time_s']:.2f} s")
    print(format_summary(open_table(written.path)))
