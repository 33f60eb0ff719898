"""Random tf2 scenarios for the differential tests: one list of operations, answered op by op by the
real tf2 (tests/tf2_reference_driver.py) and by zentf, then compared.

A scenario is ``{"seed", "cache_time": seconds, "ops": [op, ...]}``; every op gives one answer:

- ``{"op": "set", "parent", "child", "stamp": [sec, nsec], "t": [x, y, z], "q": [x, y, z, w],
  "static": bool, "authority": str}`` -> ``{"ok": True}`` (tf2 returns nothing for an insert; what it
  kept shows in later lookups and in the "frames"/"yaml" reports)
- ``{"op": "lookup", "target", "source", "time": [sec, nsec]}`` -> a transform
- ``{"op": "lookup_full", "target", "target_time", "source", "source_time", "fixed"}`` -> a transform
- ``{"op": "can", ...as lookup}`` / ``{"op": "can_full", ...as lookup_full}`` -> ``{"can", "message"}``
- ``{"op": "lct", "target", "source"}`` -> ``{"stamp"}`` (latest common time)
- ``{"op": "frames"}`` / ``{"op": "yaml"}`` -> ``{"text"}`` (allFramesAsString / allFramesAsYAML)
- ``{"op": "clear"}`` -> ``{"ok": True}``

A transform answer is ``{"ok": True, "t", "q", "stamp", "frame_id", "child_frame_id"}``; a tf2
error is ``{"ok": False, "error": class name, "message": str}``.

The generator models a robot's tf traffic: a forest of static and dynamic frames whose samples are
delivered out of order with network latency (a few so late that tf2 drops them as too old, a few
repeated), parents that switch mid-run, frames that change between static and dynamic, malformed
samples, and queries interleaved with the inserts at times chosen around the buffered window:
latest (time 0), exact sample stamps, interpolated, just past either end, pruned, unknown, empty
and slash-prefixed frames, frames in another tree, and full lookups through a fixed frame.
Only the standard library, and no iteration over sets or dicts keyed by hashed strings that could
change order between processes: the same seed gives the same scenario everywhere.
"""
from __future__ import annotations

import math
import random
from typing import Any

NS = 1_000_000_000
Op = dict[str, Any]


