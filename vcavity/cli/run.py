"""``vcavity run``: simulate a run config and write its BRDF table to HDF5.

Exit status: 0 written; 2 bad input (config, flags, output path, not enough memory or
disk, model not applicable, a write that failed), one line and no output file; 130
interrupted (the checkpoint keeps the run; ``--resume`` continues it).

The command keeps the flags and the printing; the run is the run service's
(:mod:`vcavity.simulate.plan`: every check before compiling; :mod:`vcavity.simulate.service`:
compile, model, trace with checkpoints and Ctrl-C, write the table).
"""

from __future__ import annotations

import argparse
import sys

from vcavity.cli.common import EXIT_INTERRUPTED, EXIT_OK, BadInput, error, run_epilog, seconds_arg
from vcavity.cli.tracing import ProgressBar, add_run_flags, budget_overrides, name_the_flag

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
    add_run_flags(run, NAME)
    run.add_argument("--checkpoint-every", type=seconds_arg, default=60.0, metavar="S",
                     help="save the run's progress to OUT.h5.checkpoint every S seconds (default 60); Ctrl-C "
                     "saves it too and exits 130; removed once the table is written. While the run lasts it holds "
                     "OUT.h5.lock: a second run or sweep writing OUT.h5 is refused")


def command(args: argparse.Namespace) -> int:
    """``vcavity run [CONFIG.toml] [-o OUT.h5] ...``: simulate, write the table, summarise it.

    Returns the exit status (:mod:`vcavity.cli.common`).

    Raises
    ------
    Interrupted
        On Ctrl-C, saying whether the table was written (``main`` reports it).
    """
    from vcavity.cli.common import Interrupted
    from vcavity.simulate import interrupts

    written = None
    try:
        try:
            status, written = simulate(args)
        except BadInput as exc:
            status = error(exc)
        if written is not None:
            report(*written)
        if status != EXIT_INTERRUPTED:
            interrupts.raise_if_pending()  # a Ctrl-C something swallowed: reported below
        return status
    except BaseException as exc:
        # after a swallowed SIGINT, what fails next is a consequence of the interrupt
        if not (interrupts.is_interrupt(exc) or interrupts.pending()):
            raise
        outcome = f"the table was written: {written[0].output.path}" if written is not None else "no table written"
        raise Interrupted(outcome) from exc


def _say(message: str) -> None:
    print(f"vcavity: {message}", file=sys.stderr)


def simulate(args: argparse.Namespace):
    """Plan, prepare and execute the run (:mod:`vcavity.simulate.service`).

    Returns
    -------
    tuple of (int, (RunPlan, TableValue) or None)
        The exit status and, when the table was written, what :func:`report` prints.

    Raises
    ------
    BadInput
        The first check that failed, as its one-line error.
    """
    import contextlib

    from vcavity.simulate import service
    from vcavity.simulate.plan import PlanError, RunRequest, plan_run

    request = RunRequest(read_config(args), config_file=args.config, output=args.output, overwrite=args.overwrite,
                         resume=args.resume, threads=args.threads, chunk_blocks=args.chunk_blocks, dask=args.dask,
                         checkpoint_every_s=args.checkpoint_every)
    executor = progress = None
    locks = contextlib.ExitStack()  # the output's writer lock (io/lock.py), held to the end of the run
    try:
        plan = plan_run(request, locks)
        # connected first: a scheduler that does not answer, or workers that cannot run the
        # device (CUDA), are refused in one line before anything else is said or compiled
        executor = service.connect(args.dask, plan.config) if args.dask else None
        if plan.lock_note:
            _say(plan.lock_note)
        if plan.removed:
            _say(f"removed {len(plan.removed)} stale temporary file(s) of interrupted writes: "
                 f"{', '.join(p.name for p in plan.removed)}")
        cfg = plan.config
        work = f"{plan.total_paths:,} paths" if plan.traces else f"no path ({cfg.estimator} estimator)"
        where = f"{plan.threads} thread(s)"  # --threads: the CPU's
        if cfg.device == "cuda":
            where = "on the Dask workers' GPUs" if args.dask else "on the CUDA device"
        _say(f"{cfg.source}: {len(cfg.incidence)} incident direction(s), {work}, {where}")
        if plan.resume_note:
            _say(plan.resume_note)
        simulation = service.prepare(plan, _say)
        done = int(plan.state.paths_done(cfg).sum()) if plan.state is not None else 0
        progress = None if args.quiet or not plan.traces else ProgressBar(plan.total_paths, done, "tracing")
        table = service.execute(plan, simulation, _say, progress, executor)
    except PlanError as exc:  # a refusal of an overridden field names the flag (--device)
        raise BadInput(name_the_flag(str(exc), budget_overrides(args))) from None
    finally:
        if progress is not None:
            progress.close()  # before the error's line (a failed checkpoint): no bar fragment on it
        try:
            if executor is not None:
                executor.close()
        finally:
            locks.close()
    return (EXIT_INTERRUPTED, None) if table is None else (EXIT_OK, (plan, table))


def read_config(args: argparse.Namespace):
    """The run config: CONFIG (or the built-in run) with the flags that override it.

    Returns
    -------
    vcavity.config.RunConfig
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
                     ("target_error", args.target_error), ("max_paths", args.max_paths),
                     ("device", args.device)) if value is not None}
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


def report(plan, table) -> None:
    """Print where the table went, the run's speed and the table's summary (stdout).

    Parameters
    ----------
    plan : vcavity.simulate.plan.RunPlan
        The finished run.
    table : vcavity.io.schema.TableValue
        What it wrote.
    """
    import numpy as np

    from vcavity.io.summary import format_summary
    from vcavity.io.table import open_table

    cfg = plan.config
    traced = int(table["paths"].sum())
    compute_time_s = table.attrs["compute_time_s"]
    rate = traced / compute_time_s if compute_time_s > 0 else float("inf")
    if cfg.target_error is not None and np.all(table["target_reached"] >= 0):  # a model's: its tolerance
        for d, paths, rel_error, reached in zip(cfg.incidence, table["paths"], table["relative_error"],
                                                table["target_reached"]):
            cap = "the model's mesh hit its size cap" if table.attrs["deterministic"] else "path cap hit"
            state = "reached" if reached == 1 else f"NOT reached: {cap}"
            after = "the model's estimate" if table.attrs["deterministic"] else f"after {int(paths):,} paths"
            print(f"theta_i = {d.theta_i_deg:g} deg: target error {cfg.target_error:g} {state} "
                  f"(error {rel_error:.3g}, {after})")
    print(f"wrote {plan.output.path}")
    # the models' compile (or cache load) is said apart from their time; exactly 0 without models
    model_compile_s = table.attrs["model_compile_time_s"]
    models = f", model compile/load {model_compile_s:.2f} s" if model_compile_s > 0.0 else ""
    if table.attrs["deterministic"]:
        print(f"model time {table.attrs['model_time_s']:.2f} s (deterministic table: no path traced){models}")
    else:
        print(f"run time {compute_time_s:.2f} s ({rate / 1e6:.2f} M paths/s), "
              f"kernel compile/load {table.attrs['compile_time_s']:.2f} s{models}")
    print(format_summary(open_table(plan.output.path)))
