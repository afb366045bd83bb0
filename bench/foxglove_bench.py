"""Foxglove figures for bench/run, each beside a peer measured in the same run.

bridge BIN SECONDS [DECIMATE]: omni4-fw (sim backend, 1 kHz, udpm) for SECONDS; omni4-bridge (--decimate 10)
  with a Foxglove WebSocket client subscribed to every topic, and beside it a bare LCM subscriber
  (Python, motors_t.decode of every OMNI4_MOTORS message, nothing else). Prints the CPU % of
  each (user + sys from /proc over the same window) and the rates delivered.
mcap LOG REPS: omni4-mcap on LOG, REPS times, beside a plain converter written the obvious way
  (lcm.EventLog, the generated decoder, json.dumps, the mcap library's Writer with zstd chunks; no
  derived topics), interleaved. Prints wall times per minute of log."""
import base64
import json
import os
import random
import re
import subprocess
import sys
import tempfile
import threading
import time

HZ = os.sysconf("SC_CLK_TCK")


def cpu_s(pid):
    with open(f"/proc/{pid}/stat") as fh:
        f = fh.read().rsplit(")", 1)[1].split()
    return (int(f[11]) + int(f[12])) / HZ  # utime + stime [s]


PEER = r'''
import sys, time, lcm, omni4
lc = lcm.LCM(sys.argv[1]); n = [0]
def h(ch, data):
    omni4.motors_t.decode(data); n[0] += 1
s = lc.subscribe("OMNI4_MOTORS", h); s.set_queue_capacity(100000)
end = time.monotonic() + float(sys.argv[2])
while time.monotonic() < end:
    lc.handle_timeout(50)
print(n[0], flush=True)
'''


def _count_messages(ws, counts, by_sub, stop):
    """The bridge's client side until stop[0]: subscribes to every channel advertised, counts
    the messages per topic."""
    while not stop[0]:
        try:
            m = ws.recv(timeout=0.2)
        except TimeoutError:
            continue
        except Exception:
            return
        if isinstance(m, str):
            j = json.loads(m)
            if j.get("op") == "advertise":
                subs = []
                for c in j["channels"]:
                    sid = len(by_sub) + 1
                    by_sub[sid] = c["topic"]
                    subs.append({"id": sid, "channelId": c["id"]})
                ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))
        elif m[0] == 1:
            t = by_sub[int.from_bytes(m[1:5], "little")]
            counts[t] = counts.get(t, 0) + 1


def bridge(bindir, seconds, decimate=10):
    from websockets.sync.client import connect
    url = f"udpm://239.255.76.67:{random.randint(7900, 8400)}?ttl=0"
    venv = os.path.dirname(sys.executable)
    with tempfile.TemporaryDirectory() as d:
        ini = os.path.join(d, "fw.ini")
        with open(ini, "w") as fh:
            fh.write(f"[lcm]\nurl = {url}\n[hal]\nmotor = sim\n")
        fw = subprocess.Popen([os.path.join(bindir, "omni4-fw"), "--config", ini, "--duration",
                               str(seconds + 6), "-q"], stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
        br = subprocess.Popen([os.path.join(venv, "omni4-bridge"), "--lcm", url, "--port", "0",
                               "--decimate", str(decimate)], stderr=subprocess.PIPE, text=True)
        peer = subprocess.Popen([sys.executable, "-c", PEER, url, str(seconds + 2)],
                                stdout=subprocess.PIPE, text=True)
        line = br.stderr.readline()
        port = int(re.search(r":(\d+) \(Foxglove\)", line).group(1))
        ws = connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1"],
                     open_timeout=10, proxy=None).__enter__()
        chans, counts, by_sub = {}, {}, {}
        stop = [False]

        th = threading.Thread(target=_count_messages, args=(ws, counts, by_sub, stop),
                              daemon=True)
        th.start()
        time.sleep(1.0)  # settle
        c0 = dict(counts)
        b0, p0, t0 = cpu_s(br.pid), cpu_s(peer.pid), time.monotonic()
        time.sleep(seconds)
        b1, p1, t1 = cpu_s(br.pid), cpu_s(peer.pid), time.monotonic()
        c1 = dict(counts)
        stop[0] = True
        th.join(2)
        ws.close()
        br.send_signal(2)
        err = br.communicate(timeout=10)[1]
        n_peer = int(peer.communicate(timeout=10)[0].strip() or 0)
        fw.send_signal(2)
        fw.wait(timeout=10)
    wall = t1 - t0
    rx_hz = int(re.search(r"\((\d+) Hz\)", err).group(1))
    mot = (c1.get("OMNI4_MOTORS", 0) - c0.get("OMNI4_MOTORS", 0)) / wall
    vel = (c1.get("/omni4/velocity", 0) - c0.get("/omni4/velocity", 0)) / wall
    print(f"bridge (decimate {decimate}) cpu {100 * (b1 - b0) / wall:.1f} % received {rx_hz} Hz sent motors "
          f"{mot:.0f} Hz velocity {vel:.0f} Hz; peer cpu {100 * (p1 - p0) / wall:.1f} % "
          f"received {n_peer / (seconds + 2):.0f} Hz")


