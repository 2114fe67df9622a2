"""The ``griploop`` command line: :func:`~scenarios.cli.main.main`; one module per subcommand in
``commands``.

May import everything; importing this package itself stays light (argparse only)
so that ``griploop --help`` is fast.
"""

from scenarios.cli.main import entry, main

__all__ = ["entry", "main"]
