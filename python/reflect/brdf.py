"""BRDF objects: the renderer's own BRDFs, evaluated and sampled over NumPy batches.

Each class builds the BRDF a scene file's ``brdf`` table describes (guide "Conventions" §4,
"Scene files"), so ``reflect.brdf.Microfacet(alpha=0.3)`` is exactly what a sphere with
``brdf = {type = "microfacet", alpha = 0.3}`` renders with.

**Frame.** Directions are unit vectors in the local shading frame: the normal is +z, and both ω_i
(toward the light) and ω_o (toward the viewer) point *away* from the surface. Arrays are (N, 3) (or
one (3,) direction, broadcast against the other argument); any float dtype; they are computed in
float32, as the renderer computes, and returned as float32. As in NumPy, unbatched input gives
unbatched output: when every direction argument is one (3,) vector (and, for ``sample``, ``u`` is
one (2,) pair), ``eval`` returns (3,), ``pdf`` a float32 scalar (shape ()), and ``sample`` a
:class:`Sample` of (3,), (3,), () and () arrays.

**Cosine.** :meth:`BRDF.eval` returns the paper's *transfer function* ρ̂(ω_o, ω_i) = BRDF · cos θ_i
(guide "Conventions" §4): the BRDF value multiplied by the cosine of the incident angle, 0 below the
horizon (unless the lobe is built with ``horizon="ignore"``). Divide by ``wi[:, 2]`` for the BRDF value
alone. :meth:`BRDF.sample` returns weight = ρ̂ / pdf, so a Monte Carlo estimate of the reflected
radiance from incident radiance L is ``mean(weight * L(wi))``.
"""

from __future__ import annotations

from typing import Any, Dict, NamedTuple, Optional, Sequence, Union

import numpy as np

from . import _args, _reflect
from ._errors import InputError

__all__ = ["BRDF", "Sample", "Lambert", "Mirror", "Phong", "TorranceSparrow", "Microfacet", "Mix"]

Color = Union[float, Sequence[float]]


def _directions(name: str, a: Any, n: Optional[int] = None) -> np.ndarray:
    """``a`` as a C-contiguous float32 (N, 3) array of unit vectors (a (3,) row is one direction)."""
    try:
        x = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}= must be an array of directions, shape (N, 3), got {type(a).__name__}") from None
    if x.ndim == 1:
        x = x[None, :]
    if x.ndim != 2 or x.shape[1] != 3:
        raise InputError(f"{name}= must have shape (N, 3) or (3,), got {np.shape(a)}")
    if not np.all(np.isfinite(x)):
        raise InputError(f"{name}= must be finite")
    norm = np.linalg.norm(x, axis=1)
    if x.shape[0] and np.max(np.abs(norm - 1.0)) > 1e-3:
        k = int(np.argmax(np.abs(norm - 1.0)))
        raise InputError(f"{name}= must hold unit vectors; row {k} has length {norm[k]:.6g}")
    if n is not None and x.shape[0] == 1 and n != 1:
        x = np.repeat(x, n, axis=0)
    return np.ascontiguousarray(x, dtype=np.float32)


def _uniform(name: str, a: Any, cols: int) -> np.ndarray:
    try:
        x = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        raise InputError(f"{name}= must be an array of numbers in [0, 1), got {type(a).__name__}") from None
    if cols == 1:
        if x.ndim != 1:
            raise InputError(f"{name}= must have shape (N,), got {x.shape}")
    elif x.ndim != 2 or x.shape[1] != cols:
        raise InputError(f"{name}= must have shape (N, {cols}), got {x.shape}")
    if x.size and not (np.all(x >= 0) and np.all(x < 1)):
        raise InputError(f"{name}= must hold numbers in [0, 1)")
    return np.ascontiguousarray(x, dtype=np.float32)


def _single(a: Any) -> bool:
    """One direction or pair given unbatched (a (3,) or (2,) vector, not an (N, 3) array)."""
    try:
        return np.ndim(a) == 1
    except (TypeError, ValueError):
        return False


