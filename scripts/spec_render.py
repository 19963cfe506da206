"""Camera images of a printed Kalibr AprilGrid for scripts/spec_sim.py (`--images`).

Written from shared/SPEC.md (folder layout, board definition, pixel convention, rolling-shutter row
time) and Kalibr's public board generator (kalibr_create_target_pdf), without reading or importing
ctcal's renderer or detector, so that a convention ctcal's own renderer and detector share (the
pixel centre at 0 or 0.5, the tag layout and bit order, the corner ids' order, the board's origin
and axes, image row order, the rolling-shutter row time, image file names and stamps) but a real
Kalibr board contradicts shows up as a calibration that misses the truth.

The print, as kalibr_create_target_pdf draws it (PyX, y up): tag k at column k mod tagCols and row
floor(k / tagCols) has its lower-left corner at (col, row) * (1 + tagSpacing) * tagSize; its
tagSize edge holds 6 + 2 * blackTagBorder modules, a black border around tag36h11's 6 x 6 data
bits, the code's most significant bit at the top left, row by row (libapriltag's
apriltag_to_image); a black square of tagSpacing * tagSize sits at each of a tag's four corners.
The board frame is the print's (x right, y up, z out of the paper toward the viewer), so SPEC 5's
corner ids follow: point (r, c) at (c, r) in tag units, a tag's bottom-left corner first.

Each pixel is the mean of the board's reflectance over its area: the rays through the pixel's four
corners decide whether it sees one shade (most pixels) or an edge, and an edge pixel is
supersampled (16 samples). A ray is the pixel position unprojected by an iterative inverse of
SPEC 4's projection (spec_sim.radtan / spec_sim.kannala_brandt), turned into the board frame by
the camera's pose at the pixel row's read time t_S + v * line_delay, and cut with the plane z = 0.
Then
vignetting, a Gaussian blur (the lens), grey-level noise and 8-bit quantisation. numpy and OpenCV
(Debian's python3-numpy, python3-opencv): call /usr/bin/python3.
"""

import ctypes
import os
import time

import cv2
import numpy as np

import spec_sim as sim

BLACK, WHITE, BACKGROUND = 0.09, 0.86, 0.42  # reflectances: ink, paper, the wall behind the board
VIGNETTING = 0.25  # the image corners' loss of light

# --------------------------------------------------------------------------------------------
# The tag bits.

# Kalibr's tag36h11 codes of ids 0-2 (kalibr_create_target_pdf, from Kaess's AprilTags library):
# the printed module (i, j) from the top left is bit 35 - (6 i + j) of the code, 1 white.
KALIBR_T36H11 = [0xd5d628584, 0xd97f18b49, 0xdd280910e]


def tag36h11_data(tag_id):
    """The 6 x 6 data bits as printed (row 0 at the top seen from the printed side), True = white.
    OpenCV's DICT_APRILTAG_36h11 draws the codes turned by 180 deg against libapriltag's and
    Kalibr's print (check_tag_bits); printing OpenCV's drawing as is would decode to the right id
    with each tag's corners two places round (its corner ids turned by 180 deg)."""
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_APRILTAG_36h11)
    # OpenCV 4.7 renamed drawMarker generateImageMarker.
    draw = getattr(cv2.aruco, "generateImageMarker", None) or cv2.aruco.drawMarker
    drawing = draw(dictionary, tag_id, 8, borderBits=1)
    return np.rot90(drawing[1:7, 1:7] > 127, 2)


def check_tag_bits():
    """tag36h11_data against Kalibr's codes and, where libapriltag 3 loads, its apriltag_to_image
    (the detector's own family table, outer white ring and black ring removed)."""
    for tag_id, code in enumerate(KALIBR_T36H11):
        kalibr = np.array([(code >> (35 - k)) & 1 for k in range(36)], bool).reshape(6, 6)
        if not np.array_equal(tag36h11_data(tag_id), kalibr):
            raise RuntimeError("tag36h11 id %d: OpenCV's bits differ from Kalibr's print" % tag_id)
    try:
        lib = ctypes.CDLL("libapriltag.so.3")
    except OSError:
        return "Kalibr's codes of ids 0-2 (libapriltag.so.3 not found)"

    class ImageU8(ctypes.Structure):
        _fields_ = [("width", ctypes.c_int32), ("height", ctypes.c_int32),
                    ("stride", ctypes.c_int32), ("buf", ctypes.POINTER(ctypes.c_uint8))]

    lib.tag36h11_create.restype = ctypes.c_void_p
    lib.apriltag_to_image.restype = ctypes.POINTER(ImageU8)
    lib.apriltag_to_image.argtypes = [ctypes.c_void_p, ctypes.c_uint32]
    family = lib.tag36h11_create()
    for tag_id in range(0, 587, 7):  # a few hundred bytes each, left to the process's end
        im = lib.apriltag_to_image(family, tag_id).contents
        pixels = np.array([[im.buf[r * im.stride + c] for c in range(im.width)]
                           for r in range(im.height)])
        if not np.array_equal(tag36h11_data(tag_id), pixels[2:8, 2:8] > 127):
            raise RuntimeError("tag36h11 id %d: OpenCV's bits differ from libapriltag's" % tag_id)
    return "Kalibr's codes of ids 0-2 and libapriltag's images of 84 ids"


