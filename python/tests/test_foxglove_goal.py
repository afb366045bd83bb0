"""A goal in Foxglove (omni4/foxglove/goals.py): an LCM log with goal_t and goal_status_t
exported by omni4-mcap holds /omni4/goal (a line through the poses asked for, a marker per
pose, in "world") and /omni4/goal_reference (the plan's pose), each at its event's time."""
import math

import lcm
import pytest

import omni4

pytest.importorskip("foxglove")
pytest.importorskip("mcap")
from omni4.foxglove import export, goals  # noqa: E402
from test_foxglove_model import read_mcap_python  # noqa: E402

PATH = [[1.0, 0.0, 0.0], [1.0, 1.0, 0.5], [0.0, 1.0, 3.0]]


def write_log(path):
    w = lcm.EventLog(str(path), "w", overwrite=True)
    g = omni4.goal_t()
    g.goal_id, g.action, g.n, g.poses = 9, omni4.goal_t.ACTION_GO, len(PATH), PATH
    w.write_event(1_000_000, omni4.CHANNEL_GOAL, g.encode())
    st = omni4.goal_status_t()
    st.goal_id, st.status, st.n, st.reference = 9, st.STATUS_ACTIVE, 3, [0.25, 0.5, -1.0]
    w.write_event(1_010_000, omni4.CHANNEL_GOAL_STATUS, st.encode())
    c = omni4.goal_t()
    c.goal_id, c.action = 9, omni4.goal_t.ACTION_CANCEL
    w.write_event(1_020_000, omni4.CHANNEL_GOAL, c.encode())
    w.close()


def test_goal_and_reference_in_the_mcap(tmp_path):
    log, out = tmp_path / "g.lcmlog", str(tmp_path / "g.mcap")
    write_log(log)
    assert export.main([str(log), "--out", out, "-q"]) == 0
    got, _, _ = read_mcap_python(out)
    scene = got[goals.TOPIC_GOAL]
    assert [s for _, s, _ in scene] == ["foxglove.SceneUpdate"] * 2
    t, _, j = scene[0]
    assert t == 1_000_000_000
    ent = j["entities"][0]
    assert ent["frame_id"] == "world" and ent["id"] == "goal"
    pts = ent["lines"][0]["points"]
    assert [[p["x"], p["y"]] for p in pts] == [p[:2] for p in PATH]
    for cube, p in zip(ent["cubes"], PATH):
        q = cube["pose"]["orientation"]
        assert abs(math.remainder(2 * math.atan2(q["z"], q["w"]) - p[2], 2 * math.pi)) < 1e-12
    assert scene[1][2]["deletions"][0]["id"] == "goal" and not scene[1][2]["entities"]
    ref = got[goals.TOPIC_GOAL_REFERENCE]
    assert len(ref) == 1 and ref[0][0] == 1_010_000_000
    pos = ref[0][2]["pose"]["position"]
    assert (pos["x"], pos["y"]) == (0.25, 0.5)
    assert got[omni4.CHANNEL_GOAL][0][2]["poses"] == PATH
