"""The analyses (``reflect.analyze``, ``reflect.invert.lighting | brdf | separate``) on files,
renders and arrays, through the analysis library's own functions: no file is written, no command
line is built.

Every argument is checked here, in this API's terms: a bad one raises :class:`reflect.InputError`
(a ``ValueError``) naming its keyword (``lmax=``, ``camera=``) or the image (``<array 0>``). The
images then go to the native module as they are: a path (read there as the CLI reads it), a
:class:`RenderResult` (its layers and header, as its saved file holds them), or an array's layers
(``R``, ``G``, ``B`` and ``stderr.*``) with the header a render of its scene, its ``camera`` and its
``sphere`` carry.

Results are report objects (:class:`Report` subclasses): each field of the CLI's ``--json``
document is an attribute, every list of numbers (nested to any depth, rectangular) a NumPy array
(float64 where the document has a non-integer number or a null, null → NaN; int64 where it has only
integers, e.g. ``lm``); a list of records (one object per order, per channel: ``filter``, ``orders``,
``filter_fit``) a :class:`Table` whose columns are such arrays (``report.filter.estimate`` is
(lmax+1, 3)); :meth:`Report.to_dict` is the ``--json`` document itself. A report's ``warnings``
are also raised as :class:`reflect.Warning` (a ``UserWarning``) when the call returns.
"""

from __future__ import annotations

import copy
import json
import math
import os
import warnings as _warnings
from typing import TYPE_CHECKING, Any, Dict, Iterator, List, Optional, Sequence, Tuple, TypeVar, Union

import numpy as np

from . import _args, _reflect
from ._errors import InputError, Warning
from ._reflect import RenderResult

PathLike = Union[str, "os.PathLike[str]"]
ImageLike = Union[PathLike, RenderResult, np.ndarray]
Images = Union[ImageLike, Sequence[ImageLike]]

#: The largest order the analyses accept (``analysis::sh::MAX_LMAX``).
MAX_LMAX = 200


# ---------------------------------------------------------------------------------------------
# Reports


def _arrays(v: Any, tables: bool = False) -> Any:
    """Lists of numbers (rectangular, any depth) → NumPy arrays; null → NaN in float arrays; with
    ``tables``, lists of records (objects with the same keys) → :class:`Table`."""
    if isinstance(v, dict):
        return {k: _arrays(x, tables) for k, x in v.items()}
    if tables and _records(v):
        return Table(v)
    if isinstance(v, list):
        if v and _numeric(v):
            try:
                if _any_float(v):
                    return np.array(_nan(v), dtype=np.float64)
                return np.array(v, dtype=np.int64)
            except ValueError:  # ragged
                pass
        return [_arrays(x, tables) for x in v]
    return v


def _records(v: Any) -> bool:
    """A non-empty list of objects with the same keys, each value a scalar or a flat list (of numbers,
    one per channel, or of strings)."""
    if not isinstance(v, list) or not v or not all(isinstance(x, dict) for x in v):
        return False
    keys = list(v[0])
    flat = lambda y: not isinstance(y, dict) and (  # noqa: E731
        not isinstance(y, list) or _numeric(y) or all(isinstance(z, str) for z in y))
    return all(list(x) == keys for x in v) and all(flat(y) for x in v for y in x.values())


