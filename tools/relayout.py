"""Move modules to the layout of issue 27 round two, and rewrite every reference to them.

    python tools/relayout.py            # move what is still at an old path, rewrite, print changes
    python tools/relayout.py --check    # change nothing; exit 1 if a file is at, or anything
                                        # imports or names, an old module path
    python tools/relayout.py --upto 3   # only the moves of steps 1..3 (see MOVES)

Re-runnable on any tree (e.g. after merging a branch that still uses the old paths):

1. ``git mv`` every tracked file still at an old path (a file already moved is left alone),
   and creates the new packages' ``__init__.py``;
2. rewrites imports in every tracked ``.py`` file with :mod:`ast` (``import``, ``from ...
   import``, absolute and relative, inside functions too): each is resolved to its absolute
   module, mapped, and written back relative to the importing file's *new* location
   (absolute ones stay absolute); only the module part of the statement is edited, except
   ``from pkg import module`` where the module moved to another package, which becomes one
   statement per new package. Relative module strings (``".render_cli"`` in a command table,
   resolved against the file's own package) are rewritten the same way;
3. rewrites dotted names (``-m vo_reference.products.export_cli``, importlib strings,
   ``[project.scripts]``, monkeypatch targets) and paths (``blender_sesgen/plan.py``) in
   ``.py``, ``.md``, ``.toml``, ``.cfg``, ``Makefile`` and ``.ci/`` files.

A relative import in a file that was moved before this run (a merge brought new lines into
it) is resolved against the file's new location first and, where nothing is there, against
its old one. The layer table in tests/test_architecture.py is kept by hand.
"""
from __future__ import annotations

import argparse
import ast
import re
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("blender_sesgen", "vo_reference")

