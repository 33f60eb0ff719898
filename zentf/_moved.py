"""Old module paths (before zentf.core and zentf.tools) keep working for one release, with a DeprecationWarning."""
from __future__ import annotations

import importlib
import sys
import warnings

__all__ = ["moved"]


def moved(old: str, new: str) -> None:
    """Make module ``old`` the very module ``new`` (same objects, private names included) and warn once."""
    warnings.warn(f"{old} is deprecated and will be removed in the next release: import {new}",
                  DeprecationWarning, stacklevel=3)
    sys.modules[old] = importlib.import_module(new)
