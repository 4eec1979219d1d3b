"""The rig in 3D: a resolved scenario (`geneva scenario show`) read as a physical set-up — a
camera at a distance from the disc plane, a wheel turning about the world z axis, a printed
marker on it — and turned into world matrices for Blender.

Conventions are the scenario's documented ones (scenarios/README.md): metres; the disc plane
z = 0 with the rotation centre at the origin, x to the right and y down in the image of an
untilted camera, angles from +x towards +y; the camera on the -z side looking along +z;
camera-to-world R = Rx(tilt_x)·Ry(tilt_y) about the camera's own axes (x right, y down,
z forward); the rotation centre imaged at `camera.rotation_centre_px`. Nothing here is taken
from the project's renderers: this module derives the set-up from those statements alone.
"""

import math

import numpy as np


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]], dtype=float)


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]], dtype=float)


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]], dtype=float)


def rows(rotation, translation):
    """A 4×4 world matrix as the 16 row-major floats the Blender script reads."""
    m = np.eye(4)
    m[:3, :3] = rotation
    m[:3, 3] = translation
    return [float(v) for v in m.reshape(-1)]


def look_at(position, target, up_hint=(0.0, -1.0, 0.0)):
    """Rotation whose local -Z points from `position` at `target` (Blender's lights and
    cameras look along their local -Z)."""
    position, target = np.asarray(position, float), np.asarray(target, float)
    back = position - target
    back /= np.linalg.norm(back)
    right = np.cross(np.asarray(up_hint, float), back)
    if np.linalg.norm(right) < 1e-9:
        right = np.cross((1.0, 0.0, 0.0), back)
    right /= np.linalg.norm(right)
    up = np.cross(back, right)
    return np.column_stack([right, up, back])


class Camera:
    """The scenario's pinhole camera: intrinsics, and its pose in the world."""

    def __init__(self, scenario):
        cam = scenario["camera"]
        self.width = int(cam["width_px"])
        self.height = int(cam["height_px"])
        self.distance_m = float(cam["distance_m"])
        focal = cam["focal"]
        kind = focal["kind"]
        if kind == "image_scale":
            self.focal_px = 1000.0 * self.distance_m / float(focal["mm_per_px"])
        elif kind == "physical":
            self.focal_px = (float(focal["focal_length_mm"]) * self.width
                             / float(focal["sensor_width_mm"]))
        elif kind == "field_of_view":
            self.focal_px = self.width / (2.0 * math.tan(math.radians(float(focal["hfov_deg"])) / 2))
        else:
            raise ValueError(f"camera.focal.kind `{kind}`: not a focal length this tool reads")
        centre = ((self.width - 1) / 2.0, (self.height - 1) / 2.0)
        self.principal_px = np.array(cam.get("principal_point_px", centre), dtype=float)
        self.rotation_centre_px = np.array(cam.get("rotation_centre_px", centre), dtype=float)
        tilt = cam.get("perspective_tilt", {})
        self.tilt_deg = (float(tilt.get("tilt_x_deg", 0.0)), float(tilt.get("tilt_y_deg", 0.0))) \
            if tilt.get("enabled", False) else (0.0, 0.0)
        lens = cam.get("lens_distortion", {})
        self.distortion = [float(lens.get(k, 0.0)) for k in ("k1", "k2", "k3", "p1", "p2")] \
            if lens.get("enabled", False) else None

    def set_tilt(self, tilt_x_deg, tilt_y_deg):
        self.tilt_deg = (tilt_x_deg, tilt_y_deg)

    def camera_to_world(self):
        tx, ty = (math.radians(a) for a in self.tilt_deg)
        return rot_x(tx) @ rot_y(ty)

    def position_m(self):
        """The camera centre: on the ray through the rotation centre's pixel (undistorted, as
        the lens bends it), at the stated distance from the disc plane."""
        n = (self.rotation_centre_px - self.principal_px) / self.focal_px
        if self.distortion is not None:
            n = undistort_normalised(self.distortion, n)
        ray = self.camera_to_world() @ np.array([n[0], n[1], 1.0])
        if ray[2] <= 1e-6 * np.linalg.norm(ray):
            raise ValueError("camera: the rotation centre is behind the camera under this tilt")
        return -ray * (self.distance_m / ray[2])

    def blender_rotation(self, extra=None):
        """Blender's camera axes (x right, y up, z back) in the world, with an optional extra
        rotation about the camera's own axes (a shake, a loose mount)."""
        r = self.camera_to_world()
        if extra is not None:
            r = r @ extra
        return r @ np.diag([1.0, -1.0, -1.0])

    def project(self, points_m, position=None, rotation=None):
        """World points → undistorted pixels (for metering and checks inside this tool)."""
        position = self.position_m() if position is None else position
        r = self.camera_to_world() if rotation is None else rotation
        pc = (np.asarray(points_m, float) - position) @ r
        return self.principal_px + self.focal_px * pc[:, :2] / pc[:, 2:3]


