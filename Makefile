# Set-up and common tasks. `make demo` and `make test` work on a fresh clone.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint bench clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --upgrade pip
	$(BIN)/python -m pip install -e '.[dev]'
	# compile the numba kernels once (cached on disk for every later run)
	$(BIN)/python -c "import pytdcr.statics; pytdcr.statics.warmup()"
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/tdcr reproduce --robot paper --out out/reproduce

test: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check src tests bench examples

bench: $(STAMP)
	$(BIN)/python bench/solve.py

clean:
	rm -rf $(VENV) out bench/results
