"""Lens distortion models: projection, unprojection, folding check, undistortion tables and
calibration files (the one home of these conventions; numpy only).

Models (OpenCV's definitions, coefficients on normalised coordinates, pixels in the OpenCV
convention with K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]):

- ``pinhole``: no distortion.
- ``brown`` (Brown-Conrady, OpenCV ``k1 k2 p1 p2 k3``, ROS ``plumb_bob``): for a point
  (X, Y, Z), x = X/Z, y = Y/Z, r^2 = x^2 + y^2,
  x_d = x (1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2),
  y_d = y (1 + k1 r^2 + k2 r^4 + k3 r^6) + p1 (r^2 + 2 y^2) + 2 p2 x y,
  u = fx x_d + cx, v = fy y_d + cy.
- ``kannala_brandt`` (equidistant fisheye, OpenCV ``cv::fisheye``, Kalibr ``equidistant``,
  ``k1 k2 k3 k4``): theta = atan2(sqrt(X^2 + Y^2), Z),
  theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
  (x_d, y_d) = theta_d (X, Y) / sqrt(X^2 + Y^2).

Depth stays planar z along the optical axis, so a lens may see at most 90 degrees off
axis (checked by :func:`fold_problem`).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

MODELS = {"pinhole": 0, "brown": 5, "kannala_brandt": 4}   # model -> number of coefficients
ROS_MODEL = {"pinhole": "plumb_bob", "brown": "plumb_bob", "kannala_brandt": "equidistant"}
KALIBR_MODEL = {"pinhole": "radial-tangential", "brown": "radial-tangential", "kannala_brandt": "equidistant"}


@dataclass(frozen=True)
class Lens:
    """A camera's intrinsics and distortion: ``model`` in :data:`MODELS`, ``coeffs`` its
    coefficients (brown: k1 k2 p1 p2 k3; kannala_brandt: k1 k2 k3 k4)."""
    model: str
    coeffs: tuple[float, ...]
    fx: float
    fy: float
    cx: float
    cy: float

    @classmethod
    def from_K(cls, model: str, coeffs, K) -> "Lens":
        K = np.asarray(K, dtype=float)
        c = tuple(float(x) for x in coeffs)
        if model not in MODELS:
            raise ValueError(f"unknown lens model {model!r} ({', '.join(MODELS)})")
        n = MODELS[model]
        if model == "brown" and len(c) == 4:
            c = c + (0.0,)
        if len(c) != n:
            raise ValueError(f"lens model {model} needs {n} coefficients, got {len(c)}")
        return cls(model, c, float(K[0, 0]), float(K[1, 1]), float(K[0, 2]), float(K[1, 2]))

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def is_pinhole(self) -> bool:
        return self.model == "pinhole" or (self.model == "brown" and not any(self.coeffs))

    def scaled(self, K) -> "Lens":
        """The same lens on other intrinsics (e.g. a resolution-scaled K)."""
        return Lens.from_K(self.model, self.coeffs, K)

    # --- normalised coordinates ----------------------------------------------------------
    def distort(self, ray: np.ndarray) -> np.ndarray:
        """Camera-frame points/rays (..., 3) -> distorted normalised coordinates (..., 2)."""
        ray = np.asarray(ray, dtype=float)
        X, Y, Z = ray[..., 0], ray[..., 1], ray[..., 2]
        if self.model == "kannala_brandt":
            rho = np.hypot(X, Y)
            theta = np.arctan2(rho, Z)
            k1, k2, k3, k4 = self.coeffs
            t2 = theta * theta
            theta_d = theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
            with np.errstate(invalid="ignore", divide="ignore"):
                s = np.where(rho > 0, theta_d / np.where(rho > 0, rho, 1.0), 1.0 / np.where(Z != 0, Z, 1.0))
            return np.stack([X * s, Y * s], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            x, y = X / Z, Y / Z
        if self.model == "pinhole":
            return np.stack([x, y], axis=-1)
        return brown_distort(np.stack([x, y], axis=-1), self.coeffs)

    def undistort(self, xd: np.ndarray) -> np.ndarray:
        """Distorted normalised coordinates (..., 2) -> unit rays (..., 3) in the camera frame."""
        xd = np.asarray(xd, dtype=float)
        if self.model == "kannala_brandt":
            theta_d = np.hypot(xd[..., 0], xd[..., 1])
            theta = kb_theta(theta_d, self.coeffs)
            with np.errstate(invalid="ignore", divide="ignore"):
                s = np.where(theta_d > 0, np.sin(theta) / np.where(theta_d > 0, theta_d, 1.0), 1.0)
            return np.stack([xd[..., 0] * s, xd[..., 1] * s, np.cos(theta)], axis=-1)
        x = xd if self.model == "pinhole" else brown_undistort(xd, self.coeffs)
        ray = np.concatenate([x, np.ones(x.shape[:-1] + (1,))], axis=-1)
        return ray / np.linalg.norm(ray, axis=-1, keepdims=True)

    # --- pixels --------------------------------------------------------------------------
    def project(self, X_cam: np.ndarray) -> np.ndarray:
        """Camera-frame points (..., 3) -> pixels (..., 2)."""
        d = self.distort(X_cam)
        return np.stack([self.fx * d[..., 0] + self.cx, self.fy * d[..., 1] + self.cy], axis=-1)

    def unproject(self, px: np.ndarray) -> np.ndarray:
        """Pixels (..., 2) -> unit rays (..., 3) (camera frame, z forward)."""
        px = np.asarray(px, dtype=float)
        xd = np.stack([(px[..., 0] - self.cx) / self.fx, (px[..., 1] - self.cy) / self.fy], axis=-1)
        return self.undistort(xd)

    def pixel_rays(self, width: int, height: int) -> np.ndarray:
        """(H, W, 3) unit rays through every pixel centre."""
        v, u = np.mgrid[0:height, 0:width].astype(float)
        return self.unproject(np.stack([u, v], axis=-1))

    def to_json(self) -> dict:
        return {"model": self.model, "coeffs": list(self.coeffs), "fx": self.fx, "fy": self.fy,
                "cx": self.cx, "cy": self.cy, "ros_distortion_model": ROS_MODEL[self.model]}


# --- the two models ----------------------------------------------------------------------

def brown_distort(x: np.ndarray, coeffs) -> np.ndarray:
    k1, k2, p1, p2, k3 = (tuple(coeffs) + (0.0,) * 5)[:5]
    u, v = x[..., 0], x[..., 1]
    r2 = u * u + v * v
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    return np.stack([u * radial + 2 * p1 * u * v + p2 * (r2 + 2 * u * u),
                     v * radial + p1 * (r2 + 2 * v * v) + 2 * p2 * u * v], axis=-1)


def _brown_jacobian(x: np.ndarray, coeffs) -> np.ndarray:
    k1, k2, p1, p2, k3 = (tuple(coeffs) + (0.0,) * 5)[:5]
    u, v = x[..., 0], x[..., 1]
    r2 = u * u + v * v
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2)           # d radial / d r2
    J = np.empty(x.shape[:-1] + (2, 2))
    J[..., 0, 0] = radial + 2 * u * u * dradial + 2 * p1 * v + 6 * p2 * u
    J[..., 0, 1] = 2 * u * v * dradial + 2 * p1 * u + 2 * p2 * v
    J[..., 1, 0] = 2 * u * v * dradial + 2 * p1 * u + 2 * p2 * v
    J[..., 1, 1] = radial + 2 * v * v * dradial + 6 * p1 * v + 2 * p2 * u
    return J


def brown_undistort(xd: np.ndarray, coeffs, iterations: int = 20) -> np.ndarray:
    """Inverse of :func:`brown_distort` by Newton's method (converges to 1e-15 on a lens
    that passes :func:`fold_problem`)."""
    xd = np.asarray(xd, dtype=float)
    x = xd.copy()
    for _ in range(iterations):
        r = brown_distort(x, coeffs) - xd
        J = _brown_jacobian(x, coeffs)
        det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
        det = np.where(np.abs(det) > 1e-12, det, 1e-12)
        dx = (J[..., 1, 1] * r[..., 0] - J[..., 0, 1] * r[..., 1]) / det
        dy = (-J[..., 1, 0] * r[..., 0] + J[..., 0, 0] * r[..., 1]) / det
        x = x - np.stack([dx, dy], axis=-1)
    return x


def kb_theta_d(theta, coeffs):
    k1, k2, k3, k4 = coeffs
    t2 = np.asarray(theta, dtype=float) ** 2
    return theta * (1 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))


def kb_dtheta_d(theta, coeffs):
    k1, k2, k3, k4 = coeffs
    t2 = np.asarray(theta, dtype=float) ** 2
    return 1 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))


def kb_theta(theta_d, coeffs, iterations: int = 30):
    """Inverse of theta -> theta_d by Newton's method."""
    theta_d = np.asarray(theta_d, dtype=float)
    t = theta_d.copy()
    for _ in range(iterations):
        d = kb_dtheta_d(t, coeffs)
        t = t - (kb_theta_d(t, coeffs) - theta_d) / np.where(np.abs(d) > 1e-12, d, 1e-12)
    return t