class Table:
    """A list of records of a report (one per order, per channel, …) as columns: each key of the
    records is an attribute, a NumPy array whose first axis runs over the records (float64 with
    null → NaN, int64 for integers, bool for flags; a column of strings, or of lists of them, a
    list). ``len(t)``
    is the number of records, ``t[i]`` record i as a dict of its values (``t[i]["estimate"]``),
    ``t["estimate"]`` the same as ``t.estimate``, and iterating gives the records in order; the
    report's :meth:`Report.to_dict` holds the plain list of objects."""

    def __init__(self, rows: List[Dict[str, Any]]) -> None:
        self._keys = list(rows[0])
        self._n = len(rows)
        for k in self._keys:
            col = [r[k] for r in rows]
            if all(isinstance(x, bool) for x in col):
                value: Any = np.array(col, dtype=bool)
            elif _numeric(col):
                value = _arrays(col)
                if not isinstance(value, np.ndarray):  # ragged lists of numbers stay a list of arrays
                    value = [_arrays(x) for x in col]
            else:
                value = [_arrays(x) for x in col]
            setattr(self, k, value)

    if TYPE_CHECKING:  # the columns are attributes named by the document: any name, an array or list

        def __getattr__(self, name: str) -> Any: ...

    def keys(self) -> List[str]:
        """The columns, in the records' order of keys."""
        return list(self._keys)

    def __len__(self) -> int:
        return self._n

    def __getitem__(self, key: Union[int, str]) -> Any:
        if isinstance(key, str):
            if key not in self._keys:
                raise KeyError(key)
            return getattr(self, key)
        i = range(self._n)[key]  # IndexError, negative indices
        return {k: getattr(self, k)[i] for k in self._keys}

    def __iter__(self) -> Iterator[Dict[str, Any]]:
        return (self[i] for i in range(self._n))

    def __repr__(self) -> str:
        return f"<reflect.Table {self._n} rows: {', '.join(self._keys)}>"


def _numeric(v: Any) -> bool:
    if isinstance(v, list):
        return bool(v) and all(_numeric(x) for x in v)
    return v is None or (isinstance(v, (int, float)) and not isinstance(v, bool))


def _any_float(v: Any) -> bool:
    if isinstance(v, list):
        return any(_any_float(x) for x in v)
    return v is None or isinstance(v, float)


def _nan(v: Any) -> Any:
    if isinstance(v, list):
        return [_nan(x) for x in v]
    return math.nan if v is None else v


class Report:
    """The result of an analysis: one attribute per field of the command's ``--json`` document
    (lists of numbers as NumPy arrays, see the module docs), plus :attr:`notes`.

    ``report.coefficients`` and ``report["coefficients"]`` are the same array; :meth:`to_dict`
    gives the document the CLI prints, exactly (plain lists, ``None`` for null).
    """

    #: The ``note: …`` lines the CLI prints on stderr (a layer chosen, a camera taken from matrices,
    #: pixels a filter left out); not part of :meth:`to_dict`.
    notes: List[str]
    #: Warnings, each one sentence (the CLI's ``warning: …`` lines).
    warnings: List[str]

    def __init__(self, doc: Dict[str, Any], notes: Sequence[str] = ()) -> None:
        self._doc = doc
        self.notes = list(notes)
        for k, v in doc.items():
            setattr(self, k, _arrays(v, tables=True))

    def to_dict(self) -> Dict[str, Any]:
        """The report as the CLI's ``--json`` document (a deep copy: plain lists, ``None`` for null)."""
        return copy.deepcopy(self._doc)

    def to_json(self) -> str:
        """The report as the JSON text the CLI prints with ``--json``."""
        return json.dumps(self._doc, ensure_ascii=False)

    def keys(self) -> List[str]:
        """The fields of the report, in the document's order."""
        return list(self._doc)

    def __getitem__(self, key: str) -> Any:
        if key not in self._doc:
            raise KeyError(key)
        return getattr(self, key)

    def __contains__(self, key: object) -> bool:
        return key in self._doc

    def __repr__(self) -> str:
        return f"<reflect.{type(self).__name__} {', '.join(self._doc)}>"


