# wsgrasp: every target bootstraps .venv itself.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export MPLBACKEND := Agg

.PHONY: demo test lint docs bench bench-peers eval eval-random eval-heldout eval-grippers eval-grippers-strict schema clean sysdeps

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install -q --upgrade pip setuptools wheel

sysdeps:
	@bash scripts/ensure-sysdeps.sh

$(STAMP): pyproject.toml | $(BIN)/python
	@bash scripts/ensure-sysdeps.sh
	$(BIN)/python -m pip install -q -e '.[dev]'
	@touch $(STAMP)

demo: $(STAMP)
	$(BIN)/wsgrasp demo --out demo

lint: $(STAMP)
	$(BIN)/ruff format --check wsgrasp plugins tests benchmarks docs/hooks
	$(BIN)/ruff check wsgrasp plugins tests benchmarks docs/hooks
	$(BIN)/mypy

# the documentation site (mkdocs.yml, docs/): strict, so a broken link or a
# reference page that no longer builds from the code fails; offline
docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet

test: $(STAMP) lint docs
	$(BIN)/python -m pytest -q -m "not slow"

# the commit a run starts from, written with its result under docs/results/
COMMIT := $(shell git rev-parse --short HEAD 2>/dev/null)
PUBLISH = $(BIN)/python benchmarks/publish_result.py --commit "$(COMMIT)"

BARRETT := examples/plugins/barrett_bh8_like/wsgrasp_barrett_bh8_like/barrett_bh8_like.yaml
EVAL_GRIPPERS := --gripper franka_hand --gripper allegro_right --gripper $(BARRETT)

# each gripper with its default spec, the paper's sampling and the follow-up's,
# each plan's choice beside 3 random feasible candidates of the same plan
eval: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --objects paper13 --followup \
		--trials 10 --seed 0 --baseline random --json-out eval-results/paper13.json \
		--md-out eval-results/paper13.md
	$(PUBLISH) --command "make eval" eval-results/paper13.json docs/results/eval/paper13.json

# pybullet_data's random objects, development range (000-299; 300-999 is held out)
eval-random: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --followup \
		--objects random:000-299 --trials 3 --seed 0 --baseline random \
		--json-out eval-results/random-dev.json --md-out eval-results/random-dev.md
	$(PUBLISH) --command "make eval-random" eval-results/random-dev.json \
		docs/results/eval/random-dev.json

# the held-out range, once, with the defaults chosen on the development range
eval-heldout: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --no-paper \
		--objects random:300-999 --trials 1 --seed 1 --baseline random \
		--json-out eval-results/random-heldout.json \
		--md-out eval-results/random-heldout.md
	$(PUBLISH) --command "make eval-heldout" eval-results/random-heldout.json \
		docs/results/eval/random-heldout.json

# the YCB development set (19 scanned household objects with their masses), read
# from where it lies (never copied here), beside chance: each plan's choice and 3
# random feasible candidates of the same plan, under the strict protocol
YCB_DIR ?= ../shared/objects/ycb
.PHONY: eval-ycb eval-chance eval-clutter
eval-ycb: $(STAMP)
	@test -d $(YCB_DIR) || { echo "no YCB set at $(YCB_DIR): pass YCB_DIR=..."; exit 2; }
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --no-paper --objects $(YCB_DIR) \
		--trials 2 --seed 0 --baseline random \
		--json-out eval-results/ycb.json --md-out eval-results/ycb.md
	$(PUBLISH) --command "make eval-ycb" eval-results/ycb.json docs/results/eval/ycb.json

# the choice against chance on random:000-099 under each protocol (docs: Results,
# Grasp success)
eval-chance: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	for protocol in strict lift; do \
		$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --no-paper --objects random:000-099 \
			--trials 1 --seed 0 --protocol $$protocol --baseline random \
			--json-out eval-results/chance-$$protocol.json \
			--md-out eval-results/chance-$$protocol.md || exit 1; \
		$(PUBLISH) --command "make eval-chance" eval-results/chance-$$protocol.json \
			docs/results/eval/chance-$$protocol.json || exit 1; \
	done

# clutter removal (docs: Results, Clutter): each gripper clears 20 pile and 20
# packed scenes of 5 held-out objects (random:300-999), pick until the table is
# clear, under the strict protocol; each scene a second time by random feasible
# candidates (chance)
eval-clutter: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	for scene in pile packed; do \
		$(BIN)/wsgrasp eval $(EVAL_GRIPPERS) --no-paper --scene $$scene \
			--objects random:300-999 --objects-per-scene 5 --scenes 20 --seed 1 \
			--baseline random --json-out eval-results/clutter-$$scene.json || exit 1; \
		$(PUBLISH) --command "make eval-clutter" eval-results/clutter-$$scene.json \
			docs/results/clutter/$$scene.json || exit 1; \
	done