# (step, old module or package, new module or package). A package moves with everything in it.
MOVES: list[tuple[int, str, str]] = [
    # 1. files/: our own pure file formats
    (1, "blender_sesgen.exr", "blender_sesgen.files.exr"),
    (1, "blender_sesgen.png", "blender_sesgen.files.png"),
    (1, "blender_sesgen.image_check", "blender_sesgen.files.image_check"),
    (1, "blender_sesgen.contact_sheet", "blender_sesgen.files.contact_sheet"),
    (1, "blender_sesgen.dataset", "blender_sesgen.files.dataset"),
    # 2. scene/: the pure scene model
    (2, "blender_sesgen.model", "blender_sesgen.scene.model"),
    (2, "blender_sesgen.dynamics", "blender_sesgen.scene.dynamics"),
    (2, "blender_sesgen.material_library", "blender_sesgen.scene.materials"),
    (2, "blender_sesgen.textures", "blender_sesgen.scene.textures"),
    (2, "blender_sesgen.lighting_data", "blender_sesgen.scene.lighting"),
    (2, "blender_sesgen.rounded_box", "blender_sesgen.scene.geometry.rounded_box"),
    (2, "blender_sesgen.assets", "blender_sesgen.scene.assets"),
    (2, "blender_sesgen.bounds", "blender_sesgen.scene.bounds"),
    # 3. render/: orchestration (plan, job, output folder, locks, sealing, sensor plan)
    (3, "blender_sesgen.plan", "blender_sesgen.render.plan"),
    (3, "blender_sesgen.presets", "blender_sesgen.scene.presets"),   # the RENDER statement names them: ses needs them
    (3, "blender_sesgen.job", "blender_sesgen.render.job"),
    (3, "blender_sesgen.output", "blender_sesgen.render.folder"),
    (3, "blender_sesgen.locks", "blender_sesgen.render.locks"),
    (3, "blender_sesgen.sealer", "blender_sesgen.render.sealer"),
    (3, "blender_sesgen.interrupt", "blender_sesgen.render.interrupt"),
    # (camera profiles, new on branch twins: named by the language's SENSOR profile, so model data)
    (3, "blender_sesgen.sensor.profiles", "blender_sesgen.scene.camera_profiles"),
    (3, "blender_sesgen.sensor", "blender_sesgen.render.sensor"),
    (3, "blender_sesgen.culling", "blender_sesgen.render.culling"),   # slam: render --cull
    (3, "blender_sesgen.reuse", "blender_sesgen.render.reuse"),       # speed: render --reuse-exr
    # 4. commands/ in both packages: parsers and printing
    (4, "blender_sesgen.cli", "blender_sesgen.commands.main"),
    (4, "blender_sesgen.render_cli", "blender_sesgen.commands.render"),
    (4, "blender_sesgen.check", "blender_sesgen.commands.check"),
    (4, "blender_sesgen.verify_cli", "blender_sesgen.commands.verify"),
    (4, "blender_sesgen.generate_cli", "blender_sesgen.commands.generate"),
    (4, "blender_sesgen.farm.cli", "blender_sesgen.commands.farm"),
    (4, "vo_reference.cli", "vo_reference.commands.main"),
    (4, "vo_reference.stereo.cli", "vo_reference.commands.stereo"),
    (4, "vo_reference.stereo.run_cli", "vo_reference.commands.run"),
    (4, "vo_reference.mono.cli", "vo_reference.commands.mono"),
    (4, "vo_reference.evaluate.cli", "vo_reference.commands.evaluate"),
    (4, "vo_reference.evaluate.disparity_cli", "vo_reference.commands.disparity"),
    (4, "vo_reference.products.export_cli", "vo_reference.commands.export"),
    (4, "blender_sesgen.study.cli", "blender_sesgen.commands.study"),
    (4, "vo_reference.study.cli", "vo_reference.commands.study"),
    (4, "vo_reference.products.covisibility_cli", "vo_reference.commands.covisibility"),
    # 5. vo_reference/products -> groundtruth/ (computed) + exporters/ (dataset layouts)
    (5, "vo_reference.products.disparity", "vo_reference.groundtruth.disparity"),
    (5, "vo_reference.products.flow", "vo_reference.groundtruth.flow"),
    (5, "vo_reference.products.scene_flow", "vo_reference.groundtruth.scene_flow"),
    (5, "vo_reference.products.dense_gt", "vo_reference.groundtruth.dense"),
    (5, "vo_reference.products.segmentation", "vo_reference.groundtruth.segmentation"),
    (5, "vo_reference.products.noise", "vo_reference.groundtruth.noise"),
    (5, "vo_reference.products.sparse_points", "vo_reference.groundtruth.sparse_points"),
    (5, "vo_reference.products.covisibility", "vo_reference.groundtruth.covisibility"),
    (5, "vo_reference.products.exports", "vo_reference.exporters.driver"),
    (5, "vo_reference.products.undistorted", "vo_reference.exporters.undistorted"),
    (5, "vo_reference.products.png_layout", "vo_reference.exporters.png"),
    (5, "vo_reference.products.kitti_odometry", "vo_reference.exporters.kitti_odometry"),
    (5, "vo_reference.products.kitti_stereo", "vo_reference.exporters.kitti_stereo"),
    (5, "vo_reference.products.kitti_sceneflow", "vo_reference.exporters.kitti_sceneflow"),
    (5, "vo_reference.products.sceneflow", "vo_reference.exporters.sceneflow_datasets"),
    (5, "vo_reference.products.tartanair", "vo_reference.exporters.tartanair"),
    (5, "vo_reference.products.tartanair_v2", "vo_reference.exporters.tartanair_v2"),
    (5, "vo_reference.products.vkitti2", "vo_reference.exporters.vkitti2"),
    (5, "vo_reference.products.euroc", "vo_reference.exporters.euroc"),
    (5, "vo_reference.products.tum", "vo_reference.exporters.tum"),
    (5, "vo_reference.products.rosbag_export", "vo_reference.exporters.rosbag"),
    (5, "vo_reference.products.semantic_export", "vo_reference.exporters.cityscapes"),
    (5, "vo_reference.products.label_polygons", "vo_reference.exporters.label_polygons"),
    (5, "vo_reference.products.bayer_export", "vo_reference.exporters.bayer"),
    (5, "vo_reference.products.colmap", "vo_reference.exporters.colmap"),
    (5, "vo_reference.products.nerfstudio", "vo_reference.exporters.nerfstudio"),
    (5, "vo_reference.products.slam_config", "vo_reference.exporters.slam_config"),
    (5, "vo_reference.products.middlebury", "vo_reference.exporters.middlebury"),
    (5, "vo_reference.products.sintel", "vo_reference.exporters.sintel"),
    # 6. names that say what they are
    (6, "vo_reference.evaluate._poses", "vo_reference.evaluate.poses"),
    (6, "vo_reference.realism", "vo_reference.evaluate.realism"),
    (6, "vo_reference.stereo.baseline", "vo_reference.stereo.opencv_comparison"),
]
# packages whose __init__.py is deleted once every module has moved out (step, package)
EMPTIED = [(5, "vo_reference.products")]
# new packages: their __init__ docstring
NEW_PACKAGES = {
    "blender_sesgen.files": "Our own pure file formats: EXR and PNG codecs, image checks, contact sheets, dataset indexes.",
    "blender_sesgen.scene": ("The scene model (pure): objects, motion, materials, textures, lighting, procedural assets, "
                             "the quality presets a RENDER statement names."),
    "blender_sesgen.scene.geometry": "Pure mesh geometry of the scene model's primitives.",
    "blender_sesgen.render": ("Render orchestration (pure; bpy only behind ``job``): the plan, the output folder, "
                              "its locks, sealing, Ctrl-C handling and the sensor plan."),
    "blender_sesgen.commands": ("The command line: one module per ``sesgen`` command, parsing and printing only; "
                                "nothing imports this package."),
    "vo_reference.commands": ("The command line: one module per ``vo-reference`` command, parsing and printing "
                              "only; nothing imports this package."),
    "vo_reference.groundtruth": ("Ground truth computed from renders: disparity, flow, scene flow, dense flow, "
                                 "segmentation, image noise, sparse points. Never imports the exporters."),
    "vo_reference.exporters": ("Dataset exports: one module per layout, registered in "
                               ":data:`vo_reference.exporters.driver.EXPORTERS`; the file formats they share."),
}
TEXT_SUFFIXES = {".py", ".md", ".toml", ".cfg", ".txt"}
SELF = Path(__file__).resolve()


