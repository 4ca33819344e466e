# The two commands a newcomer needs: `make demo` (the main job) and `make test` (every check).
# Both create .venv and install whatever is missing, Graphviz's `dot` included.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp
DEMO_OUT ?= demo-output

.PHONY: demo test lint typecheck unit docs bench graphviz venv clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check -e '.[dev]'
	@touch $(STAMP)

# Debian's graphviz provides `dot`; install it when missing and we may (root + apt-get).
graphviz:
	@if command -v dot >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Debian's graphviz (dot is missing)"; \
		DEBIAN_FRONTEND=noninteractive apt-get update -qq >/dev/null && \
		DEBIAN_FRONTEND=noninteractive apt-get install -y -qq graphviz >/dev/null; \
	else \
		echo "warning: Graphviz 'dot' is missing; install it (Debian: sudo apt-get install graphviz) to render .svg/.png (.dot files are still written)"; \
	fi

lint: $(STAMP)
	$(BIN)/ruff check pirate_bt tests benchmarks
	$(BIN)/ruff format --check pirate_bt tests benchmarks

typecheck: $(STAMP)
	$(BIN)/mypy --strict pirate_bt

unit: $(STAMP) graphviz
	$(BIN)/pytest

docs: $(STAMP)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir site

test: lint typecheck unit docs

demo: $(STAMP) graphviz
	$(BIN)/pirate-bt demo --output $(DEMO_OUT)

bench: $(STAMP) graphviz
	@for b in benchmarks/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) site dist build $(DEMO_OUT) .mypy_cache .ruff_cache .pytest_cache .hypothesis
