#!/usr/bin/env python3
"""An independent SPEC dataset writer: a simulated multi-sensor rig waved in front of a board.

Written from shared/SPEC.md alone (none of ctcal's simulator or sensor code is read or imported),
so that a convention shared by ctcal's simulator and its calibrator but contrary to SPEC (a time
offset's sign, T_B_S against T_S_B, an IMU model's order of operations, gravity's sign, a
distortion's parameter order, a quaternion's order, the rolling-shutter row time, a CSV unit) shows
up as a calibration that misses the truth. Python 3 standard library only.

Writes DATA/<sensor>/data.csv (inertial), DATA/<camera>/corners.csv (or, with --images, the
camera's images and data.csv, rendered by scripts/spec_render.py), DATA/<sensor>/biases.csv,
DATA/groundtruth/data.csv, DATA/truth.yaml and DATA/rig.yaml (a coarse, hand-made guess: focal
lengths 3-5 % off, no distortion, rotations a few degrees off, lever arms centimetres off, time
offsets 0, IMU intrinsics at their defaults).

    python3 scripts/spec_sim.py --out DATA [--seed N] [--duration S] [--base-model imu2]
        [--g-sensitivity full|upper|none] [--aux-imus imu2[,MODEL]] [--gyros upper[,MODEL]]
        [--cameras radtan,equidistant[,LENS]]
        [--camera-only] [--imu-rates 200,250,400] [--cam-rate 20] [--noise-scale 1]
        [--t0-ns N] [--board-hidden F] [--min-frame-corners 8] [--style block|flow|messy]
        [--target aprilgrid|kalibr-aprilgrid|checkerboard] [--rolling-shutter]
        [--max-offset-ms 10] [--images] [--image-scale 1]

Without options (and for a given seed) it writes the same dataset as its first version, the one
docs/initialisation.md's tables measured.
"""

import argparse
import math
import os
import random
import re
import sys
import time

# --------------------------------------------------------------------------------------------
# 3-vectors and 3x3 matrices as plain lists.


def add(a, b):
    return [a[0] + b[0], a[1] + b[1], a[2] + b[2]]


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def scale(s, a):
    return [s * a[0], s * a[1], s * a[2]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    return math.sqrt(dot(a, a))


def mv(m, v):
    return [dot(m[0], v), dot(m[1], v), dot(m[2], v)]


def mtv(m, v):
    """m^T v."""
    return [m[0][i] * v[0] + m[1][i] * v[1] + m[2][i] * v[2] for i in range(3)]


def mm(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def tr(m):
    return [[m[j][i] for j in range(3)] for i in range(3)]


def eye():
    return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def inv3(m):
    a, b, c = m[0]
    d, e, f = m[1]
    g, h, i = m[2]
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    return [[(e * i - f * h) / det, (c * h - b * i) / det, (b * f - c * e) / det],
            [(f * g - d * i) / det, (a * i - c * g) / det, (c * d - a * f) / det],
            [(d * h - e * g) / det, (b * g - a * h) / det, (a * e - b * d) / det]]


def rot_x(c):
    return [[1.0, 0.0, 0.0], [0.0, math.cos(c), -math.sin(c)], [0.0, math.sin(c), math.cos(c)]]


def rot_y(b):
    return [[math.cos(b), 0.0, math.sin(b)], [0.0, 1.0, 0.0], [-math.sin(b), 0.0, math.cos(b)]]


def rot_z(a):
    return [[math.cos(a), -math.sin(a), 0.0], [math.sin(a), math.cos(a), 0.0], [0.0, 0.0, 1.0]]


def exp_so3(w):
    """Rodrigues: the rotation by |w| radians about w."""
    th = norm(w)
    if th < 1e-12:
        return eye()
    k = scale(1.0 / th, w)
    K = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]]
    K2 = mm(K, K)
    s, c = math.sin(th), 1.0 - math.cos(th)
    return [[(1.0 if i == j else 0.0) + s * K[i][j] + c * K2[i][j] for j in range(3)]
            for i in range(3)]


def log_so3(R):
    c = max(-1.0, min(1.0, (R[0][0] + R[1][1] + R[2][2] - 1.0) / 2.0))
    th = math.acos(c)
    v = [R[2][1] - R[1][2], R[0][2] - R[2][0], R[1][0] - R[0][1]]
    if th < 1e-9:
        return scale(0.5, v)
    return scale(th / (2.0 * math.sin(th)), v)


