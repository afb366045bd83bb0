"""omni4.foxglove without other programs: the prediction against a closed form, the encoder
velocity against eqs 3-5, restarts, the INI [model] reader, the LCM log reader on truncated and
corrupt logs, the motors_t fast decoder against lcm-gen's, health counts, and omni4-mcap's
output read back by the Python mcap library (CRCs validated) on a synthetic log."""
import json
import math
import os
import random
import socket
import struct
import subprocess
import sys

import lcm
import numpy as np
import pytest

import omni4
from omni4.foxglove import export, lcmlog, topics
from omni4.foxglove.model import Predictor, read_model, table3
from omni4.ini import ConfigError

# The paper's Table III (docs/design.md), typed here independently of model/.
T3 = dict(d=0.089, r=0.0325, l=5.0, Kv=0.0259, Kt=0.0259, R=4.3111, M=2.34, J=0.0228,
          Bv=0.4978, Bvn=0.6763, Bw=0.0141, Cv=1.8738, Cvn=2.2198, Cw=0.1385)


def closed_form_axis(p, u, axis):
    """a, b, c of x' = a x + b - c sgn(x) for the axis, from the formulas of docs/design.md:
    f_j = l Kt i_j / r, i_j = (u_j - Kv l v_j / r) / R; Fv = f3 - f1, Fvn = f0 - f2,
    T = d (f0 + f1 + f2 + f3)."""
    g = p["l"] * p["Kt"] / (p["r"] * p["R"])       # force per volt [N/V]
    emf = g * p["Kv"] * p["l"] / p["r"]           # force per wheel speed [N/(m/s)]
    if axis == 0:
        return (-(2 * emf + p["Bv"]) / p["M"], g * (u[3] - u[1]) / p["M"], p["Cv"] / p["M"])
    if axis == 1:
        return (-(2 * emf + p["Bvn"]) / p["M"], g * (u[0] - u[2]) / p["M"], p["Cvn"] / p["M"])
    d = p["d"]
    return (-(4 * d * d * emf + p["Bw"]) / p["J"], d * g * sum(u) / p["J"], p["Cw"] / p["J"])


@pytest.mark.parametrize("axis,u", [(0, [0.0, -6.0, 0.0, 6.0]), (1, [6.0, 0.0, -6.0, 0.0]),
                                    (2, [3.0, 3.0, 3.0, 3.0])])
def test_prediction_is_the_closed_form_of_a_voltage_step(axis, u):
    pr = Predictor(T3)
    a, b, c = closed_form_axis(T3, u, axis)
    xss = -(b - c) / a
    worst = 0.0
    for k in range(3001):  # 3 s at 1 kHz from rest, bridges driven from the first sample
        meas, pred, restarted = pr.step(k * 1000, k, 2, u, [0.0] * 4)
        assert restarted == (k == 0)
        t = k * 1e-3
        want = xss * (1 - math.exp(a * t))
        worst = max(worst, abs(pred[axis] - want))
        for other in range(3):
            if other != axis:
                assert pred[other] == 0.0
    assert worst < 1e-9 * abs(xss)
    assert pred[axis] == pytest.approx(xss, rel=1e-3)  # 3 s = 10 time constants
    # docs/figures.md: steady speed at 6 V
    if axis == 0:
        assert xss == pytest.approx(1.1722, abs=1e-4)
    if axis == 1:
        assert xss == pytest.approx(1.1031, abs=1e-4)


def test_coast_down_uses_null_traction():
    """Bridges off (COAST): no drive and no back-EMF: x' = -B/M x - C/M, stop time
    M/B ln(1 + B v0 / C) (docs/figures.md: 1.3008 s from 1.2 m/s)."""
    pr = Predictor(T3)
    v0 = 1.2
    wheel = [0.0, -v0 / T3["r"], 0.0, v0 / T3["r"]]   # eq 2 for x = [v0, 0, 0]
    meas, pred, restarted = pr.step(0, 0, 3, [0.0] * 4, wheel)
    assert restarted and pred[0] == pytest.approx(v0) and meas[0] == pytest.approx(v0)
    t_stop = T3["M"] / T3["Bv"] * math.log(1 + T3["Bv"] * v0 / T3["Cv"])
    assert t_stop == pytest.approx(1.3008, abs=1e-4)
    k = 1
    while True:
        _, pred, _ = pr.step(k * 1000, k, 3, [9.0] * 4, wheel)  # voltages ignored: bridges off
        if pred[0] == 0.0:
            break
        k += 1
        assert k < 5000
    assert abs(k * 1e-3 - t_stop) <= 1e-3


def test_encoder_velocity_is_eqs_3_to_5():
    pr = Predictor(T3)
    rng = random.Random(1)
    for k in range(50):
        w = np.float32([rng.uniform(-40, 40) for _ in range(4)]).tolist()  # motors_t: float
        meas, _, _ = pr.step(k * 1000, k, 0, [0.0] * 4, w)
        vw = [x * T3["r"] for x in w]
        assert meas[0] == pytest.approx((vw[3] - vw[1]) / 2, abs=1e-12)
        assert meas[1] == pytest.approx((vw[0] - vw[2]) / 2, abs=1e-12)
        assert meas[2] == pytest.approx(sum(vw) / (4 * T3["d"]), abs=1e-12)


def test_prediction_restarts_on_gaps_and_bridge_changes():
    pr = Predictor(T3)
    w = [0.0, -10.0, 0.0, 10.0]
    seen = []
    plan = [(0, 0, 2), (1000, 1, 2), (2000, 2, 1), (3000, 4, 1), (4000, 5, 1), (4000, 6, 1),
            (104000, 7, 1), (105000, 8, 3), (106000, 9, 0), (107000, 10, 2)]
    for ut, sq, md in plan:
        meas, pred, r = pr.step(ut, sq, md, [1.0, 1.0, 1.0, 1.0], w)
        seen.append(r)
        if r:
            assert pred == meas
    # first; VOLTAGE->VELOCITY both driven: no; seq gap; no; utime not increasing; 100 ms jump;
    # driven -> COAST; COAST -> IDLE both off: no; IDLE -> VOLTAGE
    assert seen == [True, False, False, True, False, True, True, True, False, True]


