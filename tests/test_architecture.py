"""The architecture, checked from the source: the import graph of both packages (imports
inside functions included, imports of ancestor packages and the packages' root modules
too) has no cycle at module or package level, bpy stays in the bpy layer, the contract
stays numpy-only, and the two packages meet only at the contract.

Then at run time: every pure module imports in a fresh interpreter where bpy is blocked;
a module that needs an optional dependency this machine lacks is reported as such, not as
a breach of the boundary.
"""
from __future__ import annotations

import ast
import functools
import subprocess
import sys
import textwrap
from collections import defaultdict
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("blender_sesgen", "vo_reference")
BPY = {"bpy", "bmesh", "mathutils", "bpy_extras", "addon_utils"}
BPY_LAYER = ("blender_sesgen.blender", "blender_sesgen.addon")
# add-on modules that are pure on purpose (the panel's state, the preview maths, the zip builder)
PURE_ADDON = {"blender_sesgen.addon.state", "blender_sesgen.addon.preview", "blender_sesgen.addon.package"}
CONTRACT = "blender_sesgen.contract"
FARM, FARM_EXTRA = "blender_sesgen.farm", {"ray"}   # the render farm may use Ray (the [farm] extra)
# the render sessions: Blender's (started by the job) and the one that reuses a render's EXRs
BACKEND_BOUNDARY = (("blender_sesgen.render.job", "blender_sesgen.render.reuse"), "blender_sesgen.blender")
OPTIONAL = {"cv2", "scipy", "OpenEXR", "matplotlib", "yaml", "evo", "rosbags", "ray", "pykitti"}


def module_name(path: Path) -> str:
    rel = path.relative_to(REPO).with_suffix("")
    parts = rel.parts[:-1] if rel.name == "__init__" else rel.parts
    return ".".join(parts)


@functools.lru_cache(maxsize=1)
def all_modules() -> dict[str, Path]:
    return {module_name(p): p for pkg in PACKAGES for p in sorted((REPO / pkg).rglob("*.py"))
            if "__pycache__" not in p.parts}


def imports_of(name: str, path: Path, eager_only: bool = False) -> set[str]:
    """Absolute names of everything ``name`` imports, anywhere in the file. ``from pkg import
    x`` imports module ``pkg.x`` where there is one, else ``x`` from ``pkg``'s ``__init__``:
    an edge to ``pkg`` (an ancestor package too: ``from .. import __version__``)."""
    known = all_modules()
    is_pkg = path.name == "__init__.py"
    base = name.split(".") if is_pkg else name.split(".")[:-1]
    out = set()
    tree = ast.parse(path.read_text(encoding="utf-8"))
    if eager_only:   # leave out the imports inside functions
        for f in ast.walk(tree):
            if isinstance(f, (ast.FunctionDef, ast.AsyncFunctionDef)):
                f.body = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                anchor = base[:len(base) - node.level + 1]
                mod = ".".join(anchor + ([node.module] if node.module else []))
            else:
                mod = node.module
            subs = {f"{mod}.{a.name}" for a in node.names}
            out.update(subs)                                    # `from pkg import module`
            ancestor = (name + ".").startswith(mod + ".")
            if not ancestor or not subs <= known.keys():       # a name defined in pkg/__init__
                out.add(mod)
    return out


@pytest.fixture(scope="module")
def graph() -> dict[str, set[str]]:
    mods = all_modules()
    g = {}
    for name, path in mods.items():
        g[name] = {i for i in imports_of(name, path) if i in mods and i != name}
    return g


@pytest.fixture(scope="module")
def raw_imports() -> dict[str, set[str]]:
    return {name: imports_of(name, path) for name, path in all_modules().items()}


