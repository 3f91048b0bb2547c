"""Makes the helpers the test folders share (``lfd_test_support``, ``parser_property_support``)
importable from any folder: the folders are not packages, and each test module sits in the folder
of the subpackage it tests (``tests/package/`` for the package as a whole)."""

import sys
from pathlib import Path

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)


def pytest_configure(config) -> None:
    """Ctrl-C raises KeyboardInterrupt in every test process, as in a terminal.

    Tests press Ctrl-C for real (a SIGINT, or ``_thread.interrupt_main``) and check what the
    command or the robot link does with it. A suite started in the background by a
    non-interactive shell (``make test &``) inherits SIGINT ignored, and Python then installs no
    handler, so those presses would do nothing; each process (pytest-xdist workers included)
    puts Python's own handler back."""
    import signal

    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