def test_batch_run_equals_step_by_step():
    rng = np.random.default_rng(3)
    n = 2000
    ut = np.arange(n, dtype=np.int64) * 1000
    sq = np.arange(n, dtype=np.int64)
    sq[700:] += 3  # a gap
    md = np.where((np.arange(n) // 300) % 2 == 0, 2, 3).astype(np.int8)
    u = rng.uniform(-8, 8, (n, 4)).astype(np.float32)
    w = rng.uniform(-30, 30, (n, 4)).astype(np.float32)
    meas, pred, rst = Predictor(T3).run(ut, sq, md, u, w)
    one = Predictor(T3)
    for k in range(n):
        m, p, r = one.step(int(ut[k]), int(sq[k]), int(md[k]), u[k].tolist(), w[k].tolist())
        assert list(meas[k]) == m and list(pred[k]) == p and rst[k] == r


# ---- INI ------------------------------------------------------------------------------------

def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


def test_ini_model_section(tmp_path):
    assert table3() == pytest.approx(T3)
    # no [model]: Table III, as the firmware
    p = write(tmp_path, "robot.ini", "[hal]\nmotor = sim\n[loop]\nrate_hz = 1000\n")
    assert read_model(p) == pytest.approx(T3)
    body = "".join(f"{k} = {v * 1.1} ; comment\n" for k, v in T3.items())
    p = write(tmp_path, "p.ini", "; identified\n[hal]\nmotor = sim\n[model]\n" + body)
    got = read_model(p)
    assert got == pytest.approx({k: v * 1.1 for k, v in T3.items()})
    # a drive's own keys (docs/configuration.md) are taken beside the scalars
    p = write(tmp_path, "w.ini", "[model]\n" + body + "R_2 = 5.1\nr_0 = 0.033\n")
    assert read_model(p) == pytest.approx({**{k: v * 1.1 for k, v in T3.items()},
                                           "R_2": 5.1, "r_0": 0.033})


@pytest.mark.parametrize("text,msg", [
    ("[model]\nd = 0.089\n", ":2: [model] lacks r l Kv"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()).replace("R = 4.3111", "R = x"),
     ":7: [model] R = 'x' is not a number"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()) + "Q = 1\n",
     ":16: unknown key 'Q'"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()) + "d = 1\n",
     ":16: duplicate key 'd'"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()).replace("M = 2.34", "M = -2"),
     ":8: [model] M = -2 outside its physical range [0.01, 10000]"),
    ("[model\nd = 1\n", ":1: malformed section header"),
    ("[hal]\nmotor = sim\n[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items())
     + "[hal]\nlines = none\n", ":18: duplicate section [hal]"),
    ("[model]\nd = nan\n", ":2: [model] d = 'nan' is not a number"),
    ("[model]\nd = 0x4\n", ":2: [model] d = '0x4' is not a number"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()) + "Kv_3 = 0\n",
     ":16: [model] Kv_3 = 0 outside its physical range [0.0001, 5]"),
    ("[model]\nR_1 = 4\n", ":2: [model] lacks d r l"),
    ("[model]\n" + "".join(f"{k} = {v}\n" for k, v in T3.items()) + "R_4 = 1\n",
     ":16: unknown key 'R_4'"),
])
def test_ini_errors_name_file_and_line(tmp_path, text, msg):
    p = write(tmp_path, "bad.ini", text)
    with pytest.raises(ConfigError) as e:
        read_model(p)
    assert str(e.value).startswith(p + ":") and msg in str(e.value), str(e.value)


def _range_rows():
    """tests/config/model_ranges.txt: the one table of [model] values the controller's reader
    (tests/firmware/test_model_ranges.c) is tested against too."""
    path = os.path.join(os.path.dirname(__file__), "..", "..", "tests", "config",
                        "model_ranges.txt")
    rows = []
    with open(path) as fh:
        for no, line in enumerate(fh, 1):
            if line.strip() and not line.startswith("#"):
                key, value, verdict = line.split()[:3]
                rows.append(pytest.param(key, value, verdict == "accept", id=f"{no}-{key}={value}"))
    assert len(rows) >= 40  # the table is whole
    return rows


@pytest.mark.parametrize("key,value,accept", _range_rows())
def test_model_values_have_the_controllers_verdict(tmp_path, key, value, accept):
    body = "".join(f"{k} = {value if k == key else v}\n" for k, v in T3.items())
    if key not in T3:
        body += f"{key} = {value}\n"
    p = write(tmp_path, "robot.ini", "[model]\n" + body)
    if accept:
        assert read_model(p)[key] == float(value)
    else:
        with pytest.raises(ConfigError) as e:
            read_model(p)
        assert str(e.value).startswith(p + ":") and key in str(e.value), str(e.value)


def test_ini_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="cannot read"):
        read_model(str(tmp_path / "none.ini"))


# ---- logs -----------------------------------------------------------------------------------

T0_US = 1_700_000_000_000_000


def synth_adapt(k, seq):
    """The k-th sample's adapt_t of synth_log: R in use 4.3 ohm (1 + k / 1e5), an estimate
    above it with variance 1e-4 ohm^2, ON and FED, ADAPTED from k = 1000 on."""
    a = omni4.adapt_t()
    a.utime, a.seq = k * 1000, seq
    a.R = [4.3 * (1 + k / 1e5)] * 4
    a.R_estimate = [4.3 * (1 + k / 1e5) + 0.01 * j for j in range(4)]
    a.R_variance = [1e-4] * 4
    a.supply_v, a.Cv, a.Cvn, a.Cw, a.track_rms = 12.0, 1.8738, 2.2198, 0.1385, 0.01
    a.flags = omni4.adapt_t.FLAG_ON | omni4.adapt_t.FLAG_FED | \
        (omni4.adapt_t.FLAG_ADAPTED if k >= 1000 else 0)
    return a


