"""Session-wide test setup.

A test run started in the background by a script without job control (``pytest &``)
begins with SIGINT ignored, and every process it starts inherits that. The Ctrl-C tests
(tests/test_cli_faults.py, tests/test_resume_cli.py) need what an interactive run has:
Python's default handler here, and so the default disposition in the processes they
start (a Python-level handler is reset to the default by exec; an ignored signal is not).
"""

import signal

if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
