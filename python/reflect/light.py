"""Light objects: the renderer's distant lights, evaluated and sampled over NumPy batches.

Each class builds the light a scene file's ``[lighting]`` table describes (guide "Conventions" §1, §6,
"Scene files"). Directions are unit vectors in the *world* frame (+z up), pointing from the scene
toward the light (the direction the radiance arrives from); arrays are (N, 3), any float dtype,
computed and returned in float32 (one (3,) direction, or one (2,) ``u``, gives unbatched results, as
in NumPy). Radiance is in the map's (or table's) linear RGB units per sr.
"""

from __future__ import annotations

import os
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np

from . import _args, _reflect
from .brdf import Color, Sample, _color, _directions, _single, _uniform

__all__ = ["Light", "Uniform", "Directional", "Axial", "SH", "Envmap"]


class Light:
    """A distant light of the renderer, from its ``[lighting]`` table (see the module docs)."""

    def __init__(self, table: Dict[str, Any], base: Union[str, "os.PathLike[str]", None] = None,
                 compensated: bool = False):
        #: The scene file's ``[lighting]`` table this light was built from.
        self.table = dict(table)
        base = os.fspath(base) if base is not None else os.getcwd()
        self._native = _reflect.NativeLight(self.table, base, _args.boolean("compensated", compensated))

    def eval(self, direction: Any) -> np.ndarray:
        """Radiance L(ω) arriving from each direction: (N, 3) float32 RGB (0 for :class:`Directional`)."""
        out = self._native.eval(_directions("direction", direction))
        return out[0] if _single(direction) else out

    def pdf(self, direction: Any) -> np.ndarray:
        """The density, per solid angle (sr⁻¹), with which :meth:`sample` draws each direction: (N,) float32."""
        out = self._native.pdf(_directions("direction", direction))
        return out[0] if _single(direction) else out

    def sample(self, u: Any) -> Sample:
        """Draws one direction per row of ``u`` ((N, 2) uniform numbers in [0, 1)), with density
        proportional to |L| where the light allows: :class:`reflect.brdf.Sample` ``(wi, weight =
        L/pdf, pdf, delta)``, so ``mean(weight)`` estimates ∫L dω (RGB)."""
        if _single(u):
            return Sample(*(x[0] for x in self._native.sample(_uniform("u", np.asarray(u)[None, :], 2))))
        return Sample(*self._native.sample(_uniform("u", u, 2)))

    def __repr__(self) -> str:
        return f"<reflect.light.{type(self).__name__} {self.table}>"


class Uniform(Light):
    """The same radiance from every direction (a white furnace when 1)."""

    def __init__(self, radiance: Color = 1.0):
        super().__init__({"type": "uniform", "radiance": _color("radiance", radiance)})


class Directional(Light):
    """A Dirac light: irradiance ``irradiance`` (RGB, W/m² on a surface facing it) from ``direction``."""

    def __init__(self, direction: Sequence[float], irradiance: Color = 1.0):
        d = [float(x) for x in direction]
        super().__init__({"type": "directional", "direction": d, "irradiance": _color("irradiance", irradiance)})


class Axial(Light):
    """Radiance that depends only on the angle θ from ``axis``: ``profile`` rows (θ in degrees from 0
    to 180, r, g, b), linear in between."""

    def __init__(self, profile: Sequence[Sequence[float]], axis: Sequence[float] = (0.0, 0.0, 1.0)):
        rows = [[float(x) for x in r] for r in profile]
        super().__init__({"type": "axial", "axis": [float(x) for x in axis], "profile": rows})


class SH(Light):
    """Lighting given by real SH coefficients L_lm ((L+1)², 3), index k = l(l+1) + m (guide "Conventions" §3)."""

    def __init__(self, coefficients: Any):
        c = np.asarray(coefficients, dtype=np.float64)
        if c.ndim != 2 or c.shape[1] != 3:
            raise _args.InputError(f"coefficients= must have shape ((L+1)², 3), got {c.shape}")
        super().__init__({"type": "sh", "coefficients": c.tolist()})


class Envmap(Light):
    """An environment map file (``.hdr``/``.exr``): ``mapping`` "latlong" or "angular" (default: from
    the aspect ratio), ``scale`` (multiplies the radiance), ``rotate_deg`` (x, y, z rotation, degrees;
    guide "Conventions" §2), ``layer`` (an EXR layer). The map is importance-sampled texel by texel, by
    luminance, so that :meth:`sample` alone estimates ∫L dω; with ``compensated=True``, by the
    renderer's table instead (guide "Conventions" §2, "Light sampling": luminance less the map's mean,
    zero on the darker texels), whose samples are unbiased only combined by MIS with samples that
    reach every direction, as the path tracer's BRDF samples do."""

    def __init__(
        self,
        file: Union[str, "os.PathLike[str]"],
        mapping: Optional[str] = None,
        scale: float = 1.0,
        rotate_deg: Tuple[float, float, float] = (0.0, 0.0, 0.0),
        layer: Optional[str] = None,
        compensated: bool = False,
    ):
        t: Dict[str, Any] = {
            "type": "envmap",
            "file": os.fspath(file),
            "scale": _args.real("scale", scale),
            "rotate_deg": [float(x) for x in rotate_deg],
        }
        if mapping is not None:
            t["mapping"] = _args.string("mapping", mapping)
        if layer is not None:
            t["layer"] = _args.string("layer", layer)
        super().__init__(t, compensated=compensated)
