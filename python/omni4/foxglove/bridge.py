"""omni4-bridge: the robot live in Foxglove. Listens to the OMNI4_* channels on an LCM URL (it
never publishes on LCM, so it cannot slow or steer the robot) and serves them on a Foxglove
WebSocket server (foxglove-sdk) with JSON schemas, plus the encoder velocity, the model's
prediction from the logged voltages and their difference (/omni4/velocity: of the layout of
the latest robot_t, else --params' [model] layout, else the paper's four), health
(/omni4/health), the camera pose as a transform and pose (/tf, /omni4/pose) and the robot's
body and wheels (/omni4/scene: the wheels of the latest robot_t on OMNI4_ROBOT, else the paper's
four; a new robot_t with another layout is drawn from the next scene on). Topics:
omni4/foxglove/topics.py, docs/design.md.

Every motors sample goes through the model (the prediction integrates tick by tick); what is
sent to Foxglove for OMNI4_MOTORS and /omni4/velocity is every N-th sample (--decimate N,
default 10: 100 Hz of a 1 kHz loop), chosen by its sequence number (seq % N == 0), so a sample
lost on the way leaves a gap of N and never shifts the ones after it. Commands, pose and experiment marks are never decimated.
Exit status: 0 after SIGINT/SIGTERM or --duration; 1 run-time error (the WebSocket port is
taken, LCM fails); 2 usage or configuration error (bad arguments, broken INI, bad LCM URL)."""
import argparse
import resource
import signal
import sys
import time

import lcm

import omni4
from omni4._cli import add_lcm_option
from omni4.wheels import Wheels

from . import model, topics
from .model import Predictor

PROG = "omni4-bridge"


def parse_args(argv):
    ap = argparse.ArgumentParser(
        prog=PROG, description="Serve the robot's LCM channels on a Foxglove WebSocket, with "
        "the model's prediction beside the encoders' velocity. Open Foxglove on "
        "ws://HOST:PORT.")
    add_lcm_option(ap, "LCM URL to listen on")
    ap.add_argument("--host", default="127.0.0.1", help="address the WebSocket server binds "
                    "to (default 127.0.0.1, this machine only; 0.0.0.0 for the network)")
    ap.add_argument("--port", type=int, default=8765, help="WebSocket port (default 8765; 0 = "
                    "any free port, printed at start)")
    ap.add_argument("--params", metavar="ROBOT.ini", help="robot INI whose [model] the "
                    "prediction runs, on its wheel layout when no robot_t describes one "
                    "(default: the paper's Table III and four wheels)")
    ap.add_argument("--decimate", type=int, default=10, metavar="N",
                    help="send every N-th motors sample and velocity to Foxglove (default 10; "
                    "1 = all). The model still runs on every sample.")
    ap.add_argument("--health-period", type=float, default=1.0, metavar="S",
                    help="health window [s] (default 1)")
    ap.add_argument("--duration", type=float, default=0.0, metavar="S",
                    help="stop after S seconds (default 0: until SIGINT/SIGTERM)")
    ap.add_argument("-q", "--quiet", action="store_true", help="no start and exit lines")
    a = ap.parse_args(argv)
    if a.decimate < 1:
        ap.error("--decimate must be >= 1")
    if not 0 <= a.port <= 65535:
        ap.error("--port must be 0..65535")
    if not a.health_period > 0 or a.duration < 0:
        ap.error("--health-period must be positive and --duration not negative")
    return a


class Bridge:
    def __init__(self, params, decimate, health_period_s, server_ctx):
        self.params = params
        self.decimate = decimate
        self.health_period_s = health_period_s
        self.pred = Predictor(params)
        self.restarted = False  # the prediction restarted since the last velocity sent
        self.health = topics.Health()
        self.ch = topics.Channels(server_ctx)
        self.received = {}
        self.classes = topics.lcm_classes()
        self.wheels = params.get("layout")  # the robot_t's, else --params'; None: the paper's
        # (the prediction's too: Predictor takes params' "layout")
        # advertised from the start, so a client sees them before the first message
        for topic, schema in (*topics.CHANNEL_SCHEMA.items(), *topics.DERIVED.items()):
            self.ch.get(topic, schema)

    def on_lcm(self, chname, data):
        t_ns = time.time_ns()
        self.received[chname] = self.received.get(chname, 0) + 1
        if chname == omni4.CHANNEL_MOTORS:
            try:
                self.on_motors(omni4.motors_t.decode(data), t_ns)
                return
            except Exception:  # not a motors_t (lcm-gen raises ValueError, struct.error):
                # OMNI4_MOTORS/undecodable, below
                pass
        elif chname == omni4.CHANNEL_ROBOT:
            self.on_robot(data)
        for topic, schema, msg in topics.event_messages(chname, data, t_ns, self.classes):
            self.ch.log(topic, schema, msg, t_ns)

    def on_motors(self, m, t_ns):
        meas, pred, restarted = self.pred.step(m.utime, m.seq, m.mode, m.voltage, m.wheel_speed)
        self.restarted |= restarted
        self.health.add(m.utime, m.seq, m.mode, m.faults)
        if m.seq % self.decimate == 0:
            # (decimated: "restarted" at this sample or at one since the last one sent)
            restarted, self.restarted = self.restarted, False
            self.ch.log(omni4.CHANNEL_MOTORS, "omni4.motors_t",
                        topics.motors_json(m.utime, m.seq, m.mode, m.faults, list(m.voltage),
                                           list(m.current), list(m.wheel_speed)), t_ns)
            self.ch.log(topics.TOPIC_VELOCITY, "omni4.velocity",
                        topics.velocity_json(m.utime, m.seq, m.mode, meas, pred, restarted), t_ns)

    def on_robot(self, data):
        """The latest robot_t's wheels (one that describes no robot, or a layout that does not
        drive v, vn and w, is left out): the scene's, and the prediction's from the next motors
        sample on (a new layout restarts it)."""
        try:
            wheels, _why = Wheels.from_robot(omni4.robot_t.decode(data))
        except Exception:  # another type's payload: shown as undecodable by event_messages
            return
        if wheels is None or not model.layout_drives(wheels):
            return
        self.wheels = wheels
        if not model.same_layout(wheels, self.pred.wheels):
            self.pred = Predictor(self.params, wheels=wheels)

    def tick(self, t_ns, health_due, scene_due):
        if health_due and self.health.n:
            self.ch.log(topics.TOPIC_HEALTH, "omni4.health",
                        self.health.report(self.health_period_s), t_ns)
        if scene_due:
            self.ch.log(topics.TOPIC_SCENE, "foxglove.SceneUpdate",
                        topics.scene_json(t_ns, self.params["d"], self.params["r"], self.wheels),
                        t_ns)


