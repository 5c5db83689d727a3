"""``reflect.invert.factor`` through the command line (the one analysis not yet in the ``analysis``
library as parameters → report; :mod:`reflect._analysis` is how the others are called).

Each function builds the command's argument list and runs the command's own library code in this
process (``_reflect.report``): the CLI's parser, defaults, checks and numbers. Images that are not
files are written first, to a temporary folder, as the OpenEXR files the command reads: a
:class:`RenderResult` exactly as ``save`` writes it (layers and header), an (H, W, 3) array as
R, G, B (and ``stderr.*`` when given) with a header saying what it shows: a render's header of
``scene``, and ``camera`` / ``sphere`` as given (what the CLI's view flags say for a file).
Temporary file names never reach the caller: in the report and in error messages they are
replaced by ``<array i>``, ``<RenderResult i>``, ``<lighting …>``.

The report is the document ``--json`` prints, with every list of numbers (nested to any depth,
rectangular) turned into a NumPy array: float64 where the JSON has a non-integer number or a null
(null → NaN), int64 where it has only integers (e.g. ``lm``). Lists of objects or strings stay
lists, empty lists stay ``[]``.
"""

from __future__ import annotations

import json
import keyword as keyword_module
import math
import numbers
import os
import re
import tempfile
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _args, _reflect
from ._reflect import RenderResult
from ._analysis import ImageLike  # noqa: F401  (re-exported for reflect.invert.factor)

PathLike = Union[str, "os.PathLike[str]"]

# Flags whose repeated occurrences are one value per image (ViewArgs' --extent), not one vector.
_PER_IMAGE_SCALARS = {"extent"}
# Flags written W x H / N_MU x N_PHI.
_PAIRS = {"size", "nodes", "print_nodes"}


def _number(name: str, v: Any) -> str:
    """A number of keyword ``name`` as the command line writes it; an int stays an int (the command
    refuses a float where it needs an integer, naming the flag, which :func:`_keywords` turns into
    the keyword). Bools, NaN, ±inf and non-numbers are refused here, naming the keyword."""
    if isinstance(v, (numbers.Integral, np.integer)) and not isinstance(v, (bool, np.bool_)):
        return str(int(v))
    # repr of a float is the shortest string that reads back as the same double (Rust parses it exactly).
    return repr(_args.real(name.rstrip("_"), v))


def _flag_values(name: str, v: Any) -> List[str]:
    """The command-line values of one keyword argument (one entry per occurrence of the flag)."""
    if isinstance(v, (str, os.PathLike)):
        return [os.fspath(v)]
    if name in _PAIRS and isinstance(v, (tuple, list)) and len(v) == 2:
        return [f"{_number(name, v[0])}x{_number(name, v[1])}"]
    a = np.asarray(v) if isinstance(v, (list, tuple, np.ndarray)) else None
    if a is None:
        return [_number(name, v)]
    if a.ndim == 1 and name in _PER_IMAGE_SCALARS:
        return [_number(name, x) for x in a]
    if a.ndim == 1:
        return [",".join(_number(name, x) for x in a)]  # a vector or an RGB triple: x,y,z
    if a.ndim == 2:
        return [",".join(_number(name, x) for x in row) for row in a]  # one vector per image
    raise ValueError(f"{name.rstrip('_')}=: cannot be written as a command-line value (shape {a.shape})")


def _flags(options: Dict[str, Any]) -> List[str]:
    """``name=value`` → ``--name value`` (``_`` → ``-``): None is absent, True is the bare flag."""
    argv: List[str] = []
    for name, v in options.items():
        if v is None or v is False:
            continue
        flag = "--" + name.rstrip("_").replace("_", "-")
        if v is True:
            argv.append(flag)
            continue
        for s in _flag_values(name, v):
            argv += [flag, s]
    return argv


def _arrays(v: Any) -> Any:
    """Lists of numbers (rectangular, any depth) → NumPy arrays; null → NaN in float arrays."""
    if isinstance(v, dict):
        return {k: _arrays(x) for k, x in v.items()}
    if isinstance(v, list):
        if v and _numeric(v):
            has_float = _any_float(v)
            try:
                if has_float:
                    return np.array(_nan(v), dtype=np.float64)
                return np.array(v, dtype=np.int64)
            except ValueError:  # ragged
                pass
        return [_arrays(x) for x in v]
    return v


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


