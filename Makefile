# The two commands of the README: `make demo` and `make test`. Both build .venv on first use.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
XVFB := xvfb-run -a -s "-screen 0 1920x1080x24"

.PHONY: demo test lint docs-api system-deps clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed-core: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml $(VENV)/.installed-core
	$(BIN)/python -m pip install --quiet -e ".[test,docs,psychopy,photometer]"
	touch $@

demo: $(VENV)/.installed-core
	$(BIN)/glarelab demo --protocol yoshida2008 --out out/demo

system-deps:
	bash scripts/system-deps.sh

lint: $(VENV)/.installed-test
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

# The API reference (docs/api/conf.py), nitpicky: a dead cross-reference or a docstring Sphinx
# cannot read fails the build. The pages are generated afresh each time.
docs-api: $(VENV)/.installed-test
	rm -rf docs/api/generated out/api
	$(BIN)/python -m sphinx -b html -n -W --keep-going -j auto -q docs/api out/api

# Two streams of tests at once, one per core, each on its own X screen (screen tests read back
# their own windows): the documented commands in fresh clones, the session screens and other
# runs of whole commands in the second, the rest in the first, about 22 minutes each. The second
# stream's log is printed after the first's; either failing fails the target.
SECOND_STREAM := tests/test_docs.py tests/experiments/test_pixel_exact.py \
	tests/experiments/test_real_keys.py tests/experiments/test_sessions.py \
	tests/experiments/test_session_safety.py tests/stimuli/test_photometer.py \
	tests/test_faults.py tests/test_install.py tests/test_demo.py tests/test_cli.py

test: $(VENV)/.installed-test system-deps lint docs-api
	@mkdir -p out
	@if command -v xvfb-run >/dev/null 2>&1; then set -- $(XVFB); else set --; fi; \
	"$$@" $(BIN)/python -m pytest -p no:cacheprovider --durations=20 $(SECOND_STREAM) > out/test-second.log 2>&1 & \
	second=$$!; sleep 3; \
	"$$@" $(BIN)/python -m pytest -p no:cacheprovider --durations=20 $(addprefix --ignore=,$(SECOND_STREAM)); \
	first=$$?; wait $$second; status=$$?; \
	echo "=== the second stream: $(SECOND_STREAM)"; cat out/test-second.log; \
	test $$first -eq 0 && test $$status -eq 0

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache .hypothesis docs/api/generated
