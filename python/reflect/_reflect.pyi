"""Type stub of the native module ``reflect._reflect`` (Rust, PyO3).

The public API is the package ``reflect`` (``reflect/__init__.py``, ``reflect/sh.py``, …), which
shapes arguments and calls these functions. Conventions: the project's guide in ``docs/``
(sections "Frames and directions", "Environment maps and `rotate_deg`", "Spherical harmonics: the terms the
commands print", "BRDFs", "Output images", "Scene files", "Command line"). Every function
raises ``reflect.InputError`` (a ``ValueError``) with a one-line message on bad input,
``reflect.MissingFileError`` (a ``FileNotFoundError``) when a named input file does not exist.
"""

from typing import Any, Dict, List, Optional, Tuple, Union, final

import numpy as np
import numpy.typing as npt

from ._analysis import AnalyzeReport, InvertBrdfReport, InvertFactorReport, InvertLightingReport, InvertSeparateReport

__version__: str
__all__ = [
    "NativeBrdf",
    "NativeLight",
    "RenderResult",
    "__version__",
    "analyze",
    "compare",
    "header_attributes",
    "invert_brdf",
    "invert_factor",
    "invert_factor_scene",
    "invert_lighting",
    "invert_separate",
    "load_scene",
    "read_image",
    "render",
    "sh_evaluate",
    "sh_project_array",
    "sh_project_file",
    "sh_rotate",
    "sh_transfer",
    "verify",
    "verify_checks",
    "write_image",
]

@final
class RenderResult:
    """A finished render (guide "Output images"), row 0 at the top of the image.

    Background pixels (``mask`` 0: the ray missed every object and shows the environment) have
    ``stderr`` 0 and the environment's radiance in ``rgb``, so a whole-image mean mixes them in:
    average over the object with the mask, ``image.stderr[image.mask > 0].mean()`` (or
    ``image.rgb[image.mask == 1]`` for fully covered pixels only)."""

    @property
    def rgb(self) -> npt.NDArray[np.float32]:
        """Linear RGB radiance, the mean of each pixel's samples: (H, W, 3) float32."""
    @property
    def stderr(self) -> npt.NDArray[np.float32]:
        """Standard error of each pixel mean, √(s²/n): (H, W, 3) float32 (conservative for Sobol);
        +inf at 1 spp, where one sample has no spread (no estimate, never 0 on the object). 0 on the
        background (``mask`` 0, a constant environment lookup): select the object,
        ``stderr[mask > 0]``, before averaging."""
    @property
    def stderr_own(self) -> npt.NDArray[np.float32]:
        """The pixel's own standard error, before the bound near flagged pixels (the ``stderr_own``
        layer): (H, W, 3) float32."""
    @property
    def normal(self) -> npt.NDArray[np.float32]:
        """World-space normal of the first hit, averaged and renormalized; 0 on a miss: (H, W, 3) float32."""
    @property
    def mask(self) -> npt.NDArray[np.float32]:
        """Fraction of each pixel's samples that hit an object, in [0, 1]: (H, W) float32; ``mask > 0``
        selects the object's pixels (silhouette pixels included), ``mask == 1`` the fully covered ones."""
    @property
    def stderr_flag(self) -> npt.NDArray[np.bool_]:
        """The ``stderr_flag.Y`` layer: (H, W) bool, True where the pixel's error bar cannot be trusted
        (one rare sample dominates its variance: the largest batch deviation squared exceeds half the
        sum of squared deviations, judged from 16 samples on; the same flag ``reflect render`` writes)."""
    @property
    def stats(self) -> Dict[str, Any]:
        """``wall_seconds``, ``samples``, ``rays``, ``threads``, ``samples_per_sec``, ``rays_per_sec``,
        the settings used: ``width``, ``height``, ``spp``, ``seed``, ``max_depth``, ``sampler``, and of a
        render in passes, named as ``reflect render --json``'s ``progressive`` object: ``passes``,
        ``stopped_by`` (``"target"``, ``"time-limit"``, ``"spp-cap"``), ``spp_cap`` (the most spp
        allowed), ``target_reached`` (bool; None without ``target_rel_error``), ``rel_error_p95`` (the
        95th-percentile relative error reached, or None), ``rel_error_unknown`` (why it is None),
        ``target_rel_error``, ``time_limit``."""
    @property
    def spp(self) -> int:
        """Samples per pixel of the image: the spp reached by a render to a target error or time limit."""
    @property
    def seed(self) -> int:
        """The render's seed."""
    @property
    def sampler(self) -> str:
        """The sampler: ``"sobol"``, ``"independent"`` or ``"sobol-single"`` (one Sobol sequence per pixel, no
        replicates: its ``stderr`` is conservative, 1.5–10× too wide)."""
    @property
    def seconds(self) -> float:
        """The render loop's wall time, seconds (scene loading not included)."""
    def save(self, path: str) -> None:
        """Writes the OpenEXR file ``reflect render`` writes (32-bit float R, G, B, normal.X/Y/Z,
        mask.Y, stderr.R/G/B, stderr_flag.Y, the scene in the header), atomically. ``path`` must end in ``.exr``."""

