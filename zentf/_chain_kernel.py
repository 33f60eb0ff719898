"""Deprecated alias of zentf.core._chain_kernel (moved in 0.2; removed in the next release)."""
from zentf._moved import moved

moved(__name__, "zentf.core._chain_kernel")