def synth_log(path, n=3000, gap_at=None, overruns=(), rejected=(), bad_motors=False,
              adapt=False):
    """A log of n motors samples at 1 kHz, a pose every 40, marks and commands, and one
    channel no omni4 type decodes; with adapt, an adapt_t every 100 samples (R in use rising
    0.1 % per 100 samples). Returns {channel: [(log_time_us, payload)]}."""
    out = {}
    log = lcm.EventLog(path, "w", overwrite=True)
    rng = random.Random(7)

    def put(t, ch, data):
        log.write_event(t, ch, data)
        out.setdefault(ch, []).append((t, data))

    seq = 0
    for k in range(n):
        if gap_at is not None and k == gap_at:
            seq += 5
        m = omni4.motors_t()
        m.utime, m.seq, m.mode = k * 1000, seq, 2 if (k // 700) % 2 == 0 else 3
        m.faults = (topics.FAULT_OVERRUN if k in overruns else 0) | \
            (topics.FAULT_CMD_REJECTED if k in rejected else 0)
        m.voltage = [rng.uniform(-12, 12) for _ in range(4)]
        m.current = [rng.uniform(-3, 3) for _ in range(4)]
        m.wheel_speed = [rng.uniform(-40, 40) for _ in range(4)]
        put(T0_US + k * 1000, omni4.CHANNEL_MOTORS, m.encode())
        seq += 1
        if k % 40 == 0:
            p = omni4.pose_t()
            p.utime, p.x, p.y, p.theta = k * 1000, rng.uniform(-2, 2), rng.uniform(-2, 2), \
                rng.uniform(-3, 3)
            put(T0_US + k * 1000 + 1, omni4.CHANNEL_POSE, p.encode())
        if k % 700 == 0:
            e = omni4.experiment_t()
            e.utime, e.kind, e.direction, e.level = k * 1000, "step", "vn", 6.0
            put(T0_US + k * 1000 + 2, omni4.CHANNEL_EXPERIMENT, e.encode())
            c = omni4.command_t()
            c.utime, c.seq, c.mode, c.ramp_s = k * 1000, k, 1, 0.1
            c.velocity, c.voltage = [0.5, -0.25, 1.0], [0.0] * 4
            put(T0_US + k * 1000 + 3, omni4.CHANNEL_CMD, c.encode())
        if adapt and k % 100 == 0:
            put(T0_US + k * 1000 + 4, omni4.CHANNEL_ADAPT, synth_adapt(k, seq - 1).encode())
    put(T0_US + n * 1000, "OMNI4_SOMETHING_ELSE", b"\x00\x01not an omni4 type")
    if bad_motors:
        short = omni4.motors_t().encode()[:40]          # motors_t's fingerprint, cut short
        log.write_event(T0_US + n * 1000 + 1, omni4.CHANNEL_MOTORS, short)
        e = omni4.experiment_t()
        e.kind, e.direction = "end", ""
        log.write_event(T0_US + n * 1000 + 2, omni4.CHANNEL_MOTORS, e.encode())
    log.close()
    return out


def test_log_reader_truncated_and_corrupt(tmp_path):
    path = str(tmp_path / "a.lcmlog")
    synth_log(path, n=200)
    events, st = lcmlog.read_events(path)
    full = len(events)
    assert st.lost() == "" and full == 200 + 5 + 2 + 1
    data = open(path, "rb").read()
    # cut inside the last event
    cut = str(tmp_path / "cut.lcmlog")
    open(cut, "wb").write(data[:-7])
    ev, st = lcmlog.read_events(cut)
    assert len(ev) == full - 1 and st.truncated_bytes > 0 and "truncated" in st.lost()
    # 13 bytes of junk after the first event's header position
    first_len = 28 + len(events[0][1]) + len(events[0][2])
    bad = str(tmp_path / "bad.lcmlog")
    open(bad, "wb").write(data[:first_len] + b"\x55" * 13 + data[first_len:])
    ev, st = lcmlog.read_events(bad)
    assert len(ev) == full and st.skipped_bytes == 13 and st.resyncs == 1
    # not a log
    junk = str(tmp_path / "junk.bin")
    open(junk, "wb").write(os.urandom(4000).replace(lcmlog.SYNC_BYTES, b"xxxx"))
    with pytest.raises(lcmlog.LogError, match="no intact LCM event"):
        lcmlog.read_events(junk)
    with pytest.raises(lcmlog.LogError, match="No such file"):
        lcmlog.read_events(str(tmp_path / "none.lcmlog"))


def test_fast_motors_decoder_equals_lcm_gen(tmp_path):
    path = str(tmp_path / "a.lcmlog")
    payloads = [d for _, d in synth_log(path, n=500)[omni4.CHANNEL_MOTORS]]
    fast = export.decode_motors(payloads)
    for k, p in enumerate(payloads):
        m = omni4.motors_t.decode(p)
        assert (fast["utime"][k], fast["seq"][k], fast["mode"][k], fast["faults"][k]) == \
            (m.utime, m.seq, m.mode, m.faults)
        for f in ("voltage", "current", "wheel_speed"):
            assert fast[f][k].tolist() == list(getattr(m, f))


def test_health_counts():
    h = topics.Health()
    seq = 0
    for k in range(1000):
        if k == 100:
            seq += 4   # 4 samples lost
        ut = k * 1000 + (3000 if k >= 500 else 0)  # one late tick at k = 500
        faults = (topics.FAULT_OVERRUN if k in (10, 11, 800) else 0) | \
            (topics.FAULT_CMD_REJECTED if 200 <= k < 210 or 300 <= k < 305 else 0)
        h.add(ut, seq, 1, faults)
        seq += 1
    r = json.loads(h.report(1.0))
    assert (r["dropped"], r["overruns"], r["rejected_commands"], r["late_ticks"]) == (4, 3, 2, 1)
    assert r["samples"] == 1000 and r["loop_rate_hz"] == pytest.approx(999 / 1.002)
    assert r["mode_name"] == "VELOCITY" and r["faults"] == []
    assert topics.fault_names(0x1400 | 0x8000) == ["CMD_REJECTED", "OVERRUN", "UNKNOWN_0x8000"]


# ---- omni4-mcap -----------------------------------------------------------------------------

def read_mcap_python(path):
    """The mcap library's reader, CRCs validated: {topic: [(log_time_ns, schema, json)]}."""
    from mcap.reader import make_reader
    out = {}
    with open(path, "rb") as fh:
        r = make_reader(fh, validate_crcs=True)
        summary = r.get_summary()
        for schema, channel, message in r.iter_messages(log_time_order=False):
            assert channel.message_encoding == "json" and schema.encoding == "jsonschema"
            json.loads(schema.data)
            out.setdefault(channel.topic, []).append(
                (message.log_time, schema.name, json.loads(message.data)))
        compressions = {c.compression for c in summary.chunk_indexes}
    # and once more from the first byte to the footer, streamed (data section CRC)
    from mcap.stream_reader import StreamReader
    with open(path, "rb") as fh:
        assert sum(1 for _ in StreamReader(fh, validate_crcs=True).records) > 0
    return out, summary, compressions


def check_mcap_against_log(got, logged, params):
    """Counts per channel and values of the omni4 channels equal the LCM log's."""
    for ch, evs in logged.items():
        assert len(got[ch]) == len(evs), ch
        assert [t for t, _, _ in got[ch]] == [t * 1000 for t, _ in evs], ch
    mot = got[omni4.CHANNEL_MOTORS]
    for (t, schema, j), (_, data) in zip(mot, logged[omni4.CHANNEL_MOTORS]):
        m = omni4.motors_t.decode(data)
        assert schema == "omni4.motors_t"
        assert (j["utime"], j["seq"], j["mode"], j["faults"]) == (m.utime, m.seq, m.mode,
                                                                  m.faults)
        assert j["mode_name"] == topics.MODE_NAMES[m.mode]
        for f in ("voltage", "current", "wheel_speed"):
            assert np.float32(j[f]).tolist() == list(getattr(m, f)), f
    for (t, schema, j), (_, data) in zip(got[omni4.CHANNEL_POSE], logged[omni4.CHANNEL_POSE]):
        m = omni4.pose_t.decode(data)
        assert (j["utime"], j["x"], j["y"], j["theta"]) == (m.utime, m.x, m.y, m.theta)
    for (_, _, j), (_, data) in zip(got[omni4.CHANNEL_CMD], logged[omni4.CHANNEL_CMD]):
        m = omni4.command_t.decode(data)
        assert (j["velocity"], j["voltage"], j["ramp_s"], j["seq"]) == \
            (list(m.velocity), list(m.voltage), m.ramp_s, m.seq)
        assert j["mode_name"] == topics.MODE_NAMES[m.mode]
    for (_, _, j), (_, data) in zip(got[omni4.CHANNEL_EXPERIMENT],
                                    logged[omni4.CHANNEL_EXPERIMENT]):
        m = omni4.experiment_t.decode(data)
        assert (j["kind"], j["direction"], j["level"]) == (m.kind, m.direction, m.level)
    # derived: one velocity per motors sample, the prediction of a fresh Predictor
    vel = got[topics.TOPIC_VELOCITY]
    assert len(vel) == len(mot)
    assert [t for t, _, _ in vel] == [t for t, _, _ in mot]
    assert [j["seq"] for _, _, j in vel] == [j["seq"] for _, _, j in mot]
    assert {s for _, s, _ in vel} == {"omni4.velocity"}
    ms = [j for _, _, j in mot]
    meas, pred, rst = Predictor(params).run([j["utime"] for j in ms], [j["seq"] for j in ms],
                                            [j["mode"] for j in ms],
                                            [j["voltage"] for j in ms],
                                            [j["wheel_speed"] for j in ms])
    axes = ("v", "vn", "w")
    enc = np.array([[j["encoder"][a] for a in axes] for _, _, j in vel])
    prd = np.array([[j["predicted"][a] for a in axes] for _, _, j in vel])
    dif = np.array([[j["difference"][a] for a in axes] for _, _, j in vel])
    np.testing.assert_allclose(enc, meas, rtol=0, atol=1e-12)
    np.testing.assert_allclose(prd, pred, rtol=0, atol=1e-12)
    np.testing.assert_allclose(dif, enc - prd, rtol=0, atol=1e-12)
    assert [j["restarted"] for _, _, j in vel] == rst.tolist()
    # pose as Foxglove's transform and pose
    tf = [x for x in got[topics.TOPIC_TF] if x[2]["child_frame_id"] == "robot"]
    pose = got[topics.TOPIC_POSE]
    assert len(tf) == len(pose) == len(logged[omni4.CHANNEL_POSE])
    for (t, schema, j), (_, data) in zip(tf, logged[omni4.CHANNEL_POSE]):
        m = omni4.pose_t.decode(data)
        assert schema == "foxglove.FrameTransform"
        assert (j["translation"]["x"], j["translation"]["y"]) == (m.x, m.y)
        q = j["rotation"]
        dth = 2 * math.atan2(q["z"], q["w"]) - m.theta
        assert abs(math.atan2(math.sin(dth), math.cos(dth))) < 1e-12
        assert j["timestamp"]["sec"] * 10**9 + j["timestamp"]["nsec"] == t
    assert got[topics.TOPIC_SCENE][0][1] == "foxglove.SceneUpdate"
    assert len(got[topics.TOPIC_SCENE][0][2]["entities"][0]["cylinders"]) == 4


@pytest.mark.parametrize("compression", ["zstd", "lz4"])
def test_mcap_of_a_synthetic_log(tmp_path, compression, capsys):
    log = str(tmp_path / "s.lcmlog")
    out = str(tmp_path / "s.mcap")
    logged = synth_log(log, n=3000, gap_at=1500, overruns=(10, 2500), rejected=(40, 41, 900),
                       bad_motors=True)
    assert export.main([log, "--out", out, "--compression", compression]) == 0
    err = capsys.readouterr().err
    got, summary, comps = read_mcap_python(out)
    assert comps == {compression} and len(summary.chunk_indexes) >= 1
    check_mcap_against_log(got, logged, T3)
    # payloads on OMNI4_MOTORS that are not motors_t: kept beside it, never as motors
    bad = got["OMNI4_MOTORS/undecodable"]
    assert len(bad) == 1 and bad[0][1] == "omni4.lcm_raw"
    other = got["OMNI4_MOTORS/experiment_t"]  # on the wrong channel, decoded by fingerprint
    assert len(other) == 1 and other[0][1] == "omni4.lcm_fields" and other[0][2]["kind"] == "end"
    raw = got["OMNI4_SOMETHING_ELSE"][0]
    assert raw[1] == "omni4.lcm_raw"
    assert raw[2]["data_base64"] and "OMNI4_SOMETHING_ELSE 1" in err
    health = [j for _, _, j in got[topics.TOPIC_HEALTH]]
    assert len(health) == 3  # 3 s of log, 1 s windows (the last one partial)
    assert sum(h["samples"] for h in health) == 3000
    assert health[-1]["dropped_total"] == 5 and health[-1]["overruns_total"] == 2
    assert health[-1]["rejected_commands_total"] == 2
    assert health[0]["loop_rate_hz"] == pytest.approx(1000, rel=1e-3)
    assert not os.path.exists(out + f".tmp{os.getpid()}")


def split_log(path, events, keep):
    """Write the events (log time, channel, payload) for which keep(i, channel) holds."""
    w = lcm.EventLog(str(path), "w", overwrite=True)
    for i, (t, ch, data) in enumerate(events):
        if keep(i, ch):
            w.write_event(t, ch, data)
    w.close()
    return str(path)


def test_mcap_of_logs_out_of_order_or_from_two_machines(tmp_path, capsys):
    """Several LOGs make one time-ordered MCAP whatever order they are named in: the halves of
    a split recording named last-first, and the same run recorded on two machines (the robot's
    motors on one, the camera and the commands on the other)."""
    log = str(tmp_path / "s.lcmlog")
    logged = synth_log(log, n=3000, gap_at=1500)
    events = sorted(((t, ch, d) for ch, evs in logged.items() for t, d in evs),
                    key=lambda e: e[0])
    half = len(events) // 2
    first = split_log(tmp_path / "a.lcmlog", events, lambda i, ch: i < half)
    second = split_log(tmp_path / "b.lcmlog", events, lambda i, ch: i >= half)
    robot = split_log(tmp_path / "robot.lcmlog", events,
                      lambda i, ch: ch == omni4.CHANNEL_MOTORS)
    camera = split_log(tmp_path / "camera.lcmlog", events,
                       lambda i, ch: ch != omni4.CHANNEL_MOTORS)
    out = str(tmp_path / "o.mcap")
    for names, merged in (([first, second], False), ([second, first], True),
                          ([camera, robot], True)):
        capsys.readouterr()
        assert export.main([*names, "--out", out]) == 0, names
        err = capsys.readouterr().err
        assert ("merged by log time" in err) == merged, err
        got, _, _ = read_mcap_python(out)
        check_mcap_against_log(got, logged, T3)  # per channel: every event, in log order
        health = [j for _, _, j in got[topics.TOPIC_HEALTH]]
        assert sum(h["samples"] for h in health) == 3000 and health[-1]["dropped_total"] == 5


def test_mcap_errors(tmp_path, capsys):
    log = str(tmp_path / "s.lcmlog")
    synth_log(log, n=300)
    out = str(tmp_path / "o.mcap")
    n_events = len(lcmlog.read_events(log)[0])

    def run(*args):
        capsys.readouterr()
        try:
            rc = export.main(list(args))
        except SystemExit as e:  # argparse
            rc = e.code
        return rc, capsys.readouterr().err.strip().splitlines()

    rc, err = run(str(tmp_path / "none.lcmlog"), "--out", out, "-q")
    assert rc == 1 and err == [f"omni4-mcap: {tmp_path}/none.lcmlog: No such file or directory"]
    junk = tmp_path / "junk.bin"
    junk.write_bytes(b"\x00" * 1000)
    rc, err = run(str(junk), "--out", out, "-q")
    assert rc == 1 and len(err) == 1 and "no intact LCM event" in err[0]
    bad = write(tmp_path, "bad.ini", "[model]\nd = 1\n")
    rc, err = run(log, "--out", out, "--params", bad, "-q")
    assert rc == 2 and len(err) == 1 and err[0].startswith(f"omni4-mcap: {bad}:2:")
    rc, err = run(log, "-q")  # no --out
    assert rc == 2
    assert not os.path.exists(out)
    # truncated: the complete events are converted, the loss is named, status 1 (0 if allowed)
    cut = tmp_path / "cut.lcmlog"
    cut.write_bytes(open(log, "rb").read()[:-20])
    rc, err = run(str(cut), "--out", out, "-q")
    assert rc == 1 and len(err) == 1 and "truncated: the last" in err[0]
    assert f"the {n_events - 1} complete events were converted" in err[0]
    got, _, _ = read_mcap_python(out)
    assert sum(len(got[c]) for c in got if not c.startswith("/")) == n_events - 1
    rc, err = run(str(cut), "--out", out, "-q", "--partial-ok")
    assert rc == 0 and "truncated" in err[0]


def test_console_scripts_have_help():
    bindir = os.path.dirname(sys.executable)
    for tool in ("omni4-mcap", "omni4-bridge"):
        r = subprocess.run([os.path.join(bindir, tool), "--help"], capture_output=True,
                           text=True, timeout=60)
        assert r.returncode == 0 and "usage: " + tool in r.stdout


def test_block_json_equals_the_bridges_json(tmp_path):
    """omni4-mcap builds its per-sample JSON block-wise; the bridge per message: same content."""
    path = str(tmp_path / "a.lcmlog")
    payloads = [d for _, d in synth_log(path, n=9000, rejected=(5, 6))[omni4.CHANNEL_MOTORS]]
    mot = export.decode_motors(payloads)
    mot["current"][17, 2] = np.nan  # NaN -> null in both
    meas, pred, rst = Predictor(T3).run(mot["utime"], mot["seq"], mot["mode"], mot["voltage"],
                                        mot["wheel_speed"])
    blocks_m = list(topics.motors_json_blocks(mot))
    blocks_v = list(topics.velocity_json_blocks(mot, meas, pred, rst))
    assert len(blocks_m) == len(blocks_v) == 9000
    for k in range(0, 9000, 7):
        one = topics.motors_json(*(mot[f][k].item() for f in ("utime", "seq", "mode", "faults")),
                                 *(mot[f][k].astype(np.float64).tolist()
                                   for f in ("voltage", "current", "wheel_speed")))
        a, b = json.loads(blocks_m[k]), json.loads(one)
        for f in ("voltage", "current", "wheel_speed"):  # float32-exact, shorter text
            a[f] = [None if x is None else float(np.float32(x)) for x in a[f]]
        assert a == b
        one = topics.velocity_json(int(mot["utime"][k]), int(mot["seq"][k]), int(mot["mode"][k]),
                                   meas[k].tolist(), pred[k].tolist(), bool(rst[k]))
        assert json.loads(blocks_v[k]) == json.loads(one)
    assert json.loads(blocks_m[17])["current"][2] is None


def test_layout_file_is_the_generators_and_plots_existing_fields(tmp_path):
    import re
    from omni4.foxglove import layout
    path = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "foxglove-layout.json")
    with open(path) as fh:
        text = fh.read()
    assert text == layout.layout_json(), \
        "docs/foxglove-layout.json is stale: python -m omni4.foxglove.layout > it"
    doc = json.loads(text)
    refs = []

    def walk(x):
        if isinstance(x, dict):
            for k, v in x.items():
                if k in ("value", "topicPath") and isinstance(v, str):
                    refs.append(v)
                elif k == "topics" and isinstance(v, dict):
                    refs.extend(v)
                walk(v)
        elif isinstance(x, list):
            for v in x:
                walk(v)
    walk(doc)
    assert len(refs) >= 20
    log = str(tmp_path / "s.lcmlog")
    out = str(tmp_path / "s.mcap")
    synth_log(log, n=1500, adapt=True)
    assert export.main([log, "--out", out, "-q"]) == 0
    got, _, _ = read_mcap_python(out)
    for ref in refs:
        topic = ref if ref in got else next((t for t in got if ref.startswith(t + ".")
                                             or ref.startswith(t + "{")), None)
        assert topic, f"layout plots {ref}: no such topic"
        rest = re.sub(r"\{[^}]*\}", "", ref[len(topic):])
        msg = got[topic][0][2]
        for name, idx in re.findall(r"\.(\w+)(?:\[(\d+)\])?", rest):
            assert name in msg, f"layout plots {ref}: no field {name}"
            msg = msg[name] if idx == "" else msg[name][int(idx)]


