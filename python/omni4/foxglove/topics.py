"""Topics, JSON schemas and message builders shared by omni4-bridge (live) and omni4-mcap
(logs), so that both show the same thing. Every message is JSON (message encoding "json",
schema encoding "jsonschema"). Topic list and fields: docs/design.md, "Foxglove topics".

- One topic per LCM channel, named as the channel. OMNI4_MOTORS, OMNI4_CMD, OMNI4_POSE and
  OMNI4_EXPERIMENT carry the fields of their type (docs/design.md) plus the names of mode and
  fault bits; any other channel with a type of the omni4 package carries that type's fields;
  a channel whose payload no omni4 type decodes carries {"fingerprint", "data_base64"}.
- OMNI4_ADAPT (adapt_t, the motor constants in use and their online estimates) carries its
  fields plus the flags by name and each estimate's standard deviation (plot-friendly arrays).
- /omni4/velocity: encoder velocity (eqs 3-5), the model's prediction (model/'s plant from the
  logged voltages, see _predict.c for when it restarts) and their difference, per motors sample.
- /omni4/health: loop rate, overruns, dropped samples, rejected commands, per window.
- /tf (foxglove.FrameTransform world -> robot), /omni4/pose (foxglove.PoseInFrame),
  /omni4/scene (foxglove.SceneUpdate: the body and the four wheels in frame "robot").
- The controller's state estimate (OMNI4_STATE, state_t) beside the camera's pose: /tf
  world -> robot_estimate and /omni4/estimate (foxglove.PoseInFrame).
- A goal (OMNI4_GOAL) as /omni4/goal (foxglove.SceneUpdate: its poses joined by a line, in
  "world") and the plan's reference pose (OMNI4_GOAL_STATUS) as /omni4/goal_reference.
  Their timestamps are the log (receive) time, the time Foxglove plays back in.
"""
import base64
import math

import numpy as np
import orjson

import omni4

from . import goals

TOPIC_VELOCITY = "/omni4/velocity"
TOPIC_HEALTH = "/omni4/health"
TOPIC_TF = "/tf"
TOPIC_POSE = "/omni4/pose"
TOPIC_SCENE = "/omni4/scene"
TOPIC_ESTIMATE = "/omni4/estimate"
WORLD_FRAME = "world"
ROBOT_FRAME = "robot"
ESTIMATE_FRAME = "robot_estimate"

# Mode names, fault bits, the modes that drive the bridges: core's vocab.def (omni4/_vocab.py).
from .._vocab import DRIVEN_MODES, FAULT_BITS, MODE_NAMES, mode_name  # noqa: E402,F401
from .._vocab import fault_names as _fault_names  # noqa: E402
from ..adapt import flag_names as adapt_flag_names  # noqa: E402
FAULT_OVERRUN = omni4.motors_t.FAULT_OVERRUN
FAULT_CMD_REJECTED = omni4.motors_t.FAULT_CMD_REJECTED

_fault_cache = {}


def fault_names(faults):
    names = _fault_cache.get(faults)
    if names is None:
        names = _fault_cache[faults] = _fault_names(faults)
    return names


def _num(desc):
    return {"type": "number", "description": desc}


def _int(desc):
    return {"type": "integer", "description": desc}


def _arr(n, desc):
    return {"type": "array", "items": {"type": "number"}, "minItems": n, "maxItems": n,
            "description": desc}


def _obj(props, desc=""):
    return {"type": "object", "properties": props, "description": desc}


_XYZ = {"v": _num("along the robot's heading [m/s]"), "vn": _num("normal to it [m/s]"),
        "w": _num("yaw rate [rad/s]")}
_TIME = _obj({"sec": _int("[s]"), "nsec": _int("[ns]")})
_VEC3 = _obj({"x": _num(""), "y": _num(""), "z": _num("")})
_QUAT = _obj({"x": _num(""), "y": _num(""), "z": _num(""), "w": _num("")})
_POSE = _obj({"position": _VEC3, "orientation": _QUAT})
_COLOR = _obj({"r": _num("0-1"), "g": _num("0-1"), "b": _num("0-1"), "a": _num("0-1")})

