"""omni4-bridge live: omni4-fw (sim backend) on a udpm URL of its own, omni4-bridge on a free
WebSocket port, this test as the operator (VOLTAGE step along v over LCM) and as a Foxglove
client (websockets; subprotocol foxglove.sdk.v1, the foxglove.websocket.v1 protocol's present
name). The motors, pose and velocity messages the bridge sends equal the LCM messages this test
receives itself; the encoder velocity is eqs 3-5 and the prediction the closed form of the step
from the run's first sample. The step lasts STEP_TICKS ticks of the controller and the test
waits for the bridge's health windows: counted, never timed, so a loaded machine that makes the
loop skip ticks only makes the test longer."""
import json
import math
import os
import re
import socket
import struct
import subprocess
import sys
import threading
import time

import lcm
import numpy as np
import pytest
from conftest import lcm_test_url

import omni4
from omni4.foxglove import topics

from test_foxglove_model import T3, closed_form_axis

pytestmark = pytest.mark.live
SCALE = float(os.environ.get("OMNI4_TEST_TIME_SCALE", "1"))
STEP_U = [0.0, -6.0, 0.0, 6.0]  # [V]: +v (Fv = f3 - f1)
DECIMATE = 10
STEP_TICKS = 1500               # the step's length in the controller's ticks (1.5 s at 1 kHz)
WAIT_S = 30 * max(1.0, SCALE)   # failure bound of the waits for ticks and health windows


def bindir():
    b = os.environ.get("OMNI4_BIN")
    assert b and os.path.isdir(b), "OMNI4_BIN must name the build's bin/ (set by CTest)"
    return b


class LcmSide:
    """This test's own LCM subscriber (the reference) and command publisher."""

    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.motors = {}   # seq -> motors_t
        self.poses = {}    # utime -> pose_t
        self.lock = threading.Lock()
        s1 = self.lc.subscribe(omni4.CHANNEL_MOTORS, self._m)
        s2 = self.lc.subscribe(omni4.CHANNEL_POSE, self._p)
        s1.set_queue_capacity(100000)
        s2.set_queue_capacity(100000)
        self.stop = False
        self.th = threading.Thread(target=self._run, daemon=True)
        self.th.start()

    def _m(self, ch, data):
        m = omni4.motors_t.decode(data)
        with self.lock:
            self.motors[m.seq] = m

    def _p(self, ch, data):
        p = omni4.pose_t.decode(data)
        with self.lock:
            self.poses[p.utime] = p

    def _run(self):
        while not self.stop:
            self.lc.handle_timeout(50)

    def ticks_in(self, mode):
        with self.lock:
            return sum(1 for m in self.motors.values() if m.mode == mode)

    def command(self, mode, voltage=(0.0,) * 4, seq=0):
        c = omni4.command_t()
        c.utime, c.seq, c.mode = int(time.time() * 1e6), seq, mode
        c.velocity, c.voltage, c.ramp_s = [0.0] * 3, list(voltage), 0.0
        self.lc.publish(omni4.CHANNEL_CMD, c.encode())


def start(cmd, what):
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True), what


def stop(proc, what, timeout=10):
    if proc.poll() is None:
        proc.send_signal(2)
    try:
        out, err = proc.communicate(timeout=timeout * SCALE)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate(timeout=5)
        pytest.fail(f"{what} did not stop within {timeout * SCALE:.0f} s of SIGINT")
    return proc.returncode, err


def read_port(proc, timeout):
    """The port omni4-bridge prints on its first stderr line."""
    box = []

    def rd():
        box.append(proc.stderr.readline())
    th = threading.Thread(target=rd, daemon=True)
    th.start()
    th.join(timeout * SCALE)
    assert box and box[0], (f"omni4-bridge printed no start line within {timeout * SCALE:.0f} s"
                            f" (exit status {proc.poll()})")
    m = re.search(r"ws://127\.0\.0\.1:(\d+)", box[0])
    assert m, box[0]
    return int(m.group(1))