def test_the_voltage_of_tick_k_acts_until_tick_k_plus_1():
    """Voltages changing every tick (4..8 V along v, the robot moving forward throughout): each
    step is the exact solution of x' = a x + b_k - c with the voltage logged at the step's
    start, integrated here independently."""
    rng = random.Random(5)
    pr = Predictor(T3)
    x = 0.6  # [m/s] start, from the encoders
    w0 = [0.0, -x / T3["r"], 0.0, x / T3["r"]]
    us = [np.float32([0.0, -u, 0.0, u]).tolist()  # motors_t voltages are float
          for u in (rng.uniform(4, 8) for _ in range(400))]
    _, pred, _ = pr.step(0, 0, 2, us[0], w0)
    assert pred[0] == pytest.approx(x)
    x = pred[0]  # the encoders' value of the float wheel speeds
    t = 0
    for k in range(1, 400):
        dt_us = rng.choice((900, 1000, 1100))
        t += dt_us
        _, pred, r = pr.step(t, k, 2, us[k], w0)
        assert not r
        a, b, c = closed_form_axis(T3, us[k - 1], 0)
        xss = -(b - c) / a
        x = xss + (x - xss) * math.exp(a * dt_us * 1e-6)
        assert pred[0] == pytest.approx(x, abs=1e-12)


