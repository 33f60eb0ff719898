"""A fuzzing process throws thousands of random, truncated and mutated payloads at a listener."""
from __future__ import annotations

import textwrap

from zentf.transport.buffer import Buffer
from zentf.transport.listener import TransformListener
from zentf.core.messages import Header, Quaternion, Transform, TransformStamped, Vector3
from zentf.transport.node import Node
from zentf.core.time import Time

FUZZER = textwrap.dedent("""
    import math, os, random, sys
    import msgpack, zenoh
    from zentf.transport.options import ZenohOptions
    from zentf.transport.wire import codec as wire
    seed = int(sys.argv[1]); n = int(sys.argv[2]); ns = os.environ["ZENTF_NAMESPACE"]
    rnd = random.Random(seed)
    s = ZenohOptions.from_env().open_session()
    keys = [f"{ns}/tf", f"{ns}/tf_static"]
    tf_enc = wire.encoding_for("tf2_msgs/msg/TFMessage")
    pubs = {k: s.declare_publisher(k, encoding=tf_enc, congestion_control=zenoh.CongestionControl.BLOCK)
            for k in keys}
    def good(i):
        return {"header": {"stamp": {"sec": 1000 + i, "nanosec": 0}, "frame_id": f"z{rnd.randrange(5)}"},
                "child_frame_id": f"z{5 + rnd.randrange(5)}",
                "transform": {"translation": {"x": 1.0, "y": 2.0, "z": 3.0},
                              "rotation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}}}
    WEIRD = [None, True, "x", "", -1, 2**64 - 1, -2**63, float("nan"), float("inf"), [], {}, [1, 2], b"\\xff",
             {"sec": 1}, 1e308, "/", "a/b"]
    def mutate(d, depth=0):
        if not isinstance(d, dict) or depth > 4:
            return rnd.choice(WEIRD)
        d = dict(d)
        k = rnd.choice(list(d))
        r = rnd.random()
        if r < 0.3:
            del d[k]
        elif r < 0.6:
            d[k] = rnd.choice(WEIRD)
        else:
            d[k] = mutate(d[k], depth + 1)
        return d
    def payload(i):
        kind = rnd.randrange(7)
        if kind == 0:
            return rnd.randbytes(rnd.randrange(0, 300))
        msg = {"transforms": [good(i) for _ in range(rnd.randrange(1, 6))]}
        if kind == 1:
            b = msgpack.packb(msg)
            return b[: rnd.randrange(0, len(b))]
        if kind == 2:
            msg["transforms"] = [mutate(t) if rnd.random() < 0.7 else t for t in msg["transforms"]]
            return msgpack.packb(msg, use_bin_type=True)
        if kind == 3:
            return msgpack.packb(rnd.choice([[1, 2, 3], "str", 5, {"transforms": 5}, {"x": []},
                                             {"transforms": [1, "a", None]}]), use_bin_type=True)
        if kind == 4:
            b = bytearray(msgpack.packb(msg))
            for _ in range(rnd.randrange(1, 6)):
                b[rnd.randrange(len(b))] = rnd.randrange(256)
            return bytes(b)
        if kind == 5:  # deep nesting and bogus lengths
            return rnd.choice([b"\\x91" * 5000, b"\\xdd\\xff\\xff\\xff\\xff", b"\\xdf\\xff\\xff\\xff\\xff\\x01",
                               b"\\xdb\\xff\\xff\\xff\\xff"])
        return msgpack.packb(msg, use_bin_type=True)  # valid, in fuzz frames
    for i in range(n):
        key = rnd.choice(keys)
        att = rnd.choice([None, b"/fuzzer", b"\\xff\\xfe", b"x" * 1000])
        enc = rnd.choice([None, None, None, "application/msgpack;geometry_msgs/msg/Point", "text/plain"])
        kw = {"attachment": att} if att is not None else {}
        if enc:
            kw["encoding"] = enc
        pubs[key].put(payload(i), **kw)
    # a huge but valid message, then the sentinel; order per key is preserved, so when the
    # sentinel is visible every payload before it has been handled
    big = {"transforms": [dict(good(0), child_frame_id=f"big{j}", header={"stamp": {"sec": 5, "nanosec": 0},
                                                                         "frame_id": "bigroot"})
                          for j in range(20000)]}
    pubs[keys[0]].put(msgpack.packb(big))
    for k, child in zip(keys, ["sentinel_tf", "sentinel_static"]):
        sentinel = {"transforms": [dict(good(0), child_frame_id=child,
                                        header={"stamp": {"sec": 7, "nanosec": 0}, "frame_id": "good_parent"})]}
        pubs[k].put(msgpack.packb(sentinel), attachment=b"/fuzzer")
    print("done", n, flush=True)
    s.close()
""")


def _ts(parent: str, child: str, x: float, stamp: Time) -> TransformStamped:
    return TransformStamped(Header(stamp, parent), child, Transform(Vector3(x, 0, 0), Quaternion(0, 0, 0, 1)))


def test_listener_survives_fuzzing(spawn, node_options) -> None:
    with Node("victim", options=node_options) as node:
        buf = Buffer(node=node, max_frames=30_000)  # the huge valid message below holds 20,000 frames
        tl = TransformListener(buf, node)
        buf.set_transform(_ts("good_parent", "good_child", 1.5, Time(sec=7)), "test", is_static=True)
        buf.set_transform(_ts("odom", "base", 0.5, Time(sec=1000)), "test")
        p = spawn.python("-c", FUZZER, "1234", "4000")
        p.wait_for_line(r"^done 4000", timeout=120)
        assert buf.can_transform("good_parent", "sentinel_tf", Time(sec=7), timeout=30), p.output()[-2000:]
        assert buf.can_transform("good_parent", "sentinel_static", Time(sec=7), timeout=30)
        assert buf.can_transform("bigroot", "big19999", Time(), timeout=30)
        st = tl.stats()
        assert st["bad_messages"] > 500 and st["malformed"] > 100 and st["messages"] > 500, st
        # nothing already buffered was lost or changed
        assert buf.lookup_transform("good_parent", "good_child", Time()).transform.translation.x == 1.5
        assert buf.lookup_transform("odom", "base", Time(sec=1000)).transform.translation.x == 0.5
        # and it still answers new data from a well-behaved sender
        from zentf.transport.broadcaster import TransformBroadcaster

        with Node("honest", options=node_options) as src:
            br = TransformBroadcaster(src)
            assert br.wait_for_subscribers(5)
            br.send_transform(_ts("odom", "base", 0.75, Time(sec=1001)))
            assert buf.can_transform("odom", "base", Time(sec=1001), timeout=5)
            assert buf.lookup_transform("odom", "base", Time(sec=1001)).transform.translation.x == 0.75
        assert "Traceback" not in p.output()