def quat_wxyz(R):
    """Hamilton quaternion (w, x, y, z) of a rotation matrix, w >= 0."""
    t = R[0][0] + R[1][1] + R[2][2]
    if t > 0.0:
        s = 2.0 * math.sqrt(t + 1.0)
        q = [0.25 * s, (R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s]
    elif R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = 2.0 * math.sqrt(1.0 + R[0][0] - R[1][1] - R[2][2])
        q = [(R[2][1] - R[1][2]) / s, 0.25 * s, (R[0][1] + R[1][0]) / s, (R[0][2] + R[2][0]) / s]
    elif R[1][1] > R[2][2]:
        s = 2.0 * math.sqrt(1.0 + R[1][1] - R[0][0] - R[2][2])
        q = [(R[0][2] - R[2][0]) / s, (R[0][1] + R[1][0]) / s, 0.25 * s, (R[1][2] + R[2][1]) / s]
    else:
        s = 2.0 * math.sqrt(1.0 + R[2][2] - R[0][0] - R[1][1])
        q = [(R[1][0] - R[0][1]) / s, (R[0][2] + R[2][0]) / s, (R[1][2] + R[2][1]) / s, 0.25 * s]
    return q if q[0] >= 0.0 else [-x for x in q]


def upper_from6(d):
    """SPEC 3: an upper-triangular matrix stored column-wise [d11, d12, d22, d13, d23, d33]."""
    return [[d[0], d[1], d[3]], [0.0, d[2], d[4]], [0.0, 0.0, d[5]]]


def full_from9(d):
    return [d[0:3], d[3:6], d[6:9]]


def gauss3(rng, s):
    return [rng.gauss(0.0, s), rng.gauss(0.0, s), rng.gauss(0.0, s)]


def random_rotation(rng, max_deg):
    axis = gauss3(rng, 1.0)
    return exp_so3(scale(math.radians(max_deg) * rng.uniform(0.6, 1.0) / norm(axis), axis))


# --------------------------------------------------------------------------------------------
# The trajectory T_W_B(t): position and ZYX Euler angles as sums of sinusoids, with closed-form
# derivatives, R_W_B(t) = R_W_B0 * Rz(a) * Ry(b) * Rx(c).
#
# With Q = Rz(a) Ry(b) Rx(c), Q^T Q' = [Rx^T Ry^T e3 a' + Rx^T e2 b' + e1 c']_x, so the body rate is
#   w_B = (c' - a' sin b,  a' sin c cos b + b' cos c,  a' cos c cos b - b' sin c)
# and its derivative (the body angular acceleration; d/dt w_W = R_W_B d/dt w_B since w x w = 0)
# follows by the product rule.


class Sinusoids:
    def __init__(self, rng, amplitude, freqs):
        self.terms = [(amplitude * rng.uniform(0.5, 1.0) / len(freqs), 2.0 * math.pi * f,
                       rng.uniform(0.0, 2.0 * math.pi)) for f in freqs]

    def eval(self, t):
        """Value, first and second derivative."""
        x = dx = ddx = 0.0
        for a, w, ph in self.terms:
            s, c = math.sin(w * t + ph), math.cos(w * t + ph)
            x += a * s
            dx += a * w * c
            ddx -= a * w * w * s
        return x, dx, ddx


class Trajectory:
    def __init__(self, rng, p0, R0, pos_amp, rot_amp):
        self.p0, self.R0 = p0, R0
        self.pos = [Sinusoids(rng, pos_amp, [rng.uniform(0.2, 0.5), rng.uniform(0.6, 1.1)])
                    for _ in range(3)]
        self.ang = [Sinusoids(rng, rot_amp, [rng.uniform(0.15, 0.45), rng.uniform(0.5, 0.9)])
                    for _ in range(3)]

    def position(self, t):
        """p_W_B, v_W_B, acc_W_B."""
        e = [s.eval(t) for s in self.pos]
        return (add(self.p0, [x[0] for x in e]), [x[1] for x in e], [x[2] for x in e])

    def rotation(self, t):
        """R_W_B, w_B, alpha_B (body-frame angular velocity and acceleration)."""
        (a, da, dda), (b, db, ddb), (c, dc, ddc) = [s.eval(t) for s in self.ang]
        sb, cb, sc, cc = math.sin(b), math.cos(b), math.sin(c), math.cos(c)
        R = mm(self.R0, mm(rot_z(a), mm(rot_y(b), rot_x(c))))
        w = [dc - da * sb, da * sc * cb + db * cc, da * cc * cb - db * sc]
        alpha = [ddc - dda * sb - da * cb * db,
                 dda * sc * cb + da * (cc * dc * cb - sc * sb * db) + ddb * cc - db * sc * dc,
                 dda * cc * cb - da * (sc * dc * cb + cc * sb * db) - ddb * sc - db * cc * dc]
        return R, w, alpha


def self_check(traj):
    """The closed-form derivatives against central differences (a wrong sign here would be a
    wrong dataset, not a wrong calibrator)."""
    h = 1e-5
    for t in (0.3, 1.7, 4.2):
        R, w, alpha = traj.rotation(t)
        Rp, wp, _ = traj.rotation(t + h)
        Rm, wm, _ = traj.rotation(t - h)
        w_fd = scale(1.0 / (2.0 * h), sub(log_so3(mm(tr(R), Rp)), log_so3(mm(tr(R), Rm))))
        a_fd = scale(1.0 / (2.0 * h), sub(wp, wm))
        p, v, acc = traj.position(t)
        pp, vp, _ = traj.position(t + h)
        pm, vm, _ = traj.position(t - h)
        v_fd = scale(1.0 / (2.0 * h), sub(pp, pm))
        acc_fd = scale(1.0 / (2.0 * h), sub(vp, vm))
        for name, x, y in (("w_B", w, w_fd), ("alpha_B", alpha, a_fd), ("v_W", v, v_fd),
                           ("acc_W", acc, acc_fd)):
            if norm(sub(x, y)) > 1e-6 * (1.0 + norm(x)):
                raise RuntimeError("trajectory self-check failed for %s at t=%g: %s vs %s" %
                                   (name, t, x, y))


# --------------------------------------------------------------------------------------------
# Targets (SPEC 5).


def aprilgrid(cols, rows, size, spacing):
    """Corner id -> position, and the tags as lists of 4 corner ids."""
    points = {}
    for r in range(2 * rows):
        for c in range(2 * cols):
            x = (c // 2) * (1.0 + spacing) * size + (c % 2) * size
            y = (r // 2) * (1.0 + spacing) * size + (r % 2) * size
            points[r * 2 * cols + c] = [x, y, 0.0]
    tags = []
    for k in range(cols * rows):
        b = 2 * (k // cols) * 2 * cols + 2 * (k % cols)
        tags.append([b, b + 1, b + 2 * cols + 1, b + 2 * cols])
    return points, tags


def checkerboard(cols, rows, row_spacing, col_spacing):
    points = {r * cols + c: [r * row_spacing, c * col_spacing, 0.0]
              for r in range(rows) for c in range(cols)}
    return points, [sorted(points)]  # a checkerboard is detected whole or not at all


# --------------------------------------------------------------------------------------------
# Cameras (SPEC 4): pinhole projection of the normalised point, then the distortion, in Kalibr's
# parameter orders.


def radtan(k, x, y):
    """Kalibr's radtan [k1, k2, r1, r2] (OpenCV's p1, p2) of the normalised point (x, y). Plain
    arithmetic, so that spec_render.py applies it to numpy arrays."""
    k1, k2, r1, r2 = k
    rr = x * x + y * y
    radial = 1.0 + k1 * rr + k2 * rr * rr
    return (x * radial + 2.0 * r1 * x * y + r2 * (rr + 2.0 * x * x),
            y * radial + r1 * (rr + 2.0 * y * y) + 2.0 * r2 * x * y)


def kannala_brandt(k, th):
    """Kalibr's equidistant [k1..k4]: theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8) of the
    angle theta off the optical axis (plain arithmetic, as radtan)."""
    th2 = th * th
    return th * (1.0 + th2 * (k[0] + th2 * (k[1] + th2 * (k[2] + th2 * k[3]))))


def project(cam, p_C):
    if p_C[2] < 0.05:
        return None
    model = cam["camera_model"]
    if model != "pinhole":
        return project_central(cam, p_C)
    x, y = p_C[0] / p_C[2], p_C[1] / p_C[2]
    k = cam["distortion_coeffs"]
    if cam["distortion_model"] == "radtan":
        xd, yd = radtan(k, x, y)
    elif cam["distortion_model"] == "equidistant":
        r = math.sqrt(x * x + y * y)
        if r < 1e-12:
            xd, yd = x, y
        else:
            s = kannala_brandt(k, math.atan(r)) / r
            xd, yd = x * s, y * s
    else:
        xd, yd = x, y
    fu, fv, pu, pv = cam["intrinsics"]
    return fu * xd + pu, fv * yd + pv


def project_central(cam, p_C):
    """SPEC 4's models with a projection parameter, as Kalibr and basalt define them:
    omni (Mei's unified model): m = (X, Y) / (Z + xi d), d = |p|, then radtan on m if given;
    ds (double sphere): d1 = |p|, d2 = |(X, Y, xi d1 + Z)|, m = (X, Y) / (alpha d2 + (1 - alpha)
    (xi d1 + Z)); eucm: d = sqrt(beta (X^2 + Y^2) + Z^2), m = (X, Y) / (alpha d + (1 - alpha) Z).
    Points outside a model's valid cone are left out (a detector would not see them either)."""
    X, Y, Z = p_C
    q = cam["intrinsics"]
    d = norm(p_C)
    if cam["camera_model"] == "omni":
        xi, (fu, fv, pu, pv) = q[0], q[1:]
        den = Z + xi * d
        if den <= 0.1 * d:
            return None
        x, y = X / den, Y / den
        if cam["distortion_model"] == "radtan":
            x, y = radtan(cam["distortion_coeffs"], x, y)
    elif cam["camera_model"] == "ds":
        xi, alpha, fu, fv, pu, pv = q
        zz = xi * d + Z
        den = alpha * math.sqrt(X * X + Y * Y + zz * zz) + (1.0 - alpha) * zz
        if den <= 0.1 * d:
            return None
        x, y = X / den, Y / den
    elif cam["camera_model"] == "eucm":
        alpha, beta, fu, fv, pu, pv = q
        den = alpha * math.sqrt(beta * (X * X + Y * Y) + Z * Z) + (1.0 - alpha) * Z
        if den <= 0.1 * d:
            return None
        x, y = X / den, Y / den
    else:
        raise ValueError("unknown camera_model " + cam["camera_model"])
    return fu * x + pu, fv * y + pv


# The lenses --cameras offers: SPEC 4's (camera_model, distortion_model) pairs.
LENSES = {"radtan": ("pinhole", "radtan"), "equidistant": ("pinhole", "equidistant"),
          "pinhole": ("pinhole", "none"), "omni": ("omni", "none"),
          "omni-radtan": ("omni", "radtan"), "ds": ("ds", "none"), "eucm": ("eucm", "none")}


def set_lens(cam, lens, rng):
    """Gives `cam` (which has a pinhole focal length f for its field of view) the lens `lens`, with
    about the same field of view: Mei's and the double sphere's focal length near the axis is
    fu / (1 + xi), the EUCM's fu."""
    f, _, pu, pv = cam["intrinsics"][-4:]
    wide = f < 300.0
    cam["camera_model"], cam["distortion_model"] = LENSES[lens]
    cam["distortion_coeffs"] = []
    if lens == "radtan":
        cam["distortion_coeffs"] = ([-0.05 + rng.uniform(-0.01, 0.01), 0.004, 1.5e-4, -1.0e-4]
                                    if wide else
                                    [-0.28 + rng.uniform(-0.02, 0.02), 0.075, 2.1e-4, -1.4e-4])
    elif lens == "equidistant":
        cam["distortion_coeffs"] = [-0.012 + rng.uniform(-0.003, 0.003), 0.021, -0.018, 0.0045]
    elif lens == "omni-radtan":
        cam["distortion_coeffs"] = [-0.04 + rng.uniform(-0.01, 0.01), 0.006, 1.2e-4, -0.8e-4]
    fv_ratio = cam["intrinsics"][-3] / f
    if lens in ("omni", "omni-radtan"):
        xi = 0.9 + rng.uniform(-0.1, 0.1)
        cam["intrinsics"] = [xi, f * (1.0 + xi), f * (1.0 + xi) * fv_ratio, pu, pv]
    elif lens == "ds":
        xi, alpha = -0.18 + rng.uniform(-0.04, 0.04), 0.59 + rng.uniform(-0.03, 0.03)
        cam["intrinsics"] = [xi, alpha, f * (1.0 + xi), f * (1.0 + xi) * fv_ratio, pu, pv]
    elif lens == "eucm":
        alpha, beta = 0.6 + rng.uniform(-0.03, 0.03), 1.05 + rng.uniform(-0.05, 0.05)
        cam["intrinsics"] = [alpha, beta, f, f * fv_ratio, pu, pv]


# --------------------------------------------------------------------------------------------
# Inertial sensors (SPEC 3). A sensor's truth gives T_w = D_w^-1, T_a = D_a^-1, its rotation and
# T_g; the raw readings are
#   w_m = T_w R_w_I w_I + T_g a_I + b_g + n_g,   a_m = T_a R_a_I a_I + b_a + n_a
# with R_w_I = R_I_w^T (imu1) and R_a_I = R_I_a^T (imu2), identity otherwise.


def inertial_matrices(s):
    model = s["model"]
    if s["type"] == "gyro":
        Dw = upper_from6(s["Dw"]) if model == "upper" else (
            full_from9(s["Dw"]) if model == "full" else eye())
        return inv3(Dw), None, None
    Dw = full_from9(s["Dw"]) if model == "imu3" else (
        eye() if model == "none" else upper_from6(s["Dw"]))
    Da = full_from9(s["Da"]) if model == "imu4" else (
        eye() if model == "none" else upper_from6(s["Da"]))
    R_w_I = tr(s["R_I_w"]) if model == "imu1" else eye()
    R_a_I = tr(s["R_I_a"]) if model == "imu2" else eye()
    g = s.get("g_sensitivity", "none")
    if g == "full":
        Tg = full_from9(s["Tg"])
    elif g == "upper":
        Tg = upper_from6(s["Tg"])
    else:
        Tg = [[0.0] * 3 for _ in range(3)]
    return mm(inv3(Dw), R_w_I), mm(inv3(Da), R_a_I), Tg


def random_upper6(rng, scale_err, skew):
    return [1.0 + rng.uniform(-scale_err, scale_err), rng.uniform(-skew, skew),
            1.0 + rng.uniform(-scale_err, scale_err), rng.uniform(-skew, skew),
            rng.uniform(-skew, skew), 1.0 + rng.uniform(-scale_err, scale_err)]


def random_full9(rng, scale_err, skew):
    return [1.0 + rng.uniform(-scale_err, scale_err) if i % 4 == 0 else rng.uniform(-skew, skew)
            for i in range(9)]


def imu_truth(rng, model, noise, T_B_S=None, offset=None, g_sensitivity="full"):
    """An IMU's truth; `g_sensitivity` none leaves the key out (SPEC 7's default)."""
    s = {"type": "imu", "model": model, "noise": noise}
    if model != "none":
        s["Dw"] = random_full9(rng, 0.01, 0.005) if model == "imu3" else random_upper6(
            rng, 0.01, 0.005)
        s["Da"] = random_full9(rng, 0.01, 0.005) if model == "imu4" else random_upper6(
            rng, 0.01, 0.005)
        if g_sensitivity != "none":
            s["g_sensitivity"] = g_sensitivity
            n = 9 if g_sensitivity == "full" else 6
            s["Tg"] = [rng.uniform(-1e-3, 1e-3) for _ in range(n)]
        if model == "imu1":
            s["R_I_w"] = random_rotation(rng, 1.0)
        if model == "imu2":
            s["R_I_a"] = random_rotation(rng, 1.0)
    if T_B_S is not None:
        s["T_B_S"], s["time_offset"] = T_B_S, offset
    return s


# --------------------------------------------------------------------------------------------
# Files. Our own layout choices where SPEC leaves them open: EuRoC-style CSV headers with units,
# readings in %.10g, YAML numbers as Python's shortest round-trip repr, block-style YAML with the
# keys in an order of our own.


def fmt(x):
    return repr(float(x))


def yaml_value(v):
    if isinstance(v, str):
        return v
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(yaml_value(x) for x in v) + "]"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    return fmt(v)


def transform(R, t):
    return [R[0] + [t[0]], R[1] + [t[1]], R[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]


SENSOR_KEY_ORDER = ["type", "time_offset", "T_B_S", "model", "camera_model", "resolution",
                    "intrinsics", "distortion_model", "distortion_coeffs", "line_delay",
                    "g_sensitivity", "Dw", "Da", "Tg", "R_I_a", "R_I_w", "noise", "estimate"]


def write_rig(path, comment, base, gravity_magnitude, target, sensors, gravity_W=None):
    lines = ["# " + comment, "sensors:"]
    for name, s in sensors.items():
        lines.append("  %s:" % name)
        for key in SENSOR_KEY_ORDER:
            if key not in s:
                continue
            v = s[key]
            if key == "noise":
                lines.append("    noise:")
                lines += ["      %s: %s" % (k, yaml_value(x)) for k, x in v.items()]
            elif key in ("T_B_S", "R_I_a", "R_I_w"):
                lines.append("    %s:" % key)
                lines += ["      - %s" % yaml_value(row) for row in v]
            else:
                lines.append("    %s: %s" % (key, yaml_value(v)))
    lines.append("target:")
    lines += ["  %s: %s" % (k, yaml_value(v)) for k, v in target.items()]
    if gravity_W is not None:
        lines.append("gravity_W: %s" % yaml_value(gravity_W))
    lines.append("gravity_magnitude: %s" % fmt(gravity_magnitude))
    lines.append("base_imu: %s" % base)
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def stamps(t0_ns, duration, rate):
    period_ns = int(round(1e9 / rate))
    return [t0_ns + k * period_ns for k in range(int(duration * rate) + 1)]


def rotation_translation(T):
    return [row[:3] for row in T[:3]], [row[3] for row in T[:3]]


def body_state(traj, t):
    p, v, acc = traj.position(t)
    R, w, alpha = traj.rotation(t)
    return p, v, acc, R, w, alpha


def camera_pose(traj, R_B_C, t_B_C, t):
    """R_W_C, p_W_C at base time t."""
    p, _, _, R, _, _ = body_state(traj, t)
    return mm(R, R_B_C), add(p, mv(R, t_B_C))


# --------------------------------------------------------------------------------------------
# The rig: the truth of every sensor, in the order the files list them (not ours: cameras first,
# the base last).

BASE, AUX, GYRO, CAM_L, CAM_R = "body", "aux_imu", "fog", "left", "right"
CAMERAS = [CAM_L, CAM_R, "third"]


def make_target(kind):
    """Kalibr's target description, corner id -> position, and the corner groups a detector
    finds whole."""
    if kind == "aprilgrid":
        return ({"target_type": "aprilgrid", "tagCols": 7, "tagRows": 5, "tagSize": 0.06,
                 "tagSpacing": 0.25},) + aprilgrid(7, 5, 0.06, 0.25)
    if kind == "kalibr-aprilgrid":  # the board Kalibr offers for download (its wiki's example)
        return ({"target_type": "aprilgrid", "tagCols": 6, "tagRows": 6, "tagSize": 0.088,
                 "tagSpacing": 0.3},) + aprilgrid(6, 6, 0.088, 0.3)
    return ({"target_type": "checkerboard", "targetCols": 7, "targetRows": 6,
             "rowSpacingMeters": 0.07, "colSpacingMeters": 0.06},) + checkerboard(7, 6, 0.07, 0.06)


def make_rig(rng, args):
    """The sensors' truth and the left camera's pose R_B_L, t_B_L."""
    # Cameras: the left one looks along B's x axis (x_C = -y_B, y_C = -z_B); the right one, a
    # fisheye 11 cm to its right, looks 35 deg further right, so that the board sweeps its outer
    # field (Kannala-Brandt's k2..k4 are determined only by corners far off the axis).
    R_B_L = mm([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]], random_rotation(rng, 2.0))
    t_B_L = [0.045 + rng.uniform(-0.01, 0.01), 0.03, -0.015]
    R_B_R = mm(R_B_L, exp_so3([0.004, math.radians(35.0), 0.003]))
    t_B_R = add(t_B_L, mv(R_B_L, [0.11, 0.002, -0.001]))

    def offset(sign):
        return sign * args.max_offset_ms * 1e-3 * rng.uniform(0.35, 1.0)

    left = {"type": "camera", "camera_model": "pinhole", "resolution": [640, 480],
            "intrinsics": [412.0 + rng.uniform(-5, 5), 414.0 + rng.uniform(-5, 5),
                           322.5 + rng.uniform(-4, 4), 236.0 + rng.uniform(-4, 4)],
            "distortion_model": "radtan",
            "distortion_coeffs": [-0.28 + rng.uniform(-0.02, 0.02), 0.075, 2.1e-4, -1.4e-4],
            "T_B_S": transform(R_B_L, t_B_L), "time_offset": offset(1.0),
            "noise": {"pixel_sigma": 0.5},
            "estimate": ["intrinsics", "extrinsics", "time_offset"]}
    right = {"type": "camera", "camera_model": "pinhole", "resolution": [640, 512],
             "intrinsics": [215.0 + rng.uniform(-5, 5), 214.0 + rng.uniform(-5, 5),
                            322.0 + rng.uniform(-4, 4), 258.0 + rng.uniform(-4, 4)],
             "distortion_model": "equidistant",
             "distortion_coeffs": [-0.012 + rng.uniform(-0.003, 0.003), 0.021, -0.018, 0.0045],
             "T_B_S": transform(R_B_R, t_B_R), "time_offset": offset(-1.0),
             "line_delay": 25e-6 if args.rolling_shutter else 0.0,
             "noise": {"pixel_sigma": 0.5},
             "estimate": ["intrinsics", "extrinsics", "time_offset"] +
             (["line_delay"] if args.rolling_shutter else [])}
    imu_noise = {"update_rate": 200.0, "gyroscope_noise_density": 1.6e-4,
                 "gyroscope_random_walk": 2.0e-6, "accelerometer_noise_density": 2.0e-3,
                 "accelerometer_random_walk": 3.0e-5}
    aux_noise = {"update_rate": 250.0, "gyroscope_noise_density": 2.4e-4,
                 "gyroscope_random_walk": 4.0e-6, "accelerometer_noise_density": 2.8e-3,
                 "accelerometer_random_walk": 6.0e-5}
    gyro_noise = {"update_rate": 400.0, "gyroscope_noise_density": 5.0e-5,
                  "gyroscope_random_walk": 1.0e-6}
    rates = [float(x) for x in args.imu_rates.split(",")]
    for noise, rate in zip((imu_noise, aux_noise, gyro_noise), rates):
        noise["update_rate"] = rate
        for key in noise:
            if key != "update_rate":
                noise[key] *= args.noise_scale
    for cam in (left, right):
        cam["noise"]["pixel_sigma"] *= args.noise_scale
    base = imu_truth(rng, args.base_model, imu_noise, g_sensitivity=args.g_sensitivity)
    base["estimate"] = [] if args.base_model == "none" else ["intrinsics"]
    aux_models = [m for m in args.aux_imus.split(",") if m]
    gyro_models = [m for m in args.gyros.split(",") if m]
    # Mountings of the first and second auxiliary IMU and gyro: turned by a right angle about
    # another axis each, so that no two inertial frames are alike.
    aux_mounts = [(rot_z(math.radians(90.0)), [-0.04, 0.06, 0.02]),
                  (rot_y(math.radians(-90.0)), [0.05, -0.03, -0.02])]
    gyro_mounts = [(rot_x(math.radians(180.0)), [0.02, -0.05, 0.01]),
                   (rot_z(math.radians(-90.0)), [-0.03, 0.02, 0.04])]

    def add_aux(i):
        model = aux_models[i]
        R0, t = aux_mounts[i]
        aux = imu_truth(rng, model, aux_noise,
                        transform(mm(R0, random_rotation(rng, 5.0)),
                                  [t[0], t[1] + rng.uniform(-0.01, 0.01), t[2]]),
                        offset(-1.0 if i == 0 else 1.0), args.g_sensitivity)
        # SPEC 3: a `none` model has no intrinsics to estimate.
        aux["estimate"] = ["extrinsics", "time_offset"] + (
            [] if model == "none" else ["intrinsics"])
        return aux

    def add_gyro(i):
        model = gyro_models[i]
        R0, t = gyro_mounts[i]
        gyro = {"type": "gyro", "model": model, "noise": dict(gyro_noise),
                "T_B_S": transform(mm(R0, random_rotation(rng, 4.0)), t),
                "time_offset": offset(1.0 if i == 0 else -1.0)}
        if model == "upper":
            gyro["Dw"] = random_upper6(rng, 0.01, 0.005)
        elif model == "full":
            # Its frame is the one D_w fixes and its rotation may not be estimated (SPEC 3):
            # T_B_S keeps the mounting rotation, D_w carries scale and misalignment only.
            gyro["Dw"] = random_full9(rng, 0.01, 0.005)
        gyro["estimate"] = (["time_offset"] if model == "full" else
                            ["extrinsics", "time_offset"]) + (
            [] if model == "none" else ["intrinsics"])
        return gyro

    # The draws of the default rig come first and in their first order, so that a seed's default
    # dataset stays the one the docs' tables measured.
    aux0 = add_aux(0) if aux_models else None
    gyro0 = add_gyro(0) if gyro_models else None
    lenses = args.cameras.split(",")
    cams = [left, right][:len(lenses)]
    if len(lenses) > 2:
        # A third camera 9 cm left of the left one, looking 25 deg left and 10 deg down.
        third = dict(left, noise=dict(left["noise"]), estimate=list(left["estimate"]))
        third["T_B_S"] = transform(mm(R_B_L, exp_so3([math.radians(-10.0),
                                                      math.radians(-25.0), 0.002])),
                                   add(t_B_L, mv(R_B_L, [-0.09, 0.004, 0.002])))
        third["time_offset"] = offset(1.0)
        third["intrinsics"] = [300.0 + rng.uniform(-5, 5), 301.0 + rng.uniform(-5, 5),
                               320.0 + rng.uniform(-4, 4), 240.0 + rng.uniform(-4, 4)]
        cams.append(third)
    for i, (cam, lens) in enumerate(zip(cams, lenses)):
        if lens != ("radtan", "equidistant", "radtan")[i] or i == 2:
            set_lens(cam, lens, rng)
    sensors = dict(zip(CAMERAS, cams))
    sensors.update({GYRO: gyro0, AUX: aux0, BASE: base})
    if len(aux_models) > 1:
        sensors[AUX + "2"] = add_aux(1)
    if len(gyro_models) > 1:
        sensors[GYRO + "2"] = add_gyro(1)
    order = [CAM_R, GYRO, CAM_L, CAMERAS[2], AUX, AUX + "2", GYRO + "2", BASE]
    return ({name: sensors[name] for name in order if sensors.get(name)}, R_B_L, t_B_L)


# --------------------------------------------------------------------------------------------
# The recordings.


def write_inertial(out, name, s, traj, g_W, t0_ns, duration, rng, groundtruth):
    """DATA/<name>/data.csv and biases.csv (and, with `groundtruth`, DATA/groundtruth/data.csv)
    of an imu or gyro sensor `s`."""
    with_accel = s["type"] == "imu"
    rate = s["noise"]["update_rate"]
    os.makedirs(os.path.join(out, name), exist_ok=True)
    Mw, Ma, Tg = inertial_matrices(s)
    nz = s["noise"]
    R_B_S, t_B_S = rotation_translation(s["T_B_S"]) if "T_B_S" in s else (eye(), [0.0] * 3)
    off = s.get("time_offset", 0.0)
    dt = 1.0 / rate
    # SPEC 3 (Kalibr's densities): a sample's white noise has sigma density * sqrt(rate); a bias
    # walks by random_walk * sqrt(dt) per step.
    sg = nz["gyroscope_noise_density"] * math.sqrt(rate)
    sbg = nz["gyroscope_random_walk"] * math.sqrt(dt)
    bg = gauss3(rng, 0.01)
    ba = []
    if with_accel:
        sa = nz["accelerometer_noise_density"] * math.sqrt(rate)
        sba = nz["accelerometer_random_walk"] * math.sqrt(dt)
        ba = gauss3(rng, 0.08)
    rows, brows, gt = [], [], []
    for st in stamps(t0_ns, duration, rate):
        t = (st - t0_ns) * 1e-9 + off  # SPEC 2: taken at base time t_S + time_offset
        p, v, acc, R, w_B, alpha_B = body_state(traj, t)
        w_S = mtv(R_B_S, w_B)
        # Specific force at the sensor's origin p_W_B + R_W_B t_B_S, in the sensor's frame:
        # a_S = R_B_S^T (R_W_B^T (acc_W - g_W) + alpha_B x t_B_S + w_B x (w_B x t_B_S)).
        f_B = add(mtv(R, sub(acc, g_W)),
                  add(cross(alpha_B, t_B_S), cross(w_B, cross(w_B, t_B_S))))
        a_S = mtv(R_B_S, f_B)
        reading = add(add(mv(Mw, w_S), bg), gauss3(rng, sg))
        if with_accel:
            reading = add(reading, mv(Tg, a_S)) + add(add(mv(Ma, a_S), ba), gauss3(rng, sa))
        rows.append("%d,%s\n" % (st, ",".join("%.10g" % x for x in reading)))
        brows.append("%d,%s\n" % (st, ",".join("%.10g" % x for x in bg + ba)))
        if groundtruth:
            q = quat_wxyz(R)
            gt.append("%d,%s\n" % (st, ",".join("%.12g" % x for x in p + q + v + bg + ba)))
        bg = add(bg, gauss3(rng, sbg))
        if with_accel:
            ba = add(ba, gauss3(rng, sba))
    with open(os.path.join(out, name, "data.csv"), "w") as f:
        if with_accel:
            f.write("#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],"
                    "w_RS_S_z [rad s^-1],a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],"
                    "a_RS_S_z [m s^-2]\n")
        else:
            f.write("#timestamp [ns],w_x [rad/s],w_y [rad/s],w_z [rad/s]\n")
        f.writelines(rows)
    with open(os.path.join(out, name, "biases.csv"), "w") as f:
        f.write("#timestamp [ns],bw_x,bw_y,bw_z" + (",ba_x,ba_y,ba_z\n" if with_accel else "\n"))
        f.writelines(brows)
    if groundtruth:
        os.makedirs(os.path.join(out, "groundtruth"), exist_ok=True)
        with open(os.path.join(out, "groundtruth", "data.csv"), "w") as f:
            f.write("#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z,"
                    "bw_x,bw_y,bw_z,ba_x,ba_y,ba_z\n")
            f.writelines(gt)


def write_corners(out, name, cam, traj, points, groups, t0_ns, duration, rate, rng,
                  per_corner_sigma, folder=None, board_visible=lambda t: True, min_corners=8):
    """DATA/<name>/corners.csv (or <folder>/corners.csv with the exact projections: the truth of
    rendered images); returns (frames, corners, image cells of a 4x4 grid covered)."""
    folder = folder or os.path.join(out, name)
    exact = folder != os.path.join(out, name)
    os.makedirs(folder, exist_ok=True)
    R_B_C, t_B_C = rotation_translation(cam["T_B_S"])
    width, height = cam["resolution"]
    ld = cam.get("line_delay", 0.0)
    lines, frames, n, cells = [], 0, 0, set()
    for st in stamps(t0_ns + 25000000, duration - 0.05, rate):
        t_img = (st - t0_ns) * 1e-9 + cam["time_offset"]
        if not board_visible(t_img):
            continue
        pose_at_stamp = camera_pose(traj, R_B_C, t_B_C, t_img)
        frame = []
        for group in groups:
            seen = []
            for cid in group:
                # SPEC 2: row v is read at t_S + v * line_delay; v depends on the pose at that
                # time, so iterate (a contraction: line_delay * |dv/dt| << 1).
                R_W_C, p_W_C = pose_at_stamp
                uv = project(cam, mtv(R_W_C, sub(points[cid], p_W_C)))
                for _ in range(8 if ld > 0.0 else 0):
                    if uv is None:
                        break
                    v_row = uv[1]
                    R_W_C, p_W_C = camera_pose(traj, R_B_C, t_B_C, t_img + v_row * ld)
                    uv = project(cam, mtv(R_W_C, sub(points[cid], p_W_C)))
                    if uv is not None and abs(uv[1] - v_row) < 1e-6:
                        break
                if uv is None or not (2.0 <= uv[0] <= width - 3.0 and
                                      2.0 <= uv[1] <= height - 3.0):
                    break
                seen.append((cid, uv))
            if len(seen) == len(group):
                frame += seen
        if len(frame) < min_corners:
            continue
        frames += 1
        n += len(frame)
        for cid, (u, v) in frame:
            cells.add((int(4 * u / width), int(4 * v / height)))
            if exact:
                lines.append("%d,%d,%.6f,%.6f\n" % (st, cid, u, v))
            elif per_corner_sigma:
                s = rng.choice([0.3, 0.5, 0.8])
                lines.append("%d,%d,%.4f,%.4f,%.2f\n" % (st, cid, u + rng.gauss(0.0, s),
                                                         v + rng.gauss(0.0, s), s))
            else:
                s = cam["noise"]["pixel_sigma"]
                lines.append("%d,%d,%.4f,%.4f\n" % (st, cid, u + rng.gauss(0.0, s),
                                                    v + rng.gauss(0.0, s)))
    with open(os.path.join(folder, "corners.csv"), "w") as f:
        f.write("#timestamp [ns],corner_id,u [px],v [px]" +
                (",sigma [px]\n" if per_corner_sigma else "\n"))
        f.writelines(lines)
    return frames, n, len(cells)


def scale_camera(cam, s):
    """The same lens on a sensor with s times the pixels per side, the same readout time. SPEC 4's
    pixel (0, 0) is the centre of the top-left pixel, so the image's edge is at -0.5."""
    if s == 1.0:
        return
    fu, fv, pu, pv = cam["intrinsics"]
    cam["intrinsics"] = [fu * s, fv * s, (pu + 0.5) * s - 0.5, (pv + 0.5) * s - 0.5]
    cam["resolution"] = [int(round(n * s)) for n in cam["resolution"]]
    if "line_delay" in cam:
        cam["line_delay"] /= s


def coarse_guess(truth, rng):
    """A hand-made guess: focal lengths 3-5 % off with fu = fv and the image centre, no
    distortion, rotations 2.4-4 deg and lever arms 1-3 cm per axis off, offsets 0, IMU intrinsics
    left to their defaults."""
    guess = {}
    for name, s in truth.items():
        s = dict(s)
        if s["type"] == "camera":
            f = 1.0 + rng.choice([-1.0, 1.0]) * rng.uniform(0.03, 0.05)
            w, h = s["resolution"]
            # A projection parameter (xi, alpha, beta) to a datasheet's one decimal.
            n = len(s["intrinsics"]) - 4
            proj, fu = [round(x, 1) for x in s["intrinsics"][:n]], s["intrinsics"][n]
            s["intrinsics"] = proj + [round(fu * f), round(fu * f), (w - 1) / 2.0, (h - 1) / 2.0]
            s["distortion_coeffs"] = [0.0] * len(s["distortion_coeffs"])
            if "line_delay" in s:
                s["line_delay"] = 0.0
        else:
            for key in ("Dw", "Da", "Tg", "R_I_a", "R_I_w"):
                s.pop(key, None)  # defaults: identity / zero
        if "T_B_S" in s:
            R, t = rotation_translation(s["T_B_S"])
            if not (s["type"] == "gyro" and s["model"] == "full"):
                R = mm(random_rotation(rng, 4.0), R)
                t = add(t, [rng.choice([-1.0, 1.0]) * rng.uniform(0.01, 0.03) for _ in range(3)])
            s["T_B_S"] = transform(R, t)
            if "time_offset" in s:
                s["time_offset"] = 0.0
        guess[name] = s
    return guess


# --------------------------------------------------------------------------------------------


def camera_only_truth(truth, R_B_L, t_B_L):
    """SPEC 7's camera-only rig of the same cameras: the left camera is the reference `B`, every
    other camera's T_B_S is its pose in the left camera, no time offsets (the cameras expose at
    once) and no inertial sensors."""
    T_L_B = transform(tr(R_B_L), scale(-1.0, mtv(R_B_L, t_B_L)))
    rig = {}
    for name, s in truth.items():
        if s["type"] != "camera":
            continue
        s = dict(s)
        s.pop("time_offset", None)
        s.pop("line_delay", None)
        if name == CAM_L:
            s.pop("T_B_S")
            s["estimate"] = ["intrinsics"]
        else:
            R, t = rotation_translation(s["T_B_S"])
            R_L_B, t_L_B = rotation_translation(T_L_B)
            s["T_B_S"] = transform(mm(R_L_B, R), add(mv(R_L_B, t), t_L_B))
            s["estimate"] = ["intrinsics", "extrinsics"]
        rig[name] = s
    return rig


def sci(x):
    """A number in another spelling: scientific notation with a signed exponent."""
    return "%.9e" % x


def restyle_csv(path):
    """The same CSV as another program might write it: CRLF line ends, a blank after each comma,
    floating-point columns in scientific notation (integer columns stay integers)."""
    with open(path) as f:
        lines = f.read().splitlines()
    out = []
    for line in lines:
        if line.startswith("#"):
            out.append(line)
            continue
        fields = line.split(",")
        out.append(", ".join(sci(float(x)) if re.fullmatch(r"-?[0-9.]+(e[-+]?[0-9]+)?", x) and
                             ("." in x or "e" in x) else x for x in fields))
    with open(path, "w", newline="") as f:
        f.write("\r\n".join(out) + "\r\n")


def restyle_yaml(path):
    """CRLF line ends, a comment on every line that can take one, every decimal number in
    scientific notation."""
    with open(path) as f:
        lines = f.read().splitlines()
    out = []
    for line in lines:
        if not line.startswith("#"):
            line = re.sub(r"(?<![\w.])-?[0-9]+\.[0-9]+(e[-+]?[0-9]+)?(?![\w.])",
                          lambda m: sci(float(m.group(0))), line)
            if line.endswith(",") or line.endswith("}") or not line.startswith(" "):
                line += "  # " + ("a sensor's key" if line.startswith(" ") else "a top-level key")
        out.append(line)
    with open(path, "w", newline="") as f:
        f.write("\r\n".join(out) + "\r\n")


def write_flow_rig(path, comment, base, gravity_magnitude, target, sensors, gravity_W=None):
    """SPEC 7's example's style: top-level keys first, one flow mapping per sensor."""
    lines = ["# " + comment, "base_imu: " + base, "gravity_magnitude: " + fmt(gravity_magnitude),
             "target: {" + ", ".join("%s: %s" % (k, yaml_value(v)) for k, v in target.items())
             + "}"]
    if gravity_W is not None:
        lines.append("gravity_W: %s" % yaml_value(gravity_W))
    lines.append("sensors:")
    for name, s in sensors.items():
        items = []
        for key in reversed(SENSOR_KEY_ORDER):
            if key not in s:
                continue
            v = s[key]
            if key == "noise":
                v = "{" + ", ".join("%s: %s" % (k, yaml_value(x)) for k, x in v.items()) + "}"
            else:
                v = yaml_value(v)
            items.append("%s: %s" % (key, v))
        lines.append("  %s: {%s}" % (name, ",\n      ".join(items)))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--duration", type=float, default=18.0)
    models = ["none", "imu1", "imu2", "imu3", "imu4"]
    ap.add_argument("--base-model", default="imu2", choices=models)
    ap.add_argument("--g-sensitivity", default="full", choices=["none", "upper", "full"],
                    help="every IMU's T_g: 9 numbers, 6 (upper-triangular) or none")
    ap.add_argument("--aux-imus", default="imu2",
                    help="models of 0-2 auxiliary IMUs, comma-separated ('' for none)")
    ap.add_argument("--gyros", default="upper",
                    help="models (none, upper, full) of 0-2 gyroscopes, comma-separated")
    ap.add_argument("--cameras", default="radtan,equidistant",
                    help="lenses of 1-3 cameras, comma-separated: " + ", ".join(LENSES))
    ap.add_argument("--camera-only", action="store_true",
                    help="a camera-only rig (SPEC 7): the cameras alone, the first the reference")
    ap.add_argument("--imu-rates", default="200,250,400",
                    help="Hz of the base IMU, the auxiliary IMUs and the gyros")
    ap.add_argument("--noise-scale", type=float, default=1.0,
                    help="multiplies every noise density, random walk and pixel sigma")
    ap.add_argument("--t0-ns", type=int, default=1700000000123456789,
                    help="the base IMU's first stamp")
    ap.add_argument("--board-hidden", type=float, default=0.0,
                    help="fraction of the recording in which the board is out of sight "
                    "(two gaps, around 30 %% and 70 %% of it)")
    ap.add_argument("--min-frame-corners", type=int, default=8,
                    help="frames with fewer corners are left out (4: a single tag's frames too)")
    ap.add_argument("--style", default="block", choices=["block", "flow", "messy"],
                    help="block: block-style YAML, plain CSV; flow: SPEC 7's flow style; messy: "
                    "flow style with comments, CRLF, blanks after commas, scientific notation, "
                    "and camera data.csv files naming images that do not exist")
    ap.add_argument("--target", default="aprilgrid",
                    choices=["aprilgrid", "kalibr-aprilgrid", "checkerboard"],
                    help="aprilgrid: 7x5 tags of 6 cm; kalibr-aprilgrid: 6x6 of 8.8 cm")
    ap.add_argument("--rolling-shutter", action="store_true",
                    help="the fisheye reads its rows 25 us apart")
    ap.add_argument("--max-offset-ms", type=float, default=10.0)
    ap.add_argument("--cam-rate", type=float, default=20.0)
    ap.add_argument("--images", action="store_true",
                    help="write the cameras' images (scripts/spec_render.py; needs numpy and "
                    "OpenCV: /usr/bin/python3) instead of corners.csv; AprilGrid only")
    ap.add_argument("--image-scale", type=float, default=1.0,
                    help="scale the cameras' resolution and intrinsics (0.5: half-size images)")
    args = ap.parse_args()
    lenses = args.cameras.split(",")
    aux_models = [m for m in args.aux_imus.split(",") if m]
    gyro_models = [m for m in args.gyros.split(",") if m]
    if not 1 <= len(lenses) <= 3 or any(x not in LENSES for x in lenses):
        ap.error("--cameras: 1-3 of " + ", ".join(LENSES))
    if len(aux_models) > 2 or any(m not in models for m in aux_models):
        ap.error("--aux-imus: 0-2 of " + ", ".join(models))
    if len(gyro_models) > 2 or any(m not in ("none", "upper", "full") for m in gyro_models):
        ap.error("--gyros: 0-2 of none, upper, full")
    if args.rolling_shutter and (len(lenses) < 2 or args.camera_only):
        ap.error("--rolling-shutter is the second camera's, on a rig with IMUs")
    if args.images and args.target == "checkerboard":
        # SPEC 5 numbers a checkerboard's corners but does not fix which printed corner is the
        # first (a detector's choice under the board's 180 deg symmetry).
        ap.error("--images renders an AprilGrid only")
    if args.images and (any(LENSES[x][0] != "pinhole" for x in lenses) or args.board_hidden):
        ap.error("--images renders pinhole lenses, the board always in sight")
    render = None
    if args.images:
        sys.modules.setdefault("spec_sim", sys.modules[__name__])  # spec_render uses this module
        sys.dont_write_bytecode = True  # no __pycache__ in the source tree
        try:
            import spec_render as render
        except ImportError as e:
            print("spec_sim: --images needs numpy and OpenCV (Debian's python3-numpy, "
                  "python3-opencv; run /usr/bin/python3): %s" % e, file=sys.stderr)
            return 2
        tag_check = render.check_tag_bits()
    wall = time.time()
    rng = random.Random(args.seed)
    out = args.out
    os.makedirs(out, exist_ok=True)
    t0_ns = args.t0_ns
    g_mag = 9.80665

    target, points, groups = make_target(args.target)
    xs = [p[0] for p in points.values()]
    ys = [p[1] for p in points.values()]
    centre = [0.5 * (min(xs) + max(xs)), 0.5 * (min(ys) + max(ys)), 0.0]
    # The board hangs on a tilted wall: gravity mostly along the board's +y (its rows go down); a
    # printed board seen from its printed side has y up (Kalibr's print), gravity along -y.
    gdir = [rng.uniform(-0.2, 0.2), -1.0 if args.images else 1.0, rng.uniform(-0.3, 0.3)]
    g_W = scale(g_mag / norm(gdir), gdir)
    truth, R_B_L, t_B_L = make_rig(rng, args)
    cameras = [name for name in CAMERAS if name in truth]
    inertial = [] if args.camera_only else [n for n in (BASE, AUX, AUX + "2", GYRO, GYRO + "2")
                                            if n in truth]
    for name in cameras:
        scale_camera(truth[name], args.image_scale)
        if args.camera_only:  # SPEC 7: the cameras expose at once, at their stamps
            truth[name]["time_offset"] = 0.0

    # The motion: the left camera looks at the board's centre from 0.75 m in front: from the
    # board's -z side for corners, so that the board's x and y read as the image's u and v; from
    # its +z side for images, where the print is (x right, y up, z toward the viewer), upright:
    # x_C = x_W, y_C = -y_W.
    R_W_C0 = rot_x(math.pi) if args.images else eye()
    R_W_B0 = mm(R_W_C0, tr(R_B_L))
    p_W_B0 = sub([centre[0], centre[1], 0.75 if args.images else -0.75], mv(R_W_B0, t_B_L))
    traj = Trajectory(rng, p_W_B0, R_W_B0, pos_amp=0.22, rot_amp=0.45)
    self_check(traj)
    gaps = [(f * args.duration - 0.25 * args.board_hidden * args.duration,
             f * args.duration + 0.25 * args.board_hidden * args.duration) for f in (0.3, 0.7)]

    def board_visible(t):
        return not any(a <= t < b for a, b in gaps)

    for name in inertial:
        write_inertial(out, name, truth[name], traj, g_W, t0_ns, args.duration, rng,
                       groundtruth=name == BASE)
    stats = {}
    for i, name in enumerate(cameras):  # the left camera writes the optional sigma column
        if render:
            stats[name] = render.write_images(out, name, truth[name], traj, target, t0_ns,
                                              args.duration, args.cam_rate, args.seed * 10 + i)
            # The corners the images show, for a look at the detector alone (not a SPEC file).
            write_corners(out, name, truth[name], traj, points, groups, t0_ns, args.duration,
                          args.cam_rate, None, False, os.path.join(out, "groundtruth", name))
        else:
            stats[name] = write_corners(out, name, truth[name], traj, points, groups, t0_ns,
                                        args.duration, args.cam_rate, rng, name == CAM_L,
                                        board_visible=board_visible,
                                        min_corners=args.min_frame_corners)
            if args.style == "messy":
                with open(os.path.join(out, name, "data.csv"), "w") as f:
                    f.write("#timestamp [ns],filename\n")
                    f.writelines("%d,%d.png\n" % (st, st) for st in
                                 stamps(t0_ns + 25000000, args.duration - 0.05, args.cam_rate))

    base = BASE
    if args.camera_only:
        truth, base, g_W = camera_only_truth(truth, R_B_L, t_B_L), CAM_L, None
    write = write_rig if args.style == "block" else write_flow_rig
    write(os.path.join(out, "truth.yaml"), "ground truth written by scripts/spec_sim.py",
          base, g_mag, target, truth, gravity_W=g_W)
    write(os.path.join(out, "rig.yaml"),
          "coarse hand-made guess written by scripts/spec_sim.py", base, g_mag, target,
          coarse_guess(truth, rng))
    if args.style == "messy":
        for root, _, files in os.walk(out):
            for f in files:
                if f.endswith(".csv"):
                    restyle_csv(os.path.join(root, f))
        for f in ("truth.yaml", "rig.yaml"):
            restyle_yaml(os.path.join(out, f))

    form = ("%s %d images (%d with a whole tag), %.1f s" if render else
            "%s %d frames %d corners %d/16 image cells")
    cams = ", ".join(form % ((k,) + v) for k, v in stats.items())
    kinds = ("camera-only" if args.camera_only else "base %s, aux [%s], gyros [%s]" % (
        args.base_model, args.aux_imus, args.gyros))
    print("spec_sim: %s, %.1f s, seed %d, %s, cameras [%s], %s%s%s; %s; %.1f s" % (
        out, args.duration, args.seed, kinds, args.cameras, args.target,
        ", rolling shutter" if args.rolling_shutter else "",
        ", images (tag bits checked against %s)" % tag_check if render else "", cams,
        time.time() - wall))
    return 0


if __name__ == "__main__":
    sys.exit(main())