# which score terms rank the grasps that hold first: each built-in gripper's
# choice and 15 random feasible candidates per scene of random:000-059, labelled
# under the strict protocol with every scorer's term (benchmarks/scorer_concordance.py)
.PHONY: eval-scorers
eval-scorers: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/python benchmarks/scorer_concordance.py --objects random:000-059 \
		--random 15 --commit "$(COMMIT)"

# every URDF under GRIPPERS_DIR (the vendor descriptions wsgrasp is developed
# against), and three URDFs pybullet ships, outside that development set (an
# xArm gripper and a Franka Panda, each below its arm, and the PR2 gripper),
# scaffolded with no edit, tuned (gripper tune on random:000-119), checked,
# planned on the bundled scenes and tried on
# random:000-299 x 1 (the lift protocol; PROTOCOL=strict for eval's default), and
# every built-in and example gripper: docs/results/grippers.json, the docs'
# gripper table (benchmarks/eval_grippers.py)
# (EVAL_GRIPPERS_ARGS adds options to either target: `--only NAME --merge`
# re-runs one row into the published table)
GRIPPERS_DIR ?= ../shared/grippers
PROTOCOL ?= lift
GRIPPERS_OUT ?= eval-results/grippers
GRIPPERS_RESULTS ?= docs/results/grippers.json
eval-grippers: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[sim]'
	$(BIN)/python benchmarks/eval_grippers.py --grippers-dir $(GRIPPERS_DIR) \
		--also-dir "$$($(BIN)/python -c 'import pybullet_data; print(pybullet_data.getDataPath())')" \
		--also xarm/xarm6_with_gripper.urdf --also franka_panda/panda.urdf \
		--also pr2_gripper.urdf --protocol $(PROTOCOL) --tune \
		--out $(GRIPPERS_OUT) --results $(GRIPPERS_RESULTS) $(GRIPPERS_README) \
		$(EVAL_GRIPPERS_ARGS)

# the same under the strict protocol (wsgrasp eval's default), rendered on the
# Results: grippers page beside the lift run; the README's table gets its success
# beside the lift run's
eval-grippers-strict: $(STAMP)
	$(MAKE) eval-grippers PROTOCOL=strict GRIPPERS_OUT=eval-results/grippers-strict \
		GRIPPERS_RESULTS=docs/results/grippers-strict.json GRIPPERS_README=--no-readme
	$(BIN)/python benchmarks/eval_grippers.py --readme docs/results/grippers.json

# a default install (numba included); the dense entries' `compiled` field says
# which kernels ran. Writes docs/results/bench.json (the docs' Speed page)
bench: $(STAMP)
	@mkdir -p bench-results
	$(BIN)/wsgrasp bench --json > bench-results/bench.json
	$(PUBLISH) --command "make bench" bench-results/bench.json docs/results/bench.json

# wsgrasp's plan beside GPG's candidate generation (benchmarks/peers.py); not in
# `make test`. GPG's binding (grasp-pose-generator, an sdist) builds with CMake
# against Debian's PCL; its setup.py asks for a vcpkg toolchain (none is needed:
# /dev/null) and a platform name CMake's Makefiles take (benchmarks/gpg_build.cfg),
# and its pybind11 finds Python on PATH unless VIRTUAL_ENV names this one
PEERS_APT := libpcl-dev cmake g++
bench-peers: $(STAMP)
	@missing=$$(for p in $(PEERS_APT); do dpkg -s $$p >/dev/null 2>&1 || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	  if [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
	    echo "wsgrasp: installing" $$missing "(GPG builds against them) with apt"; \
	    apt-get update -qq; \
	    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
	      --no-install-recommends $$missing >/dev/null; \
	  else \
	    echo "wsgrasp: GPG builds against" $$missing". Install them with:" >&2; \
	    echo "    sudo apt-get install -y --no-install-recommends" $$missing >&2; \
	    exit 1; \
	  fi; \
	fi
	@echo "wsgrasp: installing grasp-pose-generator (built from source the first time)"
	VIRTUAL_ENV=$(abspath $(VENV)) VCPKG_TOOLCHAIN_FILE=/dev/null \
		DIST_EXTRA_CONFIG=$(CURDIR)/benchmarks/gpg_build.cfg \
		$(BIN)/python -m pip install -q -e '.[peers]'
	$(BIN)/python benchmarks/peers.py

schema: $(STAMP)
	$(BIN)/wsgrasp schema

clean:
	rm -rf $(VENV) demo runs eval-results site .pytest_cache .mypy_cache .ruff_cache
