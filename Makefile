# Two commands for a newcomer on Debian 12: `make run` and `make test`.
# Everything runs on Debian's /usr/bin/python3 (YADE and dolfinx are packaged for it).
PY      ?= /usr/bin/python3
STAMP   := .setup-done
PKGS    := $(shell grep -v '^\#' docker/packages.txt)
export OMP_NUM_THREADS ?= 1
export OMPI_ALLOW_RUN_AS_ROOT=1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

.PHONY: setup run test test-slow bench wave1d-study clean

# Idempotent: re-runs apt only when the package list changed.
setup: $(STAMP)
$(STAMP): docker/packages.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y $(PKGS)
	$(PY) -c "import orchestrator.env as e; e.check()"
	touch $@

run: setup
	$(PY) -m orchestrator demo --out results/demo --force

test: setup
	$(PY) -m pytest -q tests

test-slow: setup
	$(PY) -m pytest -q -m slow tests

bench: setup
	$(PY) -m orchestrator bench

clean:
	rm -rf results .pytest_cache $(STAMP)
