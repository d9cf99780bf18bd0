# floe-impact: make help
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
STUDY  ?= speed_sweep
ARGS   ?=

.DEFAULT_GOAL := help
.PHONY: help setup warm-kernels docs docs-check architecture-numbers study status test test-slow test-portable test-cluster bench bench-quadrature bench-scale bench-answered bench-integrator bench-revisions bit-for-bit fingerprint regenerate-reference variables-table clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-22s %s\n", $$1, $$2}'

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --quiet --upgrade pip
	@# setuptools warns on every editable install of a flat layout that a folder named like a
	@# package could shadow it; here those folders are the packages, so that one warning is muted
	PYTHONWARNINGS="ignore:Editable installation" $(VENV)/bin/pip install --quiet -e ".[test]"
	$(MAKE) --no-print-directory warm-kernels PY=$(VENV)/bin/python
	touch $@

setup: $(VENV)/.installed  ## create .venv and install the package with its test extras, its kernels compiled (warm-kernels)

warm-kernels:  ## compile the solver's kernels into their cache, as the tests' start does (about 40 s once; make setup runs it)
	$(PY) -c "import subprocess, sys; from solver import compile_kernels; helper = subprocess.Popen([sys.executable, 'tests/warm_kernels.py']); compile_kernels(); sys.exit(helper.wait())"

$(VENV)/.docs-installed: $(VENV)/.installed pyproject.toml
	PYTHONWARNINGS="ignore:Editable installation" $(VENV)/bin/pip install --quiet -e ".[test,docs]"
	touch $@

docs: $(VENV)/.docs-installed  ## build the docs site (Sphinx, the gallery run at full settings) -> docs/_build/html; warnings are errors
	cd docs && ../$(PY) -m sphinx -W --keep-going -b html -d _build/doctrees . _build/html

docs-check: $(VENV)/.docs-installed  ## the docs site as CI builds it: warnings are errors, the gallery's scripts not run (make test runs each one: tests/test_gallery.py) -> docs/_build/check
	cd docs && ../$(PY) -m sphinx -W --keep-going -b html -D plot_gallery=0 -d _build/doctrees-check . _build/check

study: setup  ## run a study: make study STUDY=speed_sweep [ARGS="--workers 1"]
	@$(PY) -m pipeline run studies/$(STUDY).toml $(ARGS); status=$$?; \
	case $$status in \
	  0) ;; \
	  1) echo "make study: runner exit 1: some cases failed numerically (listed above); all results are in results/$(STUDY)/";; \
	  2) echo "make study: runner exit 2: bad input (above)";; \
	  74) echo "make study: runner exit 74: I/O error (above); finished cases are kept";; \
	  75) echo "make study: runner exit 75: another runner holds the study";; \
	  130) echo "make study: runner exit 130: interrupted; finished cases are kept";; \
	  *) echo "make study: runner exit $$status";; \
	esac; exit $$status

status: setup  ## what a study has done: make status STUDY=speed_sweep
	$(PY) -m pipeline status $(STUDY)

test: setup  ## the default test suite (fast; excludes tests marked slow): 2 processes, a file each
	$(PY) -m pytest -q -n 2 --dist loadfile --durations=10

#: the tests whose numbers another CPU's round-off could move: the solver's, the regression
#: against the stored reference, and the axes a study generates
PORTABLE_TESTS := tests/test_axes.py tests/test_body_mass.py tests/test_body_shapes.py tests/test_energy_and_forcing.py tests/test_quadrature.py \
	tests/test_error_estimate.py tests/test_events.py tests/test_peak_search.py tests/test_extremes.py tests/test_integrators.py \
	tests/test_floe.py tests/test_floe_gauss.py tests/test_composition.py tests/test_impact_zone.py tests/test_kernel_pieces.py tests/test_layer_law.py tests/test_off_centre.py tests/test_paper_numbers.py \
	tests/test_pipeline.py \
	tests/test_viscoelastic.py tests/test_water_depth.py tests/test_asked.py tests/test_error_control.py tests/test_parts.py tests/test_breaking.py \
	tests/test_floe_parts.py tests/test_crack_spring.py tests/test_edge_shapes.py
#: numpy's SIMD dispatch targets above its baseline, turned off to emulate an older CPU
NO_AVX512 := X86_V4 AVX512_ICL AVX512_SPR

