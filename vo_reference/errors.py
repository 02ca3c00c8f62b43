"""The one exception family of vo_reference: expected failures print one line, exit 2."""
from __future__ import annotations

from contextlib import contextmanager

from blender_sesgen.contract.errors import ContractError



class VoError(Exception):
    """A user-facing error (bad input file, wrong format, missing pass...)."""


@contextmanager
def as_vo_error():
    """Re-raise the contract's errors (malformed files, bad --frames...) as VoError."""
    try:
        yield
    except ContractError as e:
        raise VoError(str(e)) from None
