"""The installed package: generated types round-trip, and agree with the .lcm sources."""
import os
import re
import sys

import pytest

import omni4

LCM_DIR = os.path.join(os.path.dirname(__file__), "..", "..", "lcmtypes")


def test_every_lcm_struct_is_a_package_type():
    names = set()
    for f in os.listdir(LCM_DIR):
        if f.endswith(".lcm"):
            with open(os.path.join(LCM_DIR, f)) as fh:
                names.update(re.findall(r"^struct\s+(\w+)", fh.read(), re.M))
    assert names == {"command_t", "experiment_t", "motors_t", "pose_t", "param_request_t",
                     "param_reply_t", "param_value_t", "param_changed_t", "state_t",
                     "sim_truth_t", "goal_t", "goal_status_t", "sim_plant_t", "adapt_t",
                     "robot_t"}
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


def _generator(name):
    """One of the build-time generators beside setup.py (not part of the package)."""
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
    try:
        return __import__(name)
    finally:
        sys.path.pop(0)


def _gen_channels():
    return _generator("gen_channels")


CHANNELS_H = os.path.join(LCM_DIR, "include", "omni4", "lcmtypes", "channels.h")


def test_channel_constants_are_generated_from_the_c_header():
    """The build wrote omni4/_channels.py with the generator from channels.h as it is now (a
    header changed after the install fails here), and the package takes its names from it."""
    from omni4 import _channels
    with open(CHANNELS_H) as fh:
        text = fh.read()
    with open(_channels.__file__) as fh:
        assert fh.read() == _gen_channels().python_module(text, CHANNELS_H)
    names = {n: v for n, v, _ in _gen_channels().constants(text)}
    assert {"CHANNEL_MOTORS", "CHANNEL_CMD", "MARK_END", "DEFAULT_LCM_URL"} <= set(names)
    for n, v in names.items():
        assert getattr(omni4, n) == v and n in omni4.__all__


def test_channel_generator_turns_defines_into_constants():
    g = _gen_channels()
    text = ('#ifndef G_H\n#define G_H\n/* c */\n#define OMNI4_CHANNEL_X "X_1"   /* x: a -> b */\n'
            '  #  define OMNI4_MARK_Y "y"\n#endif\n')
    assert g.constants(text) == [("CHANNEL_X", "X_1", "x: a -> b"), ("MARK_Y", "y", "")]
    ns = {}
    exec(g.python_module(text), ns)
    assert (ns["CHANNEL_X"], ns["MARK_Y"], ns["__all__"]) == ("X_1", "y", ["CHANNEL_X", "MARK_Y"])


@pytest.mark.parametrize("line, msg", [
    ("#define OMNI4_RATE_HZ 1000", ":2: not `#define OMNI4_NAME"),
    ('#define OMNI4_X "a\\"b"', ":2: not `#define OMNI4_NAME"),
    ('#define OTHER_X "a"', ":2: not `#define OMNI4_NAME"),
    ('#define OMNI4_CHANNEL_CMD "again"', ":2: OMNI4_CHANNEL_CMD defined twice"),
])
def test_channel_generator_refuses_what_it_cannot_carry_over(line, msg):
    g = _gen_channels()
    with pytest.raises(g.HeaderError) as e:
        g.constants(f'#define OMNI4_CHANNEL_CMD "OMNI4_CMD"\n{line}\n', "h.h")
    assert str(e.value).startswith("h.h" + msg), str(e.value)
    with pytest.raises(g.HeaderError, match="h.h: no `#define"):
        g.constants("#ifndef H\n#define H\n#endif\n", "h.h")


def _gen_keys():
    return _generator("gen_keys")


REPO = os.path.join(os.path.dirname(__file__), "..", "..")


def test_key_list_is_generated_from_the_layers_key_lists():
    """omni4/_keys.py is the generator's output for the *_keys.def files as they are now, read in
    the order config.c assembles them."""
    from omni4 import _keys
    g = _gen_keys()
    with open(_keys.__file__) as fh:
        assert fh.read() == g.python_module(REPO)
    with open(os.path.join(REPO, "config", "src", "config.c")) as fh:
        table = fh.read().split("const struct config_key config_keys[] = {", 1)[1]
    # The layers' lists by name, then the backends' through the file generated from
    # backends.def's keys column (cmake/backend_parts.cmake), which def_files reads in row order.
    included = re.findall(r'#include "omni4/\w+/(\w+_keys\.(?:def|inc))"',
                          table.split("\n};", 1)[0])
    assert included == [os.path.basename(p) for p in g.LAYER_FILES] + ["backend_keys.inc"]
    assert g.def_files(REPO)[:len(g.LAYER_FILES)] == g.LAYER_FILES
    assert len(_keys.KEYS) == len(set(_keys.KEYS)) and ("hal", "motor", "choice") in _keys.KEYS
    assert _keys.MODEL_KEYS == ("d", "r", "l", "Kv", "Kt", "R", "M", "J", "Bv", "Bvn", "Bw",
                                "Cv", "Cvn", "Cw")
    assert _keys.MODEL_WHEEL_KEYS == tuple(f"{q}_{j}" for q in ("r", "Kv", "Kt", "R")
                                           for j in range(4))
    assert _keys.MODEL_LAYOUT_KEYS == ("wheels",) + tuple(f"wheel_angle_{j}" for j in range(4)) + \
        tuple(f"d_{j}" for j in range(4))


def test_key_generator_refuses_a_row_it_cannot_read():
    g = _gen_keys()
    assert g.rows('OMNI4_KEY(DBL, "a", "b_c", x, 1, 0, 1, NULL, "", LIVE, "d")\n', "k.def") == \
        [("a", "b_c", "double")]
    with pytest.raises(g.KeyListError, match=r"k.def:2: not"):
        g.rows('/* */\nOMNI4_KEY(FLOAT, "a", "b", x, 1, 0, 1, NULL, "", LIVE, "d")\n', "k.def")


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