class AnalyzeReport(Report):
    """The result of :func:`reflect.analyze` (``reflect analyze --json``). Coefficient arrays are in
    index order k = l(l + 1) + m, rows labelled by :attr:`lm`; columns R, G, B."""

    lmax: int
    #: The highest order the input carries.
    lmax_carried: int
    #: The images' names (a path; ``<array i>``, ``<RenderResult i>`` for images given in memory).
    images: List[str]
    method: str
    #: ``normal`` or ``reflection``: the direction B is a function of.
    param: str
    #: ``{"center": (3,), "radius": float}``, world units.
    sphere: Dict[str, Any]
    pixels_used: int
    #: ``stderr-layer``, ``residuals`` or ``none``.
    stderr_source: str
    #: (3,) weighted RMS residual of the B_lm fit (orthographic views), else None.
    rms_residual: Optional[np.ndarray]
    #: ((lmax+1)², 2) int64: (l, m) of each row.
    lm: np.ndarray
    #: ((lmax+1)², 3) B_lm, radiance units of the image.
    coefficients: np.ndarray
    #: ((lmax+1)², 3) standard errors of B_lm, or None.
    stderr: Optional[np.ndarray]
    #: ``{"source": str, "coefficients": ((lmax+1)², 3)}``: L_lm compared with, or None.
    lighting: Optional[Dict[str, Any]]
    #: Per order l: the measured filter A_l = albedo · Λ_l ρ̂_l fitted in pixel space, or None: a
    #: :class:`Table` with ``l`` (lmax+1,) int64, ``estimate`` and ``stderr`` (lmax+1, 3) float64, … (the
    #: document's ``filter`` records as columns).
    filter: Optional["Table"]
    #: Per channel: χ², ν, p-value and covariance of the filter fit (a :class:`Table`), or None.
    filter_fit: Optional["Table"]
    #: The BRDF table (scene vocabulary), or None.
    brdf: Optional[Dict[str, Any]]
    #: (lmax+1, 3) analytic Λ_l ρ̂_l scaled by the albedo (eq. 38/43/33/50), or None.
    lambda_rho_analytic: Optional[np.ndarray]
    #: ((lmax+1)², 3) B_lm predicted by eq. 15, or None.
    predicted: Optional[np.ndarray]
    #: Noise correlation of neighbouring pixels and the variance inflation applied, or None.
    pixel_noise: Optional[Dict[str, Any]]
    #: Whether the image contradicts what it was told (lighting, BRDF, camera), or None.
    verdict: Optional[Dict[str, Any]]


class InvertLightingReport(Report):
    """The result of :func:`reflect.invert.lighting` (``reflect invert lighting --json``): L_lm
    (eq. 17) with standard errors; rows in index order k = l(l + 1) + m (:attr:`lm`), columns R, G, B."""

    lmax: int
    lmax_carried: int
    images: List[str]
    method: str
    #: The BRDF kind inverted ("lambert", "phong", …).
    brdf: str
    #: (lmax+1,) Λ_l ρ̂_l per order (unit albedo).
    lambda_rho: np.ndarray
    #: (3,) albedo / k_s / k_r.
    albedo: np.ndarray
    max_amplification: float
    #: Per order, a :class:`Table`: ``l``, ``lambda_rho``, ``amplification`` (lmax+1,) arrays, ``status`` (list of
    #: str: recovered / ill-conditioned / unobservable).
    orders: "Table"
    lm: np.ndarray
    #: ((lmax+1)², 3) L_lm, radiance units; NaN rows where unobservable.
    coefficients: np.ndarray
    #: ((lmax+1)², 3) total standard error (NaN where unobservable).
    stderr: np.ndarray
    #: The Tikhonov-regularised lighting: ``rule``, ``lambda`` (3,), ``needed`` (3,), ``coefficients`` ((lmax+1)², 3).
    regularised: Dict[str, Any]
    verdict: Optional[Dict[str, Any]]


class InvertBrdfReport(Report):
    """The result of :func:`reflect.invert.brdf` (``reflect invert brdf --json``): Λ_l ρ̂_l per order
    (eq. 16) and the fitted model parameter with its Δχ² = 1 interval."""

    lmax: int
    lmax_carried: int
    images: List[str]
    method: str
    #: Where the lighting came from.
    lighting: str
    #: "phong", "torrance-sparrow" or "microfacet".
    model: str
    #: "s" (Phong exponent), "sigma" (Torrance–Sparrow roughness, radians) or "alpha" (microfacet).
    parameter: str
    estimate: float
    #: (2,) Δχ² = 1 interval; NaN where unbounded within the search range.
    interval: np.ndarray
    #: (2,) the search range.
    range: np.ndarray
    #: (3,) the fitted scale (albedo / k_s) per channel, NaN where not fitted.
    scale: np.ndarray
    chi2_min: float
    dof: int
    #: Per order, a :class:`Table`: ``l`` (lmax+1,), ``estimate`` and ``stderr`` (lmax+1, 3), ``observable`` (lmax+1,) bool.
    filter: "Table"
    #: (N, 2) (parameter, Δχ²) along the profile.
    profile: np.ndarray
    verdict: Optional[Dict[str, Any]]


