"""reflect: a Monte Carlo path tracer and a verifier of Ramamoorthi & Hanrahan's frequency-space
theory of reflection, with NumPy arrays in and out.

- :func:`render` renders a scene (a path, TOML text, a dict or a :class:`Scene`) exactly as
  ``reflect render`` does: same scene and seed, same bits.
- :mod:`reflect.sh`: project environments into spherical harmonics, evaluate, transfer
  coefficients Λ_l ρ̂_l, rotation.
- :func:`analyze`, :mod:`reflect.invert`: the analyses on paths, renders or NumPy arrays, called
  directly (no files written), returning report objects (:class:`AnalyzeReport`, …) whose
  attributes are NumPy arrays and whose ``to_dict()`` is the CLI's ``--json`` document.
- :func:`verify`: the CLI's ``--json`` document as a dict, with numeric lists as NumPy arrays.

- :mod:`reflect.brdf` and :mod:`reflect.light`: the renderer's BRDFs and lights as objects with
  ``eval``, ``sample`` and ``pdf`` over NumPy batches.

Conventions (frame, SH basis, image layers, scene files) are those of the project's guide,
``docs/src/conventions.md`` (sections "Spherical harmonics: the terms the commands print", "Output
images", "Scene files" of the guide give the details). Bad input raises :class:`reflect.InputError` (a ``ValueError``; :class:`reflect.MissingFileError`, a
``FileNotFoundError``, for a missing file), all subclasses of :class:`reflect.Error`, with a one-line
message naming this API's keywords. Results to be read with care raise :class:`reflect.Warning` (a
``UserWarning``): a report's ``warnings``, a render short of its ``target_rel_error``.
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _args, _reflect
from ._analysis import (
    AnalyzeReport,
    InvertBrdfReport,
    InvertFactorReport,
    InvertLightingReport,
    InvertSeparateReport,
    Report,
    Table,
)
from ._errors import Error, FileError, InputError, MissingFileError, TargetNotReachedWarning, Warning
from ._reflect import RenderResult, __version__
from ._scene import Scene, SceneLike, load_scene

ImageLike = Union[str, "os.PathLike[str]", RenderResult, np.ndarray]

__all__ = [
    "AnalyzeReport",
    "Error",
    "InvertBrdfReport",
    "InvertLightingReport",
    "InvertFactorReport",
    "InvertSeparateReport",
    "Report",
    "FileError",
    "Image",
    "InputError",
    "MissingFileError",
    "brdf",
    "light",
    "analyze",
    "compare",
    "invert",
    "RenderResult",
    "Scene",
    "Table",
    "TargetNotReachedWarning",
    "Warning",
    "__version__",
    "list_checks",
    "load_scene",
    "read_image",
    "render",
    "sh",
    "verify",
    "write_image",
]


def render(
    scene: SceneLike,
    *,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    size: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    sampler: Optional[str] = None,
    progress: bool = False,
    target_rel_error: Optional[float] = None,
    time_limit: Optional[float] = None,
    checkpoint: Union[None, str, "os.PathLike[str]"] = None,
    checkpoint_every: Optional[float] = None,
) -> RenderResult:
    """Renders a scene and returns its image layers as NumPy arrays.

    ``scene`` is a path (``str`` without a line break, or ``os.PathLike``), TOML text (a ``str``
    with line breaks), a dict in the scene vocabulary (guide "Scene files"; relative data paths from
    the current directory) or a :class:`Scene`. The keyword arguments override the scene's
    ``[render]`` table as the CLI's ``--spp``, ``--seed``, ``--size WxH`` (here ``(width,
    height)``), ``--threads`` and ``--sampler`` do; the image does not depend on ``threads``.

    Integers must be ``int`` (or NumPy integers): a float (even ``3.0``), a bool, a negative or
    too large value raises ``ValueError`` naming the keyword, as does any other bad argument.

    Rendering in passes (the renderer's progressive loop, the one ``reflect render`` runs):
    ``target_rel_error`` (e.g. 0.01) stops once the 95th percentile over the object's pixels (``mask`` > 0) of the
    worst channel's relative standard error is at most it (checked from 16 spp on; ``spp`` is then the
    most samples to take); ``time_limit`` (seconds of rendering) stops after the last pass that fits;
    ``checkpoint`` (an ``.exr`` path) resumes from that file if it exists and saves the state there every
    ``checkpoint_every`` seconds (default 60) and on Ctrl-C. The image is bit-identical to a plain
    render of the samples reached. The result's :attr:`RenderResult.spp` is the spp reached and its
    ``stats`` say how it went, with the names of ``reflect render --json``'s ``progressive`` object:
    ``passes``, ``stopped_by`` ("target", "time-limit" or "spp-cap"), ``spp_cap`` (the most spp
    allowed), ``target_reached`` (None without ``target_rel_error``), ``rel_error_p95`` (None with
    ``rel_error_unknown`` saying why when there is no estimate). A render that stops short of
    ``target_rel_error`` (at the spp cap or the time limit) raises :class:`TargetNotReachedWarning`
    (a :class:`reflect.Warning`) and returns the image it has; raise ``spp`` to go further.
    ``progress=True`` draws the tile bar and one line per pass on stderr.

    Nothing is written to disk (no temporary files) unless ``checkpoint`` is given.

    The GIL is released while rendering; Ctrl-C stops the render within one tile and raises
    ``KeyboardInterrupt``. Bad arguments raise :class:`InputError` (a ``ValueError``) naming the keyword.
    """
    from ._scene import _source

    spp = _args.optional_integer("spp", spp, 0, _args.U32_MAX)
    seed = _args.optional_integer("seed", seed)
    if size is not None:
        if isinstance(size, (str, bytes)) or not hasattr(size, "__len__") or len(size) != 2:
            raise ValueError(f"size= must be a pair (width, height), got {size!r}")
        size = (_args.integer("size", size[0], 1, _args.U32_MAX), _args.integer("size", size[1], 1, _args.U32_MAX))
    threads = _args.optional_integer("threads", threads, 1, 2**31 - 1)
    sampler = _args.optional_string("sampler", sampler)
    progress = _args.boolean("progress", progress)
    target_rel_error = _positive("target_rel_error", target_rel_error)
    time_limit = _positive("time_limit", time_limit)
    checkpoint_every = _positive("checkpoint_every", checkpoint_every)
    if checkpoint_every is not None and checkpoint is None:
        raise InputError("checkpoint_every= needs checkpoint=")
    ck = None if checkpoint is None else os.fspath(checkpoint)
    if ck is not None and not ck.lower().endswith(".exr"):
        raise InputError(f"checkpoint= must name an .exr file, got {ck!r}")
    kind, value, base = _source(scene)
    result = _reflect.render(
        kind,
        value,
        base,
        spp=spp,
        seed=seed,
        size=size,
        threads=threads,
        sampler=sampler,
        progress=progress,
        target_rel_error=target_rel_error,
        time_limit=time_limit,
        checkpoint=ck,
        checkpoint_every=checkpoint_every,
    )
    if result.stats.get("target_reached") is False:
        import warnings

        st = result.stats
        err = st.get("rel_error_p95")
        got = f"{100 * err:.4g} %" if err is not None else f"unknown ({st.get('rel_error_unknown')})"
        warnings.warn(
            f"target_rel_error={target_rel_error} not reached: stopped by {st['stopped_by']} at {result.spp} of at most "
            f"{st['spp_cap']} spp with a 95th-percentile relative error of {got}; raise spp= (the cap) to go further",
            TargetNotReachedWarning,
            stacklevel=2,
        )
    return result


def _positive(name: str, v: Any) -> Optional[float]:
    x = _args.optional_real(name, v)
    if x is not None and x <= 0:
        raise InputError(f"{name}= must be a positive number, got {x}")
    return x
def _compare_input(x: Any, name: str) -> Any:
    """A path as str, an array or RenderResult as the dict of float32 arrays the native
    ``compare`` takes."""
    if isinstance(x, (str, os.PathLike)):
        return os.fspath(x)
    if isinstance(x, RenderResult):
        return {
            "rgb": np.ascontiguousarray(x.rgb, dtype=np.float32),
            "stderr": np.ascontiguousarray(x.stderr, dtype=np.float32),
            "stderr_own": np.ascontiguousarray(x.stderr_own, dtype=np.float32),
            "stderr_flag": np.ascontiguousarray(x.stderr_flag, dtype=np.float32),
            "mask": np.ascontiguousarray(x.mask, dtype=np.float32),
            "spp": int(x.stats["spp"]),
            "sampler": str(x.stats["sampler"]),
        }
    if isinstance(x, np.ndarray):
        x = {"rgb": x}
    if isinstance(x, dict):
        out: Dict[str, Any] = {}
        for k, v in x.items():
            out[k] = v if k in ("spp", "sampler") or v is None else np.ascontiguousarray(v, dtype=np.float32)
        return out
    raise TypeError(f"{name}: expected a path, an (H, W, 3) array, a dict of arrays or a RenderResult, got {type(x).__name__}")


def compare(
    a: Any,
    b: Any,
    *,
    seeds: Sequence[Any] = (),
    alpha: float = 0.01,
    block: int = 8,
    exclude_edges: int = 0,
    object_only: bool = False,
    layer: Optional[str] = None,
) -> Dict[str, Any]:
    """Is image ``a`` image ``b`` up to their Monte Carlo noise? ``reflect compare --json``.

    Each image is a path (``.exr``/``.hdr``), a :class:`RenderResult` (its ``stderr`` layer, flags,
    mask and spp are used), an (H, W, 3) array of linear radiance (no error estimate: taken as
    exact), or a dict of arrays ``{"rgb": (H, W, 3), "stderr": (H, W, 3), "stderr_own": (H, W, 3), "stderr_flag": (H, W),
    "mask": (H, W), "spp": int, "sampler": str}`` (all but ``rgb`` optional; ``spp`` and
    ``sampler`` give the error layer's degrees of freedom: spp − 1 for ``"independent"``, the
    default, ``"sobol-single"`` and any renderer whose error bar is the samples' standard error, 15 for ``"sobol"``,
    whose error bar is the spread of 16 replicates). ``seeds``: further independent renders of ``b``'s renderer; ``b``'s
    noise is then the seeds' per-pixel spread. ``alpha``: the family-wise false-alarm rate of the
    verdict; ``block``: the side of the block test's tiles (pixels); ``exclude_edges``: leave out
    pixels within that many pixels of the silhouette (3 for Mitsuba 3's default Gaussian film);
    ``object_only``: leave out the background (coverage 0 in a mask or alpha channel).

    Returns the ``--json`` document as a dict (plain lists, as the CLI prints it): ``verdict``
    ("agree" | "disagree"), ``reason``, ``alpha``, ``alpha_per_test``, ``tests``, ``scale``,
    ``pixels``, ``blocks``, ``edges``, ``histogram``, ``warnings``. No file is written. Bad input
    raises ``ValueError`` (``FileNotFoundError`` for a missing file) naming ``a``, ``b`` or
    ``seeds[k]`` (or the path).
    """
    images = [_compare_input(a, "a"), _compare_input(b, "b")]
    images += [_compare_input(s, f"seeds[{k}]") for k, s in enumerate(seeds)]
    return _reflect.compare(images, float(alpha), int(block), int(exclude_edges), layer, _args.boolean("object_only", object_only))


def read_image(path: Union[str, "os.PathLike[str]"]) -> Image:
    """Reads an ``.exr`` or ``.hdr`` file as the analysis commands read it.

    Returns an :class:`Image`: ``channels`` maps each channel name (``R``, ``G``, ``B``,
    ``normal.X``, ``mask.Y``, ``stderr.R``, …) to an (H, W) float32 array, row 0 at the top;
    ``attributes`` holds the header's string attributes (a render's ``reflect:scene``,
    ``reflect:camera``, …). Non-finite values are refused (``ValueError``). A render's state (a
    checkpoint, a ``--state`` file, a ``reflect merge --partial`` of the first shards) is read as
    the image a render of the samples it holds writes.
    """
    channels, attributes = _reflect.read_image(os.fspath(path))
    return Image(channels, attributes)


class Image:
    """An image file's channels and header (see :func:`read_image`)."""

    def __init__(self, channels: Dict[str, np.ndarray], attributes: Dict[str, str]):
        #: Channel name → (H, W) float32 array.
        self.channels = channels
        #: Header string attributes.
        self.attributes = attributes

    def layer(self, prefix: str = "") -> np.ndarray:
        """The (H, W, 3) float32 stack of ``{prefix}R/G/B`` (``""`` for radiance, ``"stderr."``, …);
        ``normal.`` takes ``X/Y/Z``."""
        names = "XYZ" if prefix == "normal." else "RGB"
        try:
            return np.stack([self.channels[prefix + c] for c in names], axis=-1)
        except KeyError as e:
            raise ValueError(f"image has no channel {e.args[0]}") from None

    def __repr__(self) -> str:
        return f"<reflect.Image channels {sorted(self.channels)}>"


