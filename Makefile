# Two commands for a newcomer on Debian 12: `make run` and `make test`.
# Everything runs on Debian's /usr/bin/python3 (YADE and dolfinx are packaged for it).
PY      ?= /usr/bin/python3
STAMP   := .setup-done
PKGS    := $(shell grep -v '^\#' docker/packages.txt)
export OMP_NUM_THREADS ?= 1
export OMPI_ALLOW_RUN_AS_ROOT=1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

.PHONY: setup run validate test test-slow bench wave1d-study clean

# Idempotent: re-runs apt only when the package list changed.
setup: $(STAMP)
$(STAMP): docker/packages.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y $(PKGS)
	$(PY) -c "import orchestrator.env as e; e.check()"
	touch $@

# The main job at small scale: the slab impact, full YADE and coupled, on three packings each
# (seeds 1, 2, 3), then the comparison: each same-seed pair, and the coupled runs against the
# full model's own scatter between packings (docs/slab.md).
SEEDS ?= 1,2,3
run: setup
	$(PY) -m orchestrator slab --model full --scale small --seeds $(SEEDS) --out results/slab-small/full --force
	$(PY) -m orchestrator slab --model coupled --scale small --seeds $(SEEDS) --out results/slab-small/coupled --force
	$(PY) -m orchestrator compare results/slab-small/full results/slab-small/coupled --out results/slab-small/compare --force

# Heavier reference ensembles (docs/slab.md): medium scale, three seeds of each model, and
# the full model kept elastic outside the DE zone (the coupling error alone); about 1 h on 2 cores.
validate: setup
	$(PY) -m orchestrator slab --model full --scale medium --seeds $(SEEDS) --out results/slab-medium/full --force
	$(PY) -m orchestrator slab --model coupled --scale medium --seeds $(SEEDS) --out results/slab-medium/coupled --force
	$(PY) -m orchestrator compare results/slab-medium/full results/slab-medium/coupled --out results/slab-medium/compare --force
	$(PY) -m orchestrator slab --model full --elastic-outside --scale medium --seeds $(SEEDS) --out results/slab-medium/full-elastic-outside --force
	$(PY) -m orchestrator compare results/slab-medium/full-elastic-outside results/slab-medium/coupled --out results/slab-medium/compare-elastic-outside --force

test: setup
	$(PY) -m pytest -q tests

test-slow: setup
	$(PY) -m pytest -q -m slow tests

# The paper's 1D spurious-reflection study (Figs. 4-7), about 3 min: results/wave1d-study/
wave1d-study: setup
	$(PY) -m orchestrator wave1d-study --out results/wave1d-study --force

# Slab full vs coupled at small, medium and paper scale against the performance goals:
# bench/results.json and docs/benchmarks.md (about 10 min; BENCH_ARGS=--quick: 1-2 min)
bench: setup
	$(PY) -m bench $(BENCH_ARGS)

clean:
	rm -rf results .pytest_cache $(STAMP)