# name -> JSON schema (dict). Schema names of the omni4 types are "omni4.<type>".
SCHEMAS = {
    "omni4.motors_t": _obj({
        "utime": _int("controller clock [us]"), "seq": _int("loop tick; a gap = lost samples"),
        "mode": _int("MODE_* of motors_t"), "mode_name": {"type": "string"},
        "faults": _int("FAULT_* bit set"),
        "fault_names": {"type": "array", "items": {"type": "string"}},
        "voltage": _arr(4, "applied [V]"), "current": _arr(4, "measured [A]"),
        "wheel_speed": _arr(4, "after the gearbox [rad/s]")}, "motors_t, one per loop tick"),
    "omni4.command_t": _obj({
        "utime": _int("sender clock [us]"), "seq": _int(""), "mode": _int("MODE_* of command_t"),
        "mode_name": {"type": "string"},
        "velocity": _arr(3, "v [m/s], vn [m/s], w [rad/s] (VELOCITY mode)"),
        "voltage": _arr(4, "per channel [V] (VOLTAGE mode)"), "ramp_s": _num("[s]")},
        "command_t, operator -> controller"),
    "omni4.pose_t": _obj({"utime": _int("image time [us]"), "x": _num("world [m]"),
                          "y": _num("world [m]"), "theta": _num("heading [rad]")}, "pose_t"),
    "omni4.experiment_t": _obj({"utime": _int("[us]"), "kind": {"type": "string"},
                                "direction": {"type": "string"}, "level": _num("[V]")},
                               "experiment_t, segment marks"),
    "omni4.adapt_t": _obj({
        "utime": _int("controller clock [us]"), "seq": _int("loop tick (motors_t.seq)"),
        "R": _arr(4, "each motor's resistance in use [ohm]"),
        "R_estimate": _arr(4, "each motor's online estimate [ohm]"),
        "R_variance": _arr(4, "its variance [ohm^2]"),
        "R_sigma": _arr(4, "its standard deviation [ohm]"),
        "supply_v": _num("supply the drives last reported [V] (0: none)"),
        "Cv": _num("Coulomb friction in use along v [N]"), "Cvn": _num("along vn [N]"),
        "Cw": _num("about w [N m]"),
        "track_rms": _num("wheels' rim speed reference - reading, RMS since the last [m/s]"),
        "flags": _int("FLAG_* bit set of adapt_t"),
        "flag_names": {"type": "array", "items": {"type": "string"}}},
        "adapt_t, the motor constants in use, 10 Hz"),
    "omni4.lcm_fields": {"type": "object", "description": "fields of an omni4 LCM type"},
    "omni4.lcm_raw": _obj({"fingerprint": {"type": "string"},
                           "data_base64": {"type": "string", "contentEncoding": "base64"}},
                          "an LCM payload that no omni4 type decodes"),
    "omni4.velocity": _obj({
        "utime": _int("motors_t utime [us]"), "seq": _int("motors_t seq"),
        "mode_name": {"type": "string"},
        "restarted": {"type": "boolean",
                      "description": "the prediction restarted from the encoders here (the "
                                     "bridge, decimating: here or since its last message)"},
        "encoder": _obj(_XYZ, "robot velocity from the wheel encoders, eqs 3-5"),
        "predicted": _obj(_XYZ, "the model driven by the logged voltages"),
        "difference": _obj(_XYZ, "encoder - predicted")}, "encoder velocity vs the model"),
    "omni4.health": _obj({
        "window_s": _num("length of the window the rates are over [s]"),
        "samples": _int("motors samples in the window"),
        "loop_rate_hz": _num("samples / controller time spanned [Hz]"),
        "dropped": _int("samples lost in the window (seq gaps)"),
        "dropped_total": _int(""),
        "overruns": _int("samples with FAULT_OVERRUN in the window"),
        "overruns_total": _int(""),
        "late_ticks": _int("utime steps longer than 1.5 periods in the window"),
        "late_ticks_total": _int(""),
        "rejected_commands": _int("FAULT_CMD_REJECTED set anew (one per rejection not "
                                  "followed by an accepted command) in the window"),
        "rejected_commands_total": _int(""),
        "faults": {"type": "array", "items": {"type": "string"},
                   "description": "fault bits of the last sample"},
        "mode_name": {"type": "string", "description": "mode of the last sample"}},
        "controller health"),
    "foxglove.FrameTransform": _obj({"timestamp": _TIME, "parent_frame_id": {"type": "string"},
                                     "child_frame_id": {"type": "string"},
                                     "translation": _VEC3, "rotation": _QUAT}),
    "foxglove.PoseInFrame": _obj({"timestamp": _TIME, "frame_id": {"type": "string"},
                                  "pose": _POSE}),
    "foxglove.SceneUpdate": _obj({
        "deletions": {"type": "array", "items": {"type": "object"}},
        "entities": {"type": "array", "items": _obj({
            "timestamp": _TIME, "frame_id": {"type": "string"}, "id": {"type": "string"},
            "lifetime": _TIME, "frame_locked": {"type": "boolean"},
            "metadata": {"type": "array", "items": {"type": "object"}},
            "cubes": {"type": "array", "items": _obj({"pose": _POSE, "size": _VEC3,
                                                       "color": _COLOR})},
            "cylinders": {"type": "array", "items": _obj({
                "pose": _POSE, "size": _VEC3, "bottom_scale": _num(""), "top_scale": _num(""),
                "color": _COLOR})},
            "lines": {"type": "array", "items": _obj({
                "type": _int("0 strip"), "pose": _POSE, "thickness": _num("[m]"),
                "scale_invariant": {"type": "boolean"},
                "points": {"type": "array", "items": _VEC3}, "color": _COLOR,
                "colors": {"type": "array"}, "indices": {"type": "array"}})}})}}),
}

