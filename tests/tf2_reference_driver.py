#!/usr/bin/python3
"""Answer tf2 scenarios (tests/tf2_scenarios.py) with the real tf2: Debian's python3-tf2, the C++
BufferCore of ROS 1 geometry2, importable only by the system interpreter.

    /usr/bin/python3 tests/tf2_reference_driver.py < scenarios.json > answers.json

Input: ``{"scenarios": [scenario, ...]}``; output: one list of answers per scenario, in order (the
answer formats are in tests/tf2_scenarios.py). JSON both ways, NaN and Infinity included. Each
scenario gets a fresh BufferCore. tf2 logs its refusals (TF_OLD_DATA, TF_NAN_INPUT, ...) on stderr.

This file runs under /usr/bin/python3 only; nothing else in the test suite imports it.
"""
import json
import sys


def main():
    import geometry_msgs.msg
    import rospy
    import tf2_py

    def time(pair):
        return rospy.Time(int(pair[0]), int(pair[1]))

    def transform(m):
        tr, rot = m.transform.translation, m.transform.rotation
        return {"ok": True, "t": [tr.x, tr.y, tr.z], "q": [rot.x, rot.y, rot.z, rot.w],
                "stamp": [m.header.stamp.secs, m.header.stamp.nsecs],
                "frame_id": m.header.frame_id, "child_frame_id": m.child_frame_id}

    def answer(core, op):
        kind = op["op"]
        if kind == "set":
            m = geometry_msgs.msg.TransformStamped()
            m.header.frame_id, m.child_frame_id = op["parent"], op["child"]
            m.header.stamp = time(op["stamp"])
            tr, rot = m.transform.translation, m.transform.rotation
            tr.x, tr.y, tr.z = op["t"]
            rot.x, rot.y, rot.z, rot.w = op["q"]
            if op["static"]:
                core.set_transform_static(m, op["authority"])
            else:
                core.set_transform(m, op["authority"])
            return {"ok": True}
        if kind == "lookup":
            return transform(core.lookup_transform_core(op["target"], op["source"], time(op["time"])))
        if kind == "lookup_full":
            return transform(core.lookup_transform_full_core(op["target"], time(op["target_time"]), op["source"],
                                                             time(op["source_time"]), op["fixed"]))
        if kind == "can":
            ok, why = core.can_transform_core(op["target"], op["source"], time(op["time"]))
            return {"ok": True, "can": bool(ok), "message": why}
        if kind == "can_full":
            ok, why = core.can_transform_full_core(op["target"], time(op["target_time"]), op["source"],
                                                   time(op["source_time"]), op["fixed"])
            return {"ok": True, "can": bool(ok), "message": why}
        if kind == "lct":
            t = core.get_latest_common_time(op["target"], op["source"])
            return {"ok": True, "stamp": [t.secs, t.nsecs]}
        if kind == "frames":
            return {"ok": True, "text": core.all_frames_as_string()}
        if kind == "yaml":
            return {"ok": True, "text": core.all_frames_as_yaml()}
        if kind == "clear":
            core.clear()
            return {"ok": True}
        raise ValueError("unknown op %r" % kind)

    out = []
    for scenario in json.load(sys.stdin)["scenarios"]:
        core = tf2_py.BufferCore(rospy.Duration.from_sec(scenario["cache_time"]))
        answers = []
        for op in scenario["ops"]:
            try:
                answers.append(answer(core, op))
            except tf2_py.TransformException as e:
                answers.append({"ok": False, "error": type(e).__name__, "message": str(e)})
        out.append(answers)
    json.dump(out, sys.stdout)


if __name__ == "__main__":
    main()