def naive_convert(log, out):
    import lcm
    import omni4
    from mcap.writer import CompressionType, Writer
    with open(out, "wb") as fh:
        w = Writer(fh, compression=CompressionType.ZSTD)
        w.start()
        chans = {}
        for ev in lcm.EventLog(log, "r"):
            cls = omni4.TYPES.get(ev.channel)
            if ev.channel not in chans:
                sid = w.register_schema(ev.channel, "jsonschema", b'{"type":"object"}')
                chans[ev.channel] = w.register_channel(ev.channel, "json", sid)
            if cls is None:  # a channel without an omni4 type (OMNI4_PARAM_CHANGED): raw bytes
                d = {"data_base64": base64.b64encode(ev.data).decode()}
            else:
                m = cls.decode(ev.data)
                d = {k: (list(v) if isinstance(v, (list, tuple)) else v)
                     for k, v in ((k, getattr(m, k)) for k in m.__slots__)}
            w.add_message(chans[ev.channel], ev.timestamp * 1000, json.dumps(d).encode(),
                          ev.timestamp * 1000)
        w.finish()


def mcap(log, reps):
    import lcm
    first = last = None
    for e in lcm.EventLog(log, "r"):
        first = first or e.timestamp
        last = e.timestamp
    minutes = (last - first) * 1e-6 / 60
    venv = os.path.dirname(sys.executable)
    ours, peer, cpu = [], [], []
    with tempfile.TemporaryDirectory() as d:
        for i in range(reps):
            r0 = os.times()
            t = time.perf_counter()
            subprocess.run([os.path.join(venv, "omni4-mcap"), log, "--out",
                            os.path.join(d, "o.mcap"), "-q"], check=True, timeout=300)
            ours.append((time.perf_counter() - t) / minutes)
            r1 = os.times()
            cpu.append((r1.children_user - r0.children_user + r1.children_system -
                        r0.children_system) / minutes)
            if i < max(1, reps // 3):
                t = time.perf_counter()
                naive_convert(log, os.path.join(d, "n.mcap"))
                peer.append((time.perf_counter() - t) / minutes)
    med = lambda x: sorted(x)[len(x) // 2]  # noqa: E731
    print(f"mcap {minutes:.2f} min: s per minute of log min/med/max {min(ours):.2f}/"
          f"{med(ours):.2f}/{max(ours):.2f} cpu {med(cpu):.2f}; peer {med(peer):.2f}")


if __name__ == "__main__":
    if sys.argv[1] == "bridge":
        bridge(sys.argv[2], float(sys.argv[3]), int(sys.argv[4]) if len(sys.argv) > 4 else 10)
    else:
        mcap(sys.argv[2], int(sys.argv[3]))
