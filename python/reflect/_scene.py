"""Scenes: a path, TOML text, a dict in the scene vocabulary (guide "Scene files"), or a `Scene`."""

from __future__ import annotations

import copy
import os
from pathlib import Path
from typing import Any, Dict, List, Optional, Tuple, Union

from . import _reflect

SceneLike = Union["Scene", str, "os.PathLike[str]", Dict[str, Any]]


class Scene:
    """A scene description whose fields can be changed before rendering.

    The tables of the scene file are plain, mutable Python objects: ``render``, ``camera`` and
    ``lighting`` are dicts, ``objects`` a list of dicts, with the keys of the guide's section "Scene
    files". Only what the source gave is there; defaults are filled in, and every
    value is checked with the same serde types as a scene file, when the scene is rendered.
    Relative data paths (``lighting.file``, mesh ``file``) are resolved against ``base``: the
    scene file's folder, else the current directory at load time.

    >>> s = reflect.load_scene("scenes/lambert_grace.toml")
    >>> s.render["spp"] = 16
    >>> s.objects[0]["brdf"] = {"type": "phong", "s": 50}
    >>> img = reflect.render(s, seed=1)
    """

    def __init__(self, table: Dict[str, Any], base: Union[str, "os.PathLike[str]"], path: Optional[str] = None):
        self._table: Dict[str, Any] = table
        #: Folder that relative data paths are resolved against.
        self.base: Path = Path(base)
        #: The scene file this description was read from, if any.
        self.path: Optional[Path] = Path(path) if path is not None else None

    def _section(self, name: str, default: Any) -> Any:
        return self._table.setdefault(name, default)

    @property
    def render(self) -> Dict[str, Any]:
        """``[render]``: ``width``, ``height``, ``spp``, ``seed``, ``max_depth``, ``sampler``."""
        return self._section("render", {})

    @property
    def camera(self) -> Dict[str, Any]:
        """``[camera]``: ``type`` ("orthographic" | "perspective" | "normal-probe") and its keys."""
        return self._section("camera", {})

    @camera.setter
    def camera(self, v: Dict[str, Any]) -> None:
        self._table["camera"] = v

    @property
    def lighting(self) -> Dict[str, Any]:
        """``[lighting]``: ``type`` ("uniform" | "directional" | "axial" | "sh" | "envmap") and its keys."""
        return self._section("lighting", {})

    @lighting.setter
    def lighting(self, v: Dict[str, Any]) -> None:
        self._table["lighting"] = v

    @property
    def objects(self) -> List[Dict[str, Any]]:
        """``[[objects]]``: each a dict with ``shape``, its placement and a ``brdf`` table."""
        return self._section("objects", [])

    @objects.setter
    def objects(self, v: List[Dict[str, Any]]) -> None:
        self._table["objects"] = v

    def to_dict(self) -> Dict[str, Any]:
        """A deep copy of the description as nested dicts and lists."""
        return copy.deepcopy(self._table)

    def copy(self) -> "Scene":
        """An independent copy (changing it leaves this scene as it is)."""
        return Scene(self.to_dict(), self.base, None if self.path is None else str(self.path))

    def __repr__(self) -> str:
        src = f"from {self.path}" if self.path is not None else f"base {self.base}"
        return f"<reflect.Scene {src}: {self.to_dict()!r}>"


def _source(scene: SceneLike) -> Tuple[str, Any, Optional[str]]:
    """(kind, value, base) for the native module: 'path', 'toml' or 'dict'."""
    if isinstance(scene, Scene):
        return "dict", scene.to_dict(), str(scene.base)
    if isinstance(scene, dict):
        return "dict", scene, None
    if isinstance(scene, os.PathLike):
        return "path", os.fspath(scene), None
    if isinstance(scene, str):
        # A scene file name has no line break; TOML text of a whole scene has several.
        return ("toml", scene, None) if "\n" in scene else ("path", scene, None)
    raise TypeError(
        f"scene must be a path, TOML text, a dict or a reflect.Scene, not {type(scene).__name__}"
    )


def load_scene(scene: SceneLike) -> Scene:
    """Reads and checks a scene (a path, TOML text, a dict or a Scene), for changing before rendering.

    Raises ``FileNotFoundError`` when the file does not exist and ``ValueError`` (the CLI's
    one-line message, with the line number for TOML) when it does not parse.
    """
    kind, value, base = _source(scene)
    table, base, path = _reflect.load_scene(kind, value, base)
    if kind == "dict":
        table = copy.deepcopy(table)
    return Scene(table, base, path)