def write_image(
    path: Union[str, "os.PathLike[str]"],
    channels: Dict[str, np.ndarray],
    attributes: Optional[Dict[str, str]] = None,
) -> None:
    """Writes a 32-bit float OpenEXR file: each (H, W) array of ``channels`` as the channel of that
    name (``R``, ``G``, ``B``, ``stderr.R``, …; all the same shape, finite), and ``attributes`` as
    string attributes of the header (ASCII). The inverse of :func:`read_image`."""
    ch = {str(k): np.ascontiguousarray(v, dtype=np.float32) for k, v in channels.items()}
    _reflect.write_image(os.fspath(path), ch, dict(attributes or {}))


def analyze(
    images: Union[ImageLike, Sequence[ImageLike]],
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
    camera: Union[None, Dict[str, Any], Sequence[Dict[str, Any]]] = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
    layer: Optional[str] = None,
    pixel_filter: Optional[str] = None,
    no_diagnosis: bool = False,
) -> "AnalyzeReport":
    """Projects images of a sphere into SH and compares them with the lighting and eq. 15: the
    analysis of ``reflect analyze``, called directly (no file is written).

    ``images``: one image or a list: ``.exr`` paths, :class:`RenderResult` objects, or (H, W, 3)
    arrays of linear radiance (one normal-probe image, or orthographic views of one sphere). An
    array has no header, so say what it shows: ``camera`` (a scene-file camera table, e.g.
    ``{"type": "orthographic", "from": [3, 0, 0], "to": [0, 0, 0], "extent": 1.05}`` or
    ``{"type": "normal-probe"}``; a list gives one per array), ``sphere`` (``{"center": [x, y,
    z], "radius": r, "brdf": {...}}``, world units; without ``brdf`` only the sphere's place)
    and/or ``scene`` (the scene it was rendered from: a path, TOML text, dict or :class:`Scene`;
    its camera, lighting and objects), and optionally ``stderr`` (an (H, W, 3) array per array
    image: the per-pixel standard error that weights the fits). Beside files, ``scene`` is the path
    of the scene they are renders of (for files whose header does not say it).

    ``lighting``: a scene file or environment-map path, a scene ``[lighting]`` table as a dict, SH
    coefficients ((L+1)², 3), or an environment-map array (H, W, 3); default: the images' own.
    ``mapping`` ("latlong" | "angular", for a map file or array): inferred when left out from the
    map's shape, W = 2H lat-long and W = H angular (another shape is an error asking for it).
    SH coefficients are read to l = max(16, lmax + 2); orders not given count as 0. ``param``: "normal" |
    "reflection" (default from the BRDF). ``brdf`` (a kind, "lambert", "phong", …), ``s``,
    ``sigma``, ``brdf_params`` (other keys of the brdf table) and ``albedo`` (one number or r, g,
    b): the sphere's BRDF where the images do not say it. ``layer``: the radiance layer of a
    multi-layer EXR; ``pixel_filter``: the reconstruction filter of another renderer
    ("gaussian:0.5", …). ``no_diagnosis``: when the image contradicts the lighting or BRDF it was
    told, ``analyze`` refits under other assumptions (a rotated or mirrored map, the other mapping,
    the camera) to name the cause, which makes a contradicted call several times slower (12 s
    instead of 3 s in a trial; minutes at 512²); ``no_diagnosis=True`` skips that search (the
    verdict still says whether there is a contradiction).

    Returns an :class:`AnalyzeReport`: ``coefficients`` B_lm ((lmax+1)², 3), ``stderr`` (same or
    None), ``lm`` ((lmax+1)², 2) int64 (k = l(l+1) + m), ``lighting["coefficients"]`` L_lm,
    ``filter`` (a :class:`Table`, per order: A_l = albedo · Λ_l ρ̂_l fitted in pixel space, ``estimate``/``stderr`` columns
    (lmax+1, 3)), ``lambda_rho_analytic`` (lmax+1, 3), ``predicted`` (eq. 15 B_lm), ``verdict``,
    ``warnings`` (also raised as :class:`reflect.Warning`); ``to_dict()`` is the CLI's ``--json``
    document. Ctrl-C raises ``KeyboardInterrupt``. Bad input raises
    :class:`InputError` (a ``ValueError``; :class:`MissingFileError` for a missing file) naming the
    keyword or the image. The GIL is released while the analysis runs.
    """
    from ._analysis import analyze as run

    return run(
        images,
        lmax=lmax,
        lighting=lighting,
        mapping=mapping,
        param=param,
        brdf=brdf,
        s=s,
        sigma=sigma,
        brdf_params=brdf_params,
        albedo=albedo,
        camera=camera,
        sphere=sphere,
        scene=scene,
        stderr=stderr,
        layer=layer,
        pixel_filter=pixel_filter,
        no_diagnosis=no_diagnosis,
    )