# Schema per LCM channel of omni4's own types.
CHANNEL_SCHEMA = {omni4.CHANNEL_MOTORS: "omni4.motors_t", omni4.CHANNEL_CMD: "omni4.command_t",
                  omni4.CHANNEL_POSE: "omni4.pose_t",
                  omni4.CHANNEL_EXPERIMENT: "omni4.experiment_t",
                  omni4.CHANNEL_ADAPT: "omni4.adapt_t"}
DERIVED = {TOPIC_VELOCITY: "omni4.velocity", TOPIC_HEALTH: "omni4.health",
           TOPIC_TF: "foxglove.FrameTransform", TOPIC_POSE: "foxglove.PoseInFrame",
           TOPIC_SCENE: "foxglove.SceneUpdate", TOPIC_ESTIMATE: "foxglove.PoseInFrame",
           goals.TOPIC_GOAL: "foxglove.SceneUpdate",
           goals.TOPIC_GOAL_REFERENCE: "foxglove.PoseInFrame"}


def schema_bytes(name):
    return orjson.dumps(SCHEMAS[name])


def _stamp(ns):
    return {"sec": ns // 1_000_000_000, "nsec": ns % 1_000_000_000}


# ---- LCM messages -> JSON ------------------------------------------------------------------

def motors_json(utime, seq, mode, faults, voltage, current, wheel_speed):
    # (called once per loop tick: the name lookups are inlined)
    fn = _fault_cache.get(faults)
    return orjson.dumps({"utime": utime, "seq": seq, "mode": mode,
                         "mode_name": MODE_NAMES.get(mode) or mode_name(mode),
                         "faults": faults,
                         "fault_names": fault_names(faults) if fn is None else fn,
                         "voltage": voltage, "current": current, "wheel_speed": wheel_speed})


def command_json(m):
    return orjson.dumps({"utime": m.utime, "seq": m.seq, "mode": m.mode,
                         "mode_name": mode_name(m.mode), "velocity": list(m.velocity),
                         "voltage": list(m.voltage), "ramp_s": m.ramp_s})


def pose_json(m):
    return orjson.dumps({"utime": m.utime, "x": m.x, "y": m.y, "theta": m.theta})


def experiment_json(m):
    return orjson.dumps({"utime": m.utime, "kind": m.kind, "direction": m.direction,
                         "level": m.level})


def adapt_json(m):
    return orjson.dumps({"utime": m.utime, "seq": m.seq, "R": list(m.R),
                         "R_estimate": list(m.R_estimate), "R_variance": list(m.R_variance),
                         "R_sigma": [math.sqrt(x) if x >= 0 else float("nan")
                                     for x in m.R_variance],
                         "supply_v": m.supply_v, "Cv": m.Cv, "Cvn": m.Cvn, "Cw": m.Cw,
                         "track_rms": m.track_rms, "flags": m.flags,
                         "flag_names": adapt_flag_names(m.flags)})


def _plain(v):
    if isinstance(v, (list, tuple)):
        return [_plain(x) for x in v]
    if isinstance(v, bytes):
        return base64.b64encode(v).decode()
    if hasattr(v, "__slots__"):
        return {k: _plain(getattr(v, k)) for k in v.__slots__}
    return v


def fields_json(m):
    """Any lcm-gen message: its fields (nested types as objects, byte arrays as base64)."""
    return orjson.dumps(_plain(m))


def raw_json(data):
    fp = data[:8].hex() if len(data) >= 8 else ""
    return orjson.dumps({"fingerprint": fp, "data_base64": base64.b64encode(data).decode()})


def lcm_classes():
    """8-byte fingerprint -> lcm-gen class, for every type of the omni4 package."""
    out = {}
    for name in dir(omni4):
        cls = getattr(omni4, name)
        if isinstance(cls, type) and hasattr(cls, "_get_packed_fingerprint"):
            out[cls._get_packed_fingerprint()] = cls
    return out


# ---- derived topics ------------------------------------------------------------------------
def event_messages(chname, data, t_ns, classes):
    """The Foxglove messages of one LCM event that is not OMNI4_MOTORS (the bridge and the
    exporter treat motors apart, for speed): a list of (topic, schema name, JSON bytes).
    classes: lcm_classes(). The channel's own type first, then any omni4 type whose
    fingerprint matches, else the raw payload; a payload that is not its channel's own type
    goes to the topic CHANNEL/<its type> or, if no omni4 type decodes it, CHANNEL/undecodable."""
    msg = None
    own = omni4.TYPES.get(chname)
    for cls in (own, classes.get(data[:8])):
        if cls is not None:
            try:
                msg = cls.decode(data)
                break
            except Exception:  # lcm-gen decoders raise ValueError, struct.error, ...
                msg = None
    if own is not None and not isinstance(msg, own):
        # not the channel's own type: kept beside the channel, never under its schema
        chname += "/undecodable" if msg is None else "/" + type(msg).__name__
    if isinstance(msg, omni4.pose_t) and chname == omni4.CHANNEL_POSE:
        tf, pose = pose_topics(t_ns, msg.x, msg.y, msg.theta)
        return [(chname, "omni4.pose_t", pose_json(msg)), (TOPIC_TF, DERIVED[TOPIC_TF], tf),
                (TOPIC_POSE, DERIVED[TOPIC_POSE], pose)]
    if isinstance(msg, omni4.state_t) and chname == omni4.CHANNEL_STATE:
        tf, pose = pose_topics(t_ns, *msg.pose, child=ESTIMATE_FRAME)
        return [(chname, "omni4.lcm_fields", fields_json(msg)),
                (TOPIC_TF, DERIVED[TOPIC_TF], tf),
                (TOPIC_ESTIMATE, DERIVED[TOPIC_ESTIMATE], pose)]
    if isinstance(msg, omni4.goal_t) and chname == omni4.CHANNEL_GOAL:
        return [(chname, "omni4.lcm_fields", fields_json(msg)),
                (goals.TOPIC_GOAL, DERIVED[goals.TOPIC_GOAL],
                 goals.goal_scene_json(t_ns, msg, WORLD_FRAME))]
    if isinstance(msg, omni4.goal_status_t) and chname == omni4.CHANNEL_GOAL_STATUS:
        return [(chname, "omni4.lcm_fields", fields_json(msg)),
                (goals.TOPIC_GOAL_REFERENCE, DERIVED[goals.TOPIC_GOAL_REFERENCE],
                 goals.reference_json(t_ns, msg, WORLD_FRAME))]
    if isinstance(msg, omni4.command_t) and chname == omni4.CHANNEL_CMD:
        return [(chname, "omni4.command_t", command_json(msg))]
    if isinstance(msg, omni4.experiment_t) and chname == omni4.CHANNEL_EXPERIMENT:
        return [(chname, "omni4.experiment_t", experiment_json(msg))]
    if isinstance(msg, omni4.adapt_t) and chname == omni4.CHANNEL_ADAPT:
        return [(chname, "omni4.adapt_t", adapt_json(msg))]
    if msg is not None:
        return [(chname, "omni4.lcm_fields", fields_json(msg))]
    return [(chname, "omni4.lcm_raw", raw_json(data))]


class Channels:
    """The Foxglove channels of one context (a WebSocket server's or an MCAP writer's), made
    as topics appear (JSON, the schema of SCHEMAS), and the messages logged per topic."""

    def __init__(self, ctx):
        import foxglove
        self._fg = foxglove
        self.ctx = ctx
        self.channels = {}
        self.counts = {}

    def get(self, topic, schema_name):
        ch = self.channels.get(topic)
        if ch is None:
            schema = self._fg.Schema(name=schema_name, encoding="jsonschema",
                                     data=schema_bytes(schema_name))
            ch = self._fg.Channel(topic, schema=schema, message_encoding="json",
                                  context=self.ctx).base
            self.channels[topic] = ch
            self.counts[topic] = 0
        return ch

    def log(self, topic, schema_name, data, t_ns):
        self.get(topic, schema_name).log(data, t_ns)
        self.counts[topic] += 1



def velocity_json(utime, seq, mode, meas, pred, restarted):
    return orjson.dumps({
        "utime": utime, "seq": seq, "mode_name": MODE_NAMES.get(mode) or mode_name(mode),
        "restarted": restarted,
        "encoder": {"v": meas[0], "vn": meas[1], "w": meas[2]},
        "predicted": {"v": pred[0], "vn": pred[1], "w": pred[2]},
        "difference": {"v": meas[0] - pred[0], "vn": meas[1] - pred[1],
                       "w": meas[2] - pred[2]}})


def pose_topics(stamp_ns, x, y, theta, child=ROBOT_FRAME):
    """(FrameTransform world -> child, PoseInFrame in world) for a pose: the camera's (child
    "robot") or the controller's estimate ("robot_estimate")."""
    t = _stamp(stamp_ns)
    q = {"x": 0.0, "y": 0.0, "z": math.sin(0.5 * theta), "w": math.cos(0.5 * theta)}
    tf = orjson.dumps({"timestamp": t, "parent_frame_id": WORLD_FRAME,
                       "child_frame_id": child,
                       "translation": {"x": x, "y": y, "z": 0.0}, "rotation": q})
    pose = orjson.dumps({"timestamp": t, "frame_id": WORLD_FRAME,
                         "pose": {"position": {"x": x, "y": y, "z": 0.0}, "orientation": q}})
    return tf, pose


def scene_json(stamp_ns, d, r, wheels=None):
    """The robot in frame "robot": a square body and its wheels. wheels None (no robot_t: the
    paper's layout): four wheels at distance d [m] (radius r [m]) on the axes of eq 2: wheel 0
    at +v (drives along vn), 1 at +vn, 2 at -v, 3 at -vn. wheels (an omni4.wheels.Wheels of
    the robot's robot_t): each of its wheels at its own angle, distance and radius."""
    t = _stamp(stamp_ns)
    ident = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}
    if wheels is not None and wheels.is_paper_geometry() and len(set(wheels.radius_m)) == 1:
        d, r, wheels = wheels.distance_m[0], wheels.radius_m[0], None   # drawn as always
    if wheels is not None:
        d, r = max(wheels.distance_m), max(wheels.radius_m)
    side = 1.2 * d
    body = {"pose": {"position": {"x": 0.0, "y": 0.0, "z": r}, "orientation": ident},
            "size": {"x": side, "y": side, "z": 0.6 * r},
            "color": {"r": 0.2, "g": 0.45, "b": 0.85, "a": 0.8}}
    # heading marker: a thin bar from the centre along +v
    nose = {"pose": {"position": {"x": 0.45 * side, "y": 0.0, "z": 1.4 * r}, "orientation": ident},
            "size": {"x": 0.3 * side, "y": 0.1 * side, "z": 0.2 * r},
            "color": {"r": 1.0, "g": 0.6, "b": 0.1, "a": 1.0}}
    wheel_list = _paper_wheels(d, r) if wheels is None else _layout_wheels(wheels)
    ent = {"timestamp": t, "frame_id": ROBOT_FRAME, "id": "omni4", "lifetime": _stamp(0),
           "frame_locked": True, "metadata": [], "cubes": [body, nose], "cylinders": wheel_list}
    return orjson.dumps({"deletions": [], "entities": [ent]})