def render(
    kind: str,
    value: Any,
    base: Optional[str] = None,
    spp: Optional[int] = None,
    seed: Optional[int] = None,
    size: Optional[Tuple[int, int]] = None,
    threads: Optional[int] = None,
    sampler: Optional[str] = None,
    progress: bool = False,
    target_rel_error: Optional[float] = None,
    time_limit: Optional[float] = None,
    checkpoint: Optional[str] = None,
    checkpoint_every: Optional[float] = None,
) -> RenderResult:
    """Renders a scene through the renderer's progressive loop (``renderer::progressive``): ``kind``
    "path" (``value`` a file), "toml" (TOML text) or "dict" (the scene tables); relative data paths
    from ``base`` (default: the file's folder, else the current directory). ``target_rel_error``
    (relative, > 0), ``time_limit`` (seconds), ``checkpoint`` (a partial-render ``.exr`` file resumed
    from and saved to every ``checkpoint_every`` seconds, removed when the render completes). The GIL is
    released; SIGINT cancels the render (saving the checkpoint) and raises KeyboardInterrupt."""

@final
class NativeBrdf:
    """A BRDF built from a scene file's ``brdf`` table (``reflect.brdf`` wraps it). Local shading frame
    (normal +z), ω_i and ω_o pointing away from the surface; C-contiguous float32 arrays."""

    def __new__(cls, table: Dict[str, Any]) -> "NativeBrdf": ...
    def eval(self, wi: npt.NDArray[np.float32], wo: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """ρ̂ = BRDF · cos θ_i per row of (N, 3) ``wi`` and ``wo``: (N, 3) float32, sr⁻¹."""
    def pdf(self, wi: npt.NDArray[np.float32], wo: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Solid-angle density of ``sample`` drawing ``wi`` given ``wo``: (N,) float32, sr⁻¹."""
    def sample(
        self, wo: npt.NDArray[np.float32], u: npt.NDArray[np.float32], u_lobe: npt.NDArray[np.float32]
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.bool_]]:
        """(wi (N, 3), weight = ρ̂/pdf (N, 3), pdf (N,), delta (N,)) for ``wo`` (N, 3), ``u`` (N, 2),
        ``u_lobe`` (N,); zeros where nothing is drawn."""

@final
class NativeLight:
    """A distant light built from a scene file's ``[lighting]`` table (``reflect.light`` wraps it).
    World-frame directions toward the light; C-contiguous float32 arrays."""

    def __new__(cls, table: Dict[str, Any], base: str) -> "NativeLight": ...
    def eval(self, direction: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Radiance L(ω) from each of (N, 3) directions: (N, 3) float32."""
    def pdf(self, direction: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        """Solid-angle density of ``sample`` drawing each direction: (N,) float32, sr⁻¹."""
    def sample(
        self, u: npt.NDArray[np.float32]
    ) -> Tuple[npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.float32], npt.NDArray[np.bool_]]:
        """(direction (N, 3), value = L/pdf (N, 3), pdf (N,), delta (N,)) for ``u`` (N, 2)."""

def load_scene(kind: str, value: Any, base: Optional[str] = None) -> Tuple[Dict[str, Any], str, Optional[str]]:
    """Checks a scene with the scene-file types and returns (tables as given, base folder, file)."""

def read_image(path: str) -> Tuple[Dict[str, npt.NDArray[np.float32]], Dict[str, str]]:
    """Every channel of an ``.exr``/``.hdr`` file as (H, W) float32, and the header's string attributes (a render's
    state: the image of the samples it holds)."""

def sh_project_file(path: str, mapping: Optional[str], lmax: int) -> npt.NDArray[np.float64]:
    """L_lm = ∫ L(ω) Y_lm(ω) dω of an environment map file, exact per pixel: ((lmax+1)², 3) float64."""

def sh_project_array(env: npt.NDArray[np.float32], mapping: Optional[str], lmax: int) -> npt.NDArray[np.float64]:
    """L_lm of an (H, W, 3) float32 C-contiguous array of linear radiance: ((lmax+1)², 3) float64."""

def sh_evaluate(coeffs: npt.NDArray[np.float64], directions: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Σ_k c_k Y_k(ω) for coefficients ((L+1)², 3) at directions (N, 3) (normalized here): (N, 3) float64."""

def sh_transfer(
    brdf: str, lmax: int, s: Optional[float] = None, sigma: Optional[float] = None, theta_o_deg: Optional[float] = None
) -> Tuple[npt.NDArray[np.float64], Optional[Tuple[str, npt.NDArray[np.float64]]]]:
    """(Λ_l ρ̂_l for l = 0 … lmax as (lmax+1,) float64, and the paper's approximation
    (equation name, values) where it has one: eq. 46 Phong, eq. 57/59 Torrance–Sparrow)."""

def sh_rotate(coeffs: npt.NDArray[np.float64], rotation: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Coefficients of f(Rᵀω) for coefficients ((L+1)², 3) and a 3 × 3 rotation R: ((L+1)², 3) float64."""

# The analyses: ``images`` are paths (str), RenderResult objects, or ``{"channels": {name: (H, W)
# float32}, "attributes": {str: str}}`` (an array's layers and the header of what it shows);
# ``names`` one name per image for reports and messages (a path, "<array i>", "<RenderResult i>");
# ``view`` ``{"scene": path | None (the sidecar scene of files), "center": [x, y, z] | None,
# "radius": float | None, "layer": str | None, "pixel_filter": str | None}``. Each returns its
# report object (``reflect._analysis``): built from the ``--json`` document (null → None) and the
# CLI's ``note: …`` lines. No file is written; the analysis runs without the GIL on a thread of its
# own, and Ctrl-C raises KeyboardInterrupt at once.

_Images = List[Any]

def analyze(
    images: _Images,
    names: List[str],
    view: Dict[str, Any],
    *,
    lmax: int,
    lighting: Any = None,
    mapping: Optional[str] = None,
    param: Optional[str] = None,
    brdf: Optional[str] = None,
    brdf_params: List[Tuple[str, Union[float, str]]] = ...,
    albedo: Optional[List[float]] = None,
    no_diagnosis: bool = False,
) -> AnalyzeReport:
    """``analysis::analyze::analyze``. ``lighting``: a path, a ``[lighting]`` dict, SH coefficients
    ((L+1)², 3) float64 or a map (H, W, 3) float32 (projected here, with ``mapping``)."""

def invert_lighting(
    images: _Images,
    names: List[str],
    view: Dict[str, Any],
    *,
    lmax: int,
    brdf: Optional[str] = None,
    brdf_params: List[Tuple[str, Union[float, str]]] = ...,
    albedo: Optional[List[float]] = None,
    max_amplification: float = ...,  # analysis::inverse::lighting::DEFAULT_MAX_AMPLIFICATION (10)
    discrepancy: bool = False,
) -> InvertLightingReport:
    """``analysis::invert::lighting`` (λ by GCV, or the discrepancy principle)."""

def invert_brdf(
    images: _Images,
    names: List[str],
    view: Dict[str, Any],
    *,
    model: str,
    lmax: int,
    lighting: Any = None,
    mapping: Optional[str] = None,
    distribution: Optional[str] = None,
    min: Optional[float] = None,
    max: Optional[float] = None,
) -> InvertBrdfReport:
    """``analysis::invert::brdf``; ``model`` "phong" | "torrance-sparrow" | "microfacet"."""

def invert_separate(
    images: _Images,
    names: List[str],
    view: Dict[str, Any],
    *,
    lmax: int,
    kd: Optional[List[float]] = None,
    ks: Optional[List[float]] = None,
    channel: Optional[int] = None,
    scan: bool = False,
) -> InvertSeparateReport:
    """``analysis::separate::separate``; ``channel`` 0, 1, 2 for R, G, B (None: all three)."""

def invert_factor(
    images: List[Any],
    names: List[str],
    view: Dict[str, Any],
    normal: Optional[Tuple[Any, str, Dict[str, Any]]],
    *,
    lmax: int,
    nodes: Optional[Tuple[int, int]],
    channel: int,
    quadrature: str,
    max_amplification: float,
) -> InvertFactorReport:
    """``analysis::factor::factor_images``: normal-probe views, one per node of the outgoing rule, and an
    optional θ_o = 0 view ``(image, name, view)``; ``channel`` 0, 1, 2 for R, G, B."""

def invert_factor_scene(
    scene: str,
    *,
    lmax: int,
    nodes: Tuple[int, int],
    size: Tuple[int, int],
    channel: int,
    quadrature: str,
    max_amplification: float,
) -> InvertFactorReport:
    """``renderer::light_field::factor_scene``: the scene file's light field, rendered in memory at
    every node and at θ_o = 0 on a ``size`` = (W, H) grid, factored; Ctrl-C stops its renders."""

def write_image(path: str, channels: Dict[str, npt.NDArray[np.float32]], attributes: Dict[str, str]) -> None:
    """Writes a 32-bit float OpenEXR: each C-contiguous (H, W) float32 array of ``channels`` (one
    shape, finite values) as the channel of that name, ``attributes`` as header string attributes."""

def header_attributes(scene: Dict[str, Any]) -> Dict[str, str]:
    """``reflect:camera``, ``reflect:lighting``, ``reflect:objects`` as a render of ``scene`` (a dict
    with ``camera``, ``lighting`` and ``objects`` tables of the scene vocabulary) writes them:
    checked with the scene file's types, defaults filled, numbers as float32 (as the renderer holds them)."""

def compare(
    images: List[Union[str, Dict[str, Any]]],
    alpha: float,
    block: int,
    exclude_edges: int,
    layer: Optional[str] = None,
    object_only: bool = False,
) -> Dict[str, Any]:
    """``analysis::compare`` on [a, b, seeds…]: each a path or a dict of float32 arrays (``rgb``
    (H, W, 3), optional ``stderr`` and ``stderr_own`` (H, W, 3), ``stderr_flag`` and ``mask`` (H, W), ``spp`` and
    ``sampler``: ``"independent"``, the default, ``"sobol"`` or ``"sobol-single"``, which fix the error layer's degrees of freedom).
    Returns the document ``reflect compare --json`` prints. Bad input raises ``ValueError``
    (``FileNotFoundError`` for a missing file) naming the input (``a``, ``b``, ``seeds[k]`` or its path)."""

def verify_checks() -> List[Tuple[str, str]]:
    """The checks of ``reflect verify --list``: (name, equations)."""

def verify(
    quick: bool = True,
    checks: Optional[List[str]] = None,
    seed: Optional[int] = None,
    data: Optional[str] = None,
    out: Optional[str] = None,
    threads: Optional[int] = None,
) -> Dict[str, Any]:
    """Runs the checks of ``reflect verify`` and returns the document of ``verify --json``."""