def list_checks() -> List[Tuple[str, str]]:
    """The checks :func:`verify` can run, as ``reflect verify --list`` prints them: (name, equations)."""
    return _reflect.verify_checks()


def verify(
    quick: bool = True,
    checks: Union[None, str, Sequence[str]] = None,
    seed: Optional[int] = None,
    *,
    data: Union[None, str, "os.PathLike[str]"] = None,
    out: Union[None, str, "os.PathLike[str]"] = None,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """Renders, projects into SH and checks the paper's claims, as ``reflect verify [--quick]``.

    Returns the document of ``reflect verify --json``: ``{"checks": [{"name", "equation",
    "passed", "measured", "expected", "tolerance", …}, …], "passed", "quick", "k_sigma",
    "seconds"}``, where each check's tolerance is k·σ (σ the standard error of the measurement)
    plus the stated approximation error. ``checks``: one name or several (see
    :func:`list_checks`; default all). ``seed``: base seed of the renders (default 1, as the
    CLI). ``data``: the folder holding ``grace_probe.hdr`` (default: ``$REFLECT_DATA``, else
    ``../shared/data`` from the current directory). ``out``: also write the report folder
    (report.md/html/json and SVG plots) there. The GIL is released; Ctrl-C stops the running check's
    render within one tile and raises ``KeyboardInterrupt``. A failed check is a result (``passed`` false), not an exception.
    Lists of numbers are NumPy arrays, as in :func:`analyze`.
    """
    from ._analysis import _arrays

    quick = _args.boolean("quick", quick)
    seed = _args.optional_integer("seed", seed)
    threads = _args.optional_integer("threads", threads, 1, 2**31 - 1)
    names = [checks] if isinstance(checks, str) else None if checks is None else list(checks)
    if names is not None and not all(isinstance(n, str) for n in names):
        raise ValueError(f"checks= must be a check name or a list of names, got {checks!r}")
    return _arrays(_reflect.verify(
        quick,
        names,
        seed,
        None if data is None else os.fspath(data),
        None if out is None else os.fspath(out),
        threads,
    ))


from . import brdf, invert, light, sh  # noqa: E402  (after render: sh imports nothing from here but keeps the order readable)
