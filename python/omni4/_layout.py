"""The wire layout of the fixed-size omni4 LCM types as numpy structured dtypes, read from the
classes lcm-gen generates (__slots__, __typenames__, __dimensions__, the packed fingerprint), so
the .lcm files stay the only definition: the log reader, omni4-mcap and any script view payloads
through wire_dtype() instead of a copy of the field list.

LCM encodes a message as its 8-byte fingerprint, then each field in .lcm order, big-endian and
packed; a fixed-size array is its elements in row-major order. A type with a string, a
variable-length array or a nested type has no fixed layout (wire_dtype returns None: decode it
message by message)."""
import functools
import struct

import numpy as np

FINGERPRINT_BYTES = 8

# LCM primitive -> numpy, big-endian (lcm-gen's struct formats: b h i q f d B ?).
_PRIMITIVES = {"int8_t": "i1", "int16_t": ">i2", "int32_t": ">i4", "int64_t": ">i8",
               "float": ">f4", "double": ">f8", "byte": "u1", "boolean": "?"}


def fingerprint(cls):
    """The type's packed fingerprint as the unsigned integer a ">u8" column holds."""
    return int.from_bytes(cls._get_packed_fingerprint(), "big")


@functools.lru_cache(maxsize=None)
def wire_dtype(cls):
    """Structured big-endian dtype of one encoded cls message: "fingerprint" (>u8), then the
    fields by name (fixed-size arrays as subarrays); None for a type without a fixed size.
    Checked against the generated encoder on a probe message; a mismatch is an error, not a
    misread."""
    fields = [("fingerprint", ">u8")]
    for name, typ, dims in zip(cls.__slots__, cls.__typenames__, cls.__dimensions__):
        dims = tuple(dims or ())
        if typ not in _PRIMITIVES or not all(isinstance(d, int) for d in dims):
            return None
        fields.append((name, _PRIMITIVES[typ], dims))
    dt = np.dtype(fields)
    _check(cls, dt)
    return dt


def _check(cls, dt):
    """Raises if dt does not read back a probe message (every element distinct) as encoded."""
    probe = cls()
    for k, name in enumerate(dt.names[1:]):
        base, shape = dt[name].base, dt[name].shape
        vals = (np.arange(int(np.prod(shape))) + 3 * k + 1).astype(base)
        value = vals.reshape(shape).tolist() if shape else vals[0].item()
        setattr(probe, name, value)
    try:
        data = probe.encode()
    except (struct.error, TypeError, ValueError):  # a value of the declared type it cannot pack
        data = b""
    row = np.frombuffer(data, dt)[0] if len(data) == dt.itemsize else None
    if row is None or int(row["fingerprint"]) != fingerprint(cls) or any(
            np.ravel(row[n]).tolist() != np.ravel(getattr(probe, n)).tolist()
            for n in dt.names[1:]):
        raise TypeError(f"omni4._layout: the layout read from {cls.__name__}'s __typenames__ "
                        f"does not decode what its encoder writes ({len(data)} bytes)")


def native(dt, name):
    """The host-order dtype of field `name` (its element type; the shape is the array's)."""
    return dt[name].base.newbyteorder("=")


def fields_of(rec):
    """{field: host-order array} of structured records of a wire_dtype (fingerprint left out);
    fixed-size arrays come out (N, ...)."""
    return {n: rec[n].astype(native(rec.dtype, n)) for n in rec.dtype.names[1:]}


def empty_fields(cls):
    """fields_of() for no message of cls (a fixed-size type)."""
    dt = wire_dtype(cls)
    return {n: np.zeros((0,) + dt[n].shape, native(dt, n)) for n in dt.names[1:]}


def fields_of_messages(cls, msgs):
    """fields_of() for decoded messages of a fixed-size cls (what the generated decoder gave)."""
    dt = wire_dtype(cls)
    return {n: np.array([getattr(m, n) for m in msgs], native(dt, n)).reshape(
        (len(msgs),) + dt[n].shape) for n in dt.names[1:]}