# --- checks ------------------------------------------------------------------------------

def _max_image_radius(lens: Lens, width: int, height: int) -> float:
    """Largest normalised distorted radius of the image (its corners, half a pixel out)."""
    us = np.array([-0.5, width - 0.5])
    vs = np.array([-0.5, height - 0.5])
    return float(max(np.hypot((u - lens.cx) / lens.fx, (v - lens.cy) / lens.fy) for u in us for v in vs))


def fold_problem(lens: Lens, width: int, height: int) -> Optional[str]:
    """None if the lens maps the scene one-to-one onto the whole image (no folding, every
    pixel sees exactly one direction, at most 90 degrees off axis); else what is wrong."""
    if lens.is_pinhole:
        return None
    rho_max = _max_image_radius(lens, width, height)
    if lens.model == "kannala_brandt":
        theta = np.linspace(0.0, np.pi / 2, 20001)
        d = kb_dtheta_d(theta, lens.coeffs)
        td = kb_theta_d(theta, lens.coeffs)
        reach = np.nonzero(td >= rho_max)[0]
        bad = np.nonzero(d <= 0)[0]
        if bad.size and (not reach.size or bad[0] <= reach[0]):
            return (f"the distortion folds the image: theta_d stops growing at {np.degrees(theta[bad[0]]):.1f} deg "
                    f"off axis, before the image corners (normalised radius {rho_max:.3f}) are reached")
        if not reach.size:
            return (f"the image corners lie more than 90 degrees off the optical axis "
                    f"(normalised radius {rho_max:.3f} > theta_d(90 deg) = {td[-1]:.3f}): planar depth is undefined there")
        return None
    k1, k2, p1, p2, k3 = lens.coeffs
    r = np.linspace(0.0, 50.0, 200001)
    r2 = r * r
    rd = r * (1 + r2 * (k1 + r2 * (k2 + r2 * k3)))
    drd = 1 + r2 * (3 * k1 + r2 * (5 * k2 + r2 * 7 * k3))
    reach = np.nonzero(rd >= rho_max * 1.02)[0]
    bad = np.nonzero(drd <= 0)[0]
    if bad.size and (not reach.size or bad[0] <= reach[0]):
        return (f"the distortion folds the image: the radial distortion stops growing at normalised radius "
                f"{r[bad[0]]:.3f}, before the image corners (distorted radius {rho_max:.3f}) are reached")
    if not reach.size:
        return f"the distortion never reaches the image corners (distorted radius {rho_max:.3f})"
    # the tangential terms too: the Jacobian of the full map stays positive on the covered disc
    rr, aa = np.meshgrid(np.linspace(0.0, r[reach[0]], 200), np.linspace(0.0, 2 * np.pi, 361))
    J = _brown_jacobian(np.stack([rr * np.cos(aa), rr * np.sin(aa)], axis=-1), lens.coeffs)
    det = J[..., 0, 0] * J[..., 1, 1] - J[..., 0, 1] * J[..., 1, 0]
    if np.any(det <= 0):
        return "the distortion folds the image (its Jacobian changes sign inside the field of view)"
    return None


