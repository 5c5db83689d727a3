"""reflect: a Monte Carlo path tracer and a verifier of Ramamoorthi & Hanrahan's frequency-space
theory of reflection, with NumPy arrays in and out.

- :func:`render` renders a scene (a path, TOML text, a dict or a :class:`Scene`) exactly as
  ``reflect render`` does: same scene and seed, same bits.
- :mod:`reflect.sh`: project environments into spherical harmonics, evaluate, transfer
  coefficients Λ_l ρ̂_l, rotation.
- :func:`analyze`, :mod:`reflect.invert`, :func:`verify`: the CLI's ``--json`` documents as
  dicts, with numeric lists as NumPy arrays.

Conventions (frame, SH basis, image layers, scene files) are those of the project's README
(sections "Frames and directions", "Spherical harmonics: the terms the commands print", "Output
images", "Scene files"). Bad input raises ``ValueError`` (``FileNotFoundError`` for a missing file) with the
CLI's one-line message.
"""

from __future__ import annotations

import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _reflect
from ._reflect import RenderResult, __version__
from ._scene import Scene, SceneLike, load_scene

__all__ = [
    "Image",
    "RenderResult",
    "Scene",
    "__version__",
    "list_checks",
    "load_scene",
    "read_image",
    "render",
    "sh",
    "verify",
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
) -> RenderResult:
    """Renders a scene and returns its image layers as NumPy arrays.

    ``scene`` is a path (``str`` without a line break, or ``os.PathLike``), TOML text (a ``str``
    with line breaks), a dict in the scene vocabulary (README "Scene files"; relative data paths from
    the current directory) or a :class:`Scene`. The keyword arguments override the scene's
    ``[render]`` table as the CLI's ``--spp``, ``--seed``, ``--size WxH`` (here ``(width,
    height)``), ``--threads`` and ``--sampler`` do; the image does not depend on ``threads``.

    The GIL is released while rendering; Ctrl-C stops the render and raises ``KeyboardInterrupt``.
    """
    from ._scene import _source

    kind, value, base = _source(scene)
    return _reflect.render(
        kind,
        value,
        base,
        spp=spp,
        seed=seed,
        size=None if size is None else (int(size[0]), int(size[1])),
        threads=threads,
        sampler=sampler,
        progress=progress,
    )


def read_image(path: Union[str, "os.PathLike[str]"]) -> Image:
    """Reads an ``.exr`` or ``.hdr`` file as the analysis commands read it.

    Returns an :class:`Image`: ``channels`` maps each channel name (``R``, ``G``, ``B``,
    ``normal.X``, ``mask.Y``, ``stderr.R``, …) to an (H, W) float32 array, row 0 at the top;
    ``attributes`` holds the header's string attributes (a render's ``reflect:scene``,
    ``reflect:camera``, …). Non-finite values are refused (``ValueError``).
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
    (report.md/html/json and SVG plots) there. The GIL is released; a Ctrl-C takes effect when
    the running checks finish. A failed check is a result (``passed`` false), not an exception.
    """
    names = [checks] if isinstance(checks, str) else None if checks is None else list(checks)
    return _reflect.verify(
        quick,
        names,
        seed,
        None if data is None else os.fspath(data),
        None if out is None else os.fspath(out),
        threads,
    )


from . import sh  # noqa: E402  (after render: sh imports nothing from here but keeps the order readable)
