"""Kind (c): URDFs mutated from the shipped chapter arm (``robots/models/chapter_arm.urdf``) and the Panda.

Mutations: bad XML, truncation, byte flips, NaN/inf/negative/absurd mass and inertia, an inertia that
breaks the triangle inequality or is indefinite, a duplicate link or joint, a kinematic cycle, a joint
whose parent or child does not exist, a removed link, NaN in an origin or axis, a bad joint type,
an entity expansion. Each file is loaded with :meth:`PinocchioRobot.from_urdf` in process.
"""

from __future__ import annotations

import random
import xml.etree.ElementTree as ET
from pathlib import Path

from .core import Case

SUBS = ("truncate", "bitflip", "not_xml", "nan_mass", "neg_mass", "absurd_mass", "inf_inertia", "neg_inertia",
        "triangle", "indefinite", "duplicate_link", "duplicate_joint", "cycle", "missing_parent", "missing_child",
        "remove_link", "nan_origin", "nan_axis", "bad_joint_type", "entity", "empty", "wrong_root", "nan_limit")
#: mutations after which loading without a warning is a silent acceptance
INVALID = {"not_xml", "nan_mass", "neg_mass", "absurd_mass", "inf_inertia", "neg_inertia", "triangle", "indefinite",
           "duplicate_link", "duplicate_joint", "cycle", "missing_parent", "missing_child", "nan_origin", "nan_axis",
           "bad_joint_type", "entity", "empty", "wrong_root", "nan_limit"}


def _sources() -> list[tuple[str, str, str, dict]]:
    """(name, text, frame, from_urdf keywords) of the URDFs mutated."""
    from forcecontrol.robots.pinocchio import example_robot_data_dir, model_path

    out = [("chapter_arm", model_path("chapter_arm").read_text(), "tip", {"task": "planar"})]
    panda = example_robot_data_dir() / "panda_description" / "urdf" / "panda.urdf"
    if panda.is_file():
        out.append(("panda", panda.read_text(), "panda_hand_tcp",
                    {"task": "pose", "locked_joints": ("panda_finger_joint1", "panda_finger_joint2")}))
    return out


def _inertials(root: ET.Element) -> list[ET.Element]:
    return [ln.find("inertial") for ln in root.findall("link") if ln.find("inertial") is not None]


def _mutate(rng: random.Random, sub: str, text: str) -> str:
    if sub == "truncate":
        return text[: rng.randrange(len(text))]
    if sub == "bitflip":
        b = bytearray(text.encode())
        for _ in range(rng.randrange(1, 6)):
            b[rng.randrange(len(b))] ^= 1 << rng.randrange(8)
        return b.decode("utf-8", "replace")
    if sub == "not_xml":
        return rng.choice(("this is not xml", "{\"robot\": 1}", "<robot", "<<<>>>"))
    if sub == "empty":
        return ""
    if sub == "entity":
        ents = "".join(f'<!ENTITY {chr(98 + i)} "' + f"&{chr(97 + i)};" * 10 + '">' for i in range(9))
        return f'<?xml version="1.0"?><!DOCTYPE r [<!ENTITY a "x">{ents}]><robot name="r">&j;</robot>'
    root = ET.fromstring(text)
    if sub == "wrong_root":
        root.tag = rng.choice(("sdf", "model", "Robot"))
        return ET.tostring(root, encoding="unicode")
    links, joints = root.findall("link"), root.findall("joint")
    inertials = _inertials(root)
    moving = [j for j in joints if j.get("type") in ("revolute", "continuous", "prismatic")]
    if sub in ("nan_mass", "neg_mass", "absurd_mass"):
        m = rng.choice(inertials).find("mass")
        m.set("value", {"nan_mass": rng.choice(("nan", "NaN", "inf")), "neg_mass": rng.choice(("-1", "-1e-9", "-50")),
                        "absurd_mass": rng.choice(("1e300", "1.7e308"))}[sub])
    elif sub in ("inf_inertia", "neg_inertia", "triangle", "indefinite"):
        inn = rng.choice(inertials).find("inertia")
        if sub == "inf_inertia":
            inn.set(rng.choice(("ixx", "iyy", "izz", "ixy")), rng.choice(("inf", "nan", "-inf")))
        elif sub == "neg_inertia":
            inn.set(rng.choice(("ixx", "iyy", "izz")), "-1")
        else:
            values = ({"ixx": "1", "iyy": "1", "izz": "3", "ixy": "0", "ixz": "0", "iyz": "0"} if sub == "triangle"
                      else {"ixx": "1", "iyy": "1", "izz": "1", "ixy": "2"})
            for k, x in values.items():
                inn.set(k, x)
    elif sub == "duplicate_link":
        root.append(ET.fromstring(ET.tostring(rng.choice(links))))
    elif sub == "duplicate_joint":
        j = ET.fromstring(ET.tostring(rng.choice(joints)))
        child = ET.SubElement(root, "link", name="extra_link")
        j.find("child").set("link", child.get("name"))
        root.append(j)
    elif sub == "cycle":
        leaf = joints[-1].find("child").get("link")
        first = joints[0].find("parent").get("link")
        j = ET.SubElement(root, "joint", name="closing", type="revolute")
        ET.SubElement(j, "parent", link=leaf)
        ET.SubElement(j, "child", link=first)
        ET.SubElement(j, "axis", xyz="0 0 1")
        ET.SubElement(j, "limit", lower="-1", upper="1", effort="1", velocity="1")
    elif sub in ("missing_parent", "missing_child"):
        j = rng.choice(joints)
        j.find("parent" if sub == "missing_parent" else "child").set("link", "no_such_link")
    elif sub == "remove_link":
        root.remove(rng.choice(links[1:]))
    elif sub in ("nan_origin", "nan_axis"):
        j = rng.choice(moving)
        el = j.find("origin" if sub == "nan_origin" else "axis")
        if el is None:
            el = ET.SubElement(j, "origin" if sub == "nan_origin" else "axis")
        bad = ("nan 0 0", "0 inf 0", "1e400 0 0") if sub == "nan_origin" else ("nan 0 1", "0 0 0")
        el.set("xyz", rng.choice(bad))
    elif sub == "bad_joint_type":
        rng.choice(moving).set("type", rng.choice(("revolut", "", "spherical")))
    elif sub == "nan_limit":
        lim = rng.choice(moving).find("limit")
        if lim is not None:
            lim.set(rng.choice(("lower", "upper")), "nan")
    return ET.tostring(root, encoding="unicode")


def make_cases(seed: int, count: int, sentinel: Path) -> list[Case]:
    rng = random.Random(f"urdf-{seed}")
    sources = _sources()
    out = []
    for i in range(count):
        name, text, frame, kw = sources[0] if rng.random() < 0.75 or len(sources) == 1 else sources[1]
        sub = rng.choice(SUBS)
        raw = _mutate(rng, sub, text)
        invalid = sub in INVALID
        if sub == "remove_link":
            invalid = True  # the joints name a link that is gone

        def prepare(d: Path, raw=raw, name=name):
            (d / f"{name}.urdf").write_text(raw, encoding="utf-8", errors="replace")

        def action(d: Path, name=name, frame=frame, kw=kw):
            from forcecontrol.robots.pinocchio import PinocchioRobot

            PinocchioRobot.from_urdf(d / f"{name}.urdf", frame, **kw)

        out.append(Case("urdf", sub, i, f"{name}.urdf ({sub})", prepare=prepare, action=action, invalid=invalid))
    return out