def _pair(wi: Any, wo: Any):
    a, b = _directions("wi", wi), _directions("wo", wo)
    n = max(len(a), len(b))
    if len(a) not in (1, n) or len(b) not in (1, n):
        raise InputError(f"wi= has {len(a)} rows and wo= {len(b)}: give the same number, or one direction")
    return _directions("wi", a, n), _directions("wo", b, n)


class Sample(NamedTuple):
    """Directions drawn from a BRDF or a light (rows where nothing is drawn are all zero)."""

    #: (N, 3) float32 unit vectors (local frame for a BRDF, world frame for a light).
    wi: np.ndarray
    #: (N, 3) float32: ρ̂/pdf for a BRDF, L/pdf for a light (RGB).
    weight: np.ndarray
    #: (N,) float32 solid-angle density, sr⁻¹ (for a Dirac lobe: the probability of choosing it).
    pdf: np.ndarray
    #: (N,) bool: drawn from a Dirac lobe (mirror) or a directional light; ``eval``/``pdf`` do not contain it.
    delta: np.ndarray


class BRDF:
    """A BRDF of the renderer, from its scene-file table (see the module docs for frame and cosine)."""

    def __init__(self, table: Dict[str, Any]):
        #: The scene file's ``brdf`` table this BRDF was built from.
        self.table = dict(table)
        self._native = _reflect.NativeBrdf(self.table)

    def eval(self, wi: Any, wo: Any) -> np.ndarray:
        """ρ̂(ω_o, ω_i) = BRDF · cos θ_i per row, (N, 3) float32 RGB, sr⁻¹ (Dirac lobes excluded).

        ``wi``, ``wo``: (N, 3) unit vectors in the local frame (normal +z), or one (3,) direction
        (broadcast against the other); both (3,): one (3,) value."""
        a, b = _pair(wi, wo)
        out = self._native.eval(a, b)
        return out[0] if _single(wi) and _single(wo) else out

    def pdf(self, wi: Any, wo: Any) -> np.ndarray:
        """The density, per solid angle (sr⁻¹), with which :meth:`sample` draws ω_i given ω_o: (N,) float32
        (a float32 scalar when ``wi`` and ``wo`` are both one (3,) direction)."""
        a, b = _pair(wi, wo)
        out = self._native.pdf(a, b)
        return out[0] if _single(wi) and _single(wo) else out

    def sample(self, wo: Any, u: Any, u_lobe: Any = None) -> Sample:
        """Draws one ω_i per row of ``u`` ((N, 2) uniform numbers in [0, 1)) given ``wo`` ((N, 3) or (3,)).

        ``u_lobe`` ((N,) in [0, 1)) chooses among the layers of a :class:`Mix` (default 0.5).
        Returns :class:`Sample` ``(wi, weight, pdf, delta)`` with weight = ρ̂/pdf: ``mean(weight)``
        over many ``u`` estimates the directional albedo ∫ρ̂ dω_i. One (3,) ``wo`` with one (2,) ``u``
        (and a scalar or no ``u_lobe``) gives one unbatched :class:`Sample`: (3,), (3,), (), ()."""
        single = _single(u) and _single(wo) and (u_lobe is None or np.ndim(u_lobe) == 0)
        if single:
            u = np.asarray(u)[None, :]
            u_lobe = None if u_lobe is None else [u_lobe]
        uu = _uniform("u", u, 2)
        o = _directions("wo", wo, len(uu))
        if len(o) != len(uu):
            raise InputError(f"wo= has {len(o)} rows and u= {len(uu)}")
        ul = np.full(len(uu), 0.5, np.float32) if u_lobe is None else _uniform("u_lobe", u_lobe, 1)
        if len(ul) != len(uu):
            raise InputError(f"u_lobe= has {len(ul)} rows and u= {len(uu)}")
        s = Sample(*self._native.sample(o, uu, ul))
        return Sample(*(x[0] for x in s)) if single else s

    def __repr__(self) -> str:
        return f"<reflect.brdf.{type(self).__name__} {self.table}>"


def _color(name: str, c: Color) -> Any:
    if isinstance(c, (int, float, np.integer, np.floating)) and not isinstance(c, bool):
        return float(c)
    try:
        v = [float(x) for x in c]  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise InputError(f"{name}= must be a number or an RGB triple, got {c!r}") from None
    if len(v) != 3:
        raise InputError(f"{name}= must be a number or an RGB triple, got {len(v)} values")
    return v


