"""``pip install blender-sesgen[vo]`` without bpy gives a working ``vo-reference`` command.

Offline and honest: the project's wheel is built here (``pip wheel --no-build-isolation``),
installed by pip into a fresh virtual environment with no site packages, whose only other
packages are exactly the distributions that the wheel's base and ``[vo]`` requirements
resolve to (read from pyproject.toml and, recursively, from each distribution's metadata,
as pip resolves them), taken from this environment -- bpy is not among them. pip's own
``check`` confirms the requirements are met; then the installed ``vo-reference`` script runs
the VO workflow on a render folder, and importing all of vo_reference there loads nothing of
blender_sesgen beyond its contract (the source-level import graph is tests/test_architecture.py).
"""
from __future__ import annotations

import ast
import json
import os
import shutil
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
packaging_req = pytest.importorskip("packaging.requirements")
from packaging.utils import canonicalize_name  # noqa: E402  (packaging is pytest's own dependency)

pytestmark = pytest.mark.slow   # subprocesses and end-to-end runs (left out of make test-fast)


def vo_requirements() -> list[str]:
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    return list(project["dependencies"]) + list(project["optional-dependencies"]["vo"])


def resolve(requirements: list[str]) -> dict[str, metadata.Distribution]:
    """{name: distribution} of the requirements and all they need (markers evaluated for this
    interpreter, no extras), each found installed here at a version the specifier allows."""
    found: dict[str, metadata.Distribution] = {}
    todo = list(requirements)
    while todo:
        req = packaging_req.Requirement(todo.pop())
        if req.marker is not None and not req.marker.evaluate({"extra": ""}):
            continue
        name = canonicalize_name(req.name)
        if name in found:
            continue
        dist = metadata.distribution(req.name)
        assert req.specifier.contains(dist.version, prereleases=True), (str(req), dist.version)
        found[name] = dist
        todo += dist.requires or []
    return found


def test_the_vo_extra_is_complete_and_has_no_blender():
    names = set(resolve(vo_requirements()))
    assert {"numpy", "openexr", "opencv-python-headless", "scipy", "matplotlib"} <= names
    assert "bpy" not in names
    project = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["scripts"]["vo-reference"] == "vo_reference.cli:main"
    assert project["optional-dependencies"]["render"] == ["bpy==5.0.1"]


@pytest.fixture(scope="module")
def vo_venv(tmp_path_factory) -> Path:
    """A fresh venv: the project's wheel (installed by pip) + the [vo] closure, nothing else."""
    tmp = tmp_path_factory.mktemp("vo_install")
    src = tmp / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy2(REPO / name, src / name)
    for pkg in ("blender_sesgen", "vo_reference"):
        shutil.copytree(REPO / pkg, src / pkg, ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    r = subprocess.run(pip + ["wheel", "--no-deps", "--no-build-isolation", "--no-index", "-q", "-w", str(tmp / "dist"),
                              str(src)], capture_output=True, text=True, timeout=300, env=_clean_env(), cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    (wheel,) = (tmp / "dist").glob("blender_sesgen-*.whl")
    venv = tmp / "venv"
    r = subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], capture_output=True, text=True,
                       timeout=120, env=_clean_env(), cwd=tmp)
    assert r.returncode == 0, r.stderr
    py = venv / "bin" / "python"
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               capture_output=True, text=True, check=True, env=_clean_env(), cwd=tmp).stdout.strip())
    deps = tmp / "deps"
    deps.mkdir()
    for dist in resolve(vo_requirements()).values():
        for top in {f.parts[0] for f in dist.files or [] if f.parts and f.parts[0] != ".."}:
            src_path = Path(dist.locate_file(top))
            if src_path.exists() and not (deps / top).exists():
                (deps / top).symlink_to(src_path, target_is_directory=src_path.is_dir())
    (site / "vo_deps.pth").write_text(str(deps) + "\n")
    r = subprocess.run(pip + ["--python", str(py), "install", "--no-deps", "--no-index", "-q", str(wheel)],
                       capture_output=True, text=True, timeout=300, env=_clean_env(), cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    assert (venv / "bin" / "vo-reference").is_file() and (site / "vo_reference").is_dir(), r.stdout + r.stderr
    return venv


def _clean_env() -> dict:
    """This environment without what would let the checkout leak into the fresh one."""
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV")}


def _run(venv: Path, *args) -> subprocess.CompletedProcess:
    """Run in the venv's own folder, so that the checkout is not the current folder either."""
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=600, cwd=venv,
                          env=_clean_env())


def test_pip_sees_the_requirements_met_and_no_blender(vo_venv):
    py = vo_venv / "bin" / "python"
    r = subprocess.run([sys.executable, "-m", "pip", "--disable-pip-version-check", "--python", str(py), "check"],
                       capture_output=True, text=True, timeout=120, env=_clean_env(), cwd=vo_venv)
    assert r.returncode == 0 and "No broken requirements" in r.stdout, r.stdout + r.stderr
    r = _run(vo_venv, py, "-c", "import bpy")
    assert r.returncode != 0 and "No module named 'bpy'" in r.stderr
    r = _run(vo_venv, py, "-c", "import vo_reference, blender_sesgen; print(vo_reference.__file__)")
    assert r.returncode == 0 and str(vo_venv) in r.stdout, r.stderr     # the installed copy, not the repo


def test_vo_reference_command_works_without_blender(vo_venv, tmp_path):
    py, vo = vo_venv / "bin" / "python", vo_venv / "bin" / "vo-reference"
    r = _run(vo_venv, vo, "--help")
    assert r.returncode == 0 and "stereo-vo" in r.stdout and "export" in r.stdout, r.stderr
    from synthetic_render import plane_scene            # the test fixture (not part of the install)
    render = plane_scene(tmp_path / "render", frames=4)
    for target in ("kitti-odometry", "tartanair", "vkitti2", "sceneflow", "euroc"):
        r = _run(vo_venv, vo, "export", render, tmp_path / target, "--to", target, "--progress", "json")
        assert r.returncode == 0, (target, r.stderr)
        assert json.loads(r.stderr.splitlines()[-1])["status"] == "ok"
    est = tmp_path / "est.txt"
    r = _run(vo_venv, vo, "stereo-vo", render, "--gt-depth", "--gt-flow", "--out", est)
    assert r.returncode == 0 and est.is_file(), r.stderr
    r = _run(vo_venv, vo, "evaluate", "--gt", render, "--est", est, "--align", "origin")
    assert r.returncode == 0 and "APE translation" in r.stdout, r.stderr
    # the renderer says what it needs instead of failing obscurely
    r = _run(vo_venv, vo_venv / "bin" / "sesgen", "render", REPO / "scenes" / "minimal.ses", "--out", tmp_path / "r")
    assert r.returncode == 2 and "needs Blender's Python module 'bpy'" in r.stderr
    # importing all of vo_reference loads nothing of blender_sesgen but its contract
    probe = ("import importlib, pkgutil, sys, vo_reference\n"
             "for i in pkgutil.walk_packages(vo_reference.__path__, 'vo_reference.'):\n"
             "    if not i.name.endswith('__main__'): importlib.import_module(i.name)\n"
             "print(sorted(m for m in sys.modules if m.startswith('blender_sesgen')))\n")
    r = _run(vo_venv, py, "-c", probe)
    loaded = ast.literal_eval(r.stdout.strip()) if r.returncode == 0 else None
    assert loaded and "blender_sesgen.contract.progress" in loaded, r.stdout + r.stderr
    assert all(m in ("blender_sesgen", "blender_sesgen.contract") or m.startswith("blender_sesgen.contract.")
               for m in loaded), loaded