# --- tables and files --------------------------------------------------------------------

def undistortion_maps(lens: Lens, width: int, height: int, K_new=None) -> tuple[np.ndarray, np.ndarray]:
    """For every pixel of the undistorted (pinhole, intrinsics ``K_new``, default the lens's
    K) image, the distorted pixel to sample: (map_x, map_y) float64 (H, W). This is the
    meaning of a RobotCar lookup table and of a ``cv2.remap`` map pair."""
    K_new = lens.K if K_new is None else np.asarray(K_new, dtype=float)
    v, u = np.mgrid[0:height, 0:width].astype(float)
    ray = np.stack([(u - K_new[0, 2]) / K_new[0, 0], (v - K_new[1, 2]) / K_new[1, 1], np.ones_like(u)], axis=-1)
    px = lens.project(ray)
    return px[..., 0], px[..., 1]


def robotcar_lut_bytes(map_x: np.ndarray, map_y: np.ndarray) -> bytes:
    """RobotCar binary layout: float64 little-endian, all W*H u then all W*H v, row-major."""
    return np.concatenate([np.asarray(map_x, "<f8").ravel(), np.asarray(map_y, "<f8").ravel()]).tobytes()


def real_text(x: float) -> str:
    """A float as YAML text that stays a real (OpenCV reads '0' as an integer)."""
    s = repr(float(x) + 0.0)   # the shortest text that reads back exactly; + 0.0: no '-0.0'
    return s if any(c in s for c in ".eEn") else s + ".0"


def opencv_matrix_text(name: str, M: np.ndarray, dt: str = "d") -> str:
    """``name: !!opencv-matrix`` (cv::FileStorage YAML); ``dt`` d = float64, f = float32."""
    M = np.atleast_2d(np.asarray(M, dtype=float))
    data = ", ".join(real_text(x) for x in M.ravel())
    return (f"{name}: !!opencv-matrix\n   rows: {M.shape[0]}\n   cols: {M.shape[1]}\n   dt: {dt}\n"
            f"   data: [ {data} ]\n")


def opencv_calibration_yaml(lens: Lens, width: int, height: int, name: str = "camera") -> str:
    """An OpenCV ``cv::FileStorage`` calibration file (readable by ``cv2.FileStorage``):
    image size, ``camera_matrix``, ``distortion_coefficients`` (k1 k2 p1 p2 k3 for
    brown/pinhole, k1..k4 for ``cv::fisheye``) and the model name."""
    coeffs = list(lens.coeffs) if lens.model != "pinhole" else [0.0] * 5
    return ("%YAML:1.0\n---\n"
            f"image_width: {int(width)}\nimage_height: {int(height)}\ncamera_name: {name}\n"
            + opencv_matrix_text("camera_matrix", lens.K)
            + f"distortion_model: {ROS_MODEL[lens.model]}\n"
            + opencv_matrix_text("distortion_coefficients", np.array([coeffs])))