# --------------------------------------------------------------------------------------------
# The board.


class AprilGridPrint:
    """Reflectance of Kalibr's printed AprilGrid at board points (x, y), board frame of SPEC 5."""

    def __init__(self, target, margin=0.03):
        self.cols, self.rows = target["tagCols"], target["tagRows"]
        self.size = target["tagSize"]
        border = target.get("blackTagBorder", 2)
        self.n = 6 + 2 * border  # modules along a tag's edge
        self.pitch = self.size * (1.0 + target["tagSpacing"])
        gap = self.size * target["tagSpacing"]
        # White paper around the outer corner squares.
        self.paper = (-gap - margin, self.cols * self.pitch + margin,
                      -gap - margin, self.rows * self.pitch + margin)
        self.tags = np.zeros((self.cols * self.rows, self.n, self.n), bool)
        for k in range(self.cols * self.rows):
            self.tags[k, border:border + 6, border:border + 6] = tag36h11_data(k)

    def reflectance(self, x, y):
        """x, y: arrays of board points (far off the board where a ray misses it)."""
        x0, x1, y0, y1 = self.paper
        out = np.where((x >= x0) & (x <= x1) & (y >= y0) & (y <= y1), WHITE, BACKGROUND)
        bx = np.floor(x / self.pitch)
        by = np.floor(y / self.pitch)
        ux = x - bx * self.pitch  # within the tag (< size) or the gap after it
        uy = y - by * self.pitch
        in_x, in_y = ux < self.size, uy < self.size
        # The corner squares fill every gap crossing next to a tag, the board's outer ones included.
        squares = ~in_x & ~in_y & (bx >= -1) & (bx < self.cols) & (by >= -1) & (by < self.rows)
        out[squares] = BLACK
        tag = in_x & in_y & (bx >= 0) & (bx < self.cols) & (by >= 0) & (by < self.rows)
        k = (by[tag] * self.cols + bx[tag]).astype(np.int64)
        mx = np.minimum((ux[tag] / self.size * self.n).astype(np.int64), self.n - 1)
        my = np.minimum((uy[tag] / self.size * self.n).astype(np.int64), self.n - 1)
        # Module rows count from the tag's top, board y upwards.
        out[tag] = np.where(self.tags[k, self.n - 1 - my, mx], WHITE, BLACK)
        return out


# --------------------------------------------------------------------------------------------
# Rays: the inverse of SPEC 4's projection.


