"""The project's model (model/src/*.c) through ctypes: encoder velocity (eqs 3-5) and the model's
prediction from the logged voltages (plant_step, eq 23), sample by sample or for a whole log, for
the robot's wheel layout (the paper's four, three wheels, or four at other angles); and its
parameters, from the [model] of a robot INI (omni4.ini reads the file) or Table III.

The shared library is built by python/setup.py from model/src/*.c and _predict.c (see there for
when the prediction restarts from the encoders)."""
import ctypes
import glob
import math
import os
import re
import sys

import numpy as np

from .. import ini
from .._keys import MODEL_KEYS, MODEL_LAYOUT_KEYS, MODEL_WHEEL_KEYS

_LIB = None
PARAM_NAMES = MODEL_KEYS  # the 14 [model] keys, in model_params_names order


def lib():
    """The loaded model library (built with the package)."""
    global _LIB
    if _LIB is None:
        here = os.path.dirname(os.path.abspath(__file__))
        found = sorted(glob.glob(os.path.join(here, "_omni4model*.so")))
        if not found:
            raise RuntimeError(f"omni4: the model library _omni4model*.so is missing in {here} "
                               "(reinstall the package: pip install ./python)")
        L = ctypes.CDLL(found[0])
        L.omni4_predictor_size.restype = ctypes.c_size_t
        L.omni4_predictor_init.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double)]
        L.omni4_predictor_init.restype = ctypes.c_int
        L.omni4_predictor_init_wheels.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double),
                                                  ctypes.POINTER(ctypes.c_double)]
        L.omni4_predictor_init_wheels.restype = ctypes.c_int
        L.omni4_predictor_set_layout.argtypes = [ctypes.c_void_p, ctypes.c_int,
                                                 ctypes.POINTER(ctypes.c_double),
                                                 ctypes.POINTER(ctypes.c_double)]
        L.omni4_predictor_set_layout.restype = ctypes.c_int
        L.omni4_model_check.argtypes = [ctypes.POINTER(ctypes.c_double),
                                        ctypes.POINTER(ctypes.c_double)]
        L.omni4_model_check.restype = ctypes.c_int
        L.omni4_model_range.argtypes = [ctypes.c_int, ctypes.POINTER(ctypes.c_double),
                                        ctypes.POINTER(ctypes.c_double)]
        L.omni4_model_range.restype = ctypes.c_int
        L.omni4_predictor_param_name.argtypes = [ctypes.c_int]
        L.omni4_predictor_param_name.restype = ctypes.c_char_p
        f32p = ctypes.POINTER(ctypes.c_float)
        f64p = ctypes.POINTER(ctypes.c_double)
        L.omni4_predictor_step.argtypes = [ctypes.c_void_p, ctypes.c_int64, ctypes.c_int64,
                                           ctypes.c_int, f32p, f32p, f64p, f64p]
        L.omni4_predictor_step.restype = ctypes.c_int
        L.omni4_predictor_run.argtypes = [ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p,
                                          ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                          ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p,
                                          ctypes.c_void_p]
        L.omni4_predictor_run.restype = None
        names = tuple(L.omni4_predictor_param_name(i).decode() for i in range(len(PARAM_NAMES)))
        if names != PARAM_NAMES:  # the C struct's order is the one that counts
            raise RuntimeError(f"omni4: model parameter order {names} != {PARAM_NAMES}")
        _LIB = L
    return _LIB


