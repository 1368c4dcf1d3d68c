"""Shipped models moved to another place: translated by (dx, dy) and rotated by an angle about the origin.

Works for any vector or kinematic-diagram model file, whether or not it has frame parameters:

* a vector model gets a frame vector ``moved_T = {x = "moved_dx", y = "moved_dy"}`` added to the
  front of every point (or, ``frame_last``, to its end: a sum is the same in any order), and every
  vector turned by ``moved_rot``: a polar
  vector's angle becomes ``(angle) + moved_rot``, a Cartesian one's components are rotated with
  ``moved_c = cos``, ``moved_s = sin`` (parameters). Every loop equation is then the old one
  turned by the same rotation, so the solution (every variable) is unchanged and every point is
  the old point rotated and translated. Its mass properties and loads are left out (a body's
  angle must name the input's variable itself, which the turned angles no longer are);
* a kinematic diagram gets every joint's ``at`` (and a body's ``at``) rotated and translated and
  every slide ``axis`` rotated; the drawn pose (so the guesses and the mode) moves with it.

The rotation is given in degrees and written in the model's angle unit.
"""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np

import loopsolve as ls

NAMES = ("moved_T", "moved_dx", "moved_dy", "moved_rot", "moved_c", "moved_s", "moved_O")


def rotation(rot_deg: float) -> np.ndarray:
    c, s = math.cos(math.radians(rot_deg)), math.sin(math.radians(rot_deg))
    return np.array([[c, -s], [s, c]])


def move_xy(xy, dx: float, dy: float, rot_deg: float) -> np.ndarray:
    """Points ``(..., 2)`` as the moved model places them."""
    return np.asarray(xy, dtype=float) @ rotation(rot_deg).T + np.array([dx, dy])


def _point_expr(expr: str, frame_last: bool = False) -> str:
    text = str(expr).strip()
    if text == "0":
        return "moved_T"
    if frame_last:
        return f"{text} + moved_T"
    return f"moved_T {text}" if text.startswith("-") else f"moved_T + {text}"


def moved_data(data: dict, dx: float, dy: float, rot_deg: float, *, frame_last: bool = False) -> dict:
    """The model file's data (as read by ``tomllib``) of the moved copy (``frame_last``: the frame
    vector written at the end of every point's sum instead of the front)."""
    data = json.loads(json.dumps(data))  # a deep copy
    R = rotation(rot_deg)

    def at(xy):
        return [float(v) for v in R @ np.asarray(xy, dtype=float) + np.array([dx, dy])]

    if "joints" in data:
        for spec in data["joints"].values():
            spec["at"] = at(spec["at"])
            if "axis" in spec:
                spec["axis"] = [float(v) for v in R @ np.asarray(spec["axis"], dtype=float)]
        for body in data.get("bodies", {}).values():
            if "at" in body:
                body["at"] = at(body["at"])
            if isinstance(body.get("com"), dict) and "at" in body["com"]:
                body["com"]["at"] = at(body["com"]["at"])
        return data
    known = set(data.get("parameters", {})) | set(data.get("vectors", {})) | set(data.get("points", {}))
    assert not known & set(NAMES), "the model already uses a name of the move"
    angle_unit = data.get("units", {}).get("angle", "deg")
    rot = rot_deg if angle_unit == "deg" else math.radians(rot_deg)
    data.setdefault("parameters", {}).update(moved_dx=dx, moved_dy=dy, moved_rot=rot, moved_c=float(R[0, 0]),
                                             moved_s=float(R[1, 0]))
    vectors = data["vectors"]
    for spec in vectors.values():
        if "x" in spec:
            x, y = spec["x"], spec["y"]
            spec["x"] = f"({x})*moved_c - ({y})*moved_s"
            spec["y"] = f"({x})*moved_s + ({y})*moved_c"
        else:
            spec["angle"] = f"({spec['angle']}) + moved_rot"
    vectors["moved_T"] = {"x": "moved_dx", "y": "moved_dy"}
    points = data.setdefault("points", {})
    for name, expr in points.items():
        points[name] = _point_expr(expr, frame_last)
    for cam in data.get("cams", {}).values():
        _move_cam(cam, points, rot, angle_unit)
    for key in ("bodies", "loads", "gravity"):  # mass properties are not what is moved here
        data.pop(key, None)
    return data


def _move_cam(cam: dict, points: dict, rot: float, angle_unit: str) -> None:
    """Turn a cam's frame by ``rot`` (model angle unit) and centre it on a moved point (``points``: the
    moved copy's; the origin's point is found, or added as ``moved_O``)."""
    assert "profile" not in cam, "moving a profile cam (a file next to the model) is not written"
    if cam.get("kind") == "oscillating":
        key, default = "pivot_angle", 0.0
    else:
        key, default = "axis", 90.0 if angle_unit == "deg" else math.pi / 2
    old = cam.get(key, default)
    cam[key] = old + rot if isinstance(old, (int, float)) else f"({old}) + moved_rot"
    if "center" not in cam:
        origin = next((name for name, expr in points.items() if expr == "moved_T"), None)
        if origin is None:
            origin = "moved_O"
            points[origin] = "moved_T"
        cam["center"] = origin


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    if isinstance(v, list):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    return "{ " + ", ".join(f"{json.dumps(k)} = {_value(x)}" for k, x in v.items()) + " }"


def toml_text(data: dict) -> str:
    """TOML of a model's data: top-level values, ``[table]`` of inline entries, ``[[array]]`` of tables."""
    head, tail = [], []
    for key, value in data.items():
        if isinstance(value, dict) and value and all(isinstance(v, dict) for v in value.values()) or (
                isinstance(value, dict) and key in ("parameters", "variables", "vectors", "points", "joints",
                                                    "links", "bodies", "modes", "input")):
            tail.append(f"\n[{key}]")
            tail += [f"{json.dumps(k)} = {_value(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            for entry in value:
                tail.append(f"\n[[{key}]]")
                tail += [f"{json.dumps(k)} = {_value(v)}" for k, v in entry.items()]
        else:
            head.append(f"{json.dumps(key)} = {_value(value)}")
    return "\n".join(head + tail) + "\n"


def moved_text(path, dx: float, dy: float, rot_deg: float, *, frame_last: bool = False) -> str:
    """The model file text of ``path`` moved by (dx, dy) and turned by ``rot_deg`` degrees."""
    with open(path, "rb") as f:
        data = tomllib.load(f)
    return toml_text(moved_data(data, dx, dy, rot_deg, frame_last=frame_last))


def moved(path, dx: float, dy: float, rot_deg: float, *, frame_last: bool = False):
    """The moved copy of the model file ``path`` as a mechanism."""
    return ls.loads(moved_text(path, dx, dy, rot_deg, frame_last=frame_last), source=f"{Path(path).name} moved")
