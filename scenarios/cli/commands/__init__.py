"""One module per ``griploop`` subcommand.

Each module defines ``register(subparsers) -> None``, which adds its parser
and sets ``func=run`` where ``run(args) -> int`` is the command. Modules are
discovered by :func:`scenarios.cli.main.build_parser`; nothing else needs editing to
add a command.
"""
