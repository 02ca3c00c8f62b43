# Two commands on a fresh machine (Python 3.11):  make demo   |   make test
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
DEMO_SCENE ?= scenes/paper_room.ses
DEMO_PHOTOREAL ?= scenes/city_kitti.ses
DEMO_OUT   ?= out/demo

.PHONY: setup test test-fast demo addon bench clean

$(STAMP): pyproject.toml
	@$(PYTHON) -c 'import sys; sys.exit(0 if sys.version_info[:2] == (3, 11) else "needs Python 3.11 (the bpy 5.0.1 wheel): make PYTHON=/path/to/python3.11 ...")'
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[render,vo,farm,test]'
	touch $(STAMP)

setup: $(STAMP)

# The whole suite on parallel workers (pytest-xdist; TEST_WORKERS=0 runs it in one process);
# each test file stays on one worker, so its module fixtures (renders, the Ray cluster) are made once;
# the files start in collection order, the longest first (tests/conftest.py: SLOWEST_FIRST).
TEST_WORKERS ?= auto
XDIST := --dist loadfile --no-loadscope-reorder
test: $(STAMP)
	$(PY) -m pytest -q -n $(TEST_WORKERS) $(XDIST)

# The pure tier: no Blender render, no long end-to-end run.
test-fast: $(STAMP)
	$(PY) -m pytest -q -n $(TEST_WORKERS) $(XDIST) -m "not render and not slow"

# The main job: a photoreal street (3 frames of the scene library's city_kitti.ses, half size) and
# the SESGen paper room: script -> render (half resolution, the draft preset at 4 denoised samples)
# -> contact sheet -> both stereo VOs -> report.
demo: $(STAMP)
	$(VENV)/bin/sesgen check $(DEMO_PHOTOREAL)
	$(VENV)/bin/sesgen render $(DEMO_PHOTOREAL) --out $(DEMO_OUT)/photoreal --frames 0:3 --resolution-scale 0.5 --quality draft --samples 4 --resume --force --contact-sheet
	$(VENV)/bin/sesgen check $(DEMO_SCENE)
	$(VENV)/bin/sesgen render $(DEMO_SCENE) --out $(DEMO_OUT)/render --resolution-scale 0.5 --quality draft --samples 4 --resume --force --contact-sheet
	$(VENV)/bin/vo-reference run $(DEMO_OUT)/render --report $(DEMO_OUT)/report
	@echo "demo: contact sheets $(DEMO_OUT)/photoreal/contact_sheet.png and $(DEMO_OUT)/render/contact_sheet.png, report $(DEMO_OUT)/report/"


# The Blender extension zip needs only the standard library: any Python >= 3.11, no .venv, no Blender.
addon:
	$(PYTHON) -m blender_sesgen.addon.package --out dist

# The speed and quality figures of the docs, each bench with its defaults (hours on 2 cores:
# quality.py renders a 4096-sample reference once, then caches it; fuzz_campaign.py and
# identical_renders.py are checks, run them by hand).
BENCHES := bench_completion bench_evaluate bench_stereo_vo bench_mono bench_render bench_gt_cost bench_memory bench_farm quality
bench: $(STAMP)
	@for b in $(BENCHES); do echo "== bench/$$b.py"; $(PY) bench/$$b.py || exit 1; done

clean:
	rm -rf out dist build .pytest_cache