def _pump(lc, bridge, a, stop, t_start):
    """LCM into the bridge until stop fills or --duration [s] has passed; health and the scene
    on their periods."""
    next_health = t_start + a.health_period
    next_scene = t_start
    interrupted = 0
    while not stop:
        now = time.monotonic()
        if a.duration and now - t_start >= a.duration:
            break
        try:
            lc.handle_timeout(50)  # [ms]: bounded, so signals and timers are served
            interrupted = 0
        except OSError:
            # select() inside was interrupted by a signal (SIGINT/SIGTERM: its handler runs
            # right after this, and the loop ends); an error that repeats is real.
            interrupted += 1
            if interrupted > 3:
                raise
            continue
        now = time.monotonic()
        h, s = now >= next_health, now >= next_scene
        if h or s:
            bridge.tick(time.time_ns(), h, s)
            if h:
                next_health += a.health_period * max(1, int((now - next_health) //
                                                            a.health_period) + 1)
            if s:
                next_scene = now + 1.0


def _summary(bridge, wall_s, cpu_s):
    rx = bridge.received.get(omni4.CHANNEL_MOTORS, 0)
    print(f"{PROG}: {wall_s:.1f} s: received {rx} motors samples ({rx / wall_s:.0f} Hz), "
          f"{sum(bridge.received.values())} LCM messages; sent "
          f"{bridge.ch.counts[omni4.CHANNEL_MOTORS]} motors, "
          f"{bridge.ch.counts[topics.TOPIC_VELOCITY]} velocity; "
          f"CPU {100 * cpu_s / wall_s:.1f} %", file=sys.stderr)


def _cpu_s():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def main(argv=None):
    a = parse_args(sys.argv[1:] if argv is None else argv)
    params = model.params_or_exit(PROG, a.params)
    try:
        lc = lcm.LCM(a.lcm)
    except Exception as e:  # lcm raises RuntimeError on a URL it cannot use
        print(f"{PROG}: --lcm {a.lcm}: {e}", file=sys.stderr)
        return 2
    import foxglove
    ctx = foxglove.Context()
    try:
        server = foxglove.start_server(name="omni4", host=a.host, port=a.port, context=ctx)
    except Exception as e:
        print(f"{PROG}: cannot serve on {a.host}:{a.port}: {e}", file=sys.stderr)
        return 1
    bridge = Bridge(params, a.decimate, a.health_period, ctx)
    sub = lc.subscribe("OMNI4_.*", bridge.on_lcm)
    sub.set_queue_capacity(100000)  # LCM's default 30 would drop samples on a busy CPU
    stop = []
    signal.signal(signal.SIGINT, lambda *_: stop.append(1))
    signal.signal(signal.SIGTERM, lambda *_: stop.append(1))
    if not a.quiet:
        print(f"{PROG}: serving ws://{a.host}:{server.port} (Foxglove) from {a.lcm}; "
              f"motors sent 1 in {a.decimate}", file=sys.stderr, flush=True)
    t_start, cpu0, rc = time.monotonic(), _cpu_s(), 0
    try:
        _pump(lc, bridge, a, stop, t_start)
    except Exception as e:
        print(f"{PROG}: {type(e).__name__}: {e}", file=sys.stderr)
        rc = 1
    finally:
        lc.unsubscribe(sub)
        server.stop()
    if not a.quiet:
        _summary(bridge, time.monotonic() - t_start, _cpu_s() - cpu0)
    return rc


if __name__ == "__main__":
    sys.exit(main())
