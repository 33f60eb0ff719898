"""The tf doctor: what is wrong with a tf tree, and why one lookup fails (``zentf tf doctor``, ``zentf tf why``).

- ``TfDoctor(node)``: gathers evidence on a live graph (``report()``, ``why(target, source, t)``);
- ``explain_lookup(buffer, target, source, t)``: explains one lookup from any Buffer alone;
- ``diagnose_bag(path)``: the doctor's report on a recording;
- ``Evidence``, ``run_checks``, ``TransformTap``: the parts, for programs that gather their own.
"""
from __future__ import annotations

from .bagread import diagnose_bag, evidence_from_bag
from .checks import Finding, Report, Thresholds, run_checks
from .evidence import Evidence
from .live import GraphTap, TapMessage, TfDoctor, TransformTap
from .why import ChainEdge, Explanation, Verdict, explain_lookup

__all__ = ["TfDoctor", "explain_lookup", "diagnose_bag", "evidence_from_bag", "Evidence", "run_checks", "Finding",
           "Report", "Thresholds", "TransformTap", "TapMessage", "GraphTap", "Explanation", "Verdict", "ChainEdge"]
