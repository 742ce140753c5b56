"""The ``runners`` command line: argument parsing and printing over the Python API (runners.api).

``parser`` builds the parser and dispatches (it imports nothing heavy, so ``--help`` is quick);
``main`` holds simulate, sweep, map, bench and figures; each command group has its own module
(``db``, ``records``, ``measured``, ``rrd``, ``export``); ``args`` holds the shared argument
checks, ``output`` the notes, JSON and progress bars, ``console`` the installed entry point.
Nothing here computes: the work is done by runners.api, runners.engine and runners.analysis.
"""