class InvertSeparateReport(Report):
    """The result of :func:`reflect.invert.separate` (``reflect invert separate --json``): diffuse +
    specular separation (sec. 3.5)."""


class InvertFactorReport(Report):
    """The result of :func:`reflect.invert.factor` (``reflect invert factor --json``): a light field
    factored into lighting and BRDF up to the global scale (eq. 18, 23)."""


def _stacklevel() -> int:
    """The ``stacklevel`` of a warning raised here that points at the caller's line, outside this package."""
    import sys

    here = os.path.dirname(os.path.abspath(__file__))
    f: Any = sys._getframe(1)
    level = 1
    while f is not None and os.path.dirname(os.path.abspath(f.f_code.co_filename)) == here:
        f, level = f.f_back, level + 1
    return level


R = TypeVar("R", bound=Report)


def _reported(report: R) -> R:
    """The report, its ``warnings`` raised as :class:`reflect.Warning` (so they are seen, and
    ``warnings.simplefilter("error", reflect.Warning)`` makes them errors); ``report.warnings``
    keeps them."""
    for w in getattr(report, "warnings", None) or []:
        _warnings.warn(str(w), Warning, stacklevel=_stacklevel())
    return report


# ---------------------------------------------------------------------------------------------
# Arguments


def _image_list(images: Any) -> List[Any]:
    if isinstance(images, (str, os.PathLike, RenderResult)):
        return [images]
    if isinstance(images, np.ndarray):
        # One array is one image (H, W, 3) or a stack of them (N, H, W, 3); anything else is named
        # whole, not split into rows that are then each "the wrong shape".
        if images.ndim == 3:
            return [images]
        if images.ndim == 4:
            return list(images)
        raise InputError(f"images= must be an (H, W, 3) array (or (N, H, W, 3) for N images), got {images.shape}")
    try:
        imgs = list(images)
    except TypeError:
        raise InputError(f"images= must be a path, a RenderResult, an (H, W, 3) array or a list of them, got {type(images).__name__}") from None
    if not imgs:
        raise InputError("images= is empty")
    for i, x in enumerate(imgs):
        if not isinstance(x, (str, os.PathLike, RenderResult, np.ndarray, list, tuple)):
            raise InputError(f"images[{i}] must be a path, a RenderResult or an (H, W, 3) array, got {type(x).__name__}")
    return imgs