def moves(upto: int) -> list[tuple[str, str]]:
    return [(o, n) for s, o, n in MOVES if s <= upto]


def map_name(name: str, table: list[tuple[str, str]]) -> str | None:
    """The new name of module ``name`` when it (or a package above it) moved, else None."""
    for old, new in table:
        if name == old or name.startswith(old + "."):
            return new + name[len(old):]
    return None


def unmap_name(name: str, table: list[tuple[str, str]]) -> str | None:
    for old, new in table:
        if name == new or name.startswith(new + "."):
            return old + name[len(new):]
    return None


def to_path(module: str, is_pkg: bool) -> Path:
    return Path(*module.split("."), "__init__.py") if is_pkg else Path(*module.split(".")).with_suffix(".py")


def module_of(rel: Path) -> tuple[str, bool]:
    parts = rel.with_suffix("").parts
    return (".".join(parts[:-1]), True) if rel.name == "__init__.py" else (".".join(parts), False)


def git(*args: str, root: Path) -> str:
    return subprocess.run(["git", *args], cwd=root, check=True, capture_output=True, text=True).stdout


def tracked(root: Path) -> list[Path]:
    return [Path(p) for p in git("ls-files", root=root).splitlines() if (root / p).is_file()]


# --- 1. the files ------------------------------------------------------------------------

def planned_moves(root: Path, table) -> list[tuple[Path, Path]]:
    """(old path, new path) of every tracked file still at an old path."""
    out = []
    for rel in tracked(root):
        if rel.parts[0] not in PACKAGES:
            continue
        if rel.suffix == ".py":
            mod, is_pkg = module_of(rel)
            new = map_name(mod, table)
            if new is not None:
                out.append((rel, to_path(new, is_pkg)))
        else:   # data inside a moved package
            mod = ".".join(rel.parent.parts)
            new = map_name(mod, table)
            if new is not None:
                out.append((rel, Path(*new.split(".")) / rel.name))
    return out


