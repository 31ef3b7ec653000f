# grouptron: `make demo` runs the main job, `make test` runs the checks. Both install first.
VENV   ?= .venv
PYTHON ?= python3
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed

# Use the benchmark copy next to the checkout when there is one; otherwise the CLI falls back
# to the user cache and `grouptron data fetch` downloads the files there.
SHARED_DATA := $(abspath ../shared/data/eth_ucy)
ifeq ($(GROUPTRON_DATA),)
ifneq ($(wildcard $(SHARED_DATA)/SHA256SUMS),)
export GROUPTRON_DATA := $(SHARED_DATA)
endif
endif

.PHONY: install demo test lint typecheck bench clean

install: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	# The tested CPU build of PyTorch; installing it first keeps pip from pulling a CUDA wheel.
	$(BIN)/pip install --quiet torch==2.13.0
	$(BIN)/pip install --quiet -e '.[dev]'
	touch $(STAMP)

# The paper's Tables I and II (most likely predictions) from the shipped checkpoints.
demo: install
	$(BIN)/grouptron data fetch
	$(BIN)/grouptron report --mode ml --models trajectron++,grouptron --seeds 0

lint: install
	$(BIN)/ruff check src tests benchmarks campaign examples
	$(BIN)/ruff format --check src tests benchmarks campaign examples
	$(BIN)/lint-imports

typecheck: install
	$(BIN)/mypy

test: lint typecheck
	$(BIN)/pytest -q

bench: install
	$(BIN)/python benchmarks/preprocessing.py
	$(BIN)/python benchmarks/training.py
	$(BIN)/python benchmarks/groups.py
	$(BIN)/python benchmarks/streaming.py --frames 40

clean:
	rm -rf $(VENV) .mypy_cache .ruff_cache .pytest_cache
