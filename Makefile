# griploop: `make demo` and `make test` set everything up on a fresh machine.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.griploop-installed
DOCS_STAMP := $(VENV)/.griploop-docs-installed
export MUJOCO_GL ?= egl
export PYOPENGL_PLATFORM ?= egl
export MPLBACKEND ?= Agg

.PHONY: demo test test-verdicts test-dispatch docs bench lint clean pretrained

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP) $(DOCS_STAMP)

# the documentation's own extra (dev carries it too, so after make test this is done)
$(DOCS_STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[docs]"
	touch $(DOCS_STAMP)

demo: $(STAMP)
	$(VENV)/bin/griploop demo --out demo_out

# the suite on pytest-xdist workers, one per core and one more: about 80 s of the suite are
# live sessions streamed in real time over loopback and sweeps stopped by signals, which
# leave their core idle while they wait (on 2 cores: 3 min 50 s with 3 workers against
# 4 min 4 s with 2, docs/results/speed.md). Each test file stays on one worker, so its
# module fixtures are built once. TEST_WORKERS=0 runs it in this process.
TEST_WORKERS ?= $(shell $(PYTHON) -c "import os; print((os.cpu_count() or 1) + 1)")
test: $(STAMP)
	$(PY) -m ruff check sim estimation controllers scenarios tests benchmarks examples docs
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m "not verdict"

# the tests marked "verdict": the population-scale findings (many subjects or episodes judged
# against measured human figures: the practised users' rigid objects, the feedback benchmarks,
# the library held with the oracle, the virtual population against the real recordings).
# .ci/run runs them after make test; together the two run every test.
test-verdicts: $(STAMP)
	$(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile -m verdict

# the tests that compare values computed through different shapes, chunkings or code paths
# (marker "portable", tests/portable.py), again with numpy's vector loops limited to AVX2
# and to SSE4.2: numpy rounds some elements differently with their place in an array on
# some CPUs, and a test promising more than the last bits across paths fails here too
DISPATCH_LEVELS ?= "X86_V4 AVX512_ICL AVX512_SPR" "X86_V3 X86_V4 AVX512_ICL AVX512_SPR"
test-dispatch: $(STAMP)
	@for level in $(DISPATCH_LEVELS); do \
	  echo "NPY_DISABLE_CPU_FEATURES=\"$$level\""; \
	  NPY_DISABLE_CPU_FEATURES="$$level" $(PY) -m pytest -q -m portable -n $(TEST_WORKERS) \
	    --dist loadfile -p no:cacheprovider || exit 1; \
	done

# the documentation site in docs/_build/html: guides, results, examples (run), API reference.
# Warnings are errors and every cross-reference to a griploop name must resolve; make test
# builds it the same way (tests/docs/test_site.py).
SPHINXOPTS ?= -W --keep-going -n -q
docs: $(DOCS_STAMP)
	$(PY) -m sphinx -b html $(SPHINXOPTS) docs docs/_build/html
	@echo "docs: docs/_build/html/index.html"

# every benchmarks/bench_*.py in its own process, then the table of their GOAL lines
BENCH_ARGS ?= --markdown bench_results.md
bench: $(STAMP)
	$(PY) benchmarks/run_all.py $(BENCH_ARGS)

# the transfer_mlp networks shipped in the package (estimation/pretrained) for the default
# settings; run after a change to what builds them (a test checks they are this source's)
# (importing scenarios registers the "virtual" corpus they are pretrained on)
pretrained: $(STAMP)
	$(PY) -c "import scenarios; from estimation.transfer import ship_default_networks as s; print(*s(), sep='\n')"

lint: $(STAMP)
	$(PY) -m ruff check sim estimation controllers scenarios tests benchmarks examples docs

clean:
	rm -rf $(VENV) demo_out .pytest_cache docs/_build docs/api docs/auto_examples
