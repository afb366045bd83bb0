"""LCM event-log encoding and the files of write_logs.py: motors_t and pose_t messages encoded
with numpy (vectorised; the self-test compares them with the generated types), experiment marks,
the event log ordered by receive time, the [model] INIs and the real-sensor sidecar JSON."""
import json
import os

import numpy as np

CH_MOTORS, CH_POSE, CH_EXP = "OMNI4_MOTORS", "OMNI4_POSE", "OMNI4_EXPERIMENT"
CH_ROBOT = "OMNI4_ROBOT"
RECEIVE_DELAY_US = 300


# ---- encoding (vectorised; the self-test compares it with the generated types) ----------------

def motors_dtype():
    """Packed big-endian layout of an encoded omni4.motors_t (fingerprint first), 77 bytes."""
    return np.dtype([("fp", "S8"), ("utime", ">i8"), ("seq", ">i8"), ("mode", "i1"),
                     ("faults", ">i4"), ("voltage", ">f4", (4,)), ("current", ">f4", (4,)),
                     ("wheel_speed", ">f4", (4,))])


def pose_dtype():
    """Packed big-endian layout of an encoded omni4.pose_t (fingerprint first), 40 bytes."""
    return np.dtype([("fp", "S8"), ("utime", ">i8"), ("x", ">f8"), ("y", ">f8"),
                     ("theta", ">f8")])


def encode_motors(omni4, utime, seq, mode, voltage, current, wheel_speed):
    """List of encoded motors_t messages (bytes) from per-message arrays."""
    a = np.zeros(len(utime), motors_dtype())
    a["fp"] = omni4.motors_t._get_packed_fingerprint()
    a["utime"], a["seq"], a["mode"] = utime, seq, mode
    a["voltage"], a["current"], a["wheel_speed"] = voltage, current, wheel_speed
    buf, w = a.tobytes(), a.dtype.itemsize
    return [buf[j * w:(j + 1) * w] for j in range(len(a))]


def encode_poses(omni4, utime, pose):
    """List of encoded pose_t messages (bytes); pose (n,3) [m, m, rad]."""
    a = np.zeros(len(utime), pose_dtype())
    a["fp"] = omni4.pose_t._get_packed_fingerprint()
    a["utime"], a["x"], a["y"], a["theta"] = utime, pose[:, 0], pose[:, 1], pose[:, 2]
    buf, w = a.tobytes(), a.dtype.itemsize
    return [buf[j * w:(j + 1) * w] for j in range(len(a))]


def encode_mark(omni4, utime, kind, direction, level):
    """Encoded experiment_t (bytes)."""
    e = omni4.experiment_t()
    e.utime, e.kind, e.direction, e.level = int(utime), kind, direction, float(level)
    return e.encode()


# ---- files ----------------------------------------------------------------------------------

def encode_robot(omni4, utime, params):
    """The robot's description of its wheels (robot_t) from a truth parameter dict: wheels,
    wheel_angle_j [deg] -> [rad], d_j (else d) [m], r_j (else r) [m], l; slot 3 of a
    three-wheel robot 0."""
    m = omni4.robot_t()
    m.utime = int(utime)
    n = int(params.get("wheels", 4))
    m.wheels = n
    paper = (0.0, 90.0, 180.0, 270.0)
    m.wheel_angle = [float(np.deg2rad(params.get(f"wheel_angle_{j}", paper[j]))) if j < n
                     else 0.0 for j in range(4)]
    m.wheel_distance = [float(params.get(f"d_{j}", params["d"])) if j < n else 0.0
                        for j in range(4)]
    m.wheel_radius = [float(params.get(f"r_{j}", params["r"])) if j < n else 0.0
                      for j in range(4)]
    m.l = float(params["l"])
    return m.encode()


def write_ini(path, params, keys):
    """Write a [model] INI with `key = value` lines (atomically: temp file + rename)."""
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        f.write("[model]\n")
        for k in keys:
            f.write(f"{k} = {params[k]!r}\n")
    os.replace(tmp, path)


def read_ini(path, section="model"):
    """Read `key = value` lines of one INI section into a dict of floats (';'/'#' comments)."""
    out, cur = {}, None
    with open(path) as f:
        for line in f:
            line = line.split(";")[0].split("#")[0].strip()
            if not line:
                continue
            if line.startswith("["):
                cur = line.strip("[]").strip()
            elif cur == section and "=" in line:
                k, v = line.split("=", 1)
                out[k.strip()] = float(v)
    return out


def write_log(lcm, omni4, path, data):
    """Write one robot's messages, ordered by receive time (utime + 0-300 us; a pose with camera
    latency: its arrival time) to `path`; the receive time is the event's timestamp."""
    rng = data["rng"]
    m, ps = data["motors"], data["poses"]
    msgs = [encode_motors(omni4, m["utime"], m["seq"], m["mode"], m["voltage"], m["current"],
                          m["wheel_speed"]),
            encode_poses(omni4, ps["utime"], ps["pose"]),
            [encode_mark(omni4, *mk) for mk in data["marks"]]]
    utimes = [m["utime"], ps["utime"], np.array([mk[0] for mk in data["marks"]], np.int64)]
    chans = (CH_MOTORS, CH_POSE, CH_EXP, CH_ROBOT)
    if data.get("robot"):  # the controller's robot_t: its first tick, then 1 Hz
        rt = np.arange(m["utime"][0], m["utime"][-1] + 1, 1_000_000, dtype=np.int64)
        msgs.append([encode_robot(omni4, t, data["robot"]) for t in rt.tolist()])
        utimes.append(rt)
    recvs = [ut + rng.integers(0, RECEIVE_DELAY_US + 1, len(ut)) for ut in utimes]
    if ps.get("recv_us") is not None:
        recvs[1] = np.asarray(ps["recv_us"], np.int64)
    recv = np.concatenate(recvs)
    src = np.concatenate([np.full(len(ut), c) for c, ut in enumerate(utimes)])
    idx = np.concatenate([np.arange(len(ut)) for ut in utimes])
    order = np.argsort(recv, kind="stable")
    recv = np.maximum.accumulate(recv[order])
    if os.path.exists(path):
        os.remove(path)
    log = lcm.EventLog(path, "w")
    try:
        for ts, c, j in zip(recv.tolist(), src[order].tolist(), idx[order].tolist()):
            log.write_event(ts, chans[c], msgs[c][j])
    finally:
        log.close()
    return {"motors": len(msgs[0]), "poses": len(msgs[1]), "marks": len(msgs[2])}


def write_sidecar(path, sensors):
    """Write the real-sensor truth of one log as JSON (atomically: temp file + rename)."""
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w") as f:
        json.dump(sensors, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)