def test_bridge_cli_errors(tmp_path, capsys):
    from omni4.foxglove import bridge

    def run(*args):
        capsys.readouterr()
        try:
            rc = bridge.main(list(args))
        except SystemExit as e:
            rc = e.code
        return rc, capsys.readouterr().err.strip().splitlines()

    bad = write(tmp_path, "bad.ini", "[model]\nd = x\n")
    rc, err = run("--params", bad, "-q")
    assert rc == 2 and err == [f"omni4-bridge: {bad}:2: [model] d = 'x' is not a number"]
    rc, err = run("--lcm", "nonsense://x", "-q", "--duration", "0.1")
    assert rc == 2 and len(err) == 1 and err[0].startswith("omni4-bridge: --lcm nonsense://x")
    assert run("--decimate", "0")[0] == 2
    with socket.socket() as s:  # a port already taken
        s.bind(("127.0.0.1", 0))
        s.listen()
        rc, err = run("--lcm", "memq://", "--port", str(s.getsockname()[1]), "-q")
    assert rc == 1 and len(err) == 1 and "cannot serve on 127.0.0.1:" in err[0]
    rc, err = run("--lcm", "memq://", "--port", "0", "--duration", "0.2")
    assert rc == 0 and "serving ws://127.0.0.1:" in err[0] and "received 0 motors" in err[1]


def test_state_estimate_beside_the_camera_pose():
    """A state_t on OMNI4_STATE: its fields, and the estimate as a transform world ->
    robot_estimate and a pose on /omni4/estimate (the camera's stay world -> robot)."""
    m = omni4.state_t()
    m.utime, m.seq, m.pose, m.flags = 123, 7, [1.5, -0.25, 3.0], omni4.state_t.FLAG_SLIP
    out = topics.event_messages(omni4.CHANNEL_STATE, m.encode(), 5_000_000_000,
                                topics.lcm_classes())
    by_topic = {t: (s, json.loads(j)) for t, s, j in out}
    assert set(by_topic) == {omni4.CHANNEL_STATE, topics.TOPIC_TF, topics.TOPIC_ESTIMATE}
    assert by_topic[omni4.CHANNEL_STATE][1]["flags"] == 1
    s, tf = by_topic[topics.TOPIC_TF]
    assert s == "foxglove.FrameTransform" and tf["child_frame_id"] == "robot_estimate"
    assert (tf["translation"]["x"], tf["translation"]["y"]) == (1.5, -0.25)
    assert abs(2 * math.atan2(tf["rotation"]["z"], tf["rotation"]["w"]) - 3.0) < 1e-12
    s, pose = by_topic[topics.TOPIC_ESTIMATE]
    assert s == "foxglove.PoseInFrame" and pose["frame_id"] == "world"
    assert pose["timestamp"] == {"sec": 5, "nsec": 0}


def test_prediction_drives_each_wheel_with_its_own_motor_and_radius():
    """One odd wheel (1: radius +4 %, Kv and Kt +5 %, R -5 %), u = (0, -6, 0, 6) along v: by
    hand, wheel j's force is b_j u_j - e_j v_j (b_j = l Kt_j / (R_j r_j), e_j = l^2 Kt_j Kv_j /
    (R_j r_j^2)); the torque d (f1 + f3) at rest in w stays below Cw (stiction), so w = 0 and
    v settles where 6 (b1 + b3) - (e1 + e3) v = Bv v + Cv."""
    own = {"r_1": 1.04 * T3["r"], "Kv_1": 1.05 * T3["Kv"], "Kt_1": 1.05 * T3["Kt"],
           "R_1": 0.95 * T3["R"]}
    p = {**T3, **own}
    w = {j: {q: p.get(f"{q}_{j}", T3[q]) for q in ("r", "Kv", "Kt", "R")} for j in (1, 3)}
    b = {j: T3["l"] * w[j]["Kt"] / (w[j]["R"] * w[j]["r"]) for j in (1, 3)}
    e = {j: T3["l"] ** 2 * w[j]["Kt"] * w[j]["Kv"] / (w[j]["R"] * w[j]["r"] ** 2) for j in (1, 3)}
    v = (6 * (b[1] + b[3]) - T3["Cv"]) / (e[1] + e[3] + T3["Bv"])
    torque = T3["d"] * (6 * (b[3] - b[1]) + (e[1] - e[3]) * v)
    assert abs(torque) < T3["Cw"]
    u = [0.0, -6.0, 0.0, 6.0]
    per_wheel, scalar = Predictor(p), Predictor(T3)
    for k in range(3001):
        _, pred, _ = per_wheel.step(k * 1000, k, 2, u, [0.0] * 4)
        _, flat, _ = scalar.step(k * 1000, k, 2, u, [0.0] * 4)
    print(f"odd wheel: steady v {pred[0]:.6f} per wheel, {flat[0]:.6f} scalar, by hand {v:.6f}")
    assert pred[0] == pytest.approx(v, rel=1e-4) and pred[2] == pytest.approx(0.0, abs=1e-9)
    assert abs(flat[0] - v) > 10 * 1e-4 * v  # the test tells the two models apart (measured 35x)
    # The encoders: each wheel's angular speed times its own radius.
    meas, _, _ = per_wheel.step(4_000_000, 0, 2, u, [0.0, -0.5 / own["r_1"], 0.0,
                                                     0.5 / T3["r"]])
    assert meas == pytest.approx([0.5, 0.0, 0.0], abs=1e-6)  # float32 speeds: 1.2e-8


