"""Deprecated alias of zentf.core.buffer_core (moved in 0.2; removed in the next release)."""
from zentf._moved import moved

moved(__name__, "zentf.core.buffer_core")