class Predictor:
    """Encoder velocity and model prediction for a stream of motors_t samples.

    params: dict with the 14 [model] keys (SI units), and optionally a drive's own r_j, Kv_j,
    Kt_j, R_j (MODEL_WHEEL_KEYS; a wheel without its key takes the scalar): the plant then has
    each wheel's radius and motor, and the encoder velocity each wheel's radius.
    wheels: the wheels' layout (omni4.wheels.Wheels: count, angle_rad, distance_m; the robot_t
    of the log or the bus), else params' "layout" (params_or_exit: the --params file's), else
    the paper's four at d. The plant simulates that layout and the encoder velocity is its
    least-squares inverse of eq 2; the paper's layout (four at 0/90/180/270 deg, all at d) keeps
    the closed forms, to the last bit as with no layout. The radii and drives stay params'."""

    def __init__(self, params, wheels=None):
        L = lib()
        self._buf = ctypes.create_string_buffer(L.omni4_predictor_size())
        vals = (ctypes.c_double * len(PARAM_NAMES))(*[float(params[k]) for k in PARAM_NAMES])
        if any(k in params for k in MODEL_WHEEL_KEYS):
            own = [float(params.get(k, params[k.split("_")[0]])) for k in MODEL_WHEEL_KEYS]
            rc = L.omni4_predictor_init_wheels(self._buf, vals, (ctypes.c_double * 16)(*own))
        else:
            rc = L.omni4_predictor_init(self._buf, vals)
        if rc != 0:
            raise ValueError("model parameters are not physical (model_params_check, or a "
                             "wheel's own value 50 % or more off its scalar)")
        self.wheels = wheels if wheels is not None else params.get("layout")
        if self.wheels is not None:
            set_layout(self._buf, self.wheels)
        self._u = (ctypes.c_float * 4)()
        self._w = (ctypes.c_float * 4)()
        self._meas = (ctypes.c_double * 3)()
        self._pred = (ctypes.c_double * 3)()

    def step(self, utime, seq, mode, voltage, wheel_speed):
        """One sample -> (measured [v, vn, w], predicted [v, vn, w], restarted)."""
        self._u[:] = voltage
        self._w[:] = wheel_speed
        r = lib().omni4_predictor_step(self._buf, utime, seq, mode, self._u, self._w,
                                       self._meas, self._pred)
        return list(self._meas), list(self._pred), bool(r)

    def run(self, utime, seq, mode, voltage, wheel_speed):
        """Arrays of n samples (voltage, wheel_speed: n x 4) -> (measured n x 3,
        predicted n x 3, restarted n), continuing from the previous call's state."""
        n = len(utime)
        ut = np.ascontiguousarray(utime, dtype=np.int64)
        sq = np.ascontiguousarray(seq, dtype=np.int64)
        md = np.ascontiguousarray(mode, dtype=np.int8)
        u = np.ascontiguousarray(voltage, dtype=np.float32).reshape(n, 4)
        w = np.ascontiguousarray(wheel_speed, dtype=np.float32).reshape(n, 4)
        meas = np.empty((n, 3))
        pred = np.empty((n, 3))
        rst = np.empty(n, dtype=np.int8)
        lib().omni4_predictor_run(self._buf, n, ut.ctypes.data, sq.ctypes.data, md.ctypes.data,
                                  u.ctypes.data, w.ctypes.data, meas.ctypes.data,
                                  pred.ctypes.data, rst.ctypes.data)
        return meas, pred, rst.astype(bool)


def set_layout(buf, wheels):
    """The layout of wheels (omni4.wheels.Wheels) on the predictor in buf; ValueError when it
    does not drive v, vn and w."""
    n = wheels.count
    deg = [a * 180.0 / math.pi for a in wheels.angle_rad] + [0.0] * (4 - n)
    dist = list(wheels.distance_m) + [0.0] * (4 - n)
    if n not in (3, 4) or lib().omni4_predictor_set_layout(
            buf, n, (ctypes.c_double * 4)(*deg), (ctypes.c_double * 4)(*dist)) != 0:
        raise ValueError(f"the wheel layout ({n} wheels at {[round(a, 3) for a in deg[:n]]} "
                         f"deg, {list(dist[:n])} m) does not drive v, vn and w")


def layout_drives(wheels):
    """True when the layout (Wheels) drives v, vn and w (the rows of full rank): one that does
    not is no robot the model can predict."""
    buf = ctypes.create_string_buffer(lib().omni4_predictor_size())
    vals = (ctypes.c_double * len(PARAM_NAMES))(*table3().values())
    if lib().omni4_predictor_init(buf, vals) != 0:
        raise RuntimeError("omni4: Table III refused by the model library")
    try:
        set_layout(buf, wheels)
    except ValueError:
        return False  # its rows do not drive v, vn and w
    return True


def same_layout(a, b):
    """True when two layouts (Wheels or None: the paper's) give the same prediction: the same
    count, angles and distances (the radii are the model's)."""
    def key(w):
        return None if w is None else (w.count, w.angle_rad, w.distance_m)
    return key(a) == key(b)


def table3():
    """The paper's Table III, read from model/ (model_params_table3)."""
    arr = (ctypes.c_double * len(PARAM_NAMES)).in_dll(lib(), "model_params_table3")
    return dict(zip(PARAM_NAMES, list(arr)))


# A decimal number as the INI's readers take one (config/src/config.c decimal_syntax): no
# blanks, hexadecimal, inf, nan or digit separators, which Python's float() would accept.
_DECIMAL = re.compile(r"[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")


