"""pytest plugin: which test compiles what, from Numba's ``numba:compile`` events.

Numba broadcasts ``numba:compile`` for every real compile (a cache miss; a cache load
raises none). This plugin writes one JSON line per compile of this process (test node id,
function, seconds of wall, whether it is a top-level compile or one nested in another's
type inference) and, at the end, the top-level compile seconds per test file. Compiles in
child processes (the CLI tests' ``python -m vcavity ...``) are not seen: their cost shows
in ``--durations`` only.

    NUMBA_CACHE_DIR=$(mktemp -d) PYTHONPATH=scripts python -m pytest -p pytest_compile_log \\
        --durations=40 [COMPILE_LOG=compiles.jsonl]
"""

from __future__ import annotations

import collections
import json
import os
import time

import pytest
from numba.core import event

_state = {"test": "<collection>", "stack": [], "rows": []}
_log = open(os.environ.get("COMPILE_LOG", "compiles.jsonl"), "a")


class _Compiles(event.Listener):
    def on_start(self, ev):
        _state["stack"].append(time.perf_counter())

    def on_end(self, ev):
        seconds = time.perf_counter() - _state["stack"].pop()
        function = getattr(ev.data["dispatcher"], "py_func", None)
        name = f"{function.__module__}.{function.__qualname__}" if function else str(ev.data["dispatcher"])
        row = {"test": _state["test"], "function": name, "s": round(seconds, 3), "top": not _state["stack"]}
        _state["rows"].append(row)
        _log.write(json.dumps(row) + "\n")
        _log.flush()


event.register("numba:compile", _Compiles())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    _state["test"] = item.nodeid
    yield


def pytest_terminal_summary(terminalreporter):
    per_file = collections.Counter()
    for row in _state["rows"]:
        if row["top"]:
            per_file[row["test"].split("::")[0]] += row["s"]
    terminalreporter.write_sep("=", "in-process Numba compiles, top level, wall seconds per test file")
    for name, seconds in per_file.most_common(25):
        terminalreporter.write_line(f"{seconds:8.1f}  {name}")