def move_files(root: Path, table, emptied, log) -> dict[Path, str]:
    """git mv; returns {new path: old module name} of the files moved now."""
    origin = {}
    for old, new in planned_moves(root, table):
        if (root / new).exists():
            raise SystemExit(f"relayout: {old} -> {new}: the target exists already (merge it by hand)")
        (root / new).parent.mkdir(parents=True, exist_ok=True)
        git("mv", str(old), str(new), root=root)
        if old.suffix == ".py":
            origin[new] = module_of(old)[0]
        log(f"moved   {old} -> {new}")
    for pkg, doc in NEW_PACKAGES.items():
        init = root / to_path(pkg, True)
        if init.parent.is_dir() and not init.exists():
            init.write_text(f'"""{doc}"""\n', encoding="utf-8")
            git("add", str(init.relative_to(root)), root=root)
            log(f"created {init.relative_to(root)}")
    for pkg in emptied:
        d = root / Path(*pkg.split("."))
        init = d / "__init__.py"
        if init.exists() and not [p for p in d.rglob("*") if p.is_file() and p != init and "__pycache__" not in p.parts]:
            git("rm", "-q", str(init.relative_to(root)), root=root)
            log(f"deleted {init.relative_to(root)} (every module moved out)")
    for pkg in PACKAGES:   # folders left with nothing but caches
        for d in sorted((root / pkg).rglob("*"), reverse=True):
            if d.is_dir() and d.name != "__pycache__" and not [p for p in d.rglob("*") if p.is_file()
                                                              and "__pycache__" not in p.parts]:
                for c in sorted(d.rglob("*"), reverse=True):
                    c.unlink() if c.is_file() else c.rmdir()
                d.rmdir()
    return origin


# --- 2. imports --------------------------------------------------------------------------

class Tree:
    """The modules of the tree now, and the names each package's ``__init__`` defines."""

    def __init__(self, root: Path):
        self.root = root
        self.modules = {}
        for pkg in PACKAGES:
            for p in (root / pkg).rglob("*.py"):
                if "__pycache__" not in p.parts:
                    self.modules[module_of(p.relative_to(root))[0]] = p
        self._names = {}

    def exists(self, module: str) -> bool:
        return module in self.modules

    def is_package(self, module: str) -> bool:
        return module in self.modules and self.modules[module].name == "__init__.py"

    def defines(self, package: str, name: str) -> bool:
        if package not in self._names:
            names = set()
            p = self.modules.get(package)
            if p is not None and p.name == "__init__.py":
                for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))):
                    if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                        names.add(node.name)
                    elif isinstance(node, ast.Name) and isinstance(node.ctx, ast.Store):
                        names.add(node.id)
                    elif isinstance(node, (ast.Import, ast.ImportFrom)):
                        names.update((a.asname or a.name).split(".")[0] for a in node.names)
            self._names[package] = names
        return name in self._names[package]


def resolve(package: str, level: int, module: str | None) -> str:
    parts = package.split(".")
    base = parts[:len(parts) - level + 1] if level > 1 else parts
    return ".".join(base + ([module] if module else []))


def relative(target: str, package: str) -> str:
    """``target`` written relative to ``package`` (both in one top-level package)."""
    t, p = target.split("."), package.split(".")
    common = 0
    while common < min(len(t), len(p)) and t[common] == p[common]:
        common += 1
    return "." * (len(p) - common + 1) + ".".join(t[common:])


def split(name: str) -> tuple[str, str]:
    head, _, tail = name.rpartition(".")
    return head, tail


