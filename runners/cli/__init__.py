"""The ``runners`` command line: argument parsing and printing over the Python API.

``main`` builds the parser and dispatches (runners.cli.main); each command group
has its own module (``db``, ``records``, ``measured``, ``rrd``); ``console`` is the
installed entry point and ``args`` holds the shared argument checks. Nothing here
computes: the work is done by runners.engine and runners.analysis.
"""
