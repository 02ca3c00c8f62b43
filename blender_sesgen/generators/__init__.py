"""Scene generators: found by name, run with a seed (pure; docs/farm.md).

A scene generator is a Python function ``generate(seed: int, **options) -> str`` that
returns an SES script; the same seed and options must give the same script. ``GENERATOR``
(in ``generate GENERATOR``) is looked up in this order:

1. a path to a Python file (``my/gen.py``): its ``generate``;
2. a plugin: an entry point ``NAME`` in the group ``blender_sesgen.generators`` of any
   installed package (``NAME = "package.module:function"`` in its pyproject.toml);
3. ``NAME.py`` in a folder named by the environment variable ``SESGEN_GENERATORS``
   (folders separated by ``os.pathsep``);
4. a built-in generator: a module of ``blender_sesgen.generators.builtin`` that defines a
   top-level ``generate`` (``city`` is ``city_kitti``): they are part of the package, so a
   wheel and the Blender extension have them too.
"""
from __future__ import annotations

import ast
import hashlib
import importlib
import importlib.util
import inspect
import json
import os
import re
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Optional

from ..errors import SesgenError

ENTRY_POINT_GROUP = "blender_sesgen.generators"
ENV_PATH = "SESGEN_GENERATORS"
ALIASES = {"city": "city_kitti"}
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_-]*$")


def builtin_folder() -> Path:
    """The folder of the built-in generators (``generators/builtin`` of this package)."""
    return Path(__file__).resolve().parent / "builtin"


def _load_builtin(path: Path, name: str) -> "Generator":
    """A built-in generator: imported as a module of the package (its relative imports)."""
    module = importlib.import_module(f"{__name__}.builtin.{path.stem}")
    return Generator(name, "built-in", str(path), module.generate)


@dataclass
class Generator:
    """A found generator: its name, where it comes from and the function."""
    name: str
    origin: str                   # "file", "plugin", "SESGEN_GENERATORS", "built-in"
    location: str                 # the file, or the entry point's "module:function"
    function: Callable[..., str]

    @property
    def source_sha256(self) -> Optional[str]:
        """SHA-256 of the generator's file (the same seed gives the same scripts only with
        the same generator)."""
        path = Path(self.location)
        if not path.is_file():
            try:
                path = Path(inspect.getsourcefile(self.function) or "")
            except TypeError:
                return None
        return hashlib.sha256(path.read_bytes()).hexdigest() if path.is_file() else None

    def options(self) -> list[str]:
        """The options it takes (its keyword parameters after the seed)."""
        params = list(inspect.signature(self.function).parameters.values())[1:]
        return [p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]

    def check_options(self, options: dict) -> None:
        """SesgenError when ``options`` are not what the function takes: an unknown name, or
        a value of another type than the parameter's default (``steps=abc`` where the
        default is 10: a number, an int for an int, true/false for a bool, text for text)."""
        sig = inspect.signature(self.function)
        try:
            sig.bind(0, **options)
        except TypeError as e:
            takes = ", ".join(self.options()) or "no options"
            raise SesgenError(f"generator {self.name}: {e} (it takes: {takes})") from None
        for name, value in options.items():
            p = sig.parameters.get(name)
            default = None if p is None else p.default
            kinds = {bool: (bool,), int: (int,), float: (int, float), str: (str,)}.get(type(default))
            if kinds and not (isinstance(value, kinds) and (type(default) is bool or not isinstance(value, bool))):
                raise SesgenError(f"generator {self.name}: option {name}={json.dumps(value)}: expected "
                                  f"{type(default).__name__} like its default {json.dumps(default)}")

    def __call__(self, seed: int, **options) -> str:
        return self.function(seed, **options)


def defines_generate(path: Path) -> bool:
    """True when the Python file defines a top-level ``generate`` (read, not run)."""
    try:
        tree = ast.parse(path.read_text(encoding="utf-8"))
    except (OSError, SyntaxError, UnicodeDecodeError, ValueError):
        return False
    return any(isinstance(n, ast.FunctionDef) and n.name == "generate" for n in tree.body)


def load_file(path: Path, name: Optional[str] = None) -> Generator:
    """The ``generate`` of a Python file (run as a module of its own)."""
    path = Path(path).resolve()
    if not path.is_file():
        raise SesgenError(f"{path}: no such generator file")
    mod_name = "sesgen_generator_" + re.sub(r"\W", "_", path.stem)
    spec = importlib.util.spec_from_file_location(mod_name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[mod_name] = module
    try:
        spec.loader.exec_module(module)
    except SesgenError:
        raise
    except Exception as e:  # noqa: BLE001 - the generator's own bug, reported as one line
        sys.modules.pop(mod_name, None)
        raise SesgenError(f"{path}: loading the generator failed: {type(e).__name__}: {e}") from None
    fn = getattr(module, "generate", None)
    if not callable(fn):
        raise SesgenError(f"{path}: defines no generate(seed, **options) function")
    return Generator(name or path.stem, "file", str(path), fn)


def _entry_points() -> dict:
    from importlib.metadata import entry_points
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def _env_folders() -> list[Path]:
    return [Path(p) for p in os.environ.get(ENV_PATH, "").split(os.pathsep) if p]


def find(spec: str) -> Generator:
    """The generator ``spec`` names (see the module docstring); SesgenError if none."""
    if spec.endswith(".py") or os.sep in spec or (os.altsep and os.altsep in spec):
        return load_file(Path(spec))
    if not _NAME.match(spec):
        raise SesgenError(f"'{spec}' is not a generator name or a .py file")
    eps = _entry_points()
    if spec in eps:
        try:
            fn = eps[spec].load()
        except Exception as e:  # noqa: BLE001
            raise SesgenError(f"generator {spec} ({eps[spec].value}): loading failed: {type(e).__name__}: {e}") \
                from None
        return Generator(spec, "plugin", eps[spec].value, fn)
    for origin, folders in ((ENV_PATH, _env_folders()), ("built-in", [builtin_folder()])):
        for folder in folders:
            for stem in (spec, ALIASES.get(spec)):
                if stem and (folder / f"{stem}.py").is_file() and defines_generate(folder / f"{stem}.py"):
                    if origin == "built-in":
                        return _load_builtin(folder / f"{stem}.py", spec)
                    g = load_file(folder / f"{stem}.py", spec)
                    g.origin = origin
                    return g
    known = ", ".join(sorted(available())) or "none"
    raise SesgenError(f"no generator '{spec}' (available: {known})")


def available() -> dict[str, str]:
    """{name: where it comes from} of every generator found (built-in, environment, plugins)."""
    out = {}
    for folder, origin in [(builtin_folder(), "built-in")] + [(f, ENV_PATH) for f in reversed(_env_folders())]:
        if folder.is_dir():
            for path in sorted(folder.glob("*.py")):
                if defines_generate(path):
                    out[path.stem] = f"{origin}: {path}"
    for alias, stem in ALIASES.items():
        if stem in out:
            out[alias] = out[stem]
    for name, ep in _entry_points().items():
        out[name] = f"plugin: {ep.value}"
    return dict(sorted(out.items()))