class _Inputs:
    """Image arguments as files: paths as given, the rest written into a temporary folder."""

    def __init__(self) -> None:
        self._tmp: Optional[tempfile.TemporaryDirectory] = None
        #: temporary path → label, for reports and messages
        self.labels: Dict[str, str] = {}

    def folder(self) -> Path:
        if self._tmp is None:
            self._tmp = tempfile.TemporaryDirectory(prefix="reflect-")
        return Path(self._tmp.name)

    def close(self) -> None:
        if self._tmp is not None:
            self._tmp.cleanup()

    def _new(self, name: str, label: str) -> Path:
        p = self.folder() / name
        self.labels[str(p)] = label
        return p

    def image(self, i: int, img: Any, header: Dict[str, str], stderr: Any) -> str:
        if isinstance(img, (str, os.PathLike)):
            return os.fspath(img)
        if isinstance(img, RenderResult):
            p = self._new(f"render{i}.exr", f"<RenderResult {i}>")
            img.save(str(p))
            return str(p)
        a = _rgb_array(img, f"image {i}")
        channels = {c: np.ascontiguousarray(a[..., k]) for k, c in enumerate("RGB")}
        if stderr is not None:
            s = _rgb_array(stderr, f"stderr of image {i}")
            if s.shape != a.shape:
                raise ValueError(f"stderr of image {i} has shape {s.shape}, the image {a.shape}")
            channels.update({f"stderr.{c}": np.ascontiguousarray(s[..., k]) for k, c in enumerate("RGB")})
        p = self._new(f"image{i}.exr", f"<array {i}>")
        try:
            _reflect.write_image(str(p), channels, header)
        except ValueError as e:
            # The array's own name first: "channel R: non-finite value" alone does not say which input.
            raise ValueError(f"image {i} (array): {e}") from None
        return str(p)

    def relabel(self, v: Any) -> Any:
        """Temporary paths → labels in every string of a report (or a message)."""
        if not self.labels:
            return v
        if isinstance(v, str):
            for p, label in self.labels.items():
                v = v.replace(p, label)
            return v
        if isinstance(v, dict):
            return {k: self.relabel(x) for k, x in v.items()}
        if isinstance(v, list):
            return [self.relabel(x) for x in v]
        return v


