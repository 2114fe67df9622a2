"""The griploop CLI: every command registered, --help complete, user errors as one line."""

from __future__ import annotations

import subprocess
import sys

import pytest

from scenarios.cli import build_parser, main


def test_every_command_has_help() -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    assert sub.choices, "no subcommands registered"
    for name, command in sub.choices.items():
        assert command.description or command.format_help(), name
        text = command.format_help()
        for action in command._actions:
            if action.dest != "help" and action.option_strings:
                assert action.help, f"griploop {name} {action.option_strings[0]} has no help"
        assert text.startswith("usage: griploop " + name)


def test_user_error_is_one_line_without_traceback(tmp_path) -> None:
    bad = tmp_path / "missing.npz"
    proc = subprocess.run(
        [sys.executable, "-m", "scenarios.cli", "plot-recording", str(bad), "--out",
         str(tmp_path / "x.png")],
        capture_output=True, text=True, check=False,
    )
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "no such file" in lines[0] and "Traceback" not in proc.stderr


def test_unknown_command_exits_nonzero(capsys) -> None:
    with pytest.raises(SystemExit) as info:
        main(["no-such-command"])
    assert info.value.code == 2
