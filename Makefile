# Set-up and common tasks. `make demo` and `make test` work on a fresh clone.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
DOCS_STAMP := $(VENV)/.docs-installed

.PHONY: demo test test-slow docs lint bench clean

# the compiled core (pytdcr._core), built by the install: an edited C++ source re-installs. Every model runs in
# it, so nothing compiles at first use (numba compiles only the tests' reference kernels, when a test calls them)
CORE := CMakeLists.txt $(wildcard src/cpp/*.cpp src/cpp/*.hpp)

$(STAMP): pyproject.toml $(CORE)
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/python -m pip install -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/tdcr reproduce --robot paper --out out/reproduce

# the tests but the slow validation runs (marked `slow`): the check to run while working; on every core
# (pytest-xdist; TEST_WORKERS=0 runs them in this process)
TEST_WORKERS ?= auto
test: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m "not slow" -n $(TEST_WORKERS)

# the slow validation runs alone: golden baselines of the long commands, signals, the notebook, the browser;
# CI runs them after `make test`
test-slow: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -m slow

$(DOCS_STAMP): $(STAMP) pyproject.toml
	$(BIN)/python -m pip install -e '.[dev,docs]'
	touch $(DOCS_STAMP)

# the documentation site, from docs/ (the tutorial executed, the CLI and API references generated), into site/;
# any warning fails the build, and so does a Sphinx role left as raw text (docs/_hooks/griffe_sphinx_roles.py
# turns the docstrings' roles into links)
SPHINX_ROLE := :(py:)?(func|class|data|meth|attr|mod|exc|obj|const|type|ref):(<code>|`)

docs: $(DOCS_STAMP)
	NO_MKDOCS_2_WARNING=1 MPLBACKEND=Agg $(BIN)/mkdocs build --strict
	@if grep -rnoE '$(SPHINX_ROLE)[^<`]*' site --include='*.html'; then \
	  echo "error: the Sphinx roles above are raw text in the built site"; exit 1; fi

lint: $(STAMP)
	$(BIN)/ruff check src tests bench examples

bench: $(STAMP)
	$(BIN)/python bench/solve.py

clean:
	rm -rf $(VENV) out bench/results site .cache build