def unproject(cam, u, v, start=None):
    """Unit rays in the camera frame through pixel positions (u, v) (SPEC 4: pixel (0, 0) is the
    centre of the top-left pixel); nan where the model has no inverse. Newton on spec_sim's own
    distortion functions (derivatives by differences) from `start` (rays near the answer; default
    the undistorted ones) until the distortion of the answer is the pixel's to 1e-12 (normalised
    plane, ~1e-10 px)."""
    fu, fv, pu, pv = cam["intrinsics"]
    xd, yd = (u - pu) / fu, (v - pv) / fv
    k = cam["distortion_coeffs"]
    h = 1e-7
    if cam["distortion_model"] == "equidistant":
        th_d = np.sqrt(xd * xd + yd * yd)
        th = th_d if start is None else np.arctan2(np.hypot(start[..., 0], start[..., 1]),
                                                   start[..., 2])
        for _ in range(50):
            g = sim.kannala_brandt(k, th)
            if np.nanmax(np.abs(g - th_d), initial=0.0) < 1e-12:
                break
            slope = (sim.kannala_brandt(k, th + h) - g) / h
            th = np.clip(th - (g - th_d) / slope, 0.0, 3.1)
        slope = (sim.kannala_brandt(k, th + h) - sim.kannala_brandt(k, th)) / h
        ok = (np.abs(sim.kannala_brandt(k, th) - th_d) < 1e-12) & (slope > 0.0)
        s = np.sin(th) / np.where(th_d > 0.0, th_d, 1.0)
        rays = np.stack([xd * s, yd * s, np.cos(th)], axis=-1)
    else:
        x, y = (xd, yd) if start is None else (start[..., 0] / start[..., 2],
                                               start[..., 1] / start[..., 2])
        ok = np.ones(x.shape, bool)
        for _ in range(50 if cam["distortion_model"] == "radtan" else 0):
            fx, fy = sim.radtan(k, x, y)
            ex, ey = fx - xd, fy - yd
            ok = np.hypot(ex, ey) < 1e-12
            if np.all(ok | np.isnan(ex)):
                break
            ax, ay = sim.radtan(k, x + h, y)
            bx, by = sim.radtan(k, x, y + h)
            j00, j01, j10, j11 = (ax - fx) / h, (bx - fx) / h, (ay - fy) / h, (by - fy) / h
            det = j00 * j11 - j01 * j10
            # Only the branch through the image centre, where the distortion keeps orientation.
            ok &= det > 0.0
            x, y = x - (j11 * ex - j01 * ey) / det, y - (j00 * ey - j10 * ex) / det
        rays = np.stack([x, y, np.ones(x.shape)], axis=-1)
        rays /= np.linalg.norm(rays, axis=-1, keepdims=True)
    rays[~ok] = np.nan
    return rays


# A pixel's 16 samples: (i + 1/2) / 16 and ((7 i + 3) mod 16 + 1/2) / 16, a shifted rank-1
# lattice that takes every column and row of a 16 x 16 grid once, so that an edge of any direction
# is resolved to ~1/16 of a pixel (a regular 4 x 4 grid: 1/4 along the axes). The shift 3 makes it
# symmetric about the pixel's centre (sample 15 - i is sample i mirrored): without it, corners
# measured in the images move by -0.002 px in u and v against 256 samples per pixel.
SAMPLES = [((i + 0.5) / 16, ((7 * i + 3) % 16 + 0.5) / 16) for i in range(16)]


