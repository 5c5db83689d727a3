"""Spherical harmonics on NumPy arrays (guide "Spherical harmonics: the terms the commands
print").

Real, orthonormal basis without the Condon–Shortley phase; coefficient k = l(l+1) + m, so
l_max = L means (L+1)² coefficients. RGB coefficient arrays have shape ((L+1)², 3), float64.
"""

from __future__ import annotations

import os
from typing import Optional, Sequence, Union

import numpy as np

from . import _args, _reflect

__all__ = ["evaluate", "index", "lm", "project", "rotate", "rotation_xyz_deg", "transfer"]

ArrayLike = Union[np.ndarray, Sequence]


def index(l: int, m: int) -> int:  # noqa: E741  (the paper's symbol)
    """Flat index k = l(l+1) + m of Y_lm."""
    l = _args.integer("l", l)  # noqa: E741
    m = _args.integer("m", m, -(2**62), 2**62)
    if not -l <= m <= l:
        raise ValueError(f"m = {m} is outside -l..l for l = {l}")
    return l * (l + 1) + m


def lm(k: int) -> tuple:
    """(l, m) of flat index k."""
    k = _args.integer("k", k)
    l = int(np.floor(np.sqrt(k)))  # noqa: E741
    return l, k - l * (l + 1)


def project(
    env: Union[str, "os.PathLike[str]", ArrayLike], mapping: Optional[str] = None, *, lmax: int
) -> np.ndarray:
    """L_lm of an environment map: ((lmax+1)², 3) float64.

    ``env`` is an ``.exr``/``.hdr`` file or an (H, W, 3) array of linear RGB radiance (taken as
    float32, the precision the renderer lights with). ``mapping`` is ``"latlong"`` or
    ``"angular"`` (guide "Environment maps and `rotate_deg`"); by default it is inferred from
    the aspect ratio (W = H angular, W = 2H lat-long). Each Y_lm is integrated exactly over each pixel of the
    piecewise-constant map, so every order is the exact expansion of the map the renderer lights
    with (``reflect sh project``). lmax ≤ 200.
    """
    if isinstance(env, (str, os.PathLike)):
        return _reflect.sh_project_file(os.fspath(env), _args.optional_string("mapping", mapping), _lmax(lmax))
    a = np.ascontiguousarray(env, dtype=np.float32)
    if a.ndim != 3:
        raise ValueError(f"environment array must have shape (H, W, 3), got {a.shape}")
    return _reflect.sh_project_array(a, _args.optional_string("mapping", mapping), _lmax(lmax))


def _lmax(lmax: object) -> int:
    return _args.integer("lmax", lmax, 0, 200)


def _rgb(coeffs: ArrayLike) -> tuple:
    c = np.asarray(coeffs, dtype=np.float64)
    if c.ndim == 1:
        return np.ascontiguousarray(np.repeat(c[:, None], 3, axis=1)), True
    if c.ndim == 2 and c.shape[1] == 3:
        return np.ascontiguousarray(c), False
    raise ValueError(f"coefficients must have shape ((lmax+1)²,) or ((lmax+1)², 3), got {c.shape}")


def evaluate(coeffs: ArrayLike, directions: ArrayLike) -> np.ndarray:
    """f(ω) = Σ_k c_k Y_k(ω) at each direction.

    ``coeffs``: ((L+1)², 3) RGB or ((L+1)²,) scalar. ``directions``: (..., 3), world frame
    (+z up), normalized here. Returns (..., 3) for RGB coefficients, (...) for scalar ones,
    float64.
    """
    c, scalar = _rgb(coeffs)
    d = np.asarray(directions, dtype=np.float64)
    if d.shape[-1:] != (3,):
        raise ValueError(f"directions must have shape (..., 3), got {d.shape}")
    out = _reflect.sh_evaluate(c, np.ascontiguousarray(d.reshape(-1, 3))).reshape(d.shape[:-1] + (3,))
    return out[..., 0] if scalar else out


def transfer(
    brdf: str,
    lmax: int,
    *,
    s: Optional[float] = None,
    sigma: Optional[float] = None,
    theta_o_deg: Optional[float] = None,
) -> np.ndarray:
    """Λ_l ρ̂_l for l = 0 … lmax: (lmax+1,) float64, for unit albedo / k_s (guide "BRDFs").

    ``brdf``: ``"lambert"`` (eq. 38: 1, 2/3, 1/4, 0, −1/24, …), ``"phong"`` with exponent ``s``
    (eq. 43, exact), ``"mirror"`` (eq. 33: all 1) or ``"torrance-sparrow"`` with roughness
    ``sigma`` in radians (eq. 50 by numerical integration; at exitance angle ``theta_o_deg``
    the q = 0 coefficient of eq. 49). As ``reflect sh transfer --json``'s ``lambda_rho``.
    """
    s, sigma = _args.optional_real("s", s), _args.optional_real("sigma", sigma)
    theta_o_deg = _args.optional_real("theta_o_deg", theta_o_deg)
    f, _approx = _reflect.sh_transfer(_args.string("brdf", brdf), _lmax(lmax), s, sigma, theta_o_deg)
    return f


def rotation_xyz_deg(deg: ArrayLike) -> np.ndarray:
    """The scene file's ``rotate_deg = [ax, ay, az]`` as a 3 × 3 matrix: R = R_z R_y R_x."""
    ax, ay, az = np.radians(np.asarray(deg, dtype=np.float64).reshape(3))

    def about(i: int, a: float) -> np.ndarray:
        c, s = np.cos(a), np.sin(a)
        j, k = (i + 1) % 3, (i + 2) % 3
        r = np.eye(3)
        r[j, j], r[j, k], r[k, j], r[k, k] = c, -s, s, c
        return r

    return about(2, az) @ about(1, ay) @ about(0, ax)


def rotate(coeffs: ArrayLike, rotation: ArrayLike) -> np.ndarray:
    """Coefficients of the rotated function f_R(ω) = f(Rᵀω) (eq. 3: orders mix only within l).

    ``rotation``: a 3 × 3 rotation matrix R (orthonormal, det +1), an object with
    ``as_matrix()`` (e.g. ``scipy.spatial.transform.Rotation``), or three angles in degrees taken
    as a scene file's ``rotate_deg`` (see :func:`rotation_xyz_deg`). Exact quadrature, so the
    result equals the projection of the rotated function to rounding error. Same shape as
    ``coeffs``.
    """
    c, scalar = _rgb(coeffs)
    if hasattr(rotation, "as_matrix"):
        rotation = rotation.as_matrix()
    r = np.asarray(rotation, dtype=np.float64)
    if r.shape == (3,):
        r = rotation_xyz_deg(r)
    out = _reflect.sh_rotate(c, np.ascontiguousarray(r))
    return out[:, 0] if scalar else out
