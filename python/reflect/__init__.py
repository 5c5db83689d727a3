"""reflect: a Monte Carlo path tracer and a verifier of Ramamoorthi & Hanrahan's frequency-space
theory of reflection, with NumPy arrays in and out.

- :func:`render` renders a scene (a path, TOML text, a dict or a :class:`Scene`) exactly as
  ``reflect render`` does: same scene and seed, same bits.
- :mod:`reflect.sh`: project environments into spherical harmonics, evaluate, transfer
  coefficients Λ_l ρ̂_l, rotation.
- :func:`analyze`, :mod:`reflect.invert`, :func:`verify`: the CLI's ``--json`` documents as
  dicts, with numeric lists as NumPy arrays.

Conventions (frame, SH basis, image layers, scene files) are those of the project's
CONVENTIONS.md. Bad input raises ``ValueError`` (``FileNotFoundError`` for a missing file) with the
CLI's one-line message.
"""

from __future__ import annotations

import os
from typing import Dict, Optional, Tuple, Union

import numpy as np

from . import _reflect
from ._reflect import RenderResult, __version__
from ._scene import Scene, SceneLike, load_scene

__all__ = [
    "Image",
    "RenderResult",
    "Scene",
    "__version__",
    "load_scene",
    "read_image",
    "render",
    "sh",
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
    with line breaks), a dict in the scene vocabulary (CONVENTIONS §6; relative data paths from
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


from . import sh  # noqa: E402  (after render: sh imports nothing from here but keeps the order readable)
