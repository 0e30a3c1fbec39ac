"""Ctrl-C after a command's output is complete gives the same one line everywhere:
``vcavity: interrupted; the output was written: PATH``, exit 130 (as ``run`` says
"interrupted; the table was written"), in the command (just after ``export`` or ``plot``
wrote its file) and once ``main`` has returned (the interpreter or a Dask cluster
shutting down). Deterministic: the interrupt is raised at a fixed point."""

import subprocess
import sys
import textwrap

import pytest

from tests.export.synthetic_table import synthetic
from vcavity.cli import main


@pytest.fixture
def table(tmp_path):
    return synthetic(tmp_path / "t.h5", theta_deg=(0, 30, 60), resolution=7).path


@pytest.mark.parametrize("command", ["export", "plot"])
def test_ctrl_c_just_after_the_file_is_written_says_so(table, tmp_path, capsys, monkeypatch, command):
    """The Ctrl-C arrives the moment the command has recorded its file as complete."""
    import vcavity.cli.export as export_cli
    import vcavity.cli.plot as plot_cli

    module = export_cli if command == "export" else plot_cli
    record = module.written

    def written_then_interrupted(path):
        record(path)
        raise KeyboardInterrupt

    monkeypatch.setattr(module, "written", written_then_interrupted)
    out = tmp_path / ("t.csv" if command == "export" else "t.png")
    argv = (["export", str(table), str(out), "--format", "csv", "--theta-i", "30"] if command == "export"
            else ["plot", str(table), "-o", str(out)])
    assert main(argv) == 130
    lines = capsys.readouterr().err.splitlines()
    assert lines == [f"vcavity: interrupted; the output was written: {out}"]
    assert out.is_file()


def test_ctrl_c_after_main_returned_is_one_line_exit_130(table, tmp_path):
    """A SIGINT while the process ends (here: as its streams are flushed, after main
    returned and before the exit) after export finished: one line naming the file, exit
    130, no traceback. The console entry has no teardown after it (os._exit), where Python
    would have put the signals back to their default actions."""
    out = tmp_path / "t.csv"
    script = textwrap.dedent(f"""
        import os, signal, sys, time

        class LateSignal:  # stdout whose last flush meets a Ctrl-C
            def __init__(self, stream):
                self.stream, self.main_returned = stream, False
            def write(self, text):
                return self.stream.write(text)
            def fileno(self):
                return self.stream.fileno()
            def flush(self):
                self.stream.flush()
                if self.main_returned:
                    os.kill(os.getpid(), signal.SIGINT)
                    time.sleep(5)

        late = sys.stdout = LateSignal(sys.stdout)
        sys.argv = ["vcavity", "export", {str(table)!r}, {str(out)!r}, "--format", "csv", "--theta-i", "30"]
        from vcavity import cli
        main = cli.main

        def main_then_arm():
            status = main()
            late.main_returned = True
            return status

        cli.main = main_then_arm
        cli.console_main()
    """)
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert done.returncode == 130, done.stderr
    assert done.stderr.splitlines() == [f"vcavity: interrupted; the output was written: {out}"]
    assert out.is_file() and done.stdout.startswith(f"wrote {out}")


@pytest.mark.parametrize("command", ["export", "plot"])
def test_a_sigint_the_moment_the_file_is_renamed_names_the_file(table, tmp_path, capsys, monkeypatch, command):
    """Issue 38: a real SIGINT right after the rename put the file in place, before the
    command recorded it as written, said only "interrupted" (as if nothing was written)."""
    import os
    import signal

    real_replace = os.replace

    def replace_then_sigint(source, destination):
        real_replace(source, destination)
        os.kill(os.getpid(), signal.SIGINT)  # handled at once, in the next bytecode

    monkeypatch.setattr(os, "replace", replace_then_sigint)
    out = tmp_path / ("t.csv" if command == "export" else "t.png")
    argv = (["export", str(table), str(out), "--format", "csv", "--theta-i", "30"] if command == "export"
            else ["plot", str(table), "-o", str(out)])
    assert main(argv) == 130
    assert capsys.readouterr().err.splitlines() == [f"vcavity: interrupted; the output was written: {out}"]
    assert out.is_file()


@pytest.mark.parametrize("command", ["export", "plot"])
def test_a_sigint_before_the_rename_writes_nothing(table, tmp_path, capsys, monkeypatch, command):
    """The other side of the same moment: a SIGINT while the file is being written cancels
    the rename; nothing is written and no temporary file is left."""
    import os
    import signal

    from vcavity.io import atomic

    real_fsync = atomic._fsync

    def fsync_then_sigint(path):
        real_fsync(path)
        if path.name.endswith(".tmp"):
            os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(atomic, "_fsync", fsync_then_sigint)
    out = tmp_path / ("t.csv" if command == "export" else "t.png")
    argv = (["export", str(table), str(out), "--format", "csv", "--theta-i", "30"] if command == "export"
            else ["plot", str(table), "-o", str(out)])
    assert main(argv) == 130
    assert capsys.readouterr().err.splitlines() == ["vcavity: interrupted"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["t.h5"]
