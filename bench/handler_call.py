"""Per-sample cost of a TransformListener's TfHandler.__call__ (Zenoh's callback path) on real zenoh.Samples:
N x R one-transform messages with distinct stamps are received first, then handed to the handler, R rounds.

    python bench/handler_call.py [N] [R]            # ns per sample (noisy on a loaded machine)
    PYTHONMALLOC=malloc valgrind --tool=callgrind --collect-atstart=no \
        --toggle-collect=__pyx_pw_5zentf_9transport_6ingest_7handler_9TfHandler_3__call__ \
        python bench/handler_call.py 5000 1         # instructions in __call__ only: / 5000 per sample

Run it with PYTHONPATH at two trees (e.g. main and a branch) to compare builds in one session.
"""
import statistics
import sys
import threading
import time

from zentf.transport.node import Node
from zentf.transport.buffer import Buffer
from zentf.transport.listener import TransformListener
from zentf.transport.options import NodeOptions, ZenohOptions
from zentf.core.messages import TransformStamped, Header, Transform, Vector3, Quaternion
from zentf.core.time import Time
from zentf.transport.wire import codec as wire
import zentf

print(zentf.__file__)
opts = NodeOptions(namespace="hb", zenoh=ZenohOptions(no_multicast=True, listen=["tcp/127.0.0.1:0"]))
node = Node("hb", options=opts)
buf = Buffer(node=node)
tl = TransformListener(buf, node)
h = [x for x in tl._handlers][-1]
got = []
ev = threading.Event()
sub = node.session.declare_subscriber("hb/tf", lambda s: (got.append(s), ev.set()))
N = int(sys.argv[1]) if len(sys.argv) > 1 else 30000
R = int(sys.argv[2]) if len(sys.argv) > 2 else 7
pub = node.session.declare_publisher("hb/tf", encoding=wire.encoding_for("tf2_msgs/msg/TFMessage"))
for i in range(N * R):
    pub.put(wire.encode_tf([TransformStamped(Header(Time(1, i * 1000), "a"), "b", Transform(Vector3(1,0,0), Quaternion(0,0,0,1)))]), attachment=b"/x")
while len(got) < N * R:
    ev.clear(); ev.wait(1)
res = []
for r in range(R):
    chunk = got[r * N:(r + 1) * N]
    t = time.perf_counter()
    for s in chunk:
        h(s)
    res.append((time.perf_counter() - t) / N * 1e9)
print("ns per sample: median %.0f min %.0f" % (statistics.median(res), min(res)), h.transforms)
node.shutdown()
