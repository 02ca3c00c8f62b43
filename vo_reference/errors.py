"""The one exception family of vo_reference: expected failures print one line, exit 2."""
from __future__ import annotations


class VoError(Exception):
    """A user-facing error (bad input file, wrong format, missing pass...)."""
