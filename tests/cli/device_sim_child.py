"""Child process of tests/cli/test_device.py: ``vcavity run --device cuda`` under numba's simulator.

Run with ``NUMBA_ENABLE_CUDASIM=1`` (numba reads it when numba.cuda is imported, so it
must be set before this process starts): ``python device_sim_child.py CONFIG FOLDER``.
It runs the CLI in this process on CONFIG, writing into FOLDER:

- ``cpu.h5``: ``--device cpu``;
- ``cuda.h5``: ``--device cuda`` (one kernel call per direction: the default chunk);
- ``cuda_chunked.h5``: ``--device cuda --chunk-blocks 1`` (one call per block);
- ``cuda_resumed.h5``: ``--device cuda --chunk-blocks 1``, interrupted after its first
  call (a SIGINT to itself, as a Ctrl-C), then ``--resume``;

and prints one JSON line: each command's exit status and what ``vcavity info`` says of
``cuda.h5``. The test compares the tables.
"""

import contextlib
import io
import json
import os
import signal
import sys


def main():
    assert os.environ.get("NUMBA_ENABLE_CUDASIM") == "1", "run under the CUDA simulator (NUMBA_ENABLE_CUDASIM=1)"
    # the simulator runs a CUDA block's threads as Python threads that its own thread polls:
    # a short switch interval keeps a block of idle threads from costing seconds
    # (tests/kernels/cuda_sim_child.py)
    sys.setswitchinterval(1e-4)
    from vcavity.cli import main as vcavity
    from vcavity.simulate import interrupts, pipeline

    config, folder = sys.argv[1], sys.argv[2]

    def run(name, *flags):
        return vcavity(["run", config, "-o", os.path.join(folder, name), "-q", *flags])

    statuses = {"cpu": run("cpu.h5", "--device", "cpu"), "cuda": run("cuda.h5", "--device", "cuda"),
                "chunked": run("cuda_chunked.h5", "--device", "cuda", "--chunk-blocks", "1")}
    execute = pipeline.Simulation.execute

    def execute_then_interrupt(simulation, unit):
        outcome = execute(simulation, unit)
        os.kill(os.getpid(), signal.SIGINT)  # the run stops after this unit, with a checkpoint
        return outcome

    pipeline.Simulation.execute = execute_then_interrupt
    try:
        statuses["interrupted"] = run("cuda_resumed.h5", "--device", "cuda", "--chunk-blocks", "1",
                                      "--checkpoint-every", "1000")
    finally:
        pipeline.Simulation.execute = execute
        interrupts.reset()  # the next command starts with no interrupt remembered
    statuses["resumed"] = run("cuda_resumed.h5", "--device", "cuda", "--chunk-blocks", "1", "--resume")
    text = io.StringIO()
    with contextlib.redirect_stdout(text):
        statuses["info"] = vcavity(["info", os.path.join(folder, "cuda.h5")])
    print(json.dumps({"statuses": statuses, "info": text.getvalue()}), flush=True)


if __name__ == "__main__":
    main()