def stamp(ns: int) -> list[int]:
    """[sec, nsec] of a non-negative time in nanoseconds."""
    return [ns // NS, ns % NS]


def unit_quaternion(rng: random.Random) -> list[float]:
    """A uniformly random rotation (normalized Gaussian 4-vector), either sign."""
    while True:
        q = [rng.gauss(0.0, 1.0) for _ in range(4)]
        n = math.sqrt(sum(x * x for x in q))
        if n > 1e-6:
            return [x / n for x in q]


def _set(parent: str, child: str, at_ns: int, t: list[float], q: list[float], static: bool = False,
         authority: str = "gen") -> Op:
    return {"op": "set", "parent": parent, "child": child, "stamp": stamp(at_ns), "t": t, "q": q,
            "static": static, "authority": authority}


class _Scenario:
    """Builds one scenario: inserts with delivery times, queries placed between them."""

    def __init__(self, seed: int, n_frames: int, n_queries: int, cache_time: float | None) -> None:
        self.rng = rng = random.Random(seed)
        self.seed = seed
        self.cache_time = cache_time if cache_time is not None else rng.choice([0.5, 1.0, 2.0, 10.0])
        self.cache_ns = int(self.cache_time * NS)
        self.n_queries = n_queries
        # names: plain, and sometimes with an inner slash (a namespace is only text to tf2)
        prefix = rng.choice(["f", "f", "robot1/f"])
        self.names = [f"{prefix}{i}" for i in range(n_frames)]
        n_roots = rng.randint(1, min(3, n_frames))
        self.parent: dict[str, str] = {}
        for i in range(n_roots, n_frames):
            chain = rng.random() < 0.4  # long chains as well as bushy trees
            self.parent[self.names[i]] = self.names[i - 1] if chain else rng.choice(self.names[:i])
        self.children = [n for n in self.names if n in self.parent]  # list: deterministic order
        self.static = [c for c in self.children if rng.random() < 0.3]
        self.t0 = 1000 * NS + rng.randrange(100 * NS)
        self.span = int(rng.uniform(0.5, 3.0) * self.cache_ns)
        self.events: list[tuple[int, int, Op]] = []  # (delivery time, tie-break, op)
        self.sampled: list[int] = []                   # stamps of dynamic samples, for exact-time queries
        self.extra_names: list[str] = []               # frames that only malformed or odd inserts name
        self.known: list[str] = []                     # frames named by the inserts delivered so far

    # ---- inserts -------------------------------------------------------------------------------
    def deliver(self, at: int, op: Op) -> None:
        self.events.append((at, len(self.events), op))

    def sample(self, parent: str, child: str, when: int, static: bool = False) -> Op:
        rng = self.rng
        return _set(parent, child, when, [rng.uniform(-5, 5) for _ in range(3)], unit_quaternion(rng), static)

    def descendants(self, frame: str) -> list[str]:
        out = [frame]
        for child in self.children:  # children come after their parents in self.names
            if self.parent[child] in out:
                out.append(child)
        return out

    def ancestor(self, frame: str) -> str:
        """The frame's parent, grandparent, ... in the base tree, picked at random."""
        up = []
        while frame in self.parent:
            frame = self.parent[frame]
            up.append(frame)
        return self.rng.choice(up)

    def other_parent(self, child: str) -> str:
        """A parent to switch to that does not make a loop in the base tree."""
        below = self.descendants(child)
        options = [n for n in self.names if n not in below]
        return self.rng.choice(options) if options else self.parent[child]

    def add_static(self, child: str) -> None:
        rng = self.rng
        when = rng.choice([0, self.t0, self.t0 + rng.randrange(self.span)])
        self.deliver(self.t0 + rng.randrange(-self.span // 10, self.span // 2), self.sample(self.parent[child], child, when, True))
        r = rng.random()
        if r < 0.15:  # re-sent later, maybe under another parent: the single slot is overwritten
            parent = self.other_parent(child) if rng.random() < 0.5 else self.parent[child]
            self.deliver(self.t0 + rng.randrange(self.span), self.sample(parent, child, rng.choice([0, self.t0]), True))
        elif r < 0.2:  # a dynamic sample for a static frame (ROS 1: it overwrites the static slot)
            w = self.t0 + rng.randrange(self.span)
            self.deliver(w, self.sample(self.parent[child], child, w))

    def add_dynamic(self, child: str) -> None:
        rng = self.rng
        shape = rng.random()
        if shape < 0.03:
            n = 1                                  # one sample: "only time S is in the buffer"
        elif shape < 0.12:
            n = rng.randint(2, 4)                  # sparse
        else:
            n = rng.randint(5, 40)
        start = self.t0 + rng.randrange(self.span // 3 + 1)
        end = self.t0 + self.span - rng.randrange(self.span // (3 if rng.random() < 0.2 else 20) + 1)
        step = max((end - start) // max(n - 1, 1), 1)
        switch_at = start + rng.randrange(max(end - start, 1)) if rng.random() < 0.15 else None
        other = self.other_parent(child) if switch_at is not None else ""
        back_at = switch_at + step * rng.randint(1, 8) if switch_at is not None and rng.random() < 0.4 else None
        make_static = rng.randrange(n) if rng.random() < 0.04 else -1  # ROS 1 keeps it a timed sample
        for k in range(n):
            when = start + k * step + int(rng.uniform(-0.3, 0.3) * step)
            when = max(when, 1)
            parent = self.parent[child]
            if switch_at is not None and when >= switch_at and (back_at is None or when < back_at):
                parent = other
            op = self.sample(parent, child, when, static=(k == make_static))
            self.sampled.append(when)
            r = rng.random()
            if r < 0.04:
                latency = int(rng.uniform(0.8, 1.6) * self.cache_ns)   # very late: may be too old
            elif r < 0.3:
                latency = int(rng.expovariate(1.0) * 5 * step)           # overtaken by later samples
            else:
                latency = rng.randrange(step // 4 + 1)
            self.deliver(when + latency, op)
            if rng.random() < 0.03:  # the same stamp again, other values: ROS 1 keeps the first
                self.deliver(when + latency + rng.randrange(step + 1), self.sample(parent, child, when))
        if rng.random() < 0.15 and n > 1:
            # after the newest sample: one exactly cache_time older (kept) or 1 ns more (too old)
            late = when - self.cache_ns - rng.choice([0, 0, 1])    # the last sample is the newest
            if late > 0:
                self.deliver(when + latency + 1, self.sample(self.parent[child], child, late))

    def add_malformed(self) -> None:
        rng = self.rng
        child = rng.choice(self.children) if self.children and rng.random() < 0.6 else f"bad{rng.randrange(10)}"
        parent = self.parent.get(child, self.names[0])
        when = self.t0 + rng.randrange(self.span)
        op = self.sample(parent, child, when)
        kind = rng.randrange(16)
        if kind == 0:
            op["t"][rng.randrange(3)] = float("nan")
        elif kind == 1:
            op["q"][rng.randrange(4)] = float("nan")
        elif kind == 2:
            # tiny, subnormal and negative zero: accepted. (An infinite translation, which tf2 stores,
            # is a deliberate refusal of zentf's, docs/protocol.md "Limits"; huge ones would make the
            # comparison meaningless, as lookups that cancel them leave rounding noise of their size.)
            op["t"] = [rng.choice([5e-324, -1e-300, -0.0, 1e-12]) for _ in range(3)]
        elif kind == 3:
            op["q"][rng.randrange(4)] = float("inf")
        elif kind == 4:
            op["q"] = [0.0, 0.0, 0.0, 0.0]
        elif kind == 5:
            op["q"] = [x * rng.choice([0.9, 1.1, 0.5]) for x in op["q"]]   # outside the 0.01 tolerance
        elif kind == 6:
            op["q"] = [x * rng.choice([0.996, 1.004]) for x in op["q"]]    # inside it: stored as given
        elif kind == 7:
            op["parent"] = ""
        elif kind == 8:
            op["child"] = ""
        elif kind == 9:
            op["parent"] = op["child"] = rng.choice(["", child])
        elif kind == 10:
            op["parent"] = "/" + parent                                     # one slash is stripped
        elif kind == 11:
            op["child"] = "/" + child
        elif kind == 12:
            op["parent"] = "/"
        elif kind == 13:
            op["parent"] = "//" + parent                                    # leaves a frame "/parent"
            self.extra_names.append("/" + parent)
        elif kind == 14:
            op["child"] = "/" + op["parent"]                                # self after stripping
        else:
            op["parent"], op["child"] = child, parent                       # a loop
        if kind not in (0, 1, 3, 4, 5, 7, 8, 9, 12, 14):
            self.sampled.append(when)
        if op["child"].startswith("bad"):
            self.extra_names.append(op["child"])
        self.deliver(when + rng.randrange(self.span // 10 + 1), op)

    # ---- queries -------------------------------------------------------------------------------
    def frame(self) -> str:
        rng = self.rng
        r = rng.random()
        if r < 0.82 and self.known:
            return rng.choice(self.known)                          # named by an insert so far
        if r < 0.9 or (r < 0.94 and not self.extra_names):
            return rng.choice(self.names)                          # maybe not (yet) known
        if r < 0.94:
            return rng.choice(self.extra_names)
        return rng.choice(["unknown_frame", "", "/" + rng.choice(self.names), "/"])

    def when(self, now: int) -> list[int]:
        rng, c = self.rng, self.cache_ns
        r = rng.random()
        if r < 0.22:
            t = 0                                                  # latest common time
        elif r < 0.37 and self.sampled:
            t = rng.choice(self.sampled)                           # exactly a sample's stamp
        elif r < 0.62:
            t = now - rng.randrange(max(min(c, now - self.t0), 0) + 1)  # inside the window: interpolation
        elif r < 0.69:
            t = now + rng.randrange(c // 5 + 1)                    # just ahead: future extrapolation
        elif r < 0.79:
            t = now - int(rng.uniform(1.0, 2.5) * c)               # pruned or before the first sample
        elif r < 0.83:
            t = rng.choice([1, NS, self.t0 - 1])                   # long before anything
        else:
            t = self.t0 + rng.randrange(-c, self.span + c)         # anywhere in the run
        return stamp(max(t, 0))

    def query(self, now: int) -> Op:
        rng = self.rng
        target, source = self.frame(), self.frame()
        if rng.random() < 0.05:
            source = target                                        # identity, even for odd names
        r = rng.random()
        if r < 0.45:
            return {"op": "lookup", "target": target, "source": source, "time": self.when(now)}
        if r < 0.62:
            return {"op": "can", "target": target, "source": source, "time": self.when(now)}
        f = rng.random()
        if f < 0.4 and source in self.parent:
            fixed = self.ancestor(source)                          # as robots do: odom, map
        else:
            fixed = self.frame() if f < 0.92 else rng.choice(self.names)
        if r < 0.82:
            return {"op": "lookup_full", "target": target, "target_time": self.when(now), "source": source,
                    "source_time": self.when(now), "fixed": fixed}
        if r < 0.94:
            return {"op": "can_full", "target": target, "target_time": self.when(now), "source": source,
                    "source_time": self.when(now), "fixed": fixed}
        return {"op": "lct", "target": target, "source": source}

    # ---- assembly ------------------------------------------------------------------------------
    def build(self) -> dict[str, Any]:
        rng = self.rng
        for child in self.children:
            if child in self.static:
                self.add_static(child)
            else:
                self.add_dynamic(child)
        for _ in range(rng.randint(1, 6)):
            self.add_malformed()
        if rng.random() < 0.2:
            self.deliver(self.t0 + rng.randrange(self.span), {"op": "clear"})
        if not self.events:
            self.deliver(self.t0, self.sample(self.names[0], "lonely", self.t0))
        self.events.sort(key=lambda e: (e[0], e[1]))
        first, last = self.events[0][0], self.events[-1][0]
        # queries: most between inserts, the rest once everything has arrived
        moments = sorted(rng.randrange(first, last + 1) for _ in range(int(self.n_queries * 0.7)))
        ops: list[Op] = []
        i = 0
        for at, _, op in self.events:
            while i < len(moments) and moments[i] <= at:
                ops.append(self.query(moments[i]))
                i += 1
            ops.append(op)
            if op["op"] == "set":
                for name in (op["parent"], op["child"]):
                    name = name[1:] if name.startswith("/") else name   # tf2 strips one slash
                    if name and name not in self.known:
                        self.known.append(name)
            if rng.random() < 0.01:
                ops.append({"op": rng.choice(["frames", "yaml"])})
        while len(ops) < len(self.events) + self.n_queries:
            ops.append(self.query(last))
        ops += [{"op": "frames"}, {"op": "yaml"}]
        return {"seed": self.seed, "cache_time": self.cache_time, "ops": ops}


def generate(seed: int, frames: int = 20, queries: int = 250, cache_time: float | None = None) -> dict[str, Any]:
    """One random scenario; the same arguments give the same scenario in any process."""
    return _Scenario(seed, frames, queries, cache_time).build()


def chaos(seed: int, n_ops: int = 400) -> dict[str, Any]:
    """Small and dense: six frames, a coarse grid of stamps (so repeated stamps, exact-sample
    lookups and re-parenting are frequent), static/dynamic switches, loops, clear(), slashes,
    NaN and denormalized input, a short cache."""
    rng = random.Random(seed)
    frames = ["a", "b", "c", "d", "e", "f"]
    grid = [1000 * NS + k * NS // 4 for k in range(24)]

    def when() -> list[int]:
        r = rng.random()
        if r < 0.15:
            return [0, 0]
        t = rng.choice(grid)
        if r < 0.9:
            t += rng.choice([0, 0, NS // 8, NS // 16, 1])
        else:
            t += int(rng.uniform(-3, 9) * NS)
        return stamp(t)

    ops: list[Op] = []
    for _ in range(n_ops):
        kind = rng.random()
        if kind < 0.5:
            parent, child = rng.sample(frames, 2)
            q = unit_quaternion(rng)
            t = [rng.uniform(-2, 2) for _ in range(3)]
            bad = rng.random()
            if bad < 0.03:
                t[0] = float("nan")
            elif bad < 0.06:
                q = [0.0, 0.0, 0.3, 0.3]
            elif bad < 0.09:
                parent = "/" + parent
            elif bad < 0.11:
                child = parent
            s = when()
            ops.append({"op": "set", "parent": parent, "child": child, "stamp": s if s != [0, 0] else [1000, 0],
                        "t": t, "q": q, "static": rng.random() < 0.15, "authority": "chaos"})
        elif kind < 0.52:
            ops.append({"op": "clear"})
        else:
            a, b = rng.choice(frames + ["zz", "", "/a"]), rng.choice(frames)
            r = rng.random()
            if r < 0.42:
                ops.append({"op": "lookup", "target": a, "source": b, "time": when()})
            elif r < 0.65:
                ops.append({"op": "can", "target": a, "source": b, "time": when()})
            elif r < 0.85:
                ops.append({"op": "lookup_full", "target": a, "target_time": when(), "source": b,
                            "source_time": when(), "fixed": rng.choice(frames)})
            elif r < 0.95:
                ops.append({"op": "can_full", "target": a, "target_time": when(), "source": b,
                            "source_time": when(), "fixed": rng.choice(frames)})
            else:
                ops.append({"op": "lct", "target": a, "source": b})
    ops += [{"op": "frames"}, {"op": "yaml"}]
    return {"seed": seed, "cache_time": rng.choice([1.0, 2.0, 10.0]), "ops": ops}


def hand_made() -> dict[str, Any]:
    """Corners random scenarios rarely reach, each written out: repeated stamps, NO_DATA, pruning,
    TF_OLD_DATA, static/dynamic switches, loops, clear(), a parent switch between two samples,
    slashes and empty names, full lookups through an unknown fixed frame."""
    def s(parent: str, child: str, sec: int, x: float = 1.0, static: bool = False,
          q: tuple[float, ...] = (0.0, 0.0, 0.0, 1.0)) -> Op:
        return _set(parent, child, sec * NS, [x, 0.0, 0.0], list(q), static, "hand")

    def lk(target: str, source: str, sec: int, nsec: int = 0) -> Op:
        return {"op": "lookup", "target": target, "source": source, "time": [sec, nsec]}

    def can(target: str, source: str, sec: int, nsec: int = 0) -> Op:
        return {"op": "can", "target": target, "source": source, "time": [sec, nsec]}

    def full(target: str, tt: int, source: str, st: int, fixed: str, op: str = "lookup_full") -> Op:
        return {"op": op, "target": target, "target_time": [tt, 0], "source": source, "source_time": [st, 0],
                "fixed": fixed}

    ops = [
        lk("a", "b", 1), can("a", "b", 1), {"op": "yaml"}, {"op": "frames"},
        s("a", "b", 1), s("a", "b", 2, 2.0), s("a", "b", 2, 9.0),            # repeated: first wins
        lk("a", "b", 2), lk("a", "b", 1, 500_000_000), lk("a", "b", 3), lk("a", "b", 0),
        s("x", "y", 5), lk("a", "y", 1), lk("a", "y", 0), can("a", "y", 0),   # two trees
        s("a", "b", 20, 5.0), lk("a", "b", 1), lk("a", "b", 15),             # pruned, old data gone
        s("a", "b", 9, 7.0), s("a", "b", 10, 7.0), lk("a", "b", 10),         # too old / exactly 10 s old
        s("s", "t", 5, 3.0, static=True), s("s", "t", 6, 4.0), lk("s", "t", 100), lk("s", "t", 0),
        s("a", "b", 30, 3.0, static=True), lk("a", "b", 30), lk("a", "b", 31),  # dynamic first: kept
        s("b", "c", 30), s("c", "b", 30), lk("a", "c", 30), lk("c", "zz", 30),  # a loop b<->c
        s("u", "v", 30), s("v", "w", 30), lk("w", "a", 30), lk("u", "w", 30), can("w", "a", 30),
        {"op": "frames"}, {"op": "clear"}, lk("a", "b", 0), lk("a", "b", 30), lk("s", "t", 7), can("a", "b", 0),
        s("a", "b", 40, 1.0), s("a", "b", 41, 2.0, q=(0.0, 0.0, 1.0, 0.0)), lk("a", "b", 40, 250_000_000),
        s("b", "e", 40), s("e", "b", 41), lk("a", "e", 40, 500_000_000),      # b and e swap places
        s("a", "k", 40, 1.0), s("x", "k", 41, 7.0), lk("a", "k", 40, 500_000_000),  # k's parent switches:
        lk("x", "k", 40, 500_000_000), lk("x", "k", 0), can("a", "k", 41),    # the older sample applies
        s("/a", "/f", 40), s("a", "a", 40), s("", "g", 40), s("a", "/", 40), s("//a", "h", 40),
        lk("a", "f", 40), lk("/a", "h", 40), lk("a", "/a", 40), can("/a", "h", 40),
        full("a", 40, "f", 40, "a"), full("a", 40, "f", 40, "nope"), full("a", 40, "f", 99, "a", "can_full"),
        full("f", 0, "y", 0, "a"), full("f", 41, "b", 40, "b"), full("f", 0, "f", 0, "x"),
        {"op": "lct", "target": "a", "source": "e"}, {"op": "lct", "target": "s", "source": "t"},
        {"op": "lct", "target": "a", "source": "zz"}, {"op": "lct", "target": "q", "source": "q"},
        s("a", "n", 40, 1e300), s("n", "o", 40, -3e299), lk("o", "a", 40), lk("a", "o", 0),   # huge
        s("a", "m", 40, q=(0.0, 0.0, 0.0, 1.004)), lk("m", "a", 40),         # near-unit: stored as given
        {"op": "frames"}, {"op": "yaml"},
    ]
    return {"seed": -1, "cache_time": 10.0, "ops": ops}