def test_adapt_channel_has_its_schema_flags_by_name_and_sigma(tmp_path):
    """OMNI4_ADAPT in the MCAP: one message per adapt_t, schema omni4.adapt_t, the values of
    the log, the flags by name as adapt_t.lcm defines the bits, and each estimate's standard
    deviation the square root of its variance (1e-4 ohm^2: 0.01 ohm)."""
    log, out = str(tmp_path / "a.lcmlog"), str(tmp_path / "a.mcap")
    logged = synth_log(log, n=1500, adapt=True)
    assert export.main([log, "--out", out, "-q"]) == 0
    got, _, _ = read_mcap_python(out)
    rows = got[omni4.CHANNEL_ADAPT]
    assert len(rows) == len(logged[omni4.CHANNEL_ADAPT]) == 15
    for (t, schema, j), (t_us, data) in zip(rows, logged[omni4.CHANNEL_ADAPT]):
        m = omni4.adapt_t.decode(data)
        assert t == t_us * 1000 and schema == "omni4.adapt_t"
        assert j["R"] == list(m.R) and j["R_estimate"] == list(m.R_estimate)
        assert j["R_sigma"] == pytest.approx([0.01] * 4, rel=1e-12)
        assert (j["supply_v"], j["Cv"], j["flags"]) == (12.0, 1.8738, m.flags)
        want = ["ON", "FED"] + (["ADAPTED"] if m.utime >= 1_000_000 else [])   # bits 1, 2, 8
        assert j["flag_names"] == want
    assert topics.event_messages(omni4.CHANNEL_ADAPT, synth_adapt(0, 0).encode(), 0,
                                 topics.lcm_classes())[0][1] == "omni4.adapt_t"


# ---- the scene of another layout (robot_t on OMNI4_ROBOT) ------------------------------------

def _robot_t(angles_deg, d, r):
    m = omni4.robot_t()
    n = len(angles_deg)
    m.wheels, m.l = n, 5.0
    m.wheel_angle = [math.radians(a) for a in angles_deg] + [0.0] * (4 - n)
    m.wheel_distance = [d] * n + [0.0] * (4 - n)
    m.wheel_radius = [r] * n + [0.0] * (4 - n)
    return m


def _layout_log(path, robots, seconds=3):
    """motors_t at 100 Hz for `seconds` s of log time, robot_t (at sample index, message)."""
    log = lcm.EventLog(str(path), "w", overwrite=True)
    t0 = 1_700_000_000_000_000
    for k in range(seconds * 100):
        for at, r in robots:
            if at == k:
                log.write_event(t0 + k * 10000, omni4.CHANNEL_ROBOT, r.encode())
        m = omni4.motors_t()
        m.utime, m.seq, m.mode = t0 + k * 10000, k, 1
        log.write_event(t0 + k * 10000 + 10, omni4.CHANNEL_MOTORS, m.encode())
    log.close()


def _axis(q):
    """Where the quaternion q turns the z axis (the cylinder's axis)."""
    x, y, z, w = q["x"], q["y"], q["z"], q["w"]
    return (2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y))


def _wheels_drawn(scene):
    (ent,) = scene["entities"]
    return [((c["pose"]["position"]["x"], c["pose"]["position"]["y"]),
             _axis(c["pose"]["orientation"]), c["size"]["x"] / 2) for c in ent["cylinders"]]


def test_mcap_scene_draws_three_wheels_at_their_angles_and_distances(tmp_path):
    d, r = 0.12, 0.03
    log, out = tmp_path / "three.lcmlog", str(tmp_path / "three.mcap")
    # robot_t after the first motors samples; the paper's four from 2 s on (a layout change).
    _layout_log(log, [(3, _robot_t((60.0, 180.0, 300.0), d, r)),
                      (200, _robot_t((0.0, 90.0, 180.0, 270.0), T3["d"], T3["r"]))])
    assert export.main([str(log), "--out", out, "-q"]) == 0
    scenes = read_mcap_python(out)[0]["/omni4/scene"]
    t0 = scenes[0][0]
    first = [_wheels_drawn(s) for t, _, s in scenes if t < t0 + 2_000_000_000 - 10_000_000]
    assert len(first) == 2 and all(len(w) == 3 for w in first)
    for (pos, axis, radius), a in zip(first[0], (60.0, 180.0, 300.0)):
        radial = (math.cos(math.radians(a)), math.sin(math.radians(a)))
        assert pos == pytest.approx((d * radial[0], d * radial[1]), abs=1e-12)
        assert axis == pytest.approx((*radial, 0.0), abs=1e-9) and radius == pytest.approx(r)
    later = [_wheels_drawn(s) for t, _, s in scenes if t >= t0 + 2_000_000_000 - 10_000_000]
    assert later and all(len(w) == 4 for w in later)
    assert later[0][1][0] == pytest.approx((0.0, T3["d"]), abs=1e-12)
    # the paper's layout described by a robot_t is drawn exactly as without one
    assert later[-1] == _wheels_drawn(json.loads(topics.scene_json(0, T3["d"], T3["r"])))


def test_mcap_scene_of_a_log_without_robot_t_is_the_papers(tmp_path):
    log, out = tmp_path / "paper.lcmlog", str(tmp_path / "paper.mcap")
    _layout_log(log, [], seconds=1)
    assert export.main([str(log), "--out", out, "-q"]) == 0
    (t, schema, scene), = read_mcap_python(out)[0]["/omni4/scene"]
    assert schema == "foxglove.SceneUpdate"
    drawn = _wheels_drawn(scene)
    d = T3["d"]
    assert [p for p, _, _ in drawn] == [(d, 0.0), (0.0, d), (-d, 0.0), (0.0, -d)]
    axes = [c for _, a, _ in drawn for c in a]
    assert axes == pytest.approx([1, 0, 0, 0, -1, 0, 1, 0, 0, 0, -1, 0], abs=1e-12)
    # byte for byte the scene of the paper's layout as drawn without a robot_t
    assert json.loads(topics.scene_json(t, d, T3["r"])) == scene


def test_bridge_draws_the_latest_robot_t(monkeypatch):
    import foxglove

    from omni4.foxglove.bridge import Bridge
    b = Bridge(T3, 10, 1.0, foxglove.Context())
    logged = []
    monkeypatch.setattr(b.ch, "log", lambda topic, schema, msg, t: logged.append((topic, msg)))
    b.tick(1, False, True)
    assert len(_wheels_drawn(json.loads(logged[-1][1]))) == 4
    b.on_lcm(omni4.CHANNEL_ROBOT, _robot_t((0.0, 120.0, 240.0), 0.1, 0.03).encode())
    b.tick(2, False, True)
    drawn = _wheels_drawn(json.loads(logged[-1][1]))
    assert len(drawn) == 3 and drawn[1][0] == pytest.approx((-0.05, 0.1 * math.sqrt(3) / 2))
    bad = _robot_t((0.0, 120.0, 240.0), 0.1, 0.03)
    bad.wheels = 7                # describes no robot: the last layout stays
    b.on_lcm(omni4.CHANNEL_ROBOT, bad.encode())
    b.tick(3, False, True)
    assert len(_wheels_drawn(json.loads(logged[-1][1]))) == 3


