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
