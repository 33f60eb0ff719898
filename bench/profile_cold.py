#!/usr/bin/env python3
"""Profile of the cold lookup (a fresh uniformly random in-range stamp on every call), as bench/lookup.py
times it: what remains in it at a given depth (issue 15 asks for depth 1).

    python bench/profile_cold.py [--depth 1] [--calls 200000] [--pyinstrument]
    py-spy record --native -o cold.svg -- python bench/profile_cold.py     # sees inside compiled code

Same 1000-frame tree and the same stamps as bench/lookup.py's "lookup d<depth> cold random time" row
(drawn and built before the loop); prints µs per call. --pyinstrument prints pyinstrument's call tree
of the loop (Python frames only: a compiled core shows as one leaf, py-spy --native opens it).
"""
from __future__ import annotations

import argparse
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.dirname(HERE)]

from lookup import all_samples, cold_times  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--depth", type=int, default=1, help="frames between f0 and the source frame (1..100)")
    ap.add_argument("--calls", type=int, default=200_000, help="lookups in the profiled loop")
    ap.add_argument("--pyinstrument", action="store_true", help="print pyinstrument's call tree of the loop")
    args = ap.parse_args()
    if not 1 <= args.depth <= 100:
        ap.error(f"--depth must be 1..100, got {args.depth}")

    from zentf.core.buffer_core import BufferCore
    from zentf.core.time import Time

    buf = BufferCore(10.0)
    for s in all_samples():
        buf.set_transform_raw(*s, "bench")
    stamps = [Time(nanoseconds=t) for t in cold_times(args.depth, args.calls)]
    src = f"f{args.depth}"
    lookup = buf.lookup_transform

    profiler = None
    if args.pyinstrument:
        from pyinstrument import Profiler

        profiler = Profiler(interval=0.0001)
        profiler.start()
    t0 = time.perf_counter()
    for stamp in stamps:
        lookup("f0", src, stamp)
    took = time.perf_counter() - t0
    if profiler is not None:
        profiler.stop()
        print(profiler.output_text(unicode=True, color=False, show_all=False))
    print(f"cold lookup f0 <- {src}: {took / args.calls * 1e6:.2f} µs per call over {args.calls} calls"
          + (" (with the profiler's overhead)" if profiler is not None else ""))


if __name__ == "__main__":
    main()
