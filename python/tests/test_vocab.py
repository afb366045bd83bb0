"""The vocabulary (core/include/omni4/core/vocab.def, drivers/include/omni4/drivers/backends.def) as the
package sees it: generated from the rows as they are now, in agreement with every constant of
the LCM types both ways, and a new mode or backend is one row."""
import os
import sys

import pytest

import omni4
from omni4 import _vocab

REPO = os.path.join(os.path.dirname(__file__), "..", "..")


def _gen_vocab():
    sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
    try:
        return __import__("gen_vocab")
    finally:
        sys.path.pop(0)


def _lcm_constants(t, prefix):
    return {n[len(prefix):]: getattr(t, n) for n in dir(t) if n.startswith(prefix)}


def test_vocab_module_is_the_generators_output_for_the_rows_as_they_are():
    with open(_vocab.__file__, encoding="utf-8") as fh:
        assert fh.read() == _gen_vocab().python_module(REPO)


def test_every_lcm_mode_fault_and_flag_is_a_row_and_every_row_an_lcm_constant():
    """The C side checks each row against its LCM constant at compile time (lcmcodec.c); here
    the other way: no MODE_/FAULT_/FLAG_ constant of the .lcm files is missing a row."""
    cmd = {n: v for n, v in _vocab.MODES.items() if v in _vocab.COMMAND_MODES}
    rep = {n: v for n, v in _vocab.MODES.items() if v in _vocab.REPORTED_MODES}
    assert _lcm_constants(omni4.command_t, "MODE_") == cmd
    assert _lcm_constants(omni4.motors_t, "MODE_") == rep
    assert _lcm_constants(omni4.motors_t, "FAULT_") == _vocab.FAULTS
    assert _lcm_constants(omni4.state_t, "FLAG_") == _vocab.FLAGS
    statuses = {n: v for v, n in _vocab.GOAL_STATUSES.items()}
    reasons = {n: v for v, (n, _) in _vocab.GOAL_REASONS.items()}
    assert _lcm_constants(omni4.goal_status_t, "STATUS_") == statuses
    assert _lcm_constants(omni4.goal_status_t, "REASON_") == reasons


def test_the_wire_values_stay_as_the_contract_says():
    """docs/design.md's numbers, pinned on purpose: a row may be added, none renumbered."""
    assert _vocab.MODES == {"IDLE": 0, "VELOCITY": 1, "VOLTAGE": 2, "COAST": 3, "CLEAR_FAULT": 4,
                            "FAULT": 5, "ESTOP": 6, "GOAL": 7}
    assert _vocab.DRIVEN_MODES == (1, 2, 7) and _vocab.KEPT_ALIVE_MODES == (1, 2, 3, 7)
    assert _vocab.FAULTED_MODES == (5, 6) and _vocab.LATCHING == 0xff
    assert _vocab.FAULTS["OVERRUN"] == 0x1000 and _vocab.FAULTS["OUTPUT"] == 0x80 and _vocab.FLAGS["NO_WHEELS"] == 0x08
    assert _vocab.GOAL_STATUSES == {0: "NONE", 1: "ACTIVE", 2: "REACHED", 3: "ABORTED",
                                    4: "REFUSED"}
    assert _vocab.GOAL_REASONS[9][0] == "REPLACED" and _vocab.GOAL_REASONS[12][0] == "SETTLING"
    assert _vocab.backend_words("motor") == ("sim", "socketcan", "vesc", "odrive")
    assert _vocab.backend_words("lines") == ("none", "sim", "gpiod")


def test_names_of_unknown_values_have_one_spelling():
    assert _vocab.mode_name(1) == "VELOCITY" and _vocab.mode_name(42) == "UNKNOWN_42"
    assert _vocab.fault_names(0x0401 | 0x8000) == ["OVERCURRENT", "CMD_REJECTED",
                                                   "UNKNOWN_0x8000"]


def _with_rows(extra_vocab="", extra_backends=""):
    g = _gen_vocab()
    out = {}
    for rel, extra in ((g.VOCAB_DEF, extra_vocab), (g.BACKENDS_DEF, extra_backends)):
        with open(os.path.join(REPO, rel), encoding="utf-8") as fh:
            for k, v in g.rows(fh.read() + extra, rel).items():
                out.setdefault(k, []).extend(v)
    return g, out


def test_a_mode_is_one_row():
    g, v = _with_rows('OMNI4_MODE(DOCK, 8, BOTH, 1, 1, 0, "drive onto the charger")\n')
    ns = {}
    exec(g.python_module(vocab=v), ns)  # noqa: S102 (the generator's own output)
    assert ns["MODES"]["DOCK"] == 8 and ns["mode_name"](8) == "DOCK"
    assert 8 in ns["DRIVEN_MODES"] and 8 in ns["KEPT_ALIVE_MODES"]
    assert 8 in ns["COMMAND_MODES"] and 8 in ns["REPORTED_MODES"]
    assert 8 not in ns["FAULTED_MODES"]
    assert "| DOCK | 8 | command_t, motors_t | yes | yes |  | drive onto the charger |" in \
        g.markdown(vocab=v)


def test_a_backend_is_one_row():
    g, v = _with_rows(extra_backends='OMNI4_BACKEND(MOTOR, SERIAL, "serial", "serial_keys.def", '
                                     'serial, serial_settings, serial_motor, "omni4/serial_motor.h", '
                                     'LINUX, "drivers on a serial line")\n')
    ns = {}
    exec(g.python_module(vocab=v), ns)  # noqa: S102
    assert ns["backend_words"]("motor") == ("sim", "socketcan", "vesc", "odrive", "serial")
    assert "| `motor` | `serial` | `serial_keys.def` | drivers on a serial line |" in \
        g.markdown(vocab=v)


def test_the_generator_refuses_a_row_it_cannot_read():
    g = _gen_vocab()
    with pytest.raises(g.VocabError, match=r"v.def:2: OMNI4_FAULT takes 4 columns"):
        g.rows('/* */\nOMNI4_FAULT(X, 0x1, "doc")\n', "v.def")
    with pytest.raises(g.VocabError, match=r"v.def:1: not a one-line"):
        g.rows('OMNI4_MODE(X, 1, BOTH, 0, 0, 0,\n', "v.def")
    _, v = _with_rows('OMNI4_MODE(AGAIN, 1, BOTH, 0, 0, 0, "a value twice")\n')
    with pytest.raises(g.VocabError, match="listed twice"):
        g._check(v, "v.def")
    _, v = _with_rows('OMNI4_FAULT(TWO_BITS, 0x6000, 0, "not one bit")\n')
    with pytest.raises(g.VocabError, match="not a single bit"):
        g._check(v, "v.def")
    _, v = _with_rows('OMNI4_MODE(ODD, 9, BOTH, 2, 0, 0, "a flag that is not 0 or 1")\n')
    with pytest.raises(g.VocabError, match="flags 0|1"):
        g._check(v, "v.def")