def model_range(key):
    """(lo, hi): the physical range of a [model] key, inclusive, as the controller checks it
    (model_params_range; a wheel's own r_j, Kv_j, Kt_j, R_j has its scalar's)."""
    L = lib()
    lo, hi = ctypes.c_double(), ctypes.c_double()
    if L.omni4_model_range(PARAM_NAMES.index(key.split("_")[0]), lo, hi):
        raise KeyError(key)
    return lo.value, hi.value


def check_model(params):
    """None if params (the 14 keys, and any r_j Kv_j Kt_j R_j) pass the controller's door for a
    model (model_params_check, model_wheels_check), else the name of the first that does not."""
    vals = (ctypes.c_double * len(PARAM_NAMES))(*[float(params[k]) for k in PARAM_NAMES])
    own = None
    if any(k in params for k in MODEL_WHEEL_KEYS):
        own = (ctypes.c_double * 16)(
            *[float(params.get(k, params[k.split("_")[0]])) for k in MODEL_WHEEL_KEYS])
    bad = lib().omni4_model_check(vals, own)
    if bad < 0:
        return None
    return PARAM_NAMES[bad] if bad < len(PARAM_NAMES) else MODEL_WHEEL_KEYS[bad - len(PARAM_NAMES)]


def read_model(path):
    """[model] of the robot INI at path -> dict of the 14 parameters (docs/design.md: d r l Kv
    Kt R M J Bv Bvn Bw Cv Cvn Cw, SI units, all or none; none = Table III, as in the firmware).
    A drive's own r_j, Kv_j, Kt_j, R_j (docs/configuration.md) is checked (a number > 0, with
    the 14) and returned beside them: the prediction drives each wheel with its own. Other sections are the firmware's and are not looked at. Errors:
    omni4.ini.ConfigError, one line FILE:LINE: ..."""
    f = ini.read(path)
    found = {}
    for key, val in f.section("model").items():
        if key in MODEL_LAYOUT_KEYS:    # the wheels' layout: omni4.wheels.Wheels.from_ini
            continue
        where = f.where("model", key)
        if key not in PARAM_NAMES and key not in MODEL_WHEEL_KEYS:
            raise ini.ConfigError(f"{where}: unknown key '{key}' in [model] "
                                  f"(expected {' '.join(PARAM_NAMES)}, and optionally "
                                  "r_0..r_3 Kv_0..Kv_3 Kt_0..Kt_3 R_0..R_3)")
        if not _DECIMAL.fullmatch(val):
            raise ini.ConfigError(f"{where}: [model] {key} = '{val}' is not a number")
        found[key] = float(val)
        lo, hi = model_range(key)
        if not math.isfinite(found[key]):
            raise ini.ConfigError(f"{where}: [model] {key} = '{val}' is not finite")
        if not lo <= found[key] <= hi:
            raise ini.ConfigError(f"{where}: [model] {key} = {val} outside its physical range "
                                  f"[{lo:g}, {hi:g}]")
    if not found:
        return table3()
    first = f"{path}:{min(f.line('model', k) or 0 for k in found)}"
    missing = [k for k in PARAM_NAMES if k not in found]
    if missing:
        raise ini.ConfigError(f"{first}: [model] lacks {' '.join(missing)} (all 14 keys or none)")
    bad = check_model(found)
    if bad is not None:
        raise ini.ConfigError(f"{first}: [model] parameters are not physical ({bad} = "
                              f"{found.get(bad, found.get(bad.split('_')[0]))}: the controller "
                              "refuses it)")
    try:
        Predictor(found)
    except ValueError:
        raise ini.ConfigError(f"{first}: [model] a wheel's own r_j, Kv_j or R_j is 50 % or more "
                              "off its scalar: the controller takes it, the prediction's plant "
                              "does not model it") from None
    return found


def params_or_exit(prog, path):
    """--params of a command-line tool: the [model] of path (Table III if None), with its
    wheels' layout under "layout" when it has layout keys (omni4.wheels.Wheels: the scene's
    wheels and the prediction's when no robot_t says otherwise); on a broken INI (or a layout
    that does not drive v, vn and w) one line on stderr and exit status 2 (a configuration
    error)."""
    from ..wheels import Wheels
    try:
        params = read_model(path) if path else table3()
        layout = Wheels.from_ini(path) if path else None
        if layout is not None and not layout_drives(layout):
            raise ini.ConfigError(f"{ini.read(path).where('model', 'wheels')}: [model] wheels, "
                                  "wheel_angle_j, d_j: not a layout that drives v, vn and w "
                                  "(no two wheels along one line)")
        if layout is not None:
            params["layout"] = layout
        return params
    except ini.ConfigError as e:
        print(f"{prog}: {e}", file=sys.stderr)
        raise SystemExit(2) from None