class FoxgloveClient:
    """A minimal Foxglove WebSocket protocol client. foxglove-sdk 0.30 accepts the protocol
    under its present name, foxglove.sdk.v1 (the foxglove.websocket.v1 messages, renamed); the
    client offers both, as the Foxglove app does."""

    def __init__(self, port, timeout):
        from websockets.sync.client import connect
        self._conn = connect(f"ws://127.0.0.1:{port}",
                             subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                             open_timeout=timeout * SCALE, max_size=None, proxy=None)
        self.ws = self._conn.__enter__()
        assert self.ws.subprotocol == "foxglove.sdk.v1"
        self.channels = {}   # topic -> advertised channel
        self.by_sub = {}     # subscription id -> topic
        self.msgs = {}       # topic -> [(recv time ns, json)]

    def close(self):
        self._conn.__exit__(None, None, None)

    def wait_advertised(self, topics_, timeout):
        end = time.monotonic() + timeout * SCALE
        while not all(t in self.channels for t in topics_):
            left = end - time.monotonic()
            assert left > 0, (f"not advertised within {timeout * SCALE:.0f} s: "
                              f"{sorted(set(topics_) - set(self.channels))}")
            self._recv(left)

    def subscribe(self, topics_):
        subs = []
        for i, t in enumerate(topics_, 1):
            self.by_sub[i] = t
            subs.append({"id": i, "channelId": self.channels[t]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def _recv(self, timeout):
        try:
            m = self.ws.recv(timeout=max(0.01, timeout))
        except TimeoutError:
            return
        if isinstance(m, str):
            j = json.loads(m)
            if j.get("op") == "advertise":
                for ch in j["channels"]:
                    self.channels[ch["topic"]] = ch
        elif m[0] == 0x01:  # MessageData: op, subscription id u32, log time u64, payload
            sid, t = struct.unpack_from("<IQ", m, 1)
            self.msgs.setdefault(self.by_sub[sid], []).append((t, json.loads(m[13:])))

    def collect(self, seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self._recv(end - time.monotonic())


free_udp_url = lcm_test_url


def test_bridge_serves_motors_pose_and_prediction(tmp_path):
    url = free_udp_url()
    ini = tmp_path / "robot.ini"
    ini.write_text(f"[lcm]\nurl = {url}\n[hal]\nmotor = sim\n[control]\ncmd_timeout_ms = 300\n")
    side = LcmSide(url)
    fw, _ = start([os.path.join(bindir(), "omni4-fw"), "--config", str(ini), "--duration",
                   str(40 * SCALE), "-q"], "omni4-fw")
    br, _ = start([os.path.join(os.path.dirname(sys.executable), "omni4-bridge"), "--lcm", url,
                   "--port", "0", "--decimate", str(DECIMATE), "--params", str(ini)],
                  "omni4-bridge")
    try:
        port = read_port(br, 20)
        cl = FoxgloveClient(port, 10)
        want = [omni4.CHANNEL_MOTORS, omni4.CHANNEL_POSE, topics.TOPIC_VELOCITY, topics.TOPIC_TF,
                topics.TOPIC_HEALTH, topics.TOPIC_SCENE, topics.TOPIC_ESTIMATE,
                omni4.CHANNEL_ADAPT]
        cl.wait_advertised(want, 10)
        assert cl.channels[omni4.CHANNEL_MOTORS]["schemaName"] == "omni4.motors_t"
        assert cl.channels[omni4.CHANNEL_ADAPT]["schemaName"] == "omni4.adapt_t"
        assert cl.channels[topics.TOPIC_TF]["schemaName"] == "foxglove.FrameTransform"
        assert cl.channels[omni4.CHANNEL_MOTORS]["encoding"] == "json"
        cl.subscribe(want)
        cl.collect(0.5)                        # at rest, IDLE
        t_end = time.monotonic() + WAIT_S      # the step along v, kept alive at 50 Hz
        k = 0
        while side.ticks_in(omni4.motors_t.MODE_VOLTAGE) < STEP_TICKS:
            assert time.monotonic() < t_end, f"{STEP_TICKS} VOLTAGE ticks not in {WAIT_S} s"
            side.command(omni4.command_t.MODE_VOLTAGE, STEP_U, k)
            k += 1
            cl.collect(0.02)
        side.command(omni4.command_t.MODE_IDLE, seq=k)
        n_health = len(cl.msgs.get(topics.TOPIC_HEALTH, []))
        t_end = time.monotonic() + WAIT_S      # the coast-down and two more health windows
        while len(cl.msgs.get(topics.TOPIC_HEALTH, [])) < n_health + 2:
            assert time.monotonic() < t_end, f"no health window in {WAIT_S} s"
            cl.collect(0.1)
        cl.close()
    finally:
        rc_br, err_br = stop(br, "omni4-bridge")
        rc_fw, _ = stop(fw, "omni4-fw")
        side.stop = True
        side.th.join(2)
    assert rc_br == 0, err_br
    print(err_br.strip())
    with side.lock:
        motors = dict(side.motors)
        poses = dict(side.poses)

    # the controller's adapt_t at 10 Hz, not decimated: its flags by name ([adapt] on by default)
    ad = [j for _, j in cl.msgs.get(omni4.CHANNEL_ADAPT, [])]
    assert len(ad) >= 5, len(ad)
    assert all(j["flag_names"][0] == "ON" and len(j["R_sigma"]) == 4 for j in ad), ad[-1]

    # motors: every 10th sample, equal to what LCM carried
    bm = [j for _, j in cl.msgs[omni4.CHANNEL_MOTORS]]
    # (counts: the step's STEP_TICKS ticks alone give 150 decimated samples)
    assert len(bm) >= 150, len(bm)
    seqs = [j["seq"] for j in bm]
    assert all(s % DECIMATE == 0 for s in seqs), "decimation: not every N-th sequence number"
    # a decimated sample lost on the way (UDP on a loaded machine) leaves a gap of a multiple of
    # N; each such gap must be among the samples the bridge's health counted as dropped
    h = [j for _, j in cl.msgs[topics.TOPIC_HEALTH]]
    assert h, "no health message"
    gaps = [b - a for a, b in zip(seqs, seqs[1:])]
    assert all(g > 0 and g % DECIMATE == 0 for g in gaps), gaps
    # (the gaps the last health window covers: samples the bridge logged before it)
    t_last = cl.msgs[topics.TOPIC_HEALTH][-1][0]
    logged = [j["seq"] for t, j in cl.msgs[omni4.CHANNEL_MOTORS] if t <= t_last]
    missing = sum((b - a) // DECIMATE - 1 for a, b in zip(logged, logged[1:]))
    seen = sum(x["dropped"] for x in h)
    print(f"decimated samples missing: {missing}; dropped (health windows seen): {seen}")
    assert missing <= seen <= h[-1]["dropped_total"], "a gap in the stream the health missed"
    for j in bm:
        m = motors.get(j["seq"])
        if m is None:
            continue
        assert (j["utime"], j["mode"], j["faults"]) == (m.utime, m.mode, m.faults)
        assert j["mode_name"] == topics.MODE_NAMES[m.mode]
        assert j["fault_names"] == topics.fault_names(m.faults)
        for f in ("voltage", "current", "wheel_speed"):
            assert np.float32(j[f]).tolist() == list(getattr(m, f))
    matched = sum(j["seq"] in motors for j in bm)
    print(f"bridge motors: {len(bm)}, {matched} also received here")
    assert matched >= 100       # (this process's own subscriber may miss a few on a busy machine)
    # pose: equal to LCM's, and as a Foxglove transform world -> robot
    bp = [j for _, j in cl.msgs[omni4.CHANNEL_POSE]]
    assert len(bp) >= 25        # the camera's poses over >= 2.5 s of ticks
    for j in bp:
        p = poses.get(j["utime"])
        if p is not None:
            assert (j["x"], j["y"], j["theta"]) == (p.x, p.y, p.theta)
    assert sum(j["utime"] in poses for j in bp) >= 20
    # /tf: the camera's pose (world -> robot) and the controller's estimate (-> robot_estimate)
    tf = [j for _, j in cl.msgs[topics.TOPIC_TF] if j["child_frame_id"] == "robot"]
    est = [j for _, j in cl.msgs[topics.TOPIC_TF] if j["child_frame_id"] == "robot_estimate"]
    assert est and len(est) - 1 <= len(cl.msgs[topics.TOPIC_ESTIMATE]) <= len(est)  # as above
    assert len(bp) - 1 <= len(tf) <= len(bp)  # the collection may stop between the two
    for j, p in zip(tf, bp):
        assert (j["translation"]["x"], j["translation"]["y"]) == (p["x"], p["y"])
        assert j["parent_frame_id"] == "world" and j["child_frame_id"] == "robot"
    # velocity: the encoders (eqs 3-5) and the model's prediction of the step
    drive = sorted(s for s, m in motors.items() if m.mode == omni4.motors_t.MODE_VOLTAGE)
    assert drive, "the controller never entered VOLTAGE mode"
    s0 = drive[0]
    m0 = motors[s0]
    assert motors[s0 - 1].mode == omni4.motors_t.MODE_IDLE
    a, b, c = closed_form_axis(T3, STEP_U, 0)
    xss = -(b - c) / a
    r = T3["r"]

    def enc(m):
        vw = [x * r for x in m.wheel_speed]
        return [(vw[3] - vw[1]) / 2, (vw[0] - vw[2]) / 2, sum(vw) / (4 * T3["d"])]

    # the documented restarts inside the drive: a tick more than 50 ms after the previous one
    # (a stalled loop on a busy machine); the prediction starts again from the encoders there.
    # The bridge restarts it too where it missed samples (a gap in seq, UDP on a loaded
    # machine): its decimated message says "restarted" on the first one sent since; where in
    # that span is found by the closed form (to 1e-9 from exactly one sample's encoders)
    restarts = [s0] + [s for s in drive if s > s0 and motors.get(s - 1)
                       and motors[s].utime - motors[s - 1].utime > 50_000]

    def closed_form(r0, m):
        t = (m.utime - r0.utime) * 1e-6
        return xss + (enc(r0)[0] - xss) * math.exp(a * t)

    def stepping(seq):
        return s0 < seq <= drive[-1] and motors[seq].mode == omni4.motors_t.MODE_VOLTAGE and \
            all(motors.get(s) and list(motors[s].voltage) == STEP_U for s in range(s0, seq))

    checked = 0
    worst = 0.0
    r0 = None
    prev = None
    unexplained = 0     # restarts said where no documented one is: samples the bridge missed
    for _, j in cl.msgs[topics.TOPIC_VELOCITY]:
        seq = j["seq"]
        since = range(seq if prev is None else prev + 1, seq + 1)
        prev = seq
        documented = [s for s in restarts if s in since]
        assert not documented or j["restarted"], f"a restart at {documented} not said by {seq}"
        if documented:
            r0 = motors[documented[-1]]
        m = motors.get(seq)
        if m is None:
            continue
        assert [j["encoder"][x] for x in ("v", "vn", "w")] == pytest.approx(enc(m), abs=1e-9)
        if j["restarted"] and not documented and stepping(seq):
            unexplained += 1
            found = [motors[s] for s in since if s in motors
                     and abs(j["predicted"]["v"] - closed_form(motors[s], m)) < 1e-9]
            r0 = found[-1] if len(found) == 1 else None     # (None: not received here)
        if r0 is not None and stepping(seq):
            worst = max(worst, abs(j["predicted"]["v"] - closed_form(r0, m)))
            assert j["predicted"]["vn"] == 0.0 and j["predicted"]["w"] == 0.0
            for x in ("v", "vn", "w"):
                assert j["difference"][x] == pytest.approx(j["encoder"][x] - j["predicted"][x],
                                                           abs=1e-12)
            checked += 1
    print(f"restarts said beside the stalls: {unexplained} (samples the bridge missed: "
          f"{h[-1]['dropped_total']})")
    assert unexplained <= h[-1]["dropped_total"]
    print(f"prediction vs closed form over {checked} samples of the step: max |dv| {worst:.2e}"
          f" m/s (v reached {max(enc(motors[s])[0] for s in drive):.3f} m/s)")
    # (checked: the step's samples whose every tick this process received; a few missed ticks
    # on a busy machine shorten that run)
    assert checked >= 20 and worst < 1e-9
    # health: the loop at 1 kHz; what was lost between fw and bridge is counted (above)
    full = [x for x in h if x["samples"] > 100]
    # 777-994 Hz measured on this 2-core machine under load (omni4-fw without SCHED_FIFO wakes
    # late, up to 38 late ticks a second, and skips ticks): fewer ticks. The rate is the
    # controller's clock's: never above 1 kHz (no tick before its deadline), any lower figure
    # is the machine's. Samples lost on UDP (none on a quiet machine; a few under the sanitizer
    # presets beside other tests) are the machine's too: counted (above).
    print("health (rate Hz, late ticks, dropped):",
          [(round(x["loop_rate_hz"]), x["late_ticks"], x["dropped"]) for x in h])
    assert full and all(0 < x["loop_rate_hz"] < 1005 for x in full)
    assert cl.msgs.get(topics.TOPIC_SCENE)
