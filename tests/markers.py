"""What a test needs, said without importing it, and how many examples a property gets.

- :func:`needs`: skip unless a module is installed, checked with ``find_spec`` (no import:
  collecting a render test must not load Blender or Ray into the test process; the renders
  run in child processes, and a test that needs the module imports it itself).
- :func:`examples`: a property's example count under the loaded hypothesis profile
  (``conftest``): the full count under ``HYPOTHESIS_PROFILE=fuzz``, a fraction by default.
"""
from __future__ import annotations

import importlib.util

import pytest
from hypothesis import settings

FULL_EXAMPLES = 100   # the fuzz profile's max_examples (hypothesis' own default): counts as written


def installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):
        return False


def needs(*modules: str, reason: str = "") -> pytest.MarkDecorator:
    """``skipif`` any of ``modules`` is not installed (the skip names them)."""
    missing = [m for m in modules if not installed(m)]
    return pytest.mark.skipif(bool(missing), reason=f"needs {', '.join(missing)}{' (' + reason + ')' if reason else ''}")


def examples(full: int, quick_most: int | None = None) -> int:
    """``full`` examples under the fuzz profile; the default profile's share of it (>= 5), at
    most ``quick_most`` (a property whose every example costs a whole parse of a large scene)."""
    share = max(5, round(full * settings.default.max_examples / FULL_EXAMPLES))
    if quick_most is not None and settings.default.max_examples < FULL_EXAMPLES:
        share = min(share, max(5, quick_most))
    return share