class CameraRays:
    """A camera's rays through its pixel corners and through its pixels' subsamples (SAMPLES:
    against 256 samples per pixel, ~7 grey levels RMS on edge pixels; a regular 4 x 4 grid:
    14.6)."""

    def __init__(self, cam, samples=SAMPLES):
        self.width, self.height = cam["resolution"]
        u, v = np.meshgrid(np.arange(self.width + 1) - 0.5, np.arange(self.height + 1) - 0.5)
        c = self.corners = unproject(cam, u, v)  # (H+1, W+1, 3)
        # Sample (a, b) of pixel (r, c) at u = c - 0.5 + a, v = r - 0.5 + b, one sample at a
        # time: Newton from the bilinear mean of the pixel's corner rays.
        u, v = np.meshgrid(np.arange(self.width) - 0.5, np.arange(self.height) - 0.5)
        self.subsamples = np.empty((self.height * self.width, len(samples), 3), np.float32)
        for k, (a, b) in enumerate(samples):
            start = ((1 - a) * (1 - b) * c[:-1, :-1] + a * (1 - b) * c[:-1, 1:] +
                     (1 - a) * b * c[1:, :-1] + a * b * c[1:, 1:])
            self.subsamples[:, k] = unproject(cam, u + a, v + b, start).reshape(-1, 3)
        # Forward check: spec_sim.project of some rays returns their pixels.
        worst = 0.0
        for r, c in ((0, 0), (self.height // 2, self.width // 3), (self.height, self.width)):
            ray = self.corners[r, c]
            if np.all(np.isfinite(ray)) and ray[2] > 0.1:
                uv = sim.project(cam, list(ray / ray[2]))
                worst = max(worst, abs(uv[0] - (c - 0.5)), abs(uv[1] - (r - 0.5)))
        if worst > 1e-6:
            raise RuntimeError("unprojection does not invert the projection (%g px)" % worst)


def board_points(R_W_C, p_W_C, rays):
    """Where rays (camera frame, n x m x 3) from the camera at R_W_C, p_W_C (n x 3 x 3, n x 3, or
    one pose) cut the board plane z = 0: x, y (n x m), 1e9 where they miss it (pointing away, or
    seeing the board from behind)."""
    d = np.matmul(rays, np.swapaxes(R_W_C, -1, -2))
    o = p_W_C[..., None, :]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = -o[..., 2] / d[..., 2]
        hit = (lam > 0.0) & (o[..., 2] > 0.0)
        x = np.where(hit, o[..., 0] + lam * d[..., 0], 1e9)
        y = np.where(hit, o[..., 1] + lam * d[..., 1], 1e9)
    return x, y


def render(rays, board, R_rows, p_rows):
    """Mean reflectance per pixel, H x W. R_rows, p_rows: the camera's pose per pixel row (one
    row: a global shutter)."""
    W, H = rays.width, rays.height
    rows = np.minimum(np.arange(H + 1), H - 1) if len(R_rows) > 1 else np.zeros(H + 1, int)
    x, y = board_points(R_rows[rows], p_rows[rows], rays.corners)
    a = board.reflectance(x, y)
    c = a[:-1, :-1]
    uniform = (c == a[:-1, 1:]) & (c == a[1:, :-1]) & (c == a[1:, 1:])
    image = c.copy()
    edge = np.flatnonzero(~uniform)
    if edge.size:
        sub = rays.subsamples[edge].astype(np.float64)  # (n, samples, 3)
        if len(R_rows) > 1:
            x, y = board_points(R_rows[edge // W], p_rows[edge // W], sub)
        else:
            x, y = board_points(R_rows[0], p_rows[0], sub)
        image.flat[edge] = board.reflectance(x, y).mean(axis=1)
    return image


def write_images(out, name, cam, traj, target, t0_ns, duration, rate, seed, blur_px=0.6,
                 noise_grey=2.0):
    """DATA/<name>/data/<stamp>.png and DATA/<name>/data.csv for the camera `cam` (SPEC 6), at
    the stamps spec_sim.write_corners uses; returns (frames, frames with a whole tag in view,
    seconds)."""
    wall = time.time()
    rng = np.random.default_rng(seed)
    rays = CameraRays(cam)
    board = AprilGridPrint(target)
    points, tags = sim.aprilgrid(target["tagCols"], target["tagRows"], target["tagSize"],
                                 target["tagSpacing"])
    R_B_C, t_B_C = sim.rotation_translation(cam["T_B_S"])
    W, H = rays.width, rays.height
    ld = cam.get("line_delay", 0.0)
    u, v = np.meshgrid(np.arange(W) - (W - 1) / 2.0, np.arange(H) - (H - 1) / 2.0)
    vignetting = 1.0 - VIGNETTING * (u * u + v * v) / ((W / 2.0) ** 2 + (H / 2.0) ** 2)
    os.makedirs(os.path.join(out, name, "data"), exist_ok=True)
    lines, frames, seen = [], 0, 0
    for st in sim.stamps(t0_ns + 25000000, duration - 0.05, rate):
        t_img = (st - t0_ns) * 1e-9 + cam["time_offset"]
        # SPEC 2: row v is read at t_S + v * line_delay.
        poses = [sim.camera_pose(traj, R_B_C, t_B_C, t_img + r * ld)
                 for r in (range(H) if ld > 0.0 else [0])]
        R_rows = np.array([P[0] for P in poses])
        p_rows = np.array([P[1] for P in poses])
        grey = render(rays, board, R_rows, p_rows) * vignetting * 255.0
        grey = cv2.GaussianBlur(grey, (0, 0), blur_px) + rng.normal(0.0, noise_grey, grey.shape)
        png = "%d.png" % st
        cv2.imwrite(os.path.join(out, name, "data", png),
                    np.clip(np.rint(grey), 0, 255).astype(np.uint8))
        lines.append("%d,%s\n" % (st, png))
        frames += 1
        R_W_C, p_W_C = poses[len(poses) // 2]
        for tag in tags:
            uvs = [sim.project(cam, sim.mtv(R_W_C, sim.sub(points[i], p_W_C))) for i in tag]
            if all(uv is not None and 0 <= uv[0] <= W - 1 and 0 <= uv[1] <= H - 1 for uv in uvs):
                seen += 1
                break
    with open(os.path.join(out, name, "data.csv"), "w") as f:
        f.write("#timestamp [ns],filename\n")
        f.writelines(lines)
    return frames, seen, time.time() - wall
