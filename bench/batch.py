#!/usr/bin/env python3
"""lookup_transforms against a loop of single lookups on the same buffer, in process time (CPU).

    PYTHONPATH=TREE python TREE/bench/batch.py [--repeat 7]

bench/lookup.py's 1000-frame tree; for series of 100, 1k and 100k sorted stamps at depths 1 and 100
(and 5, 20 at 100k): the best of --repeat process times of one ``lookup_transforms`` call, beside
the same times looked up one by one (the reference, in the same process; over the first 2,000
times, scaled to the series). Process time moves less
than wall time on a loaded shared machine, so two trees (e.g. before and after a change, each built
in place) compare best as alternated runs of this script. Uses only BufferCore's public methods, so
it runs on any tree that has them. A ratio below 1x means the single lookups were cheaper: a short
series over a deep chain pays for planning every link's samples.
"""
from __future__ import annotations

import gc
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))

import numpy as np  # noqa: E402

import lookup as L  # noqa: E402  (the tree and its stamps)
from zentf.core.buffer_core import BufferCore  # noqa: E402
from zentf.core.time import Time  # noqa: E402


def cpu_best(fn, calls: int, repeat: int) -> float:
    """Best process time per call (µs) of ``calls`` calls of fn, over ``repeat`` runs, GC paused."""
    out = []
    for _ in range(repeat):
        gc.collect()
        gc.disable()
        try:
            t = time.process_time()
            for _ in range(calls):
                fn()
            out.append((time.process_time() - t) / calls * 1e6)
        finally:
            gc.enable()
    return min(out)


def main() -> None:
    repeat = int(sys.argv[sys.argv.index("--repeat") + 1]) if "--repeat" in sys.argv else 7
    buf = BufferCore(10.0)
    for s in L.all_samples():
        buf.set_transform_raw(*s, "bench")
    print(f"{'series':>8} {'depth':>5} {'lookup_transforms':>18} {'single lookups':>15} {'ratio':>7}")
    for n, depths in ((100, (1, 100)), (1000, (1, 100)), (100_000, L.DEPTHS)):
        stamps = np.linspace(L.T0 + 2_000_000, L.T0 + 982 * L.S // 1000, n).astype(np.int64)
        times = [Time(nanoseconds=int(t)) for t in stamps[:min(n, 2000)]]
        for d in depths:
            src = f"f{d}"
            buf.lookup_transforms("f0", src, stamps[:100])        # warm-up (numba compiles or loads)
            batch = cpu_best(lambda: buf.lookup_transforms("f0", src, stamps), max(1, 20_000 // n), repeat)

            def loop() -> None:
                for t in times:
                    buf.lookup_transform("f0", src, t)
            single = cpu_best(loop, 1, repeat) / len(times) * n
            unit, scale = ("ms", 1e3) if n >= 100_000 else ("µs", 1.0)
            print(f"{n:>8} {d:>5} {batch / scale:>15.1f} {unit} {single / scale:>12.1f} {unit} "
                  f"{single / batch:>6.1f}x")


if __name__ == "__main__":
    main()