def distort_normalised(coeffs, n):
    """Brown–Conrady on normalised coordinates (OpenCV's k1 k2 k3 p1 p2 form)."""
    k1, k2, k3, p1, p2 = coeffs
    x, y = n[..., 0], n[..., 1]
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def undistort_normalised(coeffs, nd, iterations=40):
    """The undistorted point whose distortion is `nd` (fixed-point iteration, as OpenCV's
    undistortPoints does; fine where the lens does not fold over)."""
    nd = np.asarray(nd, float)
    n = nd.copy()
    for _ in range(iterations):
        err = distort_normalised(coeffs, n) - nd
        n = n - err
    return n


def marker_sheet(scenario, image_path, material, laminate=0.0):
    """The printed sheet (black square + white margin) as the Blender script builds it."""
    m = scenario["scene"]["marker"]
    size = float(m["size_mm"]) * 1e-3
    margin = float(m["white_margin_mm"]) * 1e-3
    mat = dict(material)
    mat["laminate"] = laminate
    return {
        "image": image_path,
        "paper_side_m": size + 2 * margin,
        "thickness_m": 0.0001,
        "material": mat,
    }


def marker_local(scenario, creep_rad=0.0):
    """The marker's pose on the wheel: centre at `radius_mm` and angle `angle_on_disc_deg`
    (plus a creep), printed right axis turned by `orientation_deg` from the radial direction."""
    m = scenario["scene"]["marker"]
    phi = math.radians(float(m["angle_on_disc_deg"])) + creep_rad
    r = float(m["radius_mm"]) * 1e-3
    centre = (r * math.cos(phi), r * math.sin(phi), 0.0)
    return rows(rot_z(phi + math.radians(float(m["orientation_deg"]))), centre)


def wheel_matrix(theta2_rad, centre_offset_m, wobble_rad=0.0, wobble_axis_rad=0.0):
    """The wheel at one instant: turned by θ2 about the axle (world z), its centre displaced
    in the plane; a wobble tilts the disc by `wobble_rad` about a diameter fixed in the wheel."""
    r = rot_z(theta2_rad)
    if wobble_rad:
        r = r @ rot_z(wobble_axis_rad) @ rot_x(wobble_rad) @ rot_z(-wobble_axis_rad)
    return rows(r, (centre_offset_m[0], centre_offset_m[1], 0.0))


def tape_strips(scenario):
    """Two strips of tape across the sheet's left and right margins onto the disc (in the
    sheet's frame): they never cover the black square."""
    m = scenario["scene"]["marker"]
    size = float(m["size_mm"]) * 1e-3
    margin = float(m["white_margin_mm"]) * 1e-3
    half = size / 2
    strips = []
    width = min(0.6 * margin, 0.012)
    for sign in (-1, 1):
        x0 = sign * (half + 0.2 * margin)
        x1 = sign * (half + 0.2 * margin + width)
        lo, hi = min(x0, x1), max(x0, x1)
        ext = half + margin + 0.012
        strips.append([(lo, -ext), (hi, -ext), (hi, ext), (lo, ext)])
    return strips
