# Two commands set everything up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint format derivations kernels clean

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

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info
