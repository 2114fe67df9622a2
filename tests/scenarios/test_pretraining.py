"""The "virtual" pretraining corpus: registered by the scenarios layer, found by every command."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str) -> str:
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    return done.stdout.strip()


def test_importing_scenarios_registers_the_virtual_corpus_by_reference():
    out = _run("import sys, scenarios\n"
               "from estimation.corpora import corpus_names, corpus_packages\n"
               "print('virtual' in corpus_names(), corpus_packages('virtual'),\n"
               "      'scenarios.runners.pretraining' in sys.modules, 'sklearn' in sys.modules)")
    assert out == "True ('sim.user',) False False"  # named, not imported: listing stays light


def test_estimation_alone_registers_no_corpus_of_a_layer_above_it():
    out = _run("import estimation.transfer\n"
               "from estimation.corpora import corpus_names\n"
               "print(corpus_names())")
    assert out == "()"


def test_the_cli_finds_the_virtual_corpus_and_keys_it_by_its_builder():
    out = _run("import scenarios.cli.main\n"
               "from estimation.corpora import corpus_builder, corpus_source\n"
               "from scenarios.runners import pretraining\n"
               "print(corpus_builder('virtual') is pretraining.virtual_corpus,\n"
               "      corpus_source('virtual') == open(pretraining.__file__, 'rb').read())")
    assert out == "True True"
