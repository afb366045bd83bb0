#!/usr/bin/env python3
"""ros_latency: /cmd_vel publish -> HAL write through omni4-ros, beside OMNI4_CMD publish -> HAL
write (the LCM path of bench/cmd_latency.c) in the same run, and omni4-ros's CPU with OMNI4_MOTORS
coming in at 1 kHz.

    .venv/bin/python bench/ros_latency.py [--bin build/bin] [--trials 100] [--cpu-s 10]

omni4-fw runs on the sim backend (udpm, ttl=0, a random port in 10000-10999), omni4-ros beside
it (Fast DDS, localhost discovery, a random ROS_DOMAIN_ID; --fresh 0.05 --stop-hold 0 so that it
returns the robot to IDLE ~0.1 s after a /cmd_vel), and this process publishes both ways.

HAL write: each trial starts in IDLE and sends one VELOCITY command (a Twist on /cmd_vel, or a
command_t on OMNI4_CMD); the tick that takes it writes the bridges' voltages to the HAL and its
motors_t is the first in MODE_VELOCITY. Latency = that sample's utime (the tick's time; the
controller's clock is the system clock, as time.time() here) - the publish time. The paths
alternate trial by trial, at random moments within the 1 ms loop period. `echo` is the same
command's return to this process as a motors_t (adds the logger's publish and LCM's delivery).
ROS -> LCM hop: /cmd_vel publish -> the command_t omni4-ros sends, received here.

CPU: omni4-ros's user + system time (/proc/PID/stat) over --cpu-s seconds at rest (1 kHz of
OMNI4_MOTORS decoded, odometry integrated, /odom and /joint_states at 50 Hz) and while a
/cmd_vel comes at 20 Hz, as % of one core.
"""
import argparse
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time

import lcm

import omni4

VELOCITY = omni4.command_t.MODE_VELOCITY
IDLE = omni4.command_t.MODE_IDLE


def pct(xs, q):
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(q / 100 * (len(xs) - 1))))]


class Watch:
    def __init__(self, url):
        self.lc = lcm.LCM(url)
        self.cond = threading.Condition()
        self.last = None
        self.cmds = []
        s = self.lc.subscribe(omni4.CHANNEL_MOTORS, self._motors)
        s.set_queue_capacity(10000)
        self.lc.subscribe(omni4.CHANNEL_CMD, self._cmd)
        self.stop = threading.Event()
        threading.Thread(target=self._loop, daemon=True).start()

    def _loop(self):
        while not self.stop.is_set():
            self.lc.handle_timeout(50)

    def _motors(self, _c, data):
        m = omni4.motors_t.decode(data)
        with self.cond:
            self.last = (time.time(), m)
            self.cond.notify_all()

    def _cmd(self, _c, data):
        m = omni4.command_t.decode(data)
        with self.cond:
            self.cmds.append((time.monotonic(), m))
            self.cond.notify_all()

    def wait_mode(self, mode, after_us, timeout_s=2.0):
        """(arrival time [s], motors_t) of the first sample in `mode` with utime >= after_us."""
        end = time.monotonic() + timeout_s
        with self.cond:
            while True:
                if self.last and self.last[1].mode == mode and self.last[1].utime >= after_us:
                    return self.last
                left = end - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no sample in mode {mode} within {timeout_s} s")
                self.cond.wait(left)

    def first_mode_since(self, mode, after_us, timeout_s=2.0):
        """The first sample in `mode` at or after after_us: samples are watched one by one."""
        return self.wait_mode(mode, after_us, timeout_s)