def cycles(g: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one node (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(g):
        if v not in index:
            visit(v)
    return out


def package_of(module: str) -> str:
    """The subpackage a module belongs to: blender_sesgen.ses, vo_reference.io, ...; a root
    module (blender_sesgen.render.plan) is a unit of its own, and so is a package's ``__init__``."""
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 1 else parts[0]


def backend_boundary(a: str, b: str) -> bool:
    """The edges from render orchestration into the bpy layer: ``render.job`` starts the back
    end's session, ``render.reuse`` writes JPEGs with Blender's writer (lazily, inside a
    function: test_render_reaches_blender_only_lazily_in_the_sessions); the back end takes
    the render plan. Modules stay acyclic across them."""
    return a in BACKEND_BOUNDARY[0] and (b == BACKEND_BOUNDARY[1] or b.startswith(BACKEND_BOUNDARY[1] + "."))


def test_no_import_cycle_between_modules(graph):
    assert cycles(graph) == []


def test_no_import_cycle_between_packages(graph):
    pg = defaultdict(set)
    for a, targets in graph.items():
        for b in targets:
            pa, pb = package_of(a), package_of(b)
            # a subpackage importing its own parent's __init__ is a cycle too: only a module
            # importing a sibling inside its own subpackage stays inside
            if pa != pb and not backend_boundary(a, b) and not within(b, EXCEPTIONS.get(a, ())):
                pg[pa].add(pb)
    assert cycles(pg) == []


def test_the_graph_sees_ancestors_and_the_root(tmp_path):
    """``from . import __version__`` is an edge to the package's ``__init__`` (``from . import
    api`` one to the module), and the root's ``__init__`` is a node: the cycle __init__ ->
    addon -> addon.props -> render.plan -> __init__ would be found."""
    assert "blender_sesgen" in all_modules()
    f = tmp_path / "pipeline.py"
    f.write_text("from . import __version__, api\nfrom .contract import rig\n")
    edges = imports_of("blender_sesgen.pipeline", f)
    assert {"blender_sesgen", "blender_sesgen.api", "blender_sesgen.contract.rig"} <= edges
    f.write_text("from . import api\n")
    assert "blender_sesgen" not in imports_of("blender_sesgen.pipeline", f)
    g = {"blender_sesgen": {"blender_sesgen.addon"}, "blender_sesgen.addon": {"blender_sesgen.addon.props"},
         "blender_sesgen.addon.props": {"blender_sesgen.render.plan"}, "blender_sesgen.render.plan": {"blender_sesgen"}}
    assert cycles(g) == [sorted(g)]


def test_the_cycle_finder_finds_cycles():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]


def test_bpy_only_in_the_bpy_layer(raw_imports):
    offenders = [f"{m} imports {sorted(i.split('.')[0] for i in imps if i.split('.')[0] in BPY)}"
                 for m, imps in raw_imports.items()
                 if any(i.split(".")[0] in BPY for i in imps)
                 and not (m.startswith(BPY_LAYER) and m not in PURE_ADDON)]
    assert not offenders


def test_the_contract_needs_numpy_and_the_standard_library_only(raw_imports):
    allowed = set(sys.stdlib_module_names) | {"numpy", "__future__"}
    offenders = []
    for m, imps in raw_imports.items():
        if m == CONTRACT or m.startswith(CONTRACT + "."):
            bad = {i for i in imps if i.split(".")[0] not in allowed and not i.startswith(CONTRACT)}
            if bad:
                offenders.append(f"{m}: {sorted(bad)}")
    assert not offenders


def test_blender_sesgen_needs_blender_numpy_and_the_standard_library_only(raw_imports):
    """... and Ray in the render farm (the [farm] extra; the farm never runs inside Blender)."""
    allowed = set(sys.stdlib_module_names) | BPY | {"numpy", "__future__", "blender_sesgen"}
    offenders = [f"{m}: {sorted(bad)}" for m, imps in raw_imports.items() if m.startswith("blender_sesgen")
                 for bad in [{i for i in imps if i.split(".")[0] not in
                              (allowed | FARM_EXTRA if m.startswith(FARM + ".") else allowed)}] if bad]
    assert not offenders


def test_the_packages_meet_only_at_the_contract(raw_imports):
    offenders = []
    for m, imps in raw_imports.items():
        if m.startswith("vo_reference"):
            offenders += [f"{m} -> {i}" for i in imps if i.startswith("blender_sesgen")
                          and i != "blender_sesgen" and not i.startswith(CONTRACT)]
        else:
            offenders += [f"{m} -> {i}" for i in imps if i.startswith("vo_reference")]
    assert not offenders


# The layers (what each may import of the two packages; the standard library, numpy and
# the optional extras aside): ses -> scene -> render -> blender, the contract beside them,
# commands on top; in vo_reference the ground truth below the exporters.
LAYERS = {
    "blender_sesgen.scene": ("blender_sesgen.scene", CONTRACT),
    "blender_sesgen.ses": ("blender_sesgen.ses", "blender_sesgen.scene", CONTRACT, "blender_sesgen.files.image_check",
                           "blender_sesgen.errors"),
    "blender_sesgen.render": ("blender_sesgen.render", "blender_sesgen.scene", "blender_sesgen.ses", CONTRACT,
                              "blender_sesgen.files", "blender_sesgen.errors", BACKEND_BOUNDARY[1]),
    "vo_reference.exporters": ("vo_reference.exporters", "vo_reference.groundtruth", "vo_reference.io",
                               "vo_reference.camera", "vo_reference.errors", CONTRACT),
}
NEVER = {"vo_reference.groundtruth": ("vo_reference.exporters", "vo_reference.commands")}
COMMANDS = ("blender_sesgen.commands", "vo_reference.commands")   # imported by nothing but the packages' __main__
# Edges the layer rules allow by name, each with its reason: none. (A program that runs the
# command line is a command itself: the farm's child is commands.farm_child.)
EXCEPTIONS: dict[str, set[str]] = {}


def within(name: str, prefixes) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_each_layer_imports_only_the_layers_below(raw_imports):
    offenders = []
    for m, imps in raw_imports.items():
        for layer, allowed in LAYERS.items():
            if within(m, [layer]):
                offenders += [f"{m} -> {i}" for i in imps if within(i, PACKAGES) and not within(i, allowed)]
        for layer, forbidden in NEVER.items():
            if within(m, [layer]):
                offenders += [f"{m} -> {i}" for i in imps if within(i, forbidden) and not within(i, EXCEPTIONS.get(m, ()))]
        if not within(m, COMMANDS) and not m.endswith("__main__"):
            offenders += [f"{m} -> {i}" for i in imps if within(i, COMMANDS) and not within(i, EXCEPTIONS.get(m, ()))]
    assert not offenders


def test_render_reaches_blender_only_lazily_in_the_sessions():
    """The back-end boundary: render orchestration imports the bpy layer in ``render.job`` and
    ``render.reuse`` only, inside functions (planning and checking a render never import bpy)."""
    offenders = []
    for m, path in all_modules().items():
        if within(m, ["blender_sesgen.render"]):
            eager = {i for i in imports_of(m, path, eager_only=True) if within(i, [BACKEND_BOUNDARY[1]])}
            lazy = {i for i in imports_of(m, path) if within(i, [BACKEND_BOUNDARY[1]])}
            if eager or (lazy and m not in BACKEND_BOUNDARY[0]):
                offenders.append(f"{m}: {sorted(eager or lazy)}")
    assert not offenders


# --- at run time ------------------------------------------------------------------------

PROBE = textwrap.dedent("""
    import importlib, json, sys

    BLOCKED = set(sys.argv[1].split(","))
    OPTIONAL = set(sys.argv[2].split(","))

    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ImportError(f"{name} is blocked by the boundary test", name=name)
            return None

    sys.meta_path.insert(0, Block())
    report = {"breach": [], "optional_missing": []}
    for name in sys.argv[3:]:
        try:
            importlib.import_module(name)
        except ImportError as e:
            root = (e.name or "").split(".")[0]
            kind = "optional_missing" if root in OPTIONAL and root not in BLOCKED else "breach"
            report[kind].append(f"{name}: {e}")
        except Exception as e:
            report["breach"].append(f"{name}: {type(e).__name__}: {e}")
    leaked = sorted(m for m in sys.modules if m.split(".")[0] in BLOCKED)
    if leaked:
        report["breach"].append(f"blocked modules in sys.modules: {leaked}")
    print(json.dumps(report))
""")


def probe(modules, blocked=BPY):
    r = subprocess.run([sys.executable, "-c", PROBE, ",".join(sorted(blocked)), ",".join(sorted(OPTIONAL)), *modules],
                       cwd=REPO, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    import json
    return json.loads(r.stdout)


def pure_modules() -> list[str]:
    return [m for m in all_modules() if not (m.startswith(BPY_LAYER) and m not in PURE_ADDON)
            and not m.endswith("__main__")]


def test_every_pure_module_imports_without_bpy():
    report = probe(pure_modules())
    assert report["breach"] == []
    if report["optional_missing"]:  # not a breach: this machine lacks an optional extra
        print("optional dependencies missing here:", *report["optional_missing"], sep="\n  ")


def test_the_contract_imports_with_nothing_but_numpy():
    contract = [m for m in all_modules() if m.startswith(CONTRACT)]
    report = probe(contract, blocked=BPY | OPTIONAL | {"vo_reference"})
    assert report == {"breach": [], "optional_missing": []}


def test_a_missing_optional_dependency_is_not_a_breach():
    report = probe(["vo_reference.io.color", "vo_reference.groundtruth.flow"], blocked=BPY | {"cv2"})
    # cv2 is imported lazily in io.color (a function-level import): the module imports
    assert report["breach"] == []


def test_the_blocker_really_blocks():
    report = probe(["bpy"])
    assert report["breach"] and "blocked" in report["breach"][0]