class Rewriter:
    def __init__(self, tree: Tree, table, origin: dict[Path, str]):
        self.tree, self.table, self.origin = tree, table, origin

    def locations(self, rel: Path) -> list[str]:
        """Packages to resolve relative names against: the old one for a file moved in this
        run; the current one, then the old one, for a file moved before."""
        mod, is_pkg = module_of(rel)
        here = mod if is_pkg else split(mod)[0]
        if rel in self.origin:
            old = self.origin[rel]
            return [old if is_pkg else split(old)[0]]
        old = unmap_name(mod, self.table)
        if old is not None:
            return [here, old if is_pkg else split(old)[0]]
        return [here]

    def known(self, name: str) -> bool:
        return self.tree.exists(name) or map_name(name, self.table) is not None

    def new(self, name: str) -> str:
        return map_name(name, self.table) or name

    def target(self, rel: Path, level: int, module: str | None, names: list[str]) -> str:
        """The absolute module a ``from`` statement meant."""
        locs = self.locations(rel)
        if not level:
            return module
        for i, loc in enumerate(locs):
            t = resolve(loc, level, module)
            ok = self.known(t) and (not self.tree.is_package(self.new(t)) or all(
                self.known(f"{t}.{n}") or self.tree.defines(self.new(t), n) or n == "*" for n in names))
            if ok or i == len(locs) - 1:
                return t
        return t

    def rewrite(self, rel: Path, src: str) -> tuple[str, list[str]]:
        try:
            tree = ast.parse(src)
        except SyntaxError:
            return src, []
        mod, is_pkg = module_of(rel)
        here = mod if is_pkg else split(mod)[0]
        lines = src.splitlines(keepends=True)
        offsets = [0]
        for line in lines:
            offsets.append(offsets[-1] + len(line))

        def pos(lineno, col):   # ast columns are utf-8 byte offsets
            line = lines[lineno - 1]
            return offsets[lineno - 1] + len(line.encode("utf-8")[:col].decode("utf-8"))

        edits, notes = [], []
        module_strings = set()   # import_module(".x", ...) arguments; ".x" first in a dict value's tuple
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) == "import_module":
                module_strings.update(id(a) for a in node.args[:1])
            elif isinstance(node, ast.Dict):
                module_strings.update(id(v.elts[0]) for v in node.values if isinstance(v, ast.Tuple) and v.elts)
        for node in ast.walk(tree):
            if isinstance(node, ast.ImportFrom):
                names = [a.name for a in node.names]
                t = self.target(rel, node.level, node.module, names)
                if t is None or t.split(".")[0] not in PACKAGES:
                    continue
                groups: dict[str, list[str]] = {}
                renamed = False
                for a in node.names:
                    moved = map_name(f"{t}.{a.name}", self.table)
                    parent, name = split(moved) if moved else (self.new(t), a.name)
                    alias = a.asname or (a.name if name != a.name else None)
                    renamed |= name != a.name
                    groups.setdefault(parent, []).append(name + (f" as {alias}" if alias else ""))

                def spell(parent):
                    return relative(parent, here) if node.level else parent

                start, end = pos(node.lineno, node.col_offset), pos(node.end_lineno, node.end_col_offset)
                stmt = src[start:end]
                m = re.match(r"from\s+([.\w]+)\s+import\b", stmt)
                if len(groups) == 1 and not renamed and m:   # only the module part changes
                    wanted = spell(next(iter(groups)))
                    if m.group(1) != wanted:
                        edits.append((start + m.start(1), start + m.end(1), wanted))
                        notes.append(f"{rel}:{node.lineno}: from {m.group(1)} -> from {wanted}")
                else:
                    indent = " " * node.col_offset
                    text = f"\n{indent}".join(f"from {spell(p)} import {', '.join(ns)}" for p, ns in groups.items())
                    if text != stmt:
                        edits.append((start, end, text))
                        notes.append(f"{rel}:{node.lineno}: {' '.join(stmt.split())} -> "
                                     + " / ".join(x.strip() for x in text.splitlines()))
            elif isinstance(node, ast.Import):
                if not any(map_name(a.name, self.table) for a in node.names):
                    continue
                text = "import " + ", ".join(self.new(a.name) + (f" as {a.asname}" if a.asname else "")
                                             for a in node.names)
                start, end = pos(node.lineno, node.col_offset), pos(node.end_lineno, node.end_col_offset)
                edits.append((start, end, text))
                notes.append(f"{rel}:{node.lineno}: {src[start:end]} -> {text}")
            elif id(node) in module_strings and isinstance(node, ast.Constant) and isinstance(node.value, str) \
                    and re.fullmatch(r"\.+[A-Za-z_][\w.]*", node.value):
                # a module named relative to this file's package (a command table)
                level = len(node.value) - len(node.value.lstrip("."))
                name = node.value[level:]
                t = None
                for loc in self.locations(rel):
                    c = resolve(loc, level, name)
                    if self.known(c):
                        t = c
                        break
                if t is None:
                    continue
                wanted = relative(self.new(t), here)
                if wanted != node.value:
                    start, end = pos(node.lineno, node.col_offset), pos(node.end_lineno, node.end_col_offset)
                    q = src[start]
                    edits.append((start, end, f"{q}{wanted}{q}"))
                    notes.append(f"{rel}:{node.lineno}: {node.value!r} -> {wanted!r}")
        for start, end, text in sorted(edits, reverse=True):
            src = src[:start] + text + src[end:]
        return src, notes