def cpu_s(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def start(bindir):
    """omni4-fw on the sim backend and omni4-ros beside it, on a random LCM port and ROS domain:
    (url, fw, node)."""
    port = random.randint(10000, 10999)
    url = f"udpm://239.255.76.67:{port}?ttl=0"
    os.environ["ROS_DOMAIN_ID"] = str(random.randint(1, 100))
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    tmp = tempfile.mkdtemp(prefix="ros_latency.")
    ini = os.path.join(tmp, "robot.ini")
    with open(ini, "w") as f:
        f.write(f"[lcm]\nurl = {url}\n[hal]\nmotor = sim\n")
    fw = subprocess.Popen([os.path.join(bindir, "omni4-fw"), "--config", ini, "-q"],
                          stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    ros_exe = os.path.join(os.path.dirname(sys.executable), "omni4-ros")
    node = subprocess.Popen([ros_exe, "--lcm", url, "--fresh", "0.05", "--stop-hold", "0"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
    return url, fw, node


def twist(vx):
    from geometry_msgs.msg import Twist
    t = Twist()
    t.linear.x = vx
    return t


def wait_ready(pub, w):
    """omni4-ros up: its subscription matched and its limits read (a /cmd_vel is taken)."""
    w.wait_mode(IDLE, 0, timeout_s=10)
    end = time.monotonic() + 20
    while True:
        pub.publish(twist(0.01))
        try:
            w.wait_mode(VELOCITY, 0, timeout_s=0.3)
            break
        except TimeoutError:
            if time.monotonic() > end:
                raise SystemExit("ros_latency: omni4-ros takes no /cmd_vel within 20 s")
    w.wait_mode(IDLE, int(time.time() * 1e6), timeout_s=3)


def trial(path, pub, w, lcm_cmd, lat, echo, hop):
    """One VELOCITY command by `path` ("ros" or "lcm") from IDLE, back to IDLE."""
    time.sleep(random.uniform(0.02, 0.05))
    v = round(random.uniform(0.01, 0.05), 4)
    with w.cond:
        n_cmds = len(w.cmds)
    t_pub_mono = time.monotonic()
    t_pub_us = int(time.time() * 1e6)
    if path == "ros":
        pub.publish(twist(v))
    else:
        lcm_cmd(VELOCITY, v)
    arr, m = w.first_mode_since(VELOCITY, t_pub_us - 1000)
    lat[path].append((m.utime - t_pub_us) * 1e-6)
    echo[path].append(arr - t_pub_us * 1e-6)
    if path == "ros":
        with w.cond:
            got = [tm for tm, c in w.cmds[n_cmds:] if c.mode == VELOCITY and
                   abs(c.velocity[0] - v) < 1e-9]
        if got:
            hop.append(got[0] - t_pub_mono)
    else:
        lcm_cmd(IDLE)
    w.wait_mode(IDLE, int(time.time() * 1e6), timeout_s=3)


def cpu_pct(node, pub, seconds):
    """omni4-ros's CPU [% of a core] at rest, then with /cmd_vel at 20 Hz (IDLE in between)."""
    c0, t0 = cpu_s(node.pid), time.monotonic()
    time.sleep(seconds)
    rest = (cpu_s(node.pid) - c0) / (time.monotonic() - t0) * 100
    c0, t0 = cpu_s(node.pid), time.monotonic()
    end = t0 + seconds
    while time.monotonic() < end:
        pub.publish(twist(0.05))
        time.sleep(0.05)
    return rest, (cpu_s(node.pid) - c0) / (time.monotonic() - t0) * 100


def stop(procs):
    for p in procs:
        if p.poll() is None:
            p.send_signal(signal.SIGINT)
    for p in procs:
        try:
            p.wait(timeout=10)
        except subprocess.TimeoutExpired:
            p.kill()


def report(trials, lat, echo, hop, rest, driving):
    def us(x):
        return f"{x * 1e6:7.0f}"

    print(f"publish -> HAL write (tick in VELOCITY), {trials} commands per path, 1 kHz loop:")
    for path, label in (("ros", "/cmd_vel via omni4-ros"), ("lcm", "OMNI4_CMD (LCM)     ")):
        xs, es = lat[path], echo[path]
        print(f"  {label}: p50 {us(pct(xs, 50))} us  p99 {us(pct(xs, 99))} us  max "
              f"{us(max(xs))} us   (echo to this process: p50 {us(pct(es, 50))} p99 "
              f"{us(pct(es, 99))} us)")
    if hop:
        print(f"  /cmd_vel -> command_t on OMNI4_CMD (omni4-ros alone): p50 {us(pct(hop, 50))} us"
              f"  p99 {us(pct(hop, 99))} us  ({len(hop)} matched)")
    print(f"omni4-ros CPU (1 kHz OMNI4_MOTORS in, /odom + /joint_states at 50 Hz): at rest "
          f"{rest:.1f} % of a core, with /cmd_vel at 20 Hz {driving:.1f} %")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bin", default=os.path.join(os.path.dirname(__file__), "..", "build", "bin"))
    ap.add_argument("--trials", type=int, default=100, help="per path (default 100)")
    ap.add_argument("--cpu-s", type=float, default=10.0)
    a = ap.parse_args()

    import rclpy
    from geometry_msgs.msg import Twist

    url, fw, node = start(a.bin)
    rclpy.init()
    n = rclpy.create_node("ros_latency")
    pub = n.create_publisher(Twist, "/cmd_vel", 10)
    w = Watch(url)
    lc = lcm.LCM(url)
    seq = [0]

    def lcm_cmd(mode, v=0.0):
        c = omni4.command_t()
        c.mode, c.velocity, seq[0] = mode, [v, 0.0, 0.0], seq[0] + 1
        c.seq, c.utime = seq[0], int(time.time() * 1e6)
        lc.publish(omni4.CHANNEL_CMD, c.encode())

    lat, echo, hop = {"ros": [], "lcm": []}, {"ros": [], "lcm": []}, []
    try:
        wait_ready(pub, w)
        for k in range(2 * a.trials):
            trial("ros" if k % 2 == 0 else "lcm", pub, w, lcm_cmd, lat, echo, hop)
        rest, driving = cpu_pct(node, pub, a.cpu_s)
    finally:
        stop((node, fw))
        w.stop.set()
        n.destroy_node()
        rclpy.try_shutdown()
    report(a.trials, lat, echo, hop, rest, driving)

if __name__ == "__main__":
    main()
