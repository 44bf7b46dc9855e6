# The two entry points of the README: `make demo` and `make test`. Both set up .venv first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: demo test setup system-deps

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml package-lock.json
	scripts/install-web-deps.sh
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet -e ".[dev]"
	touch $@

demo: setup
	$(BIN)/microg demo

system-deps:
	scripts/install-system-deps.sh

# Two test processes, each module in one of them (its module-scoped fixtures are built once).
test: setup system-deps
	$(BIN)/pytest -n 2 --dist loadscope
