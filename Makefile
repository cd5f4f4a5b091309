# Two entry points, each creating the virtual environment on first use:
#   make demo   set up and run the main demo (writes out/gallery.html)
#   make test   set up, lint and run the test suite (tests/ and notebooks/)
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Machines of this project keep a CPU build of PyTorch under /opt/wheels.
FIND_LINKS := $(if $(wildcard /opt/wheels),--find-links /opt/wheels,)

.PHONY: setup demo test lint bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet $(FIND_LINKS) -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/python -m hotu_drake.demo --out out

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

clean:
	rm -rf $(VENV) out
