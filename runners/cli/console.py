"""The ``runners`` console script: runners.cli.parser.main, with Ctrl-C or SIGTERM while the command
line is still loading its modules (about a second) ending as quietly as later on."""

from __future__ import annotations

import signal
import sys


def _stop(signum, _frame) -> None:
    raise KeyboardInterrupt


def main() -> int:
    signal.signal(signal.SIGTERM, _stop)
    try:
        from runners.cli.parser import main as run
    except BaseException as exc:  # a library may wrap the interruption in an ImportError of its own
        chain = exc
        while chain is not None and not isinstance(chain, KeyboardInterrupt):
            chain = chain.__cause__ or chain.__context__
        if chain is None:
            raise
        print("error: interrupted", file=sys.stderr)
        return 130
    try:
        code = run()
    except KeyboardInterrupt:  # while the parser is still being built (run's own handler not yet active)
        print("error: interrupted", file=sys.stderr)
        return 130
    # the command is done and has said so: an interruption arriving while Python exits has
    # nothing left to stop, and must not turn a finished command into a killed one
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    return code