test-portable: setup  ## the numerics-bearing tests as on other CPUs: numpy without AVX-512 + numba for haswell; numpy's SSE baseline + numba generic
	NPY_DISABLE_CPU_FEATURES="$(NO_AVX512)" NUMBA_CPU_NAME=haswell $(PY) -m pytest -q -n 2 --dist loadfile -m "not slow and not cluster" $(PORTABLE_TESTS)
	NPY_DISABLE_CPU_FEATURES="X86_V3 $(NO_AVX512)" NUMBA_CPU_NAME=generic $(PY) -m pytest -q -n 2 --dist loadfile -m "not slow and not cluster" $(PORTABLE_TESTS)

test-cluster: setup  ## a one-node SLURM from Debian's packages (root; installed if missing), then the tests marked cluster: studies through --cluster slurm (a job cancelled, workers retiring, a Ctrl-C), a killed dask worker, a stand-in PBS
	tests/cluster/slurm.sh up
	$(PY) -m pytest -q -m cluster --durations=5 tests/test_batch_system.py tests/test_cluster.py \
		tests/test_slurm_teardown.py; status=$$?; \
	tests/cluster/slurm.sh down; exit $$status

test-slow: setup  ## only the long tests (marked slow) and the heavy ones (marked heavy: make test-portable runs them too)
	$(PY) -m pytest -q -n 2 --dist loadfile -m "slow or heavy" --durations=10

bench-compile: setup  ## the first compile from an empty cache, beside the number README.md gives (CI prints it)
	$(PY) benchmarks/first_compile.py

bench: setup  ## benchmarks -> results/bench/solver.md, results/bench/study.md
	$(PY) benchmarks/bench_solver.py
	$(PY) benchmarks/bench_study.py

variables-table: setup  ## rewrite docs/variables.md from a real study.nc (tests/test_variables.py checks it)
	$(PY) -m pipeline.common.variables

architecture-numbers: setup  ## rewrite docs/architecture.md's numbers of the code's shape from the source (tests/test_architecture.py checks them)
	$(PY) tests/architecture_numbers.py --write

layout-slots: setup  ## rewrite solver/layout.py's D_*, R_*, S_* slots from the tables of solver/outputs.py
	$(PY) -m solver.outputs

bit-for-bit: setup  ## are the solver's results exactly those of BASE (default HEAD)? (RULE=embedded: the Gauss cases under the embedded control) 30 cases (15 at the paper's rule, 8 Gauss, a floe under each, 5 that break), settings pinned, every output array and break
	$(PY) benchmarks/bit_for_bit.py --base $(or $(BASE),HEAD) --gauss-rule $(or $(RULE),gauss)

bench-integrator: setup  ## the time integrators' error against wall time on seven cases against the continuous-x model (issue 56's measure, about 10 min) -> results/bench/time_integrator.{md,csv}
	$(PY) benchmarks/time_integrator.py

bench-answered: setup  ## a crack-onset run (end = "answered") beside the full run, five cases at N = 60 -> results/bench/answered.md
	$(PY) benchmarks/answered.py

bench-revisions: setup  ## solver time of git revisions side by side (REVISIONS="46d95fa ." RULE=paper|gauss|embedded CASE=reference|breaking, settings pinned) -> results/bench/revisions.md
	$(PY) benchmarks/bench_revisions.py --revisions $(or $(REVISIONS),46d95fa .) --rule $(or $(RULE),paper) --case $(or $(CASE),reference)

bench-quadrature: setup  ## error against wall time of both forcing quadratures, N = 20, 60, 120, four cases (about 10 min) -> results/bench/quadrature.{md,csv,png}
	$(PY) benchmarks/quadrature.py

bench-scale: setup  ## 100 000 small cases end to end, a killed runner, status (about 12 min) -> results/bench/scale.md
	$(PY) benchmarks/bench_scale.py

fingerprint: setup  ## record this machine's fingerprint of the solver's results (after a bump of solver/revision.py) -> tests/data/results_fingerprint.json
	$(PY) tests/results_fingerprint.py --record

regenerate-reference: setup  ## rebuild tests/data/regression_small.nc and its spread over tolerances (only after a deliberate change)
	$(PY) tests/regenerate_reference.py

clean:  ## remove results/ and caches (keeps .venv)
	rm -rf results .pytest_cache docs/_build docs/auto_examples docs/sg_execution_times.rst
	find . -name __pycache__ -prune -exec rm -rf {} +