def _wheel(cx, cy, r, q):
    return {"pose": {"position": {"x": cx, "y": cy, "z": r}, "orientation": q},
            "size": {"x": 2 * r, "y": 2 * r, "z": 0.6 * r},
            "bottom_scale": 1.0, "top_scale": 1.0,
            "color": {"r": 0.15, "g": 0.15, "b": 0.15, "a": 1.0}}


def _paper_wheels(d, r):
    h = math.sqrt(0.5)  # quaternion component of a 90 degree turn
    out = []
    for j, (cx, cy) in enumerate(((d, 0.0), (0.0, d), (-d, 0.0), (0.0, -d))):
        # cylinder axis (its z) along the wheel's radial direction: rotate z onto x or y
        q = ({"x": 0.0, "y": h, "z": 0.0, "w": h} if j % 2 == 0
             else {"x": h, "y": 0.0, "z": 0.0, "w": h})
        out.append(_wheel(cx, cy, r, q))
    return out


def _layout_wheels(wheels):
    """Each wheel at its angle a and distance; its cylinder's axis along its radius: a turn
    of 90 deg about y (z onto x), then of a about z (quaternion product yaw(a) * y90)."""
    h = math.sqrt(0.5)
    out = []
    for (cx, cy), a, r in zip(wheels.positions(), wheels.angle_rad, wheels.radius_m):
        s, c = math.sin(a / 2), math.cos(a / 2)
        q = {"x": -s * h, "y": c * h, "z": s * h, "w": c * h}
        out.append(_wheel(cx, cy, r, q))
    return out


