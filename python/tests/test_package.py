"""The installed package: generated types round-trip, and agree with the .lcm sources."""
import os
import re
import sys

import omni4

LCM_DIR = os.path.join(os.path.dirname(__file__), "..", "..", "lcmtypes")


def test_every_lcm_struct_is_a_package_type():
    names = set()
    for f in os.listdir(LCM_DIR):
        if f.endswith(".lcm"):
            with open(os.path.join(LCM_DIR, f)) as fh:
                names.update(re.findall(r"^struct\s+(\w+)", fh.read(), re.M))
    assert names == {"command_t", "experiment_t", "motors_t", "pose_t", "param_request_t",
                     "param_reply_t", "param_value_t", "param_changed_t"}
    for n in names:
        assert hasattr(omni4, n), n


def test_motors_round_trip():
    m = omni4.motors_t()
    m.utime, m.seq, m.mode, m.faults = 123456, 7, omni4.motors_t.MODE_VELOCITY, 0x0200
    m.voltage = [1.5, -2.25, 0.0, 11.75]
    m.current = [0.5, -0.25, 0.125, 4.0]
    m.wheel_speed = [10.0, -20.0, 0.0, 3.5]
    d = omni4.motors_t.decode(m.encode())
    assert (d.utime, d.seq, d.mode, d.faults) == (123456, 7, 1, 0x0200)
    assert list(d.voltage) == m.voltage and list(d.current) == m.current
    assert list(d.wheel_speed) == m.wheel_speed


def test_channels_map_to_types():
    assert omni4.TYPES[omni4.CHANNEL_MOTORS] is omni4.motors_t
    assert omni4.TYPES[omni4.CHANNEL_CMD] is omni4.command_t
    assert omni4.TYPES[omni4.CHANNEL_POSE] is omni4.pose_t
    assert omni4.TYPES[omni4.CHANNEL_EXPERIMENT] is omni4.experiment_t


def test_channel_names_match_the_c_header():
    """omni4.CHANNEL_* and MARK_* are the names of lcmtypes/include/omni4/channels.h, one for one."""
    header = os.path.join(LCM_DIR, "include", "omni4", "channels.h")
    with open(header) as fh:
        c_names = dict(re.findall(r'#define OMNI4_((?:CHANNEL|MARK)_\w+) "(\w+)"', fh.read()))
    py_names = {n: getattr(omni4, n) for n in dir(omni4) if n.startswith(("CHANNEL_", "MARK_"))}
    assert len(c_names) >= 8 and "MARK_END" in c_names
    assert py_names == c_names


def test_foxglove_tools_without_their_extra_say_so_in_one_line(monkeypatch, capsys):
    """omni4-bridge and omni4-mcap installed without the 'foxglove' extra: status 2 and one line
    naming the missing package, not a traceback."""
    import omni4.foxglove as fg
    for missing in ("foxglove", "orjson"):
        monkeypatch.setitem(sys.modules, missing, None)  # import raises ImportError
        for entry, prog in ((fg.bridge_main, "omni4-bridge"), (fg.export_main, "omni4-mcap")):
            assert entry() == 2
            err = capsys.readouterr().err
            assert err == (f"{prog}: needs the Python package '{missing}' "
                           "(pip install './python[foxglove]')\n"), err
        monkeypatch.delitem(sys.modules, missing)
