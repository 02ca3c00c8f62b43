"""Shared test fixtures and markers.

Tiers: pure tests (no bpy), ``render`` tests (bpy, tiny Cycles renders), ``data`` tests
(real data in ../shared/data; skipped with the reason when it is absent); ``slow`` marks
the long end-to-end runs. ``make test`` runs them all on parallel workers (pytest-xdist);
``make test-fast`` only the pure tier.

Hypothesis profiles: ``quick`` (the default) runs a fifth of each property's examples,
``HYPOTHESIS_PROFILE=fuzz`` the full count (``markers.examples``).
"""
from __future__ import annotations

import os
from pathlib import Path

import pytest
from hypothesis import HealthCheck, settings

from markers import FULL_EXAMPLES

# Under `make test` two workers share the two cores: OpenBLAS's second thread per worker only spins
# (test_still_split alone, load ~6: 44.2 -> 33.5 CPU s and 35.3 -> 31.0 s wall with one thread). Set
# before numpy loads in the worker (nothing imports it before this file); the renders' children inherit it.
if os.environ.get("PYTEST_XDIST_WORKER"):
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

REPO = Path(__file__).resolve().parents[1]
settings.register_profile("fuzz", max_examples=FULL_EXAMPLES, deadline=None)
settings.register_profile("quick", max_examples=FULL_EXAMPLES // 5, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "quick"))

SHARED_DATA = Path(os.environ.get("SESGEN_SHARED_DATA", REPO.parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real test data not found at {SHARED_DATA} (set SESGEN_SHARED_DATA)")
    return SHARED_DATA


@pytest.fixture(scope="module")
def layout_render(request, tmp_path_factory) -> Path:
    """A render folder of tests/layout_scene.py (written without Blender) with the test
    module's ``N`` frames (default 4); the export-layout tests read it back."""
    pytest.importorskip("cv2")
    pytest.importorskip("OpenEXR")
    from layout_scene import write_layout_render
    return write_layout_render(tmp_path_factory.mktemp("layout") / "r", n=getattr(request.module, "N", 4))


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


# Where the suite's time goes: SESGEN_TEST_TIMES=FILE appends a JSON line as each test file ends
# (CPU seconds of the worker and of the children it waited for, wall seconds, start and end);
# tools/test_times.py sums them.
_TIMES_PATH = os.environ.get("SESGEN_TEST_TIMES")


def _cpu_s() -> float:
    import resource
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


if _TIMES_PATH:
    _file: dict = {}

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(item, nextitem):
        import json
        import time
        path = item.location[0]
        if _file.get("file") != path:
            _file.clear()
            _file.update(file=path, cpu0=_cpu_s(), start=time.time(), tests=0)
        yield
        _file["tests"] += 1
        if nextitem is None or nextitem.location[0] != path:   # the file's module fixtures are torn down
            end = time.time()
            rec = {"file": path, "worker": os.environ.get("PYTEST_XDIST_WORKER", "main"), "tests": _file["tests"],
                   "cpu_s": _cpu_s() - _file["cpu0"], "wall_s": end - _file["start"], "start": _file["start"],
                   "end": end}
            with open(_TIMES_PATH, "a") as f:
                f.write(json.dumps(rec) + "\n")
            _file.clear()


# The test files that take longest, longest first: every file of 5 CPU s or more in the fresh-clone run of
# 1218a88 (session 21, SESGEN_TEST_TIMES; test_scene_library and test_still_split at their suite21 figures),
# by CPU seconds. Ray's workers are not the worker's waited-for children, so SESGEN_TEST_TIMES counts little
# of the Ray files' CPU (test_farm_ray: 29 of 110 CPU s, test_study_render: ~2/3): they stand by their trees'
# CPU (bench/cpu_tree.py), test_farm_ray third so that its waits on Ray overlap the other worker's files.
# `make test` hands whole files to whichever worker is free, in collection order (pytest-xdist --dist
# loadfile --no-loadscope-reorder): these start first, so that the short files fill in at the end instead
# of one long file running alone on one worker (session 20's test_study_pure, test_twin_bench and
# test_vo_install, 7 CPU s each, started last in alphabetical order; test_scene_library, 88, 17th).
SLOWEST_FIRST = [
    "test_study_render.py", "test_scene_library.py", "test_farm_ray.py", "test_sensor_render.py",
    "test_still_split.py", "test_addon_blender.py", "test_mono_pipeline.py", "test_render_reliability.py",
    "test_render_cli.py", "test_render_photoreal.py", "test_scene_variations.py", "test_stereo_dynamic.py",
    "test_car_detail.py", "test_culling_render.py", "test_culling.py", "test_sensor_exports.py",
    "test_evaluate_evo.py", "test_render_integrity.py", "test_render_byo.py", "test_stereo_render.py",
    "test_building_shell.py", "test_quality_presets.py", "test_api_docs.py", "test_ground_floor.py",
    "test_still_frames.py", "test_sky_table.py", "test_assets.py", "test_exposure_metering.py",
    "test_render_dynamics.py", "test_exposure_cache.py", "test_render_textures.py", "test_mono_render.py",
    "test_vo_install.py", "test_twin_bench.py", "test_glow_glazing.py", "test_contract_homes.py",
    "test_evaluate_cli.py", "test_render_oracle.py", "test_study_pure.py", "test_render_assets.py",
    "test_cli_startup.py", "test_render_lighting.py", "test_city_grid.py", "test_refusals.py",
    "test_roller_shutters.py", "test_generate.py", "test_products_kitti_sceneflow.py", "test_stereo_cli.py",
    "test_fuzz_readers.py",
]


def pytest_collection_modifyitems(session, config, items):
    rank = {name: i for i, name in enumerate(SLOWEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))   # stable: the rest keep their order
