"""One home per convention: what the contract (``blender_sesgen/contract``) defines is not
derived again anywhere else in either package, checked on the source (AST).

- the stereo rig (``contract.rig``): no arithmetic with a baseline outside the contract, no
  baseline placed in a translation by hand;
- the pixel-affecting settings (``contract.pixel_settings``): nobody else compares a
  manifest's render settings or lists the timing keys;
- the constants: the background depth 1e10 (``contract.depth``), the default rate of 25
  frames per second (``contract.timing``), the EXR channel and pass names and the EXR header
  parser (``contract.exr_format``), the rotation-validity check (``contract.se3``).
"""
from __future__ import annotations

import ast
import functools
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("blender_sesgen", "vo_reference")
CONTRACT = REPO / "blender_sesgen" / "contract"
# a Middlebury .flo file's own "unknown" marker happens to be 1e10 too (not a depth)
OTHER_1E10 = {("vo_reference/products/flow.py", "FLO_UNKNOWN")}
TIMING_KEYS = {"rate_hz", "start_s", "exposure_s", "readout_s", "motion_blur"}
SETTING_KEYS = {"samples", "sampling", "seed", "passes", "resolution_scale"}
CHANNEL_NAMES = {"Combined", "Depth", "Object Index", "IndexOB"}


@functools.lru_cache(maxsize=1)
def _parsed() -> tuple:
    """(relative path, in the contract?, AST) of every module of both packages, parsed once."""
    return tuple((p.relative_to(REPO).as_posix(), CONTRACT in p.parents, ast.parse(p.read_text(encoding="utf-8")))
                 for pkg in PACKAGES for p in sorted((REPO / pkg).rglob("*.py")) if "__pycache__" not in p.parts)


def modules(outside_contract: bool = True):
    for path, in_contract, tree in _parsed():
        if not (outside_contract and in_contract):
            yield path, tree


def _docstrings(tree) -> set[int]:
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def _is_baseline(node) -> bool:
    if isinstance(node, ast.Name):
        return "baseline" in node.id.lower()
    if isinstance(node, ast.Attribute):
        return "baseline" in node.attr.lower()
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "float" and node.args:
        return _is_baseline(node.args[0])
    if isinstance(node, ast.UnaryOp):
        return _is_baseline(node.operand)
    if isinstance(node, ast.IfExp):
        return _is_baseline(node.body) or _is_baseline(node.orelse)
    return False


def _where(path, node) -> str:
    return f"{path}:{node.lineno}: {ast.unparse(node)[:90]}"


def test_the_rig_is_derived_in_the_contract_only():
    found = []
    for path, tree in modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.BinOp) and (_is_baseline(node.left) or _is_baseline(node.right)):
                found.append(_where(path, node))                       # B * x-axis, f * B, P - B ...
            elif isinstance(node, (ast.List, ast.Tuple)) and len(node.elts) == 3 and any(map(_is_baseline, node.elts)):
                found.append(_where(path, node))                       # (B, 0, 0)
            elif isinstance(node, (ast.Assign, ast.AugAssign)) and _is_baseline(node.value) and any(
                    isinstance(t, ast.Subscript) for t in (node.targets if isinstance(node, ast.Assign) else [node.target])):
                found.append(_where(path, node))                       # T[0, 3] = B
    assert found == [], "baseline arithmetic outside blender_sesgen/contract (use contract.rig / contract.depth):\n" \
        + "\n".join(found)


def test_the_checker_sees_a_rig_written_again():
    tree = ast.parse("T[:, :3, 3] += self.baseline * T[:, :3, 0]\nb = np.array([baseline_m, 0.0, 0.0])\n"
                     "T[0, 3] = seq.baseline_m if cam == 1 else 0.0\nok = seq.baseline_m > 0\n")
    hits = [n for n in ast.walk(tree) if isinstance(n, ast.BinOp) and (_is_baseline(n.left) or _is_baseline(n.right))
            or isinstance(n, ast.List) and any(map(_is_baseline, n.elts))
            or isinstance(n, ast.Assign) and _is_baseline(n.value) and isinstance(n.targets[0], ast.Subscript)]
    assert len(hits) == 3   # the comparison is no derivation


def _key_of(node):
    """'samples' of ``x.get("samples")`` or ``x["samples"]``."""
    if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get" and node.args \
            and isinstance(node.args[0], ast.Constant):
        return node.args[0].value
    if isinstance(node, ast.Subscript) and isinstance(node.slice, ast.Constant):
        return node.slice.value
    return None


def test_the_pixel_settings_are_compared_in_the_contract_only():
    found = []
    for path, tree in modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.Compare) and any(_key_of(x) in SETTING_KEYS | TIMING_KEYS
                                                     for x in [node.left, *node.comparators]):
                found.append(_where(path, node))
            if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
                names = {e.value for e in node.elts if isinstance(e, ast.Constant)}
                if len(names & TIMING_KEYS) >= 3:
                    found.append(_where(path, node))
    assert found == [], "settings compared outside contract.pixel_settings:\n" + "\n".join(found)


def test_the_constants_have_one_home():
    found = []
    for path, tree in modules():
        docs = _docstrings(tree)
        constant_of = {}
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign) and len(node.targets) == 1 and isinstance(node.targets[0], ast.Name):
                constant_of[id(node.value)] = node.targets[0].id
        for node in ast.walk(tree):
            if not isinstance(node, ast.Constant) or id(node) in docs:
                continue
            v = node.value
            if isinstance(v, float) and v == 1e10 and (path, constant_of.get(id(node))) not in OTHER_1E10:
                found.append(f"{path}:{node.lineno}: 1e10 (contract.depth.DEPTH_BACKGROUND)")
            elif isinstance(v, str) and (v in CHANNEL_NAMES or v.startswith("ViewLayer.")):
                found.append(f"{path}:{node.lineno}: {v!r} (contract.exr_format)")
        for node in ast.walk(tree):   # a header attribute's type tested: an EXR header parsed again
            if isinstance(node, ast.Compare) and any(isinstance(c, ast.Constant) and c.value == "chlist"
                                                     for c in [node.left, *node.comparators]):
                found.append(f"{path}:{node.lineno}: an EXR header parsed (contract.exr_format.read_header)")
        for node in ast.walk(tree):   # 25 fps written again: a default rate or fps of 25
            if isinstance(node, (ast.Assign, ast.AnnAssign, ast.keyword, ast.BoolOp)) and any(
                    isinstance(c, ast.Constant) and c.value == 25 and not isinstance(c.value, bool)
                    for c in ast.walk(node)):
                text = ast.unparse(node).lower()
                if "fps" in text or "rate" in text:
                    found.append(f"{path}:{node.lineno}: 25 fps (contract.timing.DEFAULT_FPS)")
    assert found == [], "\n".join(found)


def test_a_rotation_is_checked_in_one_place():
    """max |R^T R - I| is computed in contract.se3 only (``not_rotations``)."""
    found = []
    for path, tree in modules(outside_contract=False):
        if path == "blender_sesgen/contract/se3.py":
            continue
        for node in ast.walk(tree):
            if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Sub) and "eye(3)" in ast.unparse(node.right) \
                    and isinstance(node.left, (ast.BinOp, ast.Call)) and ("@" in ast.unparse(node.left)
                                                                          or "einsum" in ast.unparse(node.left)):
                found.append(_where(path, node))
    assert found == [], "\n".join(found)