class Health:
    """Counts over a window of motors samples; report() returns the JSON and starts a new one."""

    def __init__(self):
        self.prev_seq = None
        self.prev_utime = None
        self.prev_rejected = False
        self.period_us = None
        self.tot = {"dropped": 0, "overruns": 0, "late_ticks": 0, "rejected_commands": 0}
        self._new_window()
        self.mode = 0
        self.faults = 0

    def _new_window(self):
        self.win = {"dropped": 0, "overruns": 0, "late_ticks": 0, "rejected_commands": 0}
        self.n = 0
        self.t0 = None
        self.t1 = None

    def add(self, utime, seq, mode, faults):
        if self.prev_seq is not None:
            gap = seq - self.prev_seq - 1
            if gap > 0:
                self.win["dropped"] += gap
            step = utime - self.prev_utime
            if gap == 0 and step > 0:
                # the period: a slow running estimate (robust to single late ticks)
                if self.period_us is None:
                    self.period_us = step
                elif step < 1.5 * self.period_us:
                    self.period_us += 0.01 * (step - self.period_us)
                else:
                    self.win["late_ticks"] += 1
        if faults & FAULT_OVERRUN:
            self.win["overruns"] += 1
        rej = bool(faults & FAULT_CMD_REJECTED)
        if rej and not self.prev_rejected:
            self.win["rejected_commands"] += 1
        self.prev_rejected = rej
        self.prev_seq, self.prev_utime = seq, utime
        self.mode, self.faults = mode, faults
        if self.t0 is None:
            self.t0 = utime
        self.t1 = utime
        self.n += 1

    def report(self, window_s):
        span = (self.t1 - self.t0) * 1e-6 if self.n > 1 else 0.0
        rate = (self.n - 1) / span if span > 0 else 0.0
        msg = {"window_s": window_s, "samples": self.n, "loop_rate_hz": rate}
        for k, v in self.win.items():
            self.tot[k] += v
            msg[k] = v
            msg[k + "_total"] = self.tot[k]
        msg["faults"] = fault_names(self.faults)
        msg["mode_name"] = mode_name(self.mode)
        self._new_window()
        return orjson.dumps(msg)


