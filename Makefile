# Two commands do all the set-up on a fresh machine with only Python and the package registries:
#   make demo   - create .venv if missing, install, build the HTML report, print where it is
#   make test   - same bootstrap, then the whole test suite
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.hybobs-installed
PYTEST_ARGS ?= -n 2 --dist worksteal

.PHONY: demo test bench docs doctest install clean

$(STAMP): pyproject.toml constraints.txt
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info >= (3, 11) else "hybobs_opt needs Python >= 3.11, found " + sys.version.split()[0])'
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c constraints.txt -e '.[test,distributed,models,docs]'
	@# compile the numba kernels once into the user's cache (otherwise every test worker compiles them)
	$(PY) -m hybobs_opt._warm_up > /dev/null
	@touch $(STAMP)

install: $(STAMP)

demo: $(STAMP)
	$(VENV)/bin/hybobs report --out-dir out/report --force
	@echo "Open $(CURDIR)/out/report/index.html"

test: $(STAMP)
	@# compile (or load) the kernels first: a kernel source edited since the install would otherwise
	@# run as plain Python in every test worker (see hybobs_opt/_numba_cache.py)
	$(PY) -m hybobs_opt._warm_up > /dev/null
	@# one BLAS thread per test worker: two workers already fill the two cores (OpenBLAS's extra
	@# threads only spin: 15.4 -> 15.1 CPU minutes, 8:23 -> 8:12 wall); a value set by the caller stays
	OPENBLAS_NUM_THREADS=$${OPENBLAS_NUM_THREADS:-1} $(PY) -m pytest $(PYTEST_ARGS)

bench: $(STAMP)
	$(PY) -m benchmarks.run_all

# The documentation site (docs/): warnings are errors; the HTML lands in docs/_build/html.
docs: $(STAMP)
	MPLBACKEND=Agg $(PY) -m sphinx -b html -W --keep-going docs docs/_build/html
	@echo "Open $(CURDIR)/docs/_build/html/index.html"

# The Examples sections of the docstrings, run as doctests (make test does not run them).
doctest: $(STAMP)
	MPLBACKEND=Agg OPENBLAS_NUM_THREADS=$${OPENBLAS_NUM_THREADS:-1} $(PY) -m pytest --doctest-modules --doctest-glob='*.rst' -W error::FutureWarning -q -n 2 hybobs_opt docs/interop.rst

clean:
	rm -rf out .pytest_cache docs/_build docs/api/generated