def test_mcap_scene_of_a_log_without_robot_t_takes_the_layout_of_params(tmp_path, capsys):
    log, out, ini = tmp_path / "old.lcmlog", str(tmp_path / "p.mcap"), tmp_path / "three.ini"
    _layout_log(log, [], seconds=1)
    ini.write_text("[model]\nwheels = 3\nwheel_angle_0 = 90\nwheel_angle_1 = 210\n"
                   "wheel_angle_2 = 330\nd_0 = 0.1\nd_1 = 0.1\nd_2 = 0.1\n")
    assert export.main([str(log), "--out", out, "--params", str(ini), "-q"]) == 0
    (_t, _s, scene), = read_mcap_python(out)[0]["/omni4/scene"]
    drawn = _wheels_drawn(scene)
    assert len(drawn) == 3 and drawn[0][0] == pytest.approx((0.0, 0.1), abs=1e-12)
    assert drawn[1][2] == pytest.approx(T3["r"])         # r_j absent: Table III's r
    ini.write_text("[model]\nwheels = 2\n")
    with pytest.raises(SystemExit) as e:
        export.main([str(log), "--out", out, "--params", str(ini), "-q"])
    assert e.value.code == 2
    assert capsys.readouterr().err == f"omni4-mcap: {ini}:2: [model] wheels = 2 (3 or 4 expected)\n"


# ---- the prediction of another layout --------------------------------------------------------

def _three(d=T3["d"], angles=(0.0, 120.0, 240.0)):
    from omni4.wheels import Wheels
    return Wheels([math.radians(a) for a in angles], [d] * len(angles), [T3["r"]] * len(angles))


def test_three_wheel_encoder_velocity_is_the_inverse_of_eq_2():
    """Three wheels at 0/120/240 deg at d, worked out by hand from eq 2's rows [-sin a, cos a,
    d]: v = (s2 - s1) / sqrt(3), vn = (2 s0 - s1 - s2) / 3, w = (s0 + s1 + s2) / (3 d), s_j the
    rim speeds; slot 3 is not a wheel (whatever it holds)."""
    pr = Predictor(T3, wheels=_three())
    rng = random.Random(5)
    for k in range(50):
        w = np.float32([rng.uniform(-40, 40) for _ in range(4)]).tolist()
        meas, _, _ = pr.step(k * 1000, k, 0, [0.0] * 4, w)
        s = [x * T3["r"] for x in w[:3]]
        assert meas[0] == pytest.approx((s[2] - s[1]) / math.sqrt(3), abs=1e-12)
        assert meas[1] == pytest.approx((2 * s[0] - s[1] - s[2]) / 3, abs=1e-12)
        assert meas[2] == pytest.approx(sum(s) / (3 * T3["d"]), abs=1e-12)


@pytest.mark.parametrize("axis,u", [(0, [0.0, -6.0, 6.0, 0.0]), (2, [3.0, 3.0, 3.0, 0.0])])
def test_three_wheel_prediction_is_the_closed_form_of_a_voltage_step(axis, u):
    """Three equal wheels evenly spaced keep eq 23's axes apart. By hand (f_j = b u_j - e s_j,
    b = l Kt / (R r), e = b Kv l / r; rows as above): along v, u = (0, -U, U) pushes
    Fv = sqrt(3) b U against the back-EMF (3/2) e v; about w, u = (U, U, U) turns
    T = 3 d b U against 3 d^2 e w. x' = a x + b' - c sgn(x) from rest."""
    p = T3
    g = p["l"] * p["Kt"] / (p["r"] * p["R"])
    emf = g * p["Kv"] * p["l"] / p["r"]
    if axis == 0:
        a, b, c = -(1.5 * emf + p["Bv"]) / p["M"], math.sqrt(3) * g * u[2] / p["M"], \
            p["Cv"] / p["M"]
    else:
        d = p["d"]
        a, b, c = -(3 * d * d * emf + p["Bw"]) / p["J"], 3 * d * g * u[0] / p["J"], \
            p["Cw"] / p["J"]
    xss = -(b - c) / a
    pr = Predictor(T3, wheels=_three())
    worst = 0.0
    for k in range(2001):
        _, pred, _ = pr.step(k * 1000, k, 2, u, [0.0] * 4)
        worst = max(worst, abs(pred[axis] - xss * (1 - math.exp(a * k * 1e-3))))
        assert all(abs(pred[o]) < 1e-12 * abs(xss) for o in range(3) if o != axis)
    print(f"three wheels, axis {axis}: steady {xss:.6f}, worst error {worst:.3g}")
    assert worst < 1e-9 * abs(xss)
    # the paper's four would drive another speed from these voltages: the test tells them apart
    four = Predictor(T3)
    for k in range(2001):
        _, paper, _ = four.step(k * 1000, k, 2, u, [0.0] * 4)
    assert abs(paper[axis] - xss) > 0.05 * abs(xss)


