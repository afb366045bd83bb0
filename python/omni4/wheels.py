"""A robot's wheels as the tools show them: how many, where (angle from the v axis
counter-clockwise [rad], distance from the centre [m]), each radius [m], and the names of their
joints. From the robot's own description (robot_t on OMNI4_ROBOT, docs/design.md "Layout"),
else the paper's layout: four wheels at 0/90/180/270 deg at one distance d.

Every per-wheel array of a message keeps four slots; a three-wheel robot's fourth slot holds 0
and is left out of what a tool shows (Wheels.take(values) keeps the first `count`)."""
import math

# Table III of the paper: d [m], r [m].
PAPER_D_M = 0.089
PAPER_R_M = 0.0325
# The paper's four wheels keep the names every tool has always shown (docs/kinematics.md).
PAPER_JOINT_NAMES = ("wheel_0_front_joint", "wheel_1_left_joint", "wheel_2_rear_joint",
                     "wheel_3_right_joint")


class Wheels:
    """count (3 or 4), angle_rad, distance_m, radius_m (tuples of count), l (gearbox [-], None
    when not said), paper (True: the paper's layout, as no robot_t described it)."""

    def __init__(self, angle_rad, distance_m, radius_m, l=None, paper=False):
        self.angle_rad = tuple(float(a) for a in angle_rad)
        self.distance_m = tuple(float(x) for x in distance_m)
        self.radius_m = tuple(float(x) for x in radius_m)
        self.count = len(self.angle_rad)
        self.l = l
        self.paper = paper

    @classmethod
    def paper_layout(cls, d=PAPER_D_M, r=PAPER_R_M):
        """The paper's four wheels at 0/90/180/270 deg, distance d [m]; r: one radius [m] or
        each wheel's four."""
        radii = tuple(r) if hasattr(r, "__len__") else (r,) * 4
        return cls([j * math.pi / 2 for j in range(4)], (d,) * 4, radii, paper=True)

    @classmethod
    def from_robot(cls, m):
        """From a robot_t; None (with why) when it does not describe 3 or 4 wheels with finite
        values, positive distances and radii: the caller keeps the layout it had."""
        n = int(m.wheels)
        if n not in (3, 4):
            return None, f"robot_t: {n} wheels (3 or 4 expected)"
        a, d, r = (list(x)[:n] for x in (m.wheel_angle, m.wheel_distance, m.wheel_radius))
        if not all(math.isfinite(x) for x in a + d + r) or min(d + r) <= 0:
            return None, "robot_t: a wheel angle, distance or radius not finite or not positive"
        return cls(a, d, r, l=float(m.l)), None

    @classmethod
    def from_ini(cls, path):
        """The layout of a robot INI's [model] (`wheels`, `wheel_angle_j` [deg], `d_j`, `r_j`,
        absent: 4, 0/90/180/270, `d`, `r`, each of those absent: Table III), or None when it
        has none of the layout keys (the paper's). Raises omni4.ini.ConfigError (one line
        FILE:LINE) on a value that is not a number or a count other than 3 or 4."""
        from . import ini
        f = ini.read(path)
        sec = f.section("model")
        if not any(k == "wheels" or k.startswith(("wheel_angle_", "d_")) for k in sec):
            return None

        def num(key, default):
            try:
                x = float(sec.get(key, default))
            except (TypeError, ValueError):
                raise ini.ConfigError(f"{f.where('model', key)}: [model] {key} = "
                                      f"'{sec[key]}' is not a number") from None
            if not math.isfinite(x):
                raise ini.ConfigError(f"{f.where('model', key)}: [model] {key} not finite")
            return x
        n = num("wheels", 4)
        if n not in (3, 4):
            raise ini.ConfigError(f"{f.where('model', 'wheels')}: [model] wheels = {n:g} "
                                  "(3 or 4 expected)")
        d, r = num("d", PAPER_D_M), num("r", PAPER_R_M)
        out = cls([math.radians(num(f"wheel_angle_{j}", 90 * j)) for j in range(int(n))],
                  [num(f"d_{j}", d) for j in range(int(n))],
                  [num(f"r_{j}", r) for j in range(int(n))])
        if min(out.distance_m + out.radius_m) <= 0:
            raise ini.ConfigError(f"{f.where('model')}: [model] a wheel's distance d_j or "
                                  "radius r_j is not positive")
        return out

    def is_paper_geometry(self):
        """True when the wheels sit at 0/90/180/270 deg at one distance (the paper's axes)."""
        if self.count != 4:
            return False
        return all(abs(math.remainder(a - j * math.pi / 2, 2 * math.pi)) < 1e-9
                   for j, a in enumerate(self.angle_rad)) and \
            max(self.distance_m) - min(self.distance_m) < 1e-12

    def same(self, other):
        return other is not None and (self.angle_rad, self.distance_m, self.radius_m) == \
            (other.angle_rad, other.distance_m, other.radius_m)

    def joint_names(self):
        """The paper's four keep their names (front, left, rear, right); any other layout's
        wheels are wheel_0_joint .. wheel_{count-1}_joint (no "left" where there is none)."""
        if self.is_paper_geometry():
            return PAPER_JOINT_NAMES
        return tuple(f"wheel_{j}_joint" for j in range(self.count))

    def positions(self):
        """((x, y) [m] per wheel) in the robot frame: x along v, y along vn."""
        return tuple((d * math.cos(a), d * math.sin(a))
                     for a, d in zip(self.angle_rad, self.distance_m))

    def take(self, values):
        """The first `count` of a four-slot per-wheel array, as floats."""
        return [float(x) for x in list(values)[:self.count]]

    def rim_rows(self):
        """Eq 2's rows: rim speed_j = -sin(a_j) v + cos(a_j) vn + d_j w."""
        return [(-math.sin(a), math.cos(a), d) for a, d in zip(self.angle_rad, self.distance_m)]

    def forward(self, wheel_rad_s):
        """(v, vn, w) [m/s, m/s, rad/s] of the wheels' angular speeds [rad/s] (the first `count`
        used): the least-squares solution of eq 2 (exact for three wheels)."""
        u = [r * w for r, w in zip(self.radius_m, list(wheel_rad_s)[:self.count])]
        rows = self.rim_rows()
        ata = [[sum(row[i] * row[k] for row in rows) for k in range(3)] for i in range(3)]
        atu = [sum(row[i] * x for row, x in zip(rows, u)) for i in range(3)]
        return tuple(_solve3(ata, atu))


def _solve3(a, b):
    """x of a x = b, 3x3, by Cramer's rule."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    full = det(a)
    out = []
    for c in range(3):
        m = [[b[i] if k == c else a[i][k] for k in range(3)] for i in range(3)]
        out.append(det(m) / full)
    return out