# --- 3. dotted names and paths in text ------------------------------------------------------

def text_patterns(table):
    pats = []
    for old, new in table:
        pats.append((re.compile(rf"(?<![\w.]){re.escape(old)}(?!\w)"), new))
        o, n = old.replace(".", "/"), new.replace(".", "/")
        pats.append((re.compile(rf"(?<![\w/]){re.escape(o)}(?=\.py(?!\w)|/)"), n))
    return pats


# files that import an older tree's module paths on purpose (a bench timing a base revision
# from before the moves, beside today's paths): never rewritten, never reported
OLD_TREE_READERS = {Path("bench/profile_scenes.py")}


def text_files(root: Path) -> list[Path]:
    return [p for p in tracked(root) if (p.suffix in TEXT_SUFFIXES or p.name == "Makefile" or p.parts[0] == ".ci")
            and (root / p).resolve() != SELF and p not in OLD_TREE_READERS]


def rewrite_text(src: str, pats) -> tuple[str, int]:
    count = 0
    for pat, new in pats:
        src, k = pat.subn(new, src)
        count += k
    return src, count


# --- the run ------------------------------------------------------------------------------

def run(root: Path, upto: int, check: bool) -> int:
    table = moves(upto)
    emptied = [p for s, p in EMPTIED if s <= upto]
    out = []
    log = out.append
    if check:
        for old, new in planned_moves(root, table):
            log(f"at an old path: {old} (-> {new})")
        origin = {}
    else:
        origin = move_files(root, table, emptied, log)
    rw = Rewriter(Tree(root), table, origin)
    pats = text_patterns(table)
    for rel in text_files(root):
        path = root / rel
        src = path.read_text(encoding="utf-8")
        new, notes = rw.rewrite(rel, src) if rel.suffix == ".py" else (src, [])
        new, k = rewrite_text(new, pats)
        if k:
            notes.append(f"{rel}: {k} dotted name(s)/path(s)")
        if new != src:
            if check:
                log(f"old module path referenced: {rel}" + "".join(f"\n    {n}" for n in notes))
            else:
                path.write_text(new, encoding="utf-8")
                out.extend(notes)
    print("\n".join(out) if out else "relayout: nothing to do")
    return 1 if check and out else 0


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python tools/relayout.py", description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="change nothing; exit 1 if anything is at or names an old path")
    p.add_argument("--upto", type=int, default=max(s for s, _, _ in MOVES), metavar="STEP",
                   help="apply the moves of steps 1..STEP only (default: all)")
    p.add_argument("--root", type=Path, default=REPO, help="the work tree (default: this repository)")
    a = p.parse_args(argv)
    return run(a.root.resolve(), a.upto, a.check)


if __name__ == "__main__":
    sys.exit(main())
