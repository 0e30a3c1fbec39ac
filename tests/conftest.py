"""Session-wide test setup.

A test run started in the background by a script without job control (``pytest &``)
begins with SIGINT ignored, and every process it starts inherits that. The Ctrl-C tests
(tests/cli/test_faults.py, tests/cli/test_resume.py) need what an interactive run has:
Python's default handler here, and so the default disposition in the processes they
start (a Python-level handler is reset to the default by exec; an ignored signal is not).
"""

import json
import os
import signal
import subprocess
import sys
import tempfile
import time

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)

# OpenMP threads that sleep when idle, in the test processes and every process they start
# (set before any parallel loop runs here). The suite runs two xdist workers on two cores,
# each with as many threads as cores, plus the CLI tests' child processes: by default GNU
# OpenMP's threads spin after each parallel region (the analytic models' Numba parallel
# loops; the kernels' slots are Python threads, which sleep), and beside another busy
# process that spinning takes the cores from the work. Measured when the kernels were
# parallel loops too (docs/performance.md, "The default suite on two cores"):
# test_resume_cli's SIGINT test, which runs the kernel in chunks of 8 blocks, 7 s alone,
# 38 s in the suite, 72 s beside one busy core. Results do not depend on it.
os.environ.setdefault("OMP_WAIT_POLICY", "passive")


# --- Compiling the suite's kernel variants first, in parallel (issue 21 item 5) ----------
#
# Most of a cold run of the default suite is Numba compiling the ~20 kernel variants its
# tests use, one at a time, each in whichever test needs it first (docs/performance.md,
# "Where the cold default suite's time goes"). When the whole suite runs on several xdist
# workers (pyproject's addopts: -n 2), the controller first compiles them into the cache
# in as many processes as there are workers (what `vcavity warmup` does for a cluster), so
# the workers load them instead of each compiling the same ones. Only for a whole-suite
# run (no paths or node ids given): a run of a few files compiles just what it needs.
# A variant missing from the list is compiled on first use as before; a failed warm-up
# is reported and changes nothing else. The list: scripts/pytest_compile_log.py on a cold
# cache, each with its cold compile in seconds there (a heavily loaded machine). The
# processes share the list, largest first: each claims the next variant not yet claimed
# (a file created with O_EXCL), so they stay balanced when these costs are off.
SUITE_VARIANTS = {
    ("v-cavity", "beckmann", "interfaced_lambertian", "interfaced lambertian"): 173,
    ("v-cavity", "phong", "interfaced_lambertian", "interfaced lambertian"): 116,
    ("v-cavity", "gaussian", "interfaced_lambertian", "lambertian"): 110,
    ("v-cavity", "gaussian", "interfaced_lambertian", "interfaced lambertian"): 109,
    ("v-cavity", "ggx", "mirror", "mirror"): 100,
    ("v-cavity", "ggx", "interfaced_lambertian", "lambertian"): 95,
    ("smith", "ggx", "mirror", "mirror"): 92,
    ("v-cavity", "ggx", "interfaced_lambertian", "interfaced lambertian"): 84,
    ("v-cavity", "beckmann", "interfaced_lambertian", "specular dielectric"): 82,
    ("v-cavity", "ggx", "interfaced_lambertian", "specular dielectric"): 76,
    ("v-cavity", "beckmann", "interfaced_lambertian", "lambertian"): 70,
    ("smith", "student_t", "mirror", "mirror"): 68,
    ("v-cavity", "beckmann", "conductor", "conductor"): 64,
    ("v-cavity", "student_t", "interfaced_lambertian", "interfaced lambertian"): 57,
    ("smith", "beckmann", "mirror", "mirror"): 51,
    ("smith", "beckmann", "interfaced_lambertian", "interfaced lambertian"): 49,
    ("v-cavity", "phong", "interfaced_lambertian", "specular dielectric"): 49,
    ("smith", "phong", "mirror", "mirror"): 38,
    ("v-cavity", "beckmann", "mirror", "mirror"): 27,
    ("smith", "ggx", "interfaced_lambertian", "lambertian"): 24,
}

# argv: the variants (JSON), largest first; the folder of claims; the parent's perf_counter()
# at the start (CLOCK_MONOTONIC, shared by the processes), for the seconds each one reports
_WARM = ("import json, os, sys, time\n"
         "from vcavity.simulate.warmup import Variant, compile_variant\n"
         "done = 0\n"
         "for k, v in enumerate(json.loads(sys.argv[1])):\n"
         "    try:\n"
         "        os.close(os.open(os.path.join(sys.argv[2], str(k)), os.O_CREAT | os.O_EXCL | os.O_WRONLY))\n"
         "    except FileExistsError:\n"
         "        continue\n"
         "    compile_variant(Variant(*v))\n"
         "    done += 1\n"
         "print(done, round(time.perf_counter() - float(sys.argv[3])))\n")


def pytest_configure(config):
    workers = getattr(config.option, "numprocesses", None)
    if (hasattr(config, "workerinput") or not isinstance(workers, int) or workers < 2
            or config.args_source is not config.ArgsSource.TESTPATHS or config.option.collectonly):
        return
    t0 = time.perf_counter()
    largest_first = [list(v) for v, _ in sorted(SUITE_VARIANTS.items(), key=lambda item: -item[1])]
    with tempfile.TemporaryDirectory(prefix="vcavity-warm-") as claims:
        children = [subprocess.Popen([sys.executable, "-c", _WARM, json.dumps(largest_first), claims,
                                      repr(time.perf_counter())],
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
                    for _ in range(min(workers, len(largest_first)))]
        try:
            outputs = [child.communicate() for child in children]
        except BaseException:
            for child in children:
                child.kill()
            raise
    # each process: "<variants it compiled or loaded> <seconds until it finished>"
    shares = [out.split("\n")[-2].split() for (out, _), child in zip(outputs, children)
              if child.returncode == 0 and out.endswith("\n")]
    note = (f"tests: {len(SUITE_VARIANTS)} kernel variants compiled into (or loaded from) the Numba cache "
            f"in {len(children)} processes, {time.perf_counter() - t0:.0f} s "
            f"({', '.join(f'{n} in {s} s' for n, s in shares)})")
    failed = [err for (_, err), child in zip(outputs, children) if child.returncode != 0]
    if failed:
        note += f"; a warm-up process failed (its variants compile on first use): {failed[0].strip()[-300:]}"
    print(note, file=sys.stderr)
