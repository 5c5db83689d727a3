"""Inverse rendering from images of a sphere (paper sec. 2.2 and 3): the analyses of ``reflect
invert …``, called directly.

:func:`lighting`, :func:`brdf`, :func:`separate` and :func:`factor` take images as :func:`reflect.analyze` does
(paths, renders, or (H, W, 3) arrays with ``camera`` / ``sphere`` / ``scene`` / ``stderr``
describing them), write no file, and return report objects (:class:`reflect.InvertLightingReport`,
…) whose attributes are NumPy arrays and whose ``to_dict()`` is the CLI's ``--json`` document. Bad
input raises :class:`reflect.InputError` (a ``ValueError``; :class:`reflect.MissingFileError` for
a missing file) naming the keyword or the image.

:func:`factor` also renders a scene's light field in memory when given ``scene=`` and no images.
"""

from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Union

from . import _analysis
from ._analysis import Images, InvertBrdfReport, InvertFactorReport, InvertLightingReport, InvertSeparateReport

__all__ = ["brdf", "factor", "lighting", "separate"]


def lighting(
    images: Images,
    *,
    lmax: int,
    brdf: Optional[str] = None,
    s: Optional[float] = None,
    sigma: Optional[float] = None,
    brdf_params: Optional[Dict[str, Any]] = None,
    albedo: Union[None, float, Sequence[float]] = None,
    max_amplification: float = 10.0,
    lambda_rule: str = "gcv",
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
    pixel_filter: Optional[str] = None,
) -> InvertLightingReport:
    """The lighting L_lm from images of a sphere of known BRDF (eq. 17): ``reflect invert lighting``.

    L_lm = B_lm / (albedo Λ_l ρ̂_l) per order (a normal-probe image), or fitted in pixel space over
    the visible normals (orthographic views), with standard errors, the noise amplification and
    status of each order (``recovered`` / ``ill-conditioned`` / ``unobservable``: NaN rows in
    ``coefficients``), and the Tikhonov-regularised lighting (``regularised``, λ by
    ``lambda_rule`` "gcv" or "discrepancy"). ``brdf``, ``s``, ``sigma``, ``brdf_params``,
    ``albedo`` (one number or r, g, b): the BRDF where the images do not say it (a value that
    contradicts theirs is an error naming both). ``max_amplification`` (≥ 1): the noise
    amplification above which an order is ill-conditioned.

    Returns an :class:`reflect.InvertLightingReport`: ``coefficients`` ((lmax+1)², 3) float64
    (radiance; NaN where unobservable), ``stderr`` likewise, ``lm`` ((lmax+1)², 2) int64,
    ``lambda_rho`` (lmax+1,), ``albedo`` (3,), ``orders`` (list of dicts),
    ``regularised["coefficients"]`` ((lmax+1)², 3), ``warnings`` (list of str). Evaluate the
    regularised lighting on directions with :func:`reflect.sh.evaluate`.
    """
    return _analysis.invert_lighting(
        images,
        lmax=lmax,
        brdf=brdf,
        s=s,
        sigma=sigma,
        brdf_params=brdf_params,
        albedo=albedo,
        max_amplification=max_amplification,
        lambda_rule=lambda_rule,
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
        layer=layer,
        pixel_filter=pixel_filter,
    )


def brdf(
    images: Images,
    *,
    model: str,
    lmax: int,
    lighting: Any = None,
    mapping: Optional[str] = None,
    distribution: Optional[str] = None,
    min: Optional[float] = None,
    max: Optional[float] = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
    pixel_filter: Optional[str] = None,
) -> InvertBrdfReport:
    """Λ_l ρ̂_l per order (eq. 16) and the fitted model parameter: ``reflect invert brdf``.

    ``model``: "phong" (exponent s, eq. 43), "torrance-sparrow" (roughness σ in radians, eq. 50 /
    59) or "microfacet" (roughness α; ``distribution`` "beckmann" (default) or "ggx").
    ``lighting``: as in :func:`reflect.analyze` (a file, a ``[lighting]`` dict, SH coefficients or
    an environment-map array; default the images' own). ``min``, ``max``: the parameter's search
    range. Returns an :class:`reflect.InvertBrdfReport`: ``estimate`` (float), ``interval`` (2,)
    float64 (NaN: unbounded within the range), ``filter`` (per order: ``estimate`` / ``stderr``
    (3,)), ``profile`` (N, 2) float64 of (parameter, Δχ²).
    """
    return _analysis.invert_brdf(
        images,
        model=model,
        lmax=lmax,
        lighting=lighting,
        mapping=mapping,
        distribution=distribution,
        min=min,
        max=max,
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
        layer=layer,
        pixel_filter=pixel_filter,
    )


