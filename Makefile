# Two commands set everything up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

.PHONY: demo test lint format derivations kernels compiled docs clean

# numba kernels compiled into numba's cache (a first call would otherwise run numpy while
# they compile in the background: slbasis.numeric.jit)
JIT_MODULES := slbasis.numeric.compiled hdpbsid.models.recursion_kernels hdpbsid.refine.pem_kernels

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,plots,studies,cluster,notebooks,fast,io]"
	$(BIN)/python -m slbasis.numeric.jit $(JIT_MODULES)
	touch $(STAMP)

# the derivation report goes to a file; the terminal shows the identification
demo: $(STAMP) compiled
	@mkdir -p out/demo
	@$(BIN)/slbasis derive --family hermite_functions --nmax 3 > out/demo/hermite_functions.md
	@echo "derived and verified the Hermite functions: out/demo/hermite_functions.md"
	$(BIN)/hdpbsid demo --out out/demo

test: $(STAMP) compiled
	$(BIN)/ruff check slbasis hdpbsid tests derivations bench notebooks
	$(BIN)/ruff format --check slbasis hdpbsid tests derivations bench notebooks
	# one BLAS thread per pytest worker: the library limits BLAS only inside its own calls
	# (hdpbsid.runtime); the tests' oracles and simulations run outside them, and the
	# workers already use the cores, so a threaded BLAS there would oversubscribe them
	HYPOTHESIS_PROFILE=ci OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 \
		$(BIN)/python -m pytest -n 2 -q

lint: $(STAMP)
	$(BIN)/ruff check --fix slbasis hdpbsid tests derivations bench notebooks
	$(BIN)/ruff format slbasis hdpbsid tests derivations bench notebooks

derivations: $(STAMP)
	$(BIN)/python derivations/generate.py

kernels: $(STAMP)
	$(BIN)/python -m slbasis.kernels

compiled: $(STAMP)
	$(BIN)/python -m slbasis.numeric.jit $(JIT_MODULES)

# the site: docs/_build/html; warnings are errors; the notebooks and example pages are
# executed during the build (small settings); then the built pages are checked: nothing
# loaded from another host (MathJax served locally), every image present, figures on the
# notebook pages and the user guide's sections, the navigation on every page
$(VENV)/.docs-installed: $(STAMP) pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[docs]"
	touch $@

docs: $(VENV)/.docs-installed compiled
	$(BIN)/sphinx-build -W --keep-going -b html docs docs/_build/html
	$(BIN)/python docs/check_site.py docs/_build/html

clean:
	rm -rf $(VENV) .pytest_cache .hypothesis build *.egg-info docs/_build docs/api/generated docs/notebooks docs/_generated docs/jupyter_execute