# ---- whole logs: the same JSON, built block-wise (omni4-mcap, ~1 us per message) -----------

_MOTORS_FMT = (b'{"utime":%d,"seq":%d,"mode":%d,"mode_name":"%s","faults":%d,"fault_names":%s,'
               b'"voltage":[%s,%s,%s,%s],"current":[%s,%s,%s,%s],"wheel_speed":[%s,%s,%s,%s]}')
_VELOCITY_FMT = (b'{"utime":%d,"seq":%d,"mode_name":"%s","restarted":%s,'
                 b'"encoder":{"v":%s,"vn":%s,"w":%s},"predicted":{"v":%s,"vn":%s,"w":%s},'
                 b'"difference":{"v":%s,"vn":%s,"w":%s}}')
BLOCK = 8192


def _tokens(a):
    """Numbers of an array as JSON tokens (orjson's shortest round-trip text; float32 stays
    float32-exact; NaN becomes null as in every other message)."""
    return orjson.dumps(np.ascontiguousarray(a).ravel(),
                        option=orjson.OPT_SERIALIZE_NUMPY)[1:-1].split(b",")


def motors_json_blocks(mot):
    """motors_json for every sample of the arrays of export.decode_motors, in order."""
    modes = {}
    faults = {}
    n = len(mot["utime"])
    for b0 in range(0, n, BLOCK):
        b1 = min(n, b0 + BLOCK)
        ut, sq = mot["utime"][b0:b1].tolist(), mot["seq"][b0:b1].tolist()
        md, fl = mot["mode"][b0:b1].tolist(), mot["faults"][b0:b1].tolist()
        u, i, w = (_tokens(mot[f][b0:b1]) for f in ("voltage", "current", "wheel_speed"))
        for k in range(b1 - b0):
            m, f = md[k], fl[k]
            mn = modes.get(m)
            if mn is None:
                mn = modes[m] = mode_name(m).encode()
            fn = faults.get(f)
            if fn is None:
                fn = faults[f] = orjson.dumps(fault_names(f))
            j = 4 * k
            yield _MOTORS_FMT % (ut[k], sq[k], m, mn, f, fn, *u[j:j + 4], *i[j:j + 4],
                                 *w[j:j + 4])


def velocity_json_blocks(mot, meas, pred, restarted):
    """velocity_json for every sample (meas, pred: n x 3 from Predictor.run)."""
    modes = {}
    n = len(mot["utime"])
    for b0 in range(0, n, BLOCK):
        b1 = min(n, b0 + BLOCK)
        ut, sq = mot["utime"][b0:b1].tolist(), mot["seq"][b0:b1].tolist()
        md, rs = mot["mode"][b0:b1].tolist(), restarted[b0:b1].tolist()
        e, p = _tokens(meas[b0:b1]), _tokens(pred[b0:b1])
        d = _tokens(meas[b0:b1] - pred[b0:b1])
        for k in range(b1 - b0):
            m = md[k]
            mn = modes.get(m)
            if mn is None:
                mn = modes[m] = mode_name(m).encode()
            j = 3 * k
            yield _VELOCITY_FMT % (ut[k], sq[k], mn, b"true" if rs[k] else b"false",
                                   *e[j:j + 3], *p[j:j + 3], *d[j:j + 3])
