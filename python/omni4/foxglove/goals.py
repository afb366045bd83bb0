"""The goal in Foxglove's 3D panel (docs/goal.md): the path of a goal_t (OMNI4_GOAL) as a line
through its poses with a marker at each, and the controller's reference on its plan
(goal_status_t on OMNI4_GOAL_STATUS), all in the world frame. Shared by omni4-bridge and
omni4-mcap through topics.event_messages."""
import math

import orjson

TOPIC_GOAL = "/omni4/goal"                    # foxglove.SceneUpdate: the poses asked for
TOPIC_GOAL_REFERENCE = "/omni4/goal_reference"  # foxglove.PoseInFrame: the plan's pose now
_GREEN = {"r": 0.1, "g": 0.8, "b": 0.3, "a": 1.0}
_GOAL = {"r": 0.95, "g": 0.2, "b": 0.6, "a": 1.0}


def _q(theta):
    return {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * theta), "w": math.cos(0.5 * theta)}


def _stamp(ns):
    return {"sec": int(ns // 1_000_000_000), "nsec": int(ns % 1_000_000_000)}


def goal_scene_json(stamp_ns, msg, frame):
    """A SceneUpdate for goal_t msg: one entity "goal" (replacing the last one) with a line
    strip through the poses and a small cube per pose turned to its heading (the last one,
    the goal, larger and in its own colour). A cancel (no poses) deletes the entity."""
    t = _stamp(stamp_ns)
    if not msg.poses:
        return orjson.dumps({"deletions": [{"timestamp": t, "type": 0, "id": "goal"}],
                             "entities": []})
    pts = [{"x": p[0], "y": p[1], "z": 0.01} for p in msg.poses]
    cubes = []
    for i, p in enumerate(msg.poses):
        last = i == len(msg.poses) - 1
        s = 0.08 if last else 0.04
        cubes.append({"pose": {"position": {"x": p[0], "y": p[1], "z": 0.02},
                               "orientation": _q(p[2])},
                      "size": {"x": 2 * s, "y": s, "z": 0.02},
                      "color": _GOAL if last else _GREEN})
    line = {"type": 0, "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.0},
                                "orientation": _q(0.0)},
            "thickness": 0.01, "scale_invariant": False, "points": pts, "color": _GREEN,
            "colors": [], "indices": []}
    ent = {"timestamp": t, "frame_id": frame, "id": "goal", "lifetime": _stamp(0),
           "frame_locked": False, "metadata": [{"key": "goal_id", "value": str(msg.goal_id)}],
           "cubes": cubes, "cylinders": [], "lines": [line]}
    return orjson.dumps({"deletions": [], "entities": [ent]})


def reference_json(stamp_ns, st, frame):
    """PoseInFrame of the reference in goal_status_t st."""
    x, y, th = st.reference
    return orjson.dumps({"timestamp": _stamp(stamp_ns), "frame_id": frame,
                         "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": _q(th)}})
