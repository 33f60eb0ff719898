"""Deprecated alias of zentf.core.time (moved in 0.2; removed in the next release)."""
from zentf._moved import moved

moved(__name__, "zentf.core.time")