def separate(
    images: Images,
    *,
    lmax: int = 8,
    kd: Union[None, float, Sequence[float]] = None,
    ks: Union[None, float, Sequence[float]] = None,
    channel: Optional[str] = None,
    scan: bool = False,
    camera: Any = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
) -> InvertSeparateReport:
    """Diffuse + specular separation (sec. 3.5): ``reflect invert separate``.

    ``images``: normal-probe views of a k_d · lambert + k_s · mirror sphere, the diffuse view
    (θ_o = 0) first, then specular views (θ_o > 0, φ_o 0 or 180). Arrays need ``camera`` (one
    ``{"type": "normal-probe", "theta_o_deg": …, "phi_o_deg": …}`` per array) or ``scene``.
    ``kd``, ``ks``: one number or r, g, b (default: the header's mix). ``lmax`` ≤ 32;
    ``channel`` ("r" | "g" | "b"; default all three); ``scan``: scan the diffuse fraction for the
    consistency χ² minimum. Returns an :class:`reflect.InvertSeparateReport`.
    """
    return _analysis.invert_separate(
        images, lmax=lmax, kd=kd, ks=ks, channel=channel, scan=scan, camera=camera, scene=scene, stderr=stderr, layer=layer
    )


def factor(
    images: Images = (),
    *,
    lmax: int,
    nodes: Optional[Sequence[int]] = None,
    normal: Any = None,
    channel: str = "r",
    quadrature: str = "fejer",
    max_amplification: float = 10.0,
    scene: Any = None,
    size: Sequence[int] = (96, 48),
    camera: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
) -> InvertFactorReport:
    """Factor a sphere's reflected light field into lighting and BRDF up to scale (eq. 18, 23):
    ``reflect invert factor``.

    ``images``: normal-probe views (paths, renders or (H, W, 3) arrays, all on one lat-long grid
    of normals, rendered at pixel centres), one per node of an n_μ × n_φ product rule (the rule is
    inferred from their angles, or checked against ``nodes=(n_mu, n_phi)``); arrays need ``camera``
    (one ``{"type": "normal-probe", "theta_o_deg": …, "phi_o_deg": …}`` per array) or ``scene``.
    ``normal``: a view at θ_o = 0, which adds the normal-exitance filter (eq. 16). Or no images and
    ``scene="scene.toml"``, ``nodes=(n_mu, n_phi)``, ``size=(W, H)``: the scene's light field is
    rendered in memory (its first object must be a sphere). ``channel``: "r" | "g" | "b" (one channel
    is factored); ``quadrature``: "fejer" | "pixel" over the normals; ``max_amplification``: the
    noise amplification 1/g_l above which an order is ill-conditioned.

    Returns an :class:`reflect.InvertFactorReport`: e.g. ``orders`` (list of dicts with ``kappa_ratio``
    = κ_l/κ_0, ``gain``, ``status``), ``lighting`` ((lmax+1)²,) float64 (L_lm / P, NaN where
    ambiguous), ``source`` (the order-1 direction), ``albedo_profile``, ``filter``.
    """
    return _analysis.invert_factor(
        images, lmax=lmax, nodes=nodes, normal=normal, channel=channel, quadrature=quadrature,
        max_amplification=max_amplification, scene=scene, size=size, camera=camera, stderr=stderr, layer=layer,
    )
