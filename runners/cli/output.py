"""What the command line prints besides results: notes and progress, both on stderr, both
silenced by --quiet; results (text or --json) alone go to stdout. Progress bars are drawn on
a terminal only, and cleared when done."""

from __future__ import annotations

import json
import sys
import threading
from contextlib import contextmanager
from typing import Any, Iterator

QUIET = False  # set by runners.cli.parser.main from --quiet, for each command


def note(text: str) -> None:
    """A one-line note on stderr (nothing with --quiet)."""
    if not QUIET:
        print(f"note: {text}", file=sys.stderr)


def progress() -> bool:
    """Whether to draw progress bars: on a terminal, without --quiet (a log or a pipe gets the
    results and notes only, so that a failure there is one line)."""
    try:
        return not QUIET and sys.stderr.isatty()
    except (AttributeError, ValueError):
        return False


def result(text: str) -> None:
    """A piece of the result on stdout while a progress bar may be drawn on stderr."""
    from tqdm import tqdm

    tqdm.write(text, file=sys.stdout)
    sys.stdout.flush()


def emit_json(doc: Any) -> None:
    """The command's one JSON document, on stdout."""
    print(json.dumps(doc, indent=2, default=str))


@contextmanager
def busy(desc: str, delay: float = 1.0) -> Iterator[None]:
    """A progress line (what is being done, and for how long) on stderr for work whose size is
    not known in advance, shown once it has lasted `delay` seconds; nothing with --quiet."""
    if not progress():
        yield
        return
    from tqdm import tqdm

    done = threading.Event()
    stream = sys.stderr

    def tick() -> None:
        if done.wait(delay):
            return
        with tqdm(total=None, desc=desc, bar_format="{desc}: {elapsed}", file=stream, leave=False) as bar:
            while not done.wait(0.5):
                bar.refresh()

    thread = threading.Thread(target=tick, daemon=True)
    thread.start()
    try:
        yield
    finally:
        done.set()
        thread.join()


def stages(names: list[str], desc: str) -> Iterator[str]:
    """A progress bar over named stages, its clock ticking while a stage runs: iterate it, the
    bar names the stage running; nothing with --quiet."""
    if not progress():
        yield from names
        return
    from tqdm import tqdm

    done = threading.Event()
    with tqdm(total=len(names), desc=desc, file=sys.stderr, leave=False,
              bar_format="{desc}: {n_fmt}/{total_fmt} [{elapsed}] {postfix}") as bar:
        def tick() -> None:
            while not done.wait(0.5):
                bar.refresh()

        thread = threading.Thread(target=tick, daemon=True)
        thread.start()
        try:
            for name in names:
                bar.set_postfix_str(name)
                yield name
                bar.update()
        finally:
            done.set()
            thread.join()