def _rgb_array(a: Any, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise InputError(f"{what} must have shape (H, W, 3), got {a.shape}")
    bad = np.argwhere(~np.isfinite(a))
    if len(bad):
        r, c, k = (int(x) for x in bad[0])
        v = float(a[r, c, k])
        shown = "NaN" if math.isnan(v) else ("inf" if v > 0 else "-inf")
        raise InputError(f"{what}: channel {'RGB'[k]}: non-finite value {shown} at row {r}, column {c}")
    return a


def _plain(x: Any) -> Any:
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    return x


def _absolute_file(lighting: Dict[str, Any], base: Any) -> Dict[str, Any]:
    """An envmap table with its file made absolute (against ``base``, else the current folder)."""
    if lighting.get("type") == "envmap" and isinstance(lighting.get("file"), str) and not os.path.isabs(lighting["file"]):
        lighting = dict(lighting, file=os.path.join(os.fspath(base) if base else os.getcwd(), lighting["file"]))
    return lighting


def _header(index: int, camera: Any, sphere: Optional[Dict[str, Any]], scene: Any) -> Dict[str, str]:
    """The header attributes of array image ``index``: those a render of ``scene`` carries (its
    camera, lighting and objects), with ``camera`` and a ``sphere`` with a BRDF in their place (as
    given, in double precision), each checked with the scene file's types (unknown keys and bad
    values name the keyword)."""
    attrs: Dict[str, str] = {}
    if scene is not None:
        from ._scene import load_scene

        s = load_scene(scene)
        table = s.to_dict()
        if "lighting" in table:
            table["lighting"] = _absolute_file(table["lighting"], s.base)
        try:
            attrs = _reflect.header_attributes(table)
        except ValueError as e:
            raise InputError(f"scene=: {e}") from None
    if camera is not None:
        # Defaults (``to`` the origin, ``up`` +z, normal-probe angles 0) are the scene file's own,
        # filled in by the library that reads the header, as for ``render``.
        cam = _plain(dict(camera))
        try:
            _reflect.header_attributes({"camera": cam, "lighting": {"type": "uniform", "radiance": 1.0}, "objects": []})
        except ValueError as e:
            raise InputError(f"camera=: {str(e).removeprefix('scene: ')}") from None
        attrs["reflect:camera"] = json.dumps(cam)
    if sphere is not None and "brdf" in sphere:
        obj = dict({"shape": "sphere", "center": [0.0, 0.0, 0.0], "radius": 1.0}, **_plain(dict(sphere)))
        try:
            _reflect.header_attributes({"camera": {"type": "normal-probe"}, "lighting": {"type": "uniform", "radiance": 1.0}, "objects": [obj]})
        except ValueError as e:
            raise InputError(f"sphere=: {str(e).removeprefix('scene: ')}") from None
        attrs["reflect:objects"] = json.dumps([obj])
    if "reflect:camera" not in attrs:
        raise InputError(
            f"<array {index}>: no camera: pass camera= (a scene-file camera table, e.g. {{'type': 'orthographic', "
            "'from': [3, 0, 1], 'extent': 1.05}, or {'type': 'normal-probe'}) or scene= (the scene it is a render of)"
        )
    return attrs


def vec3(name: str, v: Any) -> List[float]:
    """Three finite numbers (a position or direction)."""
    a = np.asarray(v, dtype=object).ravel() if not isinstance(v, (str, bytes)) else None
    if a is None or len(a) != 3:
        raise InputError(f"{name}= must be three numbers x, y, z, got {v!r}")
    return [_args.real(name, x) for x in a]


def rgb(name: str, v: Any) -> Optional[List[float]]:
    """One number (grey) or three (r, g, b), finite; None stays None."""
    if v is None:
        return None
    if isinstance(v, (list, tuple, np.ndarray)):
        a = list(np.asarray(v, dtype=object).ravel())
        if len(a) != 3:
            raise InputError(f"{name}= must be one number or three (r, g, b), got {len(a)} values")
        return [_args.real(name, x) for x in a]
    x = _args.real(name, v)
    return [x, x, x]


def choice(name: str, v: Any, names: Sequence[str]) -> Optional[str]:
    """One of ``names``; None stays None."""
    if v is None:
        return None
    if not isinstance(v, str) or v not in names:
        raise InputError(f"{name}= must be one of {', '.join(repr(n) for n in names)}, got {v!r}")
    return v


def positive(name: str, v: Any) -> Optional[float]:
    x = _args.optional_real(name, v)
    if x is not None and not x > 0:
        raise InputError(f"{name}= must be a number > 0, got {x}")
    return x


def lmax_of(v: Any) -> int:
    return _args.integer("lmax", v, 0, MAX_LMAX)


class _View:
    """The image arguments, checked, as the native functions take them."""

    def __init__(
        self,
        images: Images,
        camera: Any,
        sphere: Optional[Dict[str, Any]],
        scene: Any,
        stderr: Any,
        layer: Optional[str],
        pixel_filter: Optional[str],
    ) -> None:
        imgs = _image_list(images)
        arrays = [i for i, x in enumerate(imgs) if not isinstance(x, (str, os.PathLike, RenderResult))]
        if not arrays and (camera is not None or sphere is not None or stderr is not None):
            raise InputError("camera=, sphere= and stderr= describe images given as arrays; these images are files or renders")
        cams = list(camera) if isinstance(camera, (list, tuple)) else None
        if cams is not None and len(cams) != len(arrays):
            raise InputError(f"camera= has {len(cams)} cameras for {len(arrays)} array images")
        stderrs = list(stderr) if isinstance(stderr, (list, tuple)) else [stderr] * len(imgs)
        if len(stderrs) != len(imgs):
            raise InputError(f"stderr= has {len(stderrs)} arrays for {len(imgs)} images")
        if sphere is not None and not isinstance(sphere, dict):
            raise InputError(f"sphere= must be a dict {{'center': [x, y, z], 'radius': r, 'brdf': {{…}}}}, got {type(sphere).__name__}")
        self.items: List[Any] = []
        self.names: List[str] = []
        for i, img in enumerate(imgs):
            if isinstance(img, (str, os.PathLike)):
                self.items.append(os.fspath(img))
                self.names.append(os.fspath(img))
            elif isinstance(img, RenderResult):
                self.items.append(img)
                self.names.append(f"<RenderResult {i}>")
            else:
                a = _rgb_array(img, f"image {i} (array)")
                channels = {c: np.ascontiguousarray(a[..., k]) for k, c in enumerate("RGB")}
                if stderrs[i] is not None:
                    s = _rgb_array(stderrs[i], f"stderr of image {i}")
                    if s.shape != a.shape:
                        raise InputError(f"stderr= of image {i} has shape {s.shape}, the image {a.shape}")
                    channels.update({f"stderr.{c}": np.ascontiguousarray(s[..., k]) for k, c in enumerate("RGB")})
                cam = cams[arrays.index(i)] if cams is not None else camera
                header = _header(i, cam, sphere, scene)
                self.items.append({"channels": channels, "attributes": header})
                self.names.append(f"<array {i}>")
        view: Dict[str, Any] = {"scene": None, "center": None, "radius": None, "layer": None, "pixel_filter": None}
        if scene is not None and not arrays:
            # Files say how they were made in their header; a scene beside them says it where they do not.
            if not isinstance(scene, (str, os.PathLike)) or "\n" in os.fspath(scene):
                raise InputError("scene= beside files (not arrays) must be the path of the scene file they are renders of")
            view["scene"] = os.fspath(scene)
        if sphere is not None and "brdf" not in sphere:
            # A sphere without a BRDF is no scene object: its centre and radius describe the sphere seen.
            if "center" in sphere and vec3("sphere['center']", sphere["center"]) != [0.0, 0.0, 0.0]:
                view["center"] = vec3("sphere['center']", sphere["center"])
            if "radius" in sphere and float(sphere["radius"]) != 1.0:
                view["radius"] = positive("sphere['radius']", sphere["radius"])
        view["layer"] = _args.optional_string("layer", layer)
        view["pixel_filter"] = _args.optional_string("pixel_filter", pixel_filter)
        self.view = view


def _brdf_params(s: Any, sigma: Any, brdf_params: Optional[Dict[str, Any]]) -> List[Tuple[str, Any]]:
    out: List[Tuple[str, Any]] = []
    if s is not None:
        out.append(("s", _args.real("s", s)))
    if sigma is not None:
        out.append(("sigma", _args.real("sigma", sigma)))
    for k, v in (brdf_params or {}).items():
        if not isinstance(k, str):
            raise InputError(f"brdf_params= keys must be strings (the brdf table's keys), got {k!r}")
        out.append((k, v if isinstance(v, str) else _args.real(f"brdf_params['{k}']", v)))
    return out


def _lighting(lighting: Any) -> Any:
    """A path, a ``[lighting]`` dict, SH coefficients ((L+1)², 3) or a map (H, W, 3), checked."""
    if lighting is None or isinstance(lighting, (str, os.PathLike)):
        return None if lighting is None else os.fspath(lighting)
    if isinstance(lighting, dict):
        return _absolute_file(_plain(lighting), None)
    a = np.asarray(lighting, dtype=np.float64)
    if a.ndim == 2 and a.shape[1] == 3 and a.shape[0] >= 1:
        if not np.isfinite(a).all():
            raise InputError("lighting= coefficients must be finite")
        return np.ascontiguousarray(a)
    if a.ndim == 3:
        return np.ascontiguousarray(_rgb_array(a, "lighting= (map array)"))
    raise InputError(f"lighting= must be a path, a [lighting] dict, SH coefficients ((L+1)², 3) or a map (H, W, 3), got shape {a.shape}")


def analyze(
    images: Images,
    *,
    lmax: int,
    lighting: Any = None,
    mapping: Optional[str] = None,
    param: Optional[str] = None,
    brdf: Optional[str] = None,
    s: Optional[float] = None,
    sigma: Optional[float] = None,
    brdf_params: Optional[Dict[str, Any]] = None,
    albedo: Any = None,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
    pixel_filter: Optional[str] = None,
    no_diagnosis: bool = False,
) -> AnalyzeReport:
    view = _View(images, camera, sphere, scene, stderr, layer, pixel_filter)
    lmax = lmax_of(lmax)
    report = _reflect.analyze(
        view.items,
        view.names,
        view.view,
        lmax=lmax,
        lighting=_lighting(lighting),
        mapping=choice("mapping", mapping, ("latlong", "angular")),
        param=choice("param", param, ("normal", "reflection")),
        brdf=_args.optional_string("brdf", brdf),
        brdf_params=_brdf_params(s, sigma, brdf_params),
        albedo=rgb("albedo", albedo),
        no_diagnosis=_args.boolean("no_diagnosis", no_diagnosis),
    )
    return _reported(report)


def invert_lighting(
    images: Images,
    *,
    lmax: int,
    brdf: Optional[str] = None,
    s: Optional[float] = None,
    sigma: Optional[float] = None,
    brdf_params: Optional[Dict[str, Any]] = None,
    albedo: Any = None,
    max_amplification: float = 10.0,
    lambda_rule: str = "gcv",
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
    pixel_filter: Optional[str] = None,
) -> InvertLightingReport:
    view = _View(images, camera, sphere, scene, stderr, layer, pixel_filter)
    amp = _args.real("max_amplification", max_amplification)
    if not amp >= 1.0:
        raise InputError(f"max_amplification= must be a finite number ≥ 1, got {amp}")
    rule = choice("lambda_rule", lambda_rule, ("gcv", "discrepancy"))
    report = _reflect.invert_lighting(
        view.items,
        view.names,
        view.view,
        lmax=lmax_of(lmax),
        brdf=_args.optional_string("brdf", brdf),
        brdf_params=_brdf_params(s, sigma, brdf_params),
        albedo=rgb("albedo", albedo),
        max_amplification=amp,
        discrepancy=rule == "discrepancy",
    )
    return _reported(report)


def invert_brdf(
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
    view = _View(images, camera, sphere, scene, stderr, layer, pixel_filter)
    model = choice("model", model, ("phong", "torrance-sparrow", "microfacet"))  # type: ignore[assignment]
    if model is None:
        raise InputError("model= is required: 'phong', 'torrance-sparrow' or 'microfacet'")
    distribution = choice("distribution", distribution, ("beckmann", "ggx"))
    if distribution is not None and model != "microfacet":
        raise InputError("distribution= applies to model='microfacet' only")
    report = _reflect.invert_brdf(
        view.items,
        view.names,
        view.view,
        model=model,
        lmax=lmax_of(lmax),
        lighting=_lighting(lighting),
        mapping=choice("mapping", mapping, ("latlong", "angular")),
        distribution=distribution,
        min=positive("min", min),
        max=positive("max", max),
    )
    return _reported(report)


def invert_separate(
    images: Images,
    *,
    lmax: int = 8,
    kd: Any = None,
    ks: Any = None,
    channel: Optional[str] = None,
    scan: bool = False,
    camera: Any = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
) -> InvertSeparateReport:
    view = _View(images, camera, None, scene, stderr, layer, None)
    ch = choice("channel", channel, ("r", "g", "b", "R", "G", "B"))
    report = _reflect.invert_separate(
        view.items,
        view.names,
        view.view,
        # (analysis::separate::MAX_LMAX: the least squares costs O(pixels · (lmax+1)⁴).)
        lmax=_args.integer("lmax", lmax, 0, 32),
        kd=rgb("kd", kd),
        ks=rgb("ks", ks),
        channel=None if ch is None else "rgb".index(ch.lower()),
        scan=_args.boolean("scan", scan),
    )
    return _reported(report)


def _pair(name: str, v: Any, lo: int, hi: int) -> Tuple[int, int]:
    try:
        a, b = v
    except (TypeError, ValueError):
        raise InputError(f"{name}= must be a pair of integers, got {v!r}") from None
    return _args.integer(f"{name}[0]", a, lo, hi), _args.integer(f"{name}[1]", b, lo, hi)


def invert_factor(
    images: Any = (),
    *,
    lmax: int,
    nodes: Any = None,
    normal: Any = None,
    channel: str = "r",
    quadrature: str = "fejer",
    max_amplification: float = 10.0,
    scene: Any = None,
    size: Any = (96, 48),
    camera: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
) -> InvertFactorReport:
    ch = "rgb".index(str(choice("channel", channel, ("r", "g", "b", "R", "G", "B"))).lower())
    rule = str(choice("quadrature", quadrature, ("fejer", "pixel")))
    amp = _args.real("max_amplification", max_amplification)
    if not (math.isfinite(amp) and amp >= 1.0):
        raise InputError(f"max_amplification= must be a finite number ≥ 1, got {amp}")
    lmax = lmax_of(lmax)
    node_rule = None if nodes is None else _pair("nodes", nodes, 1, 1 << 20)
    no_images = isinstance(images, (list, tuple)) and len(images) == 0
    if no_images:
        # The light field of a scene file, rendered in memory at every node and at θ_o = 0.
        if scene is None:
            raise InputError("no input: give normal-probe images=, or scene= (a scene file) with nodes=(n_mu, n_phi)")
        if not isinstance(scene, (str, os.PathLike)):
            raise InputError("scene= without images must be the path of a scene file whose light field is rendered")
        if node_rule is None:
            raise InputError("scene= needs nodes=(n_mu, n_phi), e.g. (8, 16)")
        for k, v in (("normal", normal), ("camera", camera), ("stderr", stderr), ("layer", layer)):
            if v is not None:
                raise InputError(f"{k}= describes images; without images the scene's light field is rendered")
        report = _reflect.invert_factor_scene(
            os.fspath(scene), lmax=lmax, nodes=node_rule, size=_pair("size", size, 2, 4096), channel=ch,
            quadrature=rule, max_amplification=amp,
        )
        return _reported(report)
    view = _View(images, camera, None, scene, stderr, layer, None)
    normal_view = None
    if normal is not None:
        # The normal view is at θ_o = 0 by definition: an array of it needs no camera=.
        ncam = {"type": "normal-probe", "theta_o_deg": 0.0, "phi_o_deg": 0.0}
        is_file = isinstance(normal, (str, os.PathLike, RenderResult))
        nv = _View([normal], None if is_file else ncam, None, scene, None, layer, None)
        name = nv.names[0] if is_file else "<normal array>"
        normal_view = (nv.items[0], name, nv.view)
    report = _reflect.invert_factor(
        view.items, view.names, view.view, normal_view, lmax=lmax, nodes=node_rule, channel=ch, quadrature=rule,
        max_amplification=amp,
    )
    return _reported(report)