def test_paper_layout_described_predicts_to_the_bit_as_without_one():
    """The paper's layout as a robot_t describes it (angles in rad, the model's d) keeps the
    closed forms: the same bits as a Predictor without a layout; the paper's angles at another
    distance are another robot."""
    from omni4.wheels import Wheels
    rng = np.random.default_rng(11)
    n = 3000
    ut, sq = np.arange(n, dtype=np.int64) * 1000, np.arange(n, dtype=np.int64)
    md = np.where((np.arange(n) // 500) % 2 == 0, 2, 3).astype(np.int8)
    u = rng.uniform(-8, 8, (n, 4)).astype(np.float32)
    w = rng.uniform(-30, 30, (n, 4)).astype(np.float32)
    described, _ = Wheels.from_robot(_robot_t((0.0, 90.0, 180.0, 270.0), T3["d"], T3["r"]))
    base = Predictor(T3).run(ut, sq, md, u, w)
    same = Predictor(T3, wheels=described).run(ut, sq, md, u, w)
    for x, y in zip(base, same):
        assert np.array_equal(x, y)
    wider = Predictor(T3, wheels=Wheels.paper_layout(d=0.1)).run(ut, sq, md, u, w)
    assert np.abs(wider[0][:, 2] - base[0][:, 2]).max() > 0.1  # w = sum s / (4 d)


def test_a_layout_that_does_not_drive_is_refused():
    from omni4.foxglove import model
    line = _three(angles=(0.0, 180.0, 0.0))   # all rows along one line: v is not driven
    assert not model.layout_drives(line) and model.layout_drives(_three())
    with pytest.raises(ValueError, match="does not drive v, vn and w"):
        Predictor(T3, wheels=line)


def _moving_layout_log(path, robots, n=3000):
    """motors_t at 1 kHz with random voltages and wheel speeds (driven, then coasting every
    other 700 samples), robot_t (at sample index, message). -> the motors arrays."""
    log = lcm.EventLog(str(path), "w", overwrite=True)
    rng = random.Random(9)
    rows = {f: [] for f in ("utime", "seq", "mode", "voltage", "wheel_speed")}
    for k in range(n):
        for at, r in robots:
            if at == k:
                log.write_event(T0_US + k * 1000, omni4.CHANNEL_ROBOT, r.encode())
        m = omni4.motors_t()
        m.utime, m.seq, m.mode = k * 1000, k, 2 if (k // 700) % 2 == 0 else 3
        m.voltage = np.float32([rng.uniform(-12, 12) for _ in range(3)] + [0.0]).tolist()
        m.wheel_speed = np.float32([rng.uniform(-40, 40) for _ in range(4)]).tolist()
        log.write_event(T0_US + k * 1000 + 10, omni4.CHANNEL_MOTORS, m.encode())
        for f in rows:
            rows[f].append(getattr(m, f))
    log.close()
    return {f: np.array(v) for f, v in rows.items()}


def _velocity(out):
    vel = read_mcap_python(out)[0][topics.TOPIC_VELOCITY]
    axes = ("v", "vn", "w")
    return (np.array([[j["encoder"][a] for a in axes] for _, _, j in vel]),
            np.array([[j["predicted"][a] for a in axes] for _, _, j in vel]),
            np.array([j["restarted"] for _, _, j in vel]))


def test_mcap_predicts_the_layout_of_the_logs_robot_t(tmp_path):
    """/omni4/velocity of a log whose robot_t says three wheels (after the first samples) and,
    from sample 2000 on, the paper's four: the three-wheel model from the start (the first
    robot_t's layout, as the scene), the paper's from the change on (restarted there)."""
    log, out = tmp_path / "lay.lcmlog", str(tmp_path / "lay.mcap")
    three = _robot_t((0.0, 120.0, 240.0), T3["d"], T3["r"])
    mot = _moving_layout_log(log, [(3, three), (2000, _robot_t((0.0, 90.0, 180.0, 270.0),
                                                                T3["d"], T3["r"]))])
    assert export.main([str(log), "--out", out, "-q"]) == 0
    enc, prd, rst = _velocity(out)
    args = [mot[f] for f in ("utime", "seq", "mode", "voltage", "wheel_speed")]
    want3 = Predictor(T3, wheels=_three()).run(*[a[:2000] for a in args])
    want4 = Predictor(T3).run(*[a[2000:] for a in args])
    for got, w3, w4 in zip((enc, prd, rst), want3, want4):
        assert np.array_equal(got[:2000], w3) and np.array_equal(got[2000:], w4)
    assert rst[2000] and not rst[1999] and not rst[2001]
    s = mot["wheel_speed"][:2000, :3].astype(np.float64) * T3["r"]   # by hand, as above
    assert enc[:2000, 2] == pytest.approx(s.sum(axis=1) / (3 * T3["d"]), abs=1e-12)


def test_mcap_of_a_log_without_robot_t_predicts_the_layout_of_params(tmp_path):
    log, out, ini = tmp_path / "old.lcmlog", str(tmp_path / "p.mcap"), tmp_path / "three.ini"
    mot = _moving_layout_log(log, [], n=1500)
    ini.write_text("[model]\nwheels = 3\nwheel_angle_0 = 0\nwheel_angle_1 = 120\n"
                   "wheel_angle_2 = 240\n")
    assert export.main([str(log), "--out", out, "--params", str(ini), "-q"]) == 0
    enc, prd, _ = _velocity(out)
    s = mot["wheel_speed"][:, :3].astype(np.float64) * T3["r"]
    assert enc[:, 0] == pytest.approx((s[:, 2] - s[:, 1]) / math.sqrt(3), abs=1e-12)
    want = Predictor(T3, wheels=_three()).run(
        *[mot[f] for f in ("utime", "seq", "mode", "voltage", "wheel_speed")])
    assert np.array_equal(prd, want[1])
    # the same log without --params: the paper's four, as before
    assert export.main([str(log), "--out", out, "-q"]) == 0
    enc4, prd4, _ = _velocity(out)
    base = Predictor(T3).run(*[mot[f] for f in ("utime", "seq", "mode", "voltage",
                                                 "wheel_speed")])
    assert np.array_equal(enc4, base[0]) and np.array_equal(prd4, base[1])


def test_bridge_predicts_the_layout_of_the_latest_robot_t():
    import foxglove

    from omni4.foxglove.bridge import Bridge
    b = Bridge(T3, 1, 1.0, foxglove.Context())
    sent = []
    b.ch.log = lambda topic, schema, msg, t: sent.append((topic, msg))
    m = omni4.motors_t()
    m.mode, m.wheel_speed = 2, [10.0, -20.0, 30.0, 40.0]

    def encoder(seq):
        m.utime, m.seq = seq * 1000, seq
        b.on_lcm(omni4.CHANNEL_MOTORS, m.encode())
        msg = json.loads([x for t, x in sent if t == topics.TOPIC_VELOCITY][-1])
        return [msg["encoder"][a] for a in ("v", "vn", "w")], msg["restarted"]

    s = [x * T3["r"] for x in m.wheel_speed]
    paper = [(s[3] - s[1]) / 2, (s[0] - s[2]) / 2, sum(s) / (4 * T3["d"])]
    three = [(s[2] - s[1]) / math.sqrt(3), (2 * s[0] - s[1] - s[2]) / 3, sum(s[:3]) / (3 * T3["d"])]
    assert encoder(0) == (pytest.approx(paper, abs=1e-12), True)
    assert encoder(1)[1] is False
    b.on_lcm(omni4.CHANNEL_ROBOT, _robot_t((0.0, 120.0, 240.0), T3["d"], T3["r"]).encode())
    assert encoder(2) == (pytest.approx(three, abs=1e-12), True)   # a new robot: restarted
    b.on_lcm(omni4.CHANNEL_ROBOT, _robot_t((0.0, 120.0, 240.0), T3["d"], T3["r"]).encode())
    assert encoder(3)[1] is False                                   # the same robot again
    line = _robot_t((0.0, 180.0, 0.0), T3["d"], T3["r"])           # drives no body: left out
    b.on_lcm(omni4.CHANNEL_ROBOT, line.encode())
    assert encoder(4) == (pytest.approx(three, abs=1e-12), False)


def test_bridge_predicts_the_layout_of_params_before_any_robot_t():
    """--params' [model] layout (params_or_exit's "layout") until a robot_t says otherwise."""
    import foxglove

    from omni4.foxglove.bridge import Bridge
    b = Bridge({**T3, "layout": _three()}, 1, 1.0, foxglove.Context())
    sent = []
    b.ch.log = lambda topic, schema, msg, t: sent.append((topic, msg))
    m = omni4.motors_t()
    m.mode, m.wheel_speed = 2, [10.0, -20.0, 30.0, 0.0]
    b.on_lcm(omni4.CHANNEL_MOTORS, m.encode())
    msg = json.loads([x for t, x in sent if t == topics.TOPIC_VELOCITY][-1])
    s = [x * T3["r"] for x in m.wheel_speed[:3]]
    assert msg["encoder"]["w"] == pytest.approx(sum(s) / (3 * T3["d"]), abs=1e-12)
    assert msg["encoder"]["v"] == pytest.approx((s[2] - s[1]) / math.sqrt(3), abs=1e-12)


def test_params_layout_that_does_not_drive_is_one_line(tmp_path, capsys):
    log, out, ini = tmp_path / "old.lcmlog", str(tmp_path / "p.mcap"), tmp_path / "line.ini"
    _layout_log(log, [], seconds=1)
    ini.write_text("[model]\nwheels = 3\nwheel_angle_0 = 0\nwheel_angle_1 = 180\n"
                   "wheel_angle_2 = 360\n")
    with pytest.raises(SystemExit) as e:
        export.main([str(log), "--out", out, "--params", str(ini), "-q"])
    assert e.value.code == 2 and not os.path.exists(out)
    assert capsys.readouterr().err == (
        f"omni4-mcap: {ini}:2: [model] wheels, wheel_angle_j, d_j: not a layout that drives "
        "v, vn and w (no two wheels along one line)\n")


def test_bridge_says_restarted_on_the_decimated_message_after_a_restart():
    """omni4-bridge sends every N-th sample: a restart of the prediction at a sample it does not
    send (a gap in seq: samples it missed) is said on the next one it sends, and only there."""
    import foxglove

    from omni4.foxglove.bridge import Bridge
    b = Bridge(T3, 10, 1.0, foxglove.Context())
    sent = []
    b.ch.log = lambda topic, schema, msg, t: sent.append((topic, msg))
    m = omni4.motors_t()
    m.mode, m.voltage, m.wheel_speed = 3, [0.0, -6.0, 0.0, 6.0], [0.0] * 4
    for seq in [*range(0, 12), *range(14, 41)]:       # 12 and 13 missed: restarted at 14
        m.utime, m.seq = seq * 1000, seq
        b.on_lcm(omni4.CHANNEL_MOTORS, m.encode())
    said = {j["seq"]: j["restarted"] for j in (json.loads(x) for t, x in sent
                                                if t == topics.TOPIC_VELOCITY)}
    assert said == {0: True, 10: False, 20: True, 30: False, 40: False}
