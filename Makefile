# Two commands set everything up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint format derivations kernels docs clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,plots,studies,cluster,notebooks,fast,io]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/slbasis derive --family hermite_functions --nmax 3
	$(BIN)/hdpbsid demo --out out/demo

test: $(STAMP)
	$(BIN)/ruff check slbasis hdpbsid tests derivations bench notebooks
	$(BIN)/ruff format --check slbasis hdpbsid tests derivations bench notebooks
	# one BLAS thread per pytest worker: the small-matrix loops (refine, Monte Carlo) were
	# measured 8x slower with two workers each running threaded OpenBLAS on 2 cores
	HYPOTHESIS_PROFILE=ci OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
		$(BIN)/python -m pytest -n 2 -q

lint: $(STAMP)
	$(BIN)/ruff check --fix slbasis hdpbsid tests derivations bench notebooks
	$(BIN)/ruff format slbasis hdpbsid tests derivations bench notebooks

derivations: $(STAMP)
	$(BIN)/python derivations/generate.py

kernels: $(STAMP)
	$(BIN)/python -m slbasis.kernels

# the site: docs/_build/html; warnings are errors; notebooks rendered without execution
$(VENV)/.docs-installed: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $@

docs: $(VENV)/.docs-installed
	OPENBLAS_NUM_THREADS=1 $(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info docs/_build docs/api/generated docs/notebooks
