"""What one xacro expansion may spend: CPU seconds and memory, and the meter that enforces them.

The budget is spent by the expander itself (every expression step, element and byte is counted, CPU
time is read every few thousand steps) and, as a backstop, by the kernel in the child process that
expands (``RLIMIT_CPU``, ``RLIMIT_AS``): whatever a model does, it stops with one line.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass

from .errors import BudgetExceeded

__all__ = ["Budget", "Meter", "parse_budget", "DEFAULT_BUDGET", "BUDGET_OPTION"]

#: The option's name wherever a model is loaded (zentf urdf, robot-state-publisher, launch urdf).
BUDGET_OPTION = "--xacro-budget"

_PART = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)\s*(s|sec|secs|seconds?|mb|m|gb|g)\s*$", re.I)


@dataclass(frozen=True, slots=True)
class Budget:
    """CPU seconds and megabytes of memory for one expansion; the size caps follow from the memory."""

    cpu_s: float = 10.0
    memory_mb: int = 512

    @property
    def memory_bytes(self) -> int:
        return self.memory_mb * 1024 * 1024

    @property
    def max_elements(self) -> int:
        """Elements created in all (each costs a few hundred bytes live)."""
        return self.memory_bytes // 1024

    @property
    def max_length(self) -> int:
        """Characters of one string, items of one list or dict, made by an expression."""
        return self.memory_bytes // 64

    @property
    def max_output(self) -> int:
        """Characters of the expanded URDF."""
        return self.memory_bytes // 16

    @property
    def max_read(self) -> int:
        """Bytes read from model files in all (includes and YAML)."""
        return self.memory_bytes // 16

    def __str__(self) -> str:
        return f"{self.cpu_s:g}s,{self.memory_mb}MB"


DEFAULT_BUDGET = Budget()


def parse_budget(text: str) -> Budget:
    """``30s``, ``2GB``, ``30s,2GB`` (either part may be left out: it keeps its default) -> Budget;
    ValueError with one line otherwise."""
    cpu, mem = DEFAULT_BUDGET.cpu_s, DEFAULT_BUDGET.memory_mb
    parts = [p for p in str(text).split(",")]
    if not 1 <= len(parts) <= 2:
        raise ValueError(f"{BUDGET_OPTION} expects SECONDSs[,MEGABYTESMB], e.g. 30s,2GB; got {text!r}")
    seen = set()
    for p in parts:
        m = _PART.match(p)
        if m is None:
            raise ValueError(f"{BUDGET_OPTION} expects SECONDSs[,MEGABYTESMB], e.g. 30s,2GB; got {text!r}")
        value, unit = float(m.group(1)), m.group(2).lower()
        kind = "cpu" if unit.startswith("s") else "mem"
        if kind in seen:
            raise ValueError(f"{BUDGET_OPTION}: {kind} given twice in {text!r}")
        seen.add(kind)
        if kind == "cpu":
            if not 0.1 <= value <= 86400:
                raise ValueError(f"{BUDGET_OPTION}: CPU seconds must be 0.1..86400, got {p.strip()!r}")
            cpu = value
        else:
            mb = value * (1024 if unit.startswith("g") else 1)
            if not 16 <= mb <= 1024 * 1024:
                raise ValueError(f"{BUDGET_OPTION}: memory must be 16MB..1024GB, got {p.strip()!r}")
            mem = int(mb)
    return Budget(cpu, mem)


class Meter:
    """Counts what an expansion spends and raises BudgetExceeded (one line) when over the budget."""

    __slots__ = ("budget", "steps", "elements", "read", "_deadline", "_next_check")

    _CHECK_EVERY = 4096

    def __init__(self, budget: Budget) -> None:
        self.budget = budget
        self.steps = 0
        self.elements = 0
        self.read = 0
        self._deadline = time.process_time() + budget.cpu_s
        self._next_check = self._CHECK_EVERY

    def tick(self, n: int = 1) -> None:
        """``n`` units of work (an expression step, an iteration, ~64 bytes made by a native call)."""
        self.steps += n
        if self.steps >= self._next_check:
            self._next_check = self.steps + self._CHECK_EVERY
            if time.process_time() > self._deadline:
                raise BudgetExceeded(f"xacro expansion stopped: it used up its CPU budget of "
                                     f"{self.budget.cpu_s:g} s (raise it with {BUDGET_OPTION})")

    def element(self, n: int = 1) -> None:
        """``n`` elements were made."""
        self.elements += n
        if self.elements > self.budget.max_elements:
            raise BudgetExceeded(f"xacro expansion stopped: it made more than {self.budget.max_elements} elements, "
                                 f"over its memory budget of {self.budget.memory_mb} MB (raise it with "
                                 f"{BUDGET_OPTION})")
        self.tick(n)

    def length(self, n: int, what: str = "a value") -> None:
        """An expression is about to make ``what`` of length ``n``: refused when over the cap."""
        if n > self.budget.max_length:
            raise BudgetExceeded(f"xacro expression stopped: {what} of {n} items is over the budget's "
                                 f"{self.budget.max_length} (raise it with {BUDGET_OPTION})")
        self.tick(1 + (n >> 6))

    def bytes_read(self, n: int, what: str) -> None:
        self.read += n
        if self.read > self.budget.max_read:
            raise BudgetExceeded(f"xacro expansion stopped: reading {what} goes over the {self.budget.max_read} "
                                 f"bytes its budget allows (raise it with {BUDGET_OPTION})")
