"""A URDF checked before Pinocchio or MuJoCo sees it: XML, names, tree structure, physical inertias.

:func:`check_urdf` reads the file through :mod:`forcecontrol.core.files` (a regular file of at most
64 MiB by default) and refuses, with the file and the element named and never the file's content:

* XML that is not well formed (with the line and column of the parser's error), a root element
  that is not ``<robot>``;
* a link or joint name used twice, a joint whose parent or child is not a link, a link that is
  the child of two joints, a kinematic cycle, no root or several roots;
* a mass that is not finite or negative; an inertia that is not finite, not positive
  semi-definite, or whose principal moments break the triangle inequality
  (I₁ + I₂ ≥ I₃ for every ordering). A massless link (mass 0) must have a zero inertia; a point mass
  (mass > 0, zero inertia) is accepted, as in the chapter's arm's motor body.
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from ..core.files import MAX_TABLE_BYTES, excerpt, read_text_limited
from ..errors import ParameterError

__all__ = ["check_urdf", "MAX_LINK_MASS", "MAX_LINK_INERTIA"]

#: the largest link mass [kg] and inertia entry [kg m²] read: far beyond any robot (a ship's hull is 1e7 kg),
#: small enough that the dynamics stay finite (1e300 kg made every torque overflow)
MAX_LINK_MASS = 1e9
MAX_LINK_INERTIA = 1e12


def _float(value: str | None, where: str, src: str) -> float:
    if value is None:
        raise ParameterError(f"URDF {src}: {where} has no value")
    try:
        return float(value)
    except ValueError:
        raise ParameterError(f"URDF {src}: {where} is not a number ({len(value)} characters)") from None


def _check_inertial(link: ET.Element, lname: str, src: str, strict: bool) -> None:
    inertial = link.find("inertial")
    if inertial is None:
        return
    mass_el = inertial.find("mass")
    m = 0.0 if mass_el is None else _float(mass_el.get("value"), f"link {lname}: <mass value>", src)
    if not math.isfinite(m) or m < 0.0:
        raise ParameterError(f"URDF {src}: link {lname}: <mass value> must be a finite number >= 0 kg; got {m!r}")
    if m > MAX_LINK_MASS:
        raise ParameterError(f"URDF {src}: link {lname}: <mass value> must be at most {MAX_LINK_MASS:.0e} kg; got {m!r}")
    inertia_el = inertial.find("inertia")
    keys = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
    v = {k: 0.0 for k in keys}
    if inertia_el is not None:
        v = {k: _float(inertia_el.get(k, "0"), f"link {lname}: <inertia {k}>", src) for k in keys}
    bad = [k for k in keys if not math.isfinite(v[k]) or abs(v[k]) > MAX_LINK_INERTIA]
    if bad:
        raise ParameterError(f"URDF {src}: link {lname}: <inertia {bad[0]}> must be finite and at most {MAX_LINK_INERTIA:.0e} "
                             f"kg m² in magnitude; got {v[bad[0]]!r}")
    inertia = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]], [v["ixz"], v["iyz"], v["izz"]]])
    scale = max(1.0, float(np.abs(inertia).max()))
    tol = 1e-9 * scale  # relative: rounding in a file's last digit is not a defect
    def refuse(msg: str) -> None:
        if strict:
            raise ParameterError(f"URDF {src}: link {lname}: {msg} (check_inertia=False loads it with a warning)")
        warnings.warn(f"URDF {src}: link {lname}: {msg}; loaded anyway (check_inertia=False)", UserWarning, stacklevel=4)

    if m == 0.0:
        if np.abs(inertia).max() > 0.0:
            refuse("mass 0 with a non-zero inertia; a massless link must have a zero inertia")
        return
    lam = np.linalg.eigvalsh(inertia)
    diag = [k for k in ("ixx", "iyy", "izz") if v[k] < -tol]
    if diag:
        raise ParameterError(f"URDF {src}: link {lname}: <inertia {diag[0]}> must be >= 0 kg m²; got {v[diag[0]]!r}")
    moments = ", ".join(f"{x:.6g}" for x in lam)
    if lam[0] < -tol:
        refuse(f"the inertia matrix is not positive semi-definite (principal moments {moments} kg m²)")
    elif lam[0] + lam[1] < lam[2] - tol:
        refuse(f"the principal moments {moments} kg m² break the triangle inequality (I1 + I2 >= I3): no rigid body has them")


def _check_axis(joint: ET.Element, jname: str, src: str) -> None:
    """A moving joint's <axis xyz>: three finite numbers, not all zero (a zero axis moves nothing)."""
    axis = joint.find("axis")
    if joint.get("type") not in ("revolute", "continuous", "prismatic") or axis is None or axis.get("xyz") is None:
        return
    parts = axis.get("xyz", "").split()
    try:
        v = [float(x) for x in parts]
    except ValueError:
        v = []
    if len(v) != 3 or not all(map(math.isfinite, v)) or not any(v):
        raise ParameterError(f"URDF {src}: joint {excerpt(jname)}: <axis xyz> must be 3 finite numbers, not all zero; "
                             f"got {excerpt(axis.get('xyz'))}")