def _positive(name: str, v: Any) -> float:
    x = _args.real(name, v)
    if x <= 0:
        raise InputError(f"{name}= must be positive, got {x}")
    return x


class Lambert(BRDF):
    """BRDF = albedo/π, so ρ̂ = albedo · cos θ_i / π. ``albedo``: a number or RGB, each in [0, 1]."""

    def __init__(self, albedo: Color = 0.8):
        super().__init__({"type": "lambert", "albedo": _color("albedo", albedo)})


class Mirror(BRDF):
    """A perfect mirror, ρ̂ = k_r δ(ω_i = R(ω_o)): ``eval`` and ``pdf`` are 0, ``sample`` returns R with weight k_r."""

    def __init__(self, kr: Color = 1.0):
        super().__init__({"type": "mirror", "kr": _color("kr", kr)})


class Phong(BRDF):
    """The normalized Phong lobe of the paper's eq. 40: exponent ``s`` > 0, colour ``ks``;
    ``horizon`` "clamp" (default) or "ignore" (guide "Conventions" §4)."""

    def __init__(self, s: float, ks: Color = 1.0, horizon: str = "clamp"):
        super().__init__({"type": "phong", "s": _positive("s", s), "ks": _color("ks", ks), "horizon": horizon})


class TorranceSparrow(BRDF):
    """The Torrance–Sparrow lobe of the paper's eq. 48: roughness ``sigma`` > 0 (radians), colour ``ks``."""

    def __init__(self, sigma: float, ks: Color = 1.0, horizon: str = "clamp"):
        super().__init__(
            {"type": "torrance-sparrow", "sigma": _positive("sigma", sigma), "ks": _color("ks", ks), "horizon": horizon}
        )


class Microfacet(BRDF):
    """A microfacet BRDF D·G·F / (4 cos θ_i cos θ_o) (guide "Conventions" §4; ``eval`` returns
    ρ̂ = BRDF · cos θ_i = D·G·F / (4 cos θ_o)): ``distribution`` "beckmann" (default) or "ggx", roughness
    ``alpha`` > 0, Smith's height-correlated G, and ``fresnel`` "none" (default, F = 1), "schlick"
    (needs ``f0``) or "conductor" (needs ``eta`` and ``k``, RGB).

    ``sample`` draws a half vector h and reflects ω_o about it: Beckmann from D(h) cos θ_h, GGX from
    its visible normals D_ωo(h) = G1(ω_o) max(0, ω_o·h) D(h) / cos θ_o (Heitz 2018); the pdf of ω_i is
    p(h) / (4 ω_o·h). Draws with ω_o·h ≤ 0 or ω_i below the horizon are refused (``pdf`` integrates to
    the kept fraction, a little below 1 at large ``alpha``)."""

    def __init__(
        self,
        alpha: float,
        distribution: str = "beckmann",
        fresnel: str = "none",
        f0: Optional[Color] = None,
        eta: Optional[Color] = None,
        k: Optional[Color] = None,
    ):
        t: Dict[str, Any] = {"type": "microfacet", "distribution": distribution, "alpha": _positive("alpha", alpha), "fresnel": fresnel}
        for name, v in (("f0", f0), ("eta", eta), ("k", k)):
            if v is not None:
                t[name] = _color(name, v)
        super().__init__(t)


class Mix(BRDF):
    """A weighted sum of BRDFs: ``layers`` a list of (weight ≥ 0, :class:`BRDF`); ``sample`` picks a
    layer with ``u_lobe`` in proportion to the weights."""

    def __init__(self, layers: Sequence[Any]):
        rows = []
        for i, layer in enumerate(layers):
            try:
                w, b = layer
            except (TypeError, ValueError):
                raise InputError(f"layers= item {i} must be a pair (weight, BRDF)") from None
            if not isinstance(b, BRDF):
                raise InputError(f"layers= item {i}: {b!r} is not a reflect.brdf.BRDF")
            rows.append({"weight": _args.real(f"layers[{i}] weight", w), "brdf": b.table})
        super().__init__({"type": "mix", "layers": rows})