def _rgb_array(a: Any, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3 or a.shape[0] == 0 or a.shape[1] == 0:
        raise ValueError(f"{what} must have shape (H, W, 3), got {a.shape}")
    return a


def _absolute_file(lighting: Dict[str, Any], base: Optional[Path] = None) -> Dict[str, Any]:
    """An envmap table with its file made absolute (against ``base``, else the current folder):
    the command resolves a relative one against the temporary file's folder."""
    if lighting.get("type") == "envmap" and isinstance(lighting.get("file"), str):
        f = Path(lighting["file"])
        if not f.is_absolute():
            lighting = dict(lighting, file=str((base or Path.cwd()) / f))
    return lighting


def _json(v: Any) -> str:
    def conv(x: Any) -> Any:
        if isinstance(x, np.ndarray):
            return x.tolist()
        if isinstance(x, np.generic):
            return x.item()
        raise TypeError(f"{type(x).__name__} is not a number or a list")

    return json.dumps(v, default=conv, ensure_ascii=True)


def _header(i: int, camera: Any, sphere: Optional[Dict[str, Any]], scene: Any) -> Dict[str, str]:
    """The header attributes of array image ``i``.

    ``scene``: exactly what a render of it carries (its camera, lighting and objects, numbers as
    the renderer holds them). ``camera`` and ``sphere`` (which replace the scene's) are written as
    given, in double precision, so they mean what the CLI's ``--from/--to/--up/--extent`` and
    ``--center/--radius`` mean for a file without a header; they are checked with the scene
    file's types first (unknown keys and bad values are errors).
    """
    attrs: Dict[str, str] = {}
    if scene is not None:
        from ._scene import load_scene

        s = load_scene(scene)
        table = s.to_dict()
        if "lighting" in table:
            table["lighting"] = _absolute_file(table["lighting"], s.base)
        attrs = _reflect.header_attributes(table)
    cam = camera[i] if isinstance(camera, (list, tuple)) else camera
    if cam is not None or sphere is not None:
        cam = None if cam is None else _camera_defaults(dict(cam))
        obj = None if sphere is None else dict({"shape": "sphere", "center": [0.0, 0.0, 0.0], "radius": 1.0}, **sphere)
        # The scene file's checks (placeholders where a table is not given).
        _reflect.header_attributes(
            {
                "camera": cam if cam is not None else {"type": "normal-probe"},
                "lighting": {"type": "uniform", "radiance": 1.0},
                "objects": [dict(obj, brdf=obj.get("brdf", {"type": "lambert", "albedo": 1.0}))] if obj is not None else [],
            }
        )
        if cam is not None:
            attrs["reflect:camera"] = _json(cam)
        if obj is not None and "brdf" in obj:
            attrs["reflect:objects"] = _json([obj])
    return attrs


def _sphere_flags(sphere: Optional[Dict[str, Any]]) -> Dict[str, Any]:
    """A sphere without a BRDF is no scene object (a scene's sphere has one): its centre and radius
    go to the command as ``--center`` / ``--radius`` (where they are not the defaults)."""
    if sphere is None or "brdf" in sphere:
        return {}
    flags = {}
    if "center" in sphere and list(np.asarray(sphere["center"], dtype=float)) != [0.0, 0.0, 0.0]:
        flags["center"] = sphere["center"]
    if "radius" in sphere and float(sphere["radius"]) != 1.0:
        flags["radius"] = sphere["radius"]
    return flags


def _camera_defaults(cam: Dict[str, Any]) -> Dict[str, Any]:
    """The defaults of the CLI's view flags (--to 0,0,0, --up 0,0,1) and of a normal-probe camera."""
    if cam.get("type") in ("orthographic", "perspective"):
        cam.setdefault("to", [0.0, 0.0, 0.0])
        cam.setdefault("up", [0.0, 0.0, 1.0])
    elif cam.get("type") == "normal-probe":
        cam.setdefault("theta_o_deg", 0.0)
        cam.setdefault("phi_o_deg", 0.0)
    return cam


def run(
    command: Sequence[str],
    images: Union[ImageLike, Sequence[ImageLike]],
    options: Dict[str, Any],
    *,
    camera: Any = None,
    sphere: Optional[Dict[str, Any]] = None,
    scene: Any = None,
    stderr: Any = None,
) -> Dict[str, Any]:
    """Runs ``reflect COMMAND … --flags`` in this process and returns its ``--json`` document."""
    imgs = _image_list(images)
    arrays = [i for i, x in enumerate(imgs) if not isinstance(x, (str, os.PathLike, RenderResult))]
    if not arrays and (camera is not None or sphere is not None or stderr is not None):
        raise ValueError("camera, sphere and stderr describe images given as arrays; these images are files or renders")
    if not arrays and scene is not None:
        # Files say how they were made in their header; a scene beside them is the command's --scene.
        options = dict(options, scene=scene)
        scene = None
    stderrs = stderr if isinstance(stderr, (list, tuple)) else [stderr] * len(imgs)
    if len(stderrs) != len(imgs):
        raise ValueError(f"stderr: {len(stderrs)} arrays for {len(imgs)} images")
    cams = camera if isinstance(camera, (list, tuple)) else None
    if cams is not None and len(cams) != len(arrays):
        raise ValueError(f"camera: {len(cams)} cameras for {len(arrays)} array images")
    if arrays:
        options = dict(options, **_sphere_flags(sphere))
    inputs = _Inputs()
    try:
        paths = []
        for i, img in enumerate(imgs):
            header: Dict[str, str] = {}
            if i in arrays:
                header = _header(arrays.index(i), cams if cams is not None else camera, sphere, scene)
            paths.append(inputs.image(i, img, header, stderrs[i]))
        argv = list(command) + paths
        argv += _flags(options)
        try:
            doc = _reflect.factor_report(argv[2:])
        except FileNotFoundError as e:
            raise FileNotFoundError(_keywords(inputs.relabel(str(e)))) from None
        except ValueError as e:
            raise ValueError(_keywords(inputs.relabel(str(e)))) from None
        return _arrays(inputs.relabel(doc))
    finally:
        inputs.close()


_KEYWORD_FLAG = re.compile(r"(?<![\w-])--([a-z][a-z0-9-]*)")


def _keywords(message: str) -> str:
    """The command's message in this API's terms: each ``--flag-name`` becomes the keyword
    ``flag_name=`` that gives it (``--from`` → ``from_=``, as :func:`_flags` maps them back)."""

    def keyword(m: "re.Match[str]") -> str:
        name = m.group(1).replace("-", "_")
        return f"{name}_=" if keyword_module.iskeyword(name) else f"{name}="

    out = _KEYWORD_FLAG.sub(keyword, message)
    if "from_=" in out and "camera=" not in out:
        # The flags' keywords exist, but the way to describe an array's camera is one table.
        out += " (or camera= a scene-file camera table, e.g. {'type': 'orthographic', 'from': [3, 0, 1], 'extent': 1.05})"
    return out


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
        raise ValueError(f"an image array must have shape (H, W, 3) (or (N, H, W, 3) for N images), got {images.shape}")
    imgs = list(images)
    if imgs and all(isinstance(x, (int, float)) for x in imgs):
        raise ValueError("images must be paths, renders or (H, W, 3) arrays, not numbers")
    return imgs


__all__: Tuple[str, ...] = ()
