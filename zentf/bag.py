"""Deprecated alias of zentf.tools.bag (moved in 0.2; removed in the next release)."""
from zentf._moved import moved

moved(__name__, "zentf.tools.bag")
