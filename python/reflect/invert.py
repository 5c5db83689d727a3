"""Inverse rendering from images of a sphere (paper sec. 2.2 and 3): ``reflect invert …`` in Python.

Each function runs the command's own code in this process and returns the document its
``--json`` prints, as a dict with NumPy arrays for the lists of numbers (see
:func:`reflect.analyze` for the conversion and for the image arguments: paths, renders, or
(H, W, 3) arrays with ``camera`` / ``sphere`` / ``scene`` describing them). Keyword arguments are
the command's flags (``max_amplification=20`` is ``--max-amplification 20``, ``from_=…`` is
``--from``; True is a bare flag;
vectors and RGB triples are sequences; one value per image is a list); a flag the CLI gains is
accepted here too. Bad input raises ``ValueError`` (``FileNotFoundError`` for a missing file) with
the command's one-line message, its flags named as keywords (``--from`` → ``from_=``).
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Union

from ._commands import ImageLike, run

__all__ = ["brdf", "factor", "lighting", "separate"]

Images = Union[ImageLike, Sequence[ImageLike]]


def lighting(
    images: Images,
    *,
    lmax: int,
    brdf: Optional[str] = None,
    s: Optional[float] = None,
    sigma: Optional[float] = None,
    albedo: Union[None, float, Sequence[float]] = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    **flags: Any,
) -> Dict[str, Any]:
    """The lighting L_lm from images of a sphere of known BRDF (eq. 17): ``reflect invert lighting --json``.

    L_lm = B_lm / (albedo Λ_l ρ̂_l) per order (a normal-probe image), or fitted in pixel space over
    the visible normals (orthographic views), with standard errors, the noise amplification and
    status of each order (``recovered`` / ``ill-conditioned`` / ``unobservable``: NaN rows in
    ``coefficients``), and the Tikhonov-regularised lighting (``regularised``). ``brdf``, ``s``,
    ``sigma``, ``albedo``: the BRDF (default: the image header's). Other flags:
    ``max_amplification``, ``lambda_rule`` ("gcv" | "discrepancy"), ``output`` (a lat-long EXR
    of the regularised lighting) and ``width``.

    Returns e.g. ``coefficients`` ((lmax+1)², 3) float64 (NaN where unobservable), ``stderr``
    likewise, ``lm`` ((lmax+1)², 2) int64, ``lambda_rho`` (lmax+1,), ``orders`` (list of dicts),
    ``regularised["coefficients"]`` ((lmax+1)², 3), ``warnings`` (list of str).
    """
    return run(
        ["invert", "lighting"],
        images,
        dict(lmax=lmax, brdf=brdf, s=s, sigma=sigma, albedo=albedo, **flags),
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
    )


def brdf(
    images: Images,
    *,
    model: str,
    lmax: int,
    lighting: Any = None,
    mapping: Optional[str] = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    **flags: Any,
) -> Dict[str, Any]:
    """Λ_l ρ̂_l per order (eq. 16) and the fitted Phong s or Torrance–Sparrow σ: ``reflect invert brdf --json``.

    ``model``: "phong" (exponent s, eq. 43) or "torrance-sparrow" (roughness σ in radians, eq. 50
    / 59). ``lighting``: as in :func:`reflect.analyze` (a file, a ``[lighting]`` dict, SH
    coefficients or an environment-map array; default the image header's). Flags ``min`` and
    ``max``: the parameter's search range. Returns e.g. ``estimate`` (float), ``interval`` (2,)
    float64 (NaN: unbounded within the range), ``filter`` (list of per-order dicts with
    ``estimate`` / ``stderr`` (3,) arrays), ``profile`` (N, 2) float64 of (parameter, Δχ²).
    """
    return run(
        ["invert", "brdf"],
        images,
        dict(model=model, lmax=lmax, mapping=mapping, **flags),
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
        lighting=lighting,
    )


def separate(
    images: Images,
    *,
    kd: Union[None, float, Sequence[float]] = None,
    ks: Union[None, float, Sequence[float]] = None,
    lmax: Optional[int] = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    **flags: Any,
) -> Dict[str, Any]:
    """Diffuse + specular separation (sec. 3.5): ``reflect invert separate --json``.

    ``images``: normal-probe views of a k_d · lambert + k_s · mirror sphere, the diffuse view
    (θ_o = 0) first, then specular views (θ_o > 0, φ_o 0 or 180). Arrays need ``camera`` (one
    ``{"type": "normal-probe", "theta_o_deg": …, "phi_o_deg": …}`` per array). ``kd``, ``ks``:
    one number or RGB (default: the header's mix). Flags: ``channel`` ("r" | "g" | "b"), ``scan``
    (True), ``output``, ``width``.
    """
    return run(
        ["invert", "separate"],
        images,
        dict(kd=kd, ks=ks, lmax=lmax, **flags),
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
    )


def factor(
    images: Images = (),
    *,
    lmax: Optional[int] = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    stderr: Any = None,
    **flags: Any,
) -> Dict[str, Any]:
    """Factor a sphere's reflected light field into lighting and BRDF up to scale (eq. 18, 23):
    ``reflect invert factor --json``.

    ``images``: normal-probe renders, one per node of an n_μ × n_φ product rule. Or no images and
    ``scene="scene.toml"``, ``nodes=(n_mu, n_phi)`` (``size=(W, H)``): the light field is rendered
    in memory. Flags: ``normal`` (a θ_o = 0 render), ``channel``, ``quadrature`` ("fejer" |
    "pixel"), ``max_amplification``. Returns e.g. ``orders`` (list of dicts), ``lighting``
    ((lmax+1)²,) float64 (L_lm / P, NaN where ambiguous).
    """
    return run(["invert", "factor"], images, dict(lmax=lmax, **flags), camera=camera, sphere=sphere, stderr=stderr)
