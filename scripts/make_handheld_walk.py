#!/usr/bin/python3
"""Writes assets/scenes/handheld_walk_poses.tum: the body poses of the handheld walk scene
(assets/scenes/handheld_walk.yaml), a person walking through a 5 x 4 m bedroom/study with a camera
in hand, looking at one piece of furniture after another from 0.5-3 m.

Deterministic (no random numbers): the path is a smooth loop at 0.2-0.45 m/s, the view turns from
one look-at point to the next, and the walk's own motion is added on top: the step's vertical bob
(1.9 Hz, 2 cm), the sideways sway (0.95 Hz, 1.5 cm) and the hand's roll and pitch (2-3 deg). It
starts in motion. The body frame is the scene's (x forward along the optical axis, z up);
R_W_B = Rz(yaw) Ry(pitch) Rx(roll), pitch > 0 looks down.

    /usr/bin/python3 scripts/make_handheld_walk.py [OUT.tum]
"""
import math
import sys

import numpy as np

DURATION_S = 40.0
RATE_HZ = 100.0

# Path knots (t_s, x, y), a loop through the room; eye height 1.45 m.
PATH = [
    (0.0, 2.2, 2.4), (5.0, 2.9, 1.4), (10.0, 4.1, 1.6), (15.0, 3.8, 2.6), (20.0, 2.2, 3.3),
    (25.0, 1.3, 3.0), (30.0, 1.1, 1.6), (35.0, 2.0, 1.2), (40.0, 2.4, 2.2),
]
# Look-at points (t_s, x, y, z): the wardrobe, the door and its switch, the window, the socket,
# the desk's monitors and drawers, the painting, the wardrobe again. Walls: y = 0 (wardrobe,
# door), x = 5 (window), y = 4 (desk), x = 0 (painting).
LOOK = [
    (0.0, 1.2, 0.0, 1.3), (4.0, 1.6, 0.0, 1.1), (7.5, 4.1, 0.0, 1.2), (10.5, 5.0, 2.0, 1.4),
    (13.5, 5.0, 3.2, 0.6), (17.0, 2.0, 4.0, 1.1), (21.0, 1.0, 4.0, 0.7), (24.5, 3.5, 4.0, 1.5),
    (28.0, 0.0, 1.6, 1.4), (31.5, 0.0, 2.6, 0.6), (35.0, 0.9, 0.0, 1.2), (40.0, 2.2, 0.0, 1.5),
]


def smooth_interp(knots, t):
    """Catmull-Rom through the knots' values (columns 1..), with C1 continuity; clamped ends."""
    ts = np.array([k[0] for k in knots])
    vs = np.array([k[1:] for k in knots], dtype=float)
    i = int(np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(ts) - 2))
    t0, t1 = ts[i], ts[i + 1]
    u = (t - t0) / (t1 - t0)
    p0 = vs[max(i - 1, 0)]
    p1, p2 = vs[i], vs[i + 1]
    p3 = vs[min(i + 2, len(vs) - 1)]
    m1 = (p2 - p0) / 2.0
    m2 = (p3 - p1) / 2.0
    h00 = 2 * u**3 - 3 * u**2 + 1
    h10 = u**3 - 2 * u**2 + u
    h01 = -2 * u**3 + 3 * u**2
    h11 = u**3 - u**2
    return h00 * p1 + h10 * m1 + h01 * p2 + h11 * m2


def rot(yaw, pitch, roll):
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    return rz @ ry @ rx


def quat(r):
    """(qx, qy, qz, qw) of a rotation matrix, qw >= 0."""
    w = math.sqrt(max(0.0, 1.0 + r[0, 0] + r[1, 1] + r[2, 2])) / 2.0
    x = math.copysign(math.sqrt(max(0.0, 1.0 + r[0, 0] - r[1, 1] - r[2, 2])) / 2.0, r[2, 1] - r[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] + r[1, 1] - r[2, 2])) / 2.0, r[0, 2] - r[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - r[0, 0] - r[1, 1] + r[2, 2])) / 2.0, r[1, 0] - r[0, 1])
    n = math.sqrt(w * w + x * x + y * y + z * z)
    return x / n, y / n, z / n, w / n


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "assets/scenes/handheld_walk_poses.tum"
    lines = ["# t_s tx ty tz qx qy qz qw  (scripts/make_handheld_walk.py)"]
    n = int(round(DURATION_S * RATE_HZ)) + 1
    prev_yaw = None
    for k in range(n):
        t = k / RATE_HZ
        x, y = smooth_interp(PATH, t)
        lx, ly, lz = smooth_interp(LOOK, t)
        # The walk's own motion: the step's bob and the body's sway (across the view direction).
        z = 1.45 + 0.02 * math.sin(2 * math.pi * 1.9 * t)
        yaw = math.atan2(ly - y, lx - x)
        if prev_yaw is not None:  # unwrap
            yaw = prev_yaw + math.remainder(yaw - prev_yaw, 2 * math.pi)
        prev_yaw = yaw
        sway = 0.015 * math.sin(2 * math.pi * 0.95 * t + 0.3)
        x += -math.sin(yaw) * sway
        y += math.cos(yaw) * sway
        dist = math.hypot(lx - x, ly - y)
        pitch = math.atan2(z - lz, dist)  # > 0: looking down
        pitch += math.radians(2.0) * math.sin(2 * math.pi * 1.9 * t + 1.0)
        roll = math.radians(3.0) * math.sin(2 * math.pi * 0.95 * t + 0.7)
        yaw += math.radians(1.5) * math.sin(2 * math.pi * 0.95 * t + 2.0)
        qx, qy, qz, qw = quat(rot(yaw, pitch, roll))
        lines.append("%.6f %.9f %.9f %.9f %.12f %.12f %.12f %.12f" % (t, x, y, z, qx, qy, qz, qw))
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("wrote %d poses to %s" % (n, out))


if __name__ == "__main__":
    main()
