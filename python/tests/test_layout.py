"""omni4._layout: the wire dtypes read from the generated classes."""
import random

import numpy as np
import pytest

import omni4
from omni4 import _layout


def random_message(cls, rng):
    m = cls()
    dt = _layout.wire_dtype(cls)
    for name in dt.names[1:]:
        base, shape = dt[name].base, dt[name].shape
        if base.kind == "i":
            bits = 8 * base.itemsize - 1
            vals = [rng.randint(-2 ** bits, 2 ** bits - 1) for _ in range(int(np.prod(shape)))]
        else:  # float32 fields get values float32 holds exactly
            vals = [float(np.asarray(rng.uniform(-1e3, 1e3), base)) for _ in
                    range(int(np.prod(shape)))]
        setattr(m, name, vals if shape else vals[0])
    return m


@pytest.mark.parametrize("cls, size", [(omni4.motors_t, 77), (omni4.pose_t, 40),
                                       (omni4.command_t, 89)])
def test_wire_dtype_reads_what_the_generated_encoder_writes(cls, size):
    dt = _layout.wire_dtype(cls)
    assert dt.itemsize == size and dt.names == ("fingerprint", *cls.__slots__)
    rng = random.Random(3)
    msgs = [random_message(cls, rng) for _ in range(50)]
    rec = np.frombuffer(b"".join(m.encode() for m in msgs), dt)
    assert (rec["fingerprint"] == _layout.fingerprint(cls)).all()
    fields = _layout.fields_of(rec)
    again = _layout.fields_of_messages(cls, [cls.decode(m.encode()) for m in msgs])
    for name in cls.__slots__:
        want = np.array([getattr(m, name) for m in msgs])
        assert fields[name].dtype.isnative and np.array_equal(fields[name], want), name
        assert fields[name].dtype == again[name].dtype and np.array_equal(again[name], want)
    empty = _layout.empty_fields(cls)
    assert all(empty[n].shape == (0,) + fields[n].shape[1:] for n in cls.__slots__)


def test_types_without_a_fixed_size_have_no_wire_dtype():
    for cls in (omni4.experiment_t, omni4.param_changed_t, omni4.param_request_t,
                omni4.param_reply_t, omni4.param_value_t):
        assert _layout.wire_dtype(cls) is None, cls.__name__


def declared_as(cls, field, typename):
    """A subclass of cls whose __typenames__ declares `field` as typename (the encoder is cls's)."""
    names = [typename if n == field else t for n, t in zip(cls.__slots__, cls.__typenames__)]
    return type(f"{cls.__name__}_{field}_{typename}", (cls,), {"__typenames__": names})


@pytest.mark.parametrize("cls, field, typename", [
    (omni4.motors_t, "faults", "int64_t"),     # another size
    (omni4.motors_t, "faults", "float"),       # same size, another type
    (omni4.command_t, "ramp_s", "int64_t"),
    (omni4.pose_t, "x", "string"),             # no fixed size at all
])
def test_a_layout_the_encoder_does_not_write_is_refused(cls, field, typename):
    bad = declared_as(cls, field, typename)
    if typename == "string":
        assert _layout.wire_dtype(bad) is None
        return
    with pytest.raises(TypeError, match=f"{bad.__name__}'s __typenames__ does not decode"):
        _layout.wire_dtype(bad)
    assert _layout.wire_dtype(declared_as(cls, field, dict(zip(
        cls.__slots__, cls.__typenames__))[field])) is not None  # the same, declared right
