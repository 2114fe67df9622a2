"""The README stays a few screens long, its links lead somewhere, and its commands work.

Checked: every ``griploop ...`` the README shows, inline or in a code block, names a
command that exists and only options that command's ``--help`` lists (all of them, in
this process, in about a second); the README's first-session block (the code block
made only of ``griploop`` lines) runs as written, each line as its own ``griploop``
process in an empty directory (slow: about half a minute). ``make demo`` and
``make test`` themselves are not run here: the suite is ``make test``, and the demo's
steps are these commands (tests/scenarios/test_cli*.py run them).
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from scenarios.cli.main import main

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
MAX_BYTES = 12 * 1024


def fenced_blocks(text: str) -> list[list[str]]:
    """The lines of each ``` code block."""
    blocks, current = [], None
    for line in text.splitlines():
        if line.startswith("```"):
            if current is None:
                current = []
            else:
                blocks.append(current)
                current = None
        elif current is not None:
            current.append(line)
    return blocks


def shown_commands(text: str) -> list[str]:
    """Every griploop command the README shows: inline code spans and code-block lines."""
    inline = re.findall(r"`(griploop [^`]+)`", text)
    fenced = [line.split("#")[0].strip() for block in fenced_blocks(text) for line in block
              if line.startswith("griploop ")]
    return inline + fenced


def first_session() -> list[str]:
    blocks = [b for b in fenced_blocks(README.read_text(encoding="utf-8"))
              if b and all(line.startswith("griploop ") for line in b)]
    assert len(blocks) == 1, "expected one code block made only of griploop commands"
    return blocks[0]


def help_text(*argv: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as done:
        main([*argv, "--help"])
    assert done.value.code == 0, argv
    return out.getvalue()


def test_the_readme_is_at_most_12_kb():
    assert len(README.read_bytes()) <= MAX_BYTES


def test_every_relative_link_of_the_readme_leads_to_a_file():
    text = README.read_text(encoding="utf-8")
    links = [t for t in re.findall(r"\]\(([^)]+)\)", text) if "://" not in t]
    assert any(t.startswith("docs/results/") for t in links)  # the site's pages
    missing = [t for t in links if not (ROOT / t.split("#")[0]).exists()]
    assert missing == []


def test_every_command_the_readme_shows_exists_with_the_options_it_shows():
    commands = shown_commands(README.read_text(encoding="utf-8"))
    assert len(commands) >= 20
    top = help_text()
    problems = []
    for command in commands:
        words = shlex.split(command.replace("...", ""))[1:]
        options = [w.split("=")[0] for w in words if w.startswith("--")]
        while words and words[0].startswith("--"):  # griploop's own options
            words = words[2:] if words[0] == "--plugin" else words[1:]
        if not words or words[0].isupper():  # griploop --version; --plugin MODULE COMMAND
            problems += [f"{command}: {o}" for o in options if o not in top]
            continue
        name = words[0]
        if not re.search(rf"^    {re.escape(name)}\b", top, re.MULTILINE):
            problems.append(f"{command}: no command {name}")
            continue
        own = help_text(name)
        problems += [f"{command}: {o}" for o in options if o not in own and o not in top]
    assert problems == []


@pytest.mark.slow
def test_the_first_session_of_the_readme_runs_as_written(tmp_path):
    griploop = Path(sys.executable).parent / "griploop"
    assert griploop.is_file(), f"{griploop}: the console script is not installed"
    lines = first_session()
    assert len(lines) >= 3
    for line in lines:
        done = subprocess.run([str(griploop), *shlex.split(line)[1:]], cwd=tmp_path,
                              capture_output=True, text=True, timeout=300,
                              env=dict(os.environ, MPLBACKEND="Agg"))
        assert done.returncode == 0, f"{line}\n{done.stderr[-3000:]}"
        assert done.stdout.strip(), line
