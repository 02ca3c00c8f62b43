"""The export options (``--opt key=value``) the ground truth reads itself: a background depth,
a point grid's stride. The exporters take theirs with the same :func:`pop_number`."""
from __future__ import annotations

from ..errors import VoError


def pop_number(extra: dict, key: str, kind: type = float, default=None, what: str = "a number"):
    """Take a positive number ``key`` out of an export's ``--opt`` options (``default`` when
    absent); VoError naming the option otherwise."""
    text = extra.pop(key, None)
    if text is None:
        return default
    try:
        value = kind(text)
    except ValueError:
        raise VoError(f"{key}={text!r}: expected {what}") from None
    if not value > 0:
        raise VoError(f"{key}={text!r}: must be > 0")
    return value