def check_urdf(path: str | Path, *, max_bytes: int = MAX_TABLE_BYTES, check_inertia: bool = True) -> str:
    """The text of a URDF file, after checking its XML, names, tree and inertias (see the module).

    Args:
        path: the URDF file.
        max_bytes: the size limit [bytes] (default 64 MiB).
        check_inertia: refuse an indefinite inertia, one breaking the triangle inequality and a
            massless link with inertia (True), or only warn (False: some published URDFs have
            them). NaN/inf, a negative mass and a negative diagonal moment are refused always.

    Returns:
        The file's text (so the caller parses exactly what was checked).

    Raises:
        ParameterError: the file is missing, special, too large, or fails a check (the message
            names the file, the element and the problem).
    """
    text = read_text_limited(path, "URDF file", max_bytes)
    src = repr(str(path))
    try:
        root = ET.fromstring(text)
    except ET.ParseError as exc:
        line, col = exc.position
        raise ParameterError(
            f"URDF {src} is not well-formed XML: parser error at line {line}, column {col + 1} "
            f"({str(exc).split(':')[0]})"
        ) from None
    if root.tag != "robot":
        raise ParameterError(f"URDF {src}: the root element must be <robot>; got <{excerpt(root.tag)[1:-1]}>")
    links: dict[str, ET.Element] = {}
    for el in root.findall("link"):
        name = el.get("name")
        if not name:
            raise ParameterError(f"URDF {src}: a <link> has no name")
        if name in links:
            raise ParameterError(f"URDF {src}: link {excerpt(name)} is defined twice; link names must be unique")
        links[name] = el
    if not links:
        raise ParameterError(f"URDF {src}: the robot has no <link>")
    joints: set[str] = set()
    parent_of: dict[str, tuple[str, str]] = {}  # child link -> (joint, parent link)
    children: dict[str, list[str]] = {n: [] for n in links}
    for el in root.findall("joint"):
        jname = el.get("name")
        if not jname:
            raise ParameterError(f"URDF {src}: a <joint> has no name")
        if jname in joints:
            raise ParameterError(f"URDF {src}: joint {excerpt(jname)} is defined twice; joint names must be unique")
        joints.add(jname)
        ends = {}
        for role in ("parent", "child"):
            e = el.find(role)
            lk = None if e is None else e.get("link")
            if lk is None or lk not in links:
                what = "has no" if lk is None else f"names an unknown link {excerpt(lk)} as its"
                raise ParameterError(f"URDF {src}: joint {excerpt(jname)} {what} <{role}>")
            ends[role] = lk
        _check_axis(el, jname, src)
        child, parent = ends["child"], ends["parent"]
        if child in parent_of:
            raise ParameterError(
                f"URDF {src}: link {excerpt(child)} is the child of two joints, {excerpt(parent_of[child][0])} and "
                f"{excerpt(jname)}: a URDF is a tree (kinematic loops are not supported)"
            )
        parent_of[child] = (jname, parent)
        children[parent].append(child)
    roots = [n for n in links if n not in parent_of]
    if len(roots) > 1:
        raise ParameterError(
            f"URDF {src}: {len(roots)} links have no parent joint ({', '.join(excerpt(r) for r in roots[:5])}"
            f"{', ...' if len(roots) > 5 else ''}); a URDF has exactly one root link"
        )
    reached, stack = set(roots), list(roots)
    while stack:
        for c in children[stack.pop()]:
            if c not in reached:
                reached.add(c)
                stack.append(c)
    if len(reached) < len(links):
        loop = [n for n in links if n not in reached]
        raise ParameterError(
            f"URDF {src}: a kinematic cycle through link(s) {', '.join(excerpt(n) for n in loop[:5])}"
            f"{', ...' if len(loop) > 5 else ''}{'' if roots else ' (no root link)'}: a URDF must be a tree"
        )
    for name, el in links.items():
        _check_inertial(el, excerpt(name), src, check_inertia)
    return text
