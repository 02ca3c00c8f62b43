# Two commands on a fresh machine (Python 3.11):  make demo   |   make test
PYTHON ?= python3.11
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
DEMO_SCENE ?= scenes/paper_room.ses
DEMO_OUT   ?= out/demo

.PHONY: setup test test-fast demo addon bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[render,vo,test]'
	touch $(STAMP)

setup: $(STAMP)

test: $(STAMP)
	$(PY) -m pytest -q

test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not render and not slow"

demo: $(STAMP)
	$(PY) -m blender_sesgen check $(DEMO_SCENE)

addon:
	$(PY) -m blender_sesgen.addon.package --out dist

bench: $(STAMP)
	@for b in bench/*.py; do echo "== $$b"; $(PY) $$b || exit 1; done

clean:
	rm -rf out dist build .pytest_cache
