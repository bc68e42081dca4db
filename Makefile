# Two commands for a newcomer on Debian 12: `make run` and `make test`.
# Everything runs on Debian's /usr/bin/python3 (YADE and dolfinx are packaged for it).
PY      ?= /usr/bin/python3
STAMP   := .setup-done
PKGS    := $(shell grep -v '^\#' docker/packages.txt)
export OMP_NUM_THREADS ?= 1
export OMPI_ALLOW_RUN_AS_ROOT=1
export OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1

.PHONY: setup setup-browser setup-paraview setup-image-build setup-slurm run validate render test test-slow \
        docker-test bench bench-quick wave1d-study study clean

# Idempotent: re-runs apt only when the package list changed. Without Debian's recommended
# packages (about 1 GB more: LLVM, valgrind, numba, docs; nothing the stack imports).
setup: $(STAMP)
$(STAMP): docker/packages.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(PKGS)
	$(PY) -c "import cli.env as e; e.check()"
	touch $@

# The tests' browser (a headless chromium opens report.html): not in the image. Right after
# `setup` the package lists are fresh; apt-get update only if they are not.
setup-browser: .setup-browser-done
.setup-browser-done: docker/packages-browser.txt
	DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(shell grep -v '^\#' docker/packages-browser.txt) \
	  || (apt-get update && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends $(shell grep -v '^\#' docker/packages-browser.txt))
	touch $@

# Optional package sets (same idempotent stamp scheme): ParaView for `render`, and the tools that
# build and run the Docker image without a Docker engine (`make docker-test`).
setup-paraview: .setup-paraview-done
.setup-paraview-done: docker/packages-paraview.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y $(shell grep -v '^\#' docker/packages-paraview.txt)
	touch $@

setup-slurm: .setup-slurm-done
.setup-slurm-done: docker/packages-slurm.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y $(shell grep -v '^\#' docker/packages-slurm.txt)
	touch $@

setup-image-build: .setup-image-build-done
.setup-image-build-done: docker/packages-image-build.txt
	apt-get update
	DEBIAN_FRONTEND=noninteractive apt-get install -y $(shell grep -v '^\#' docker/packages-image-build.txt)
	touch $@

# The main job at small scale, both sides of the answer (docs/slab.md, "make run"), with the FE
# that cracks where the concrete does (docs/fe-damage.md), each coupled run growing its DE zone
# from a 0.5 m box under the impact with one bridging layer (the default, docs/auto-zone.md):
# - 10 m/s, where coupling pays: full YADE and coupled on six packings each (seeds 1-6: the
#   fewest with which the equivalence test can judge a spread of half its margin), and their
#   comparison on the quantities of interest (results/slab-small/10ms/compare/report.html);
# - 40 m/s, where it does not: the zone grows until the run's own checks say why coupling
#   cannot pay (results/slab-small/40ms/coupled).
SEEDS ?= 1,2,3,4,5,6
RUN_ZONE = --scale small --fe-material damage --force
run: setup
	$(PY) -m cli slab --model full --impactor-speed 10 --scale small --force --seeds $(SEEDS) --jobs 2 --quiet --out results/slab-small/10ms/full
	$(PY) -m cli slab --model coupled --impactor-speed 10 $(RUN_ZONE) --seeds $(SEEDS) --jobs 2 --quiet --out results/slab-small/10ms/coupled
	$(PY) -m cli compare results/slab-small/10ms/full results/slab-small/10ms/coupled --out results/slab-small/10ms/compare --force
	$(PY) -m cli slab --model coupled --impactor-speed 40 $(RUN_ZONE) --out results/slab-small/40ms/coupled \
	  || [ $$? -eq 1 ]    # 1: the grown zone's outcome, that coupling cannot pay (not a fault)
	@$(MAKE) --no-print-directory render

# Heavier reference ensembles (docs/slab.md): medium scale at 40 m/s, three seeds of each
# model with the fixed full-width strip of three layers, and the full model kept elastic
# outside the DE zone (the coupling error alone); about 1 h on 2 cores.
V_SEEDS ?= 1,2,3
V_ZONE = --scale medium --de-zone 0.9 --full-width --layers 3 --seeds $(V_SEEDS) --force
validate: setup
	$(PY) -m cli slab --model full $(V_ZONE) --out results/slab-medium/full
	$(PY) -m cli slab --model coupled --zone box $(V_ZONE) --out results/slab-medium/coupled
	$(PY) -m cli compare results/slab-medium/full results/slab-medium/coupled --out results/slab-medium/compare --force
	$(PY) -m cli slab --model full --elastic-outside $(V_ZONE) --out results/slab-medium/full-elastic-outside
	$(PY) -m cli compare results/slab-medium/full-elastic-outside results/slab-medium/coupled --out results/slab-medium/compare-elastic-outside --force

# ParaView pictures of make run's coupled and full slabs at 10 m/s, seed 1 (cut through the
# impact point), and a film of the coupled one, in results/slab-small/10ms/*/seed-1/render/;
# without ParaView, says so: the matplotlib pictures are in the report page anyway.
render:
	@if command -v pvpython >/dev/null && command -v xvfb-run >/dev/null; then \
	  $(PY) -m cli render results/slab-small/10ms/coupled/seed-1 --animate --force && \
	  $(PY) -m cli render results/slab-small/10ms/full/seed-1 --force; \
	else echo "ParaView renders not made (ParaView is not installed: make setup-paraview); the \
	pictures are in results/slab-small/10ms/compare/report.html"; fi

test: setup setup-browser
	$(PY) -m pytest -q -n 2 --durations=15 tests

test-slow: setup
	$(PY) -m pytest -q -m slow tests

# The Docker image built from docker/Dockerfile and its entrypoint run on a 2-row table inside
# a container (a Docker engine, else podman/buildah and a local debian base: ~10-15 min), then
# the container's outputs checked on the host. Not part of `make test`.
docker-test: setup setup-image-build
	docker/test-image.sh results/docker-test
	DOCKER_TEST_OUT=results/docker-test $(PY) -m pytest -q -m slow tests/test_docker_image.py

# The paper's 1D spurious-reflection study (Figs. 4-7), about 3 min: results/wave1d-study/
wave1d-study: setup
	$(PY) -m cli wave1d-study --out results/wave1d-study --force

# Slab full vs coupled at small, medium and paper scale against the performance goals:
# bench/results.json and docs/benchmarks.md (about 12 min). bench-quick (about 3 min): small
# and medium only, and it fails if the medium coupled step is > 15 % slower than in results.json.
bench: setup
	$(PY) -m bench $(BENCH_ARGS)

bench-quick: setup
	$(PY) -m bench --quick

# Where coupling pays (results/where-coupling-pays/page.md): the coupled zones against the full
# ensemble of each impact, judged by the yardstick, at medium scale, 10 and 40 m/s, seeds 1-4
# (STUDY_ARGS="--dry-run" prints the plan and its projected cost; "--reuse-ensembles DIR"
# reuses finished runs of the same description; "--sweep full" adds 20 m/s, the 1.0 m box, the
# reinforced slab and the paper scale).
study: setup
	$(PY) -m cli study $(STUDY_ARGS)

clean:
	rm -rf results .pytest_cache $(STAMP)
