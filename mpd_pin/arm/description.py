"""The URDF text before Pinocchio sees it (docs/design.md §1c): read from a path or a
string, expanded from xacro, validated with lxml and yourdfpy (one clear message per
malformed file), ``package://`` and relative mesh paths resolved, ``continuous`` joints
rewritten as revolute ones in [−π, π], missing effort and velocity limits stated as 0,
joints named like links renamed, floating bases and SRDFs naming unknown links refused.
:class:`mpd_pin.arm.model.Arm` builds the model from what these return.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import pinocchio as pin

__all__ = [
    "check_srdf_links",
    "expand_xacro",
    "has_floating_joint",
    "read_urdf_text",
    "rename_joints_named_like_links",
    "resolve_meshes",
    "resolve_package_uri",
    "revolute_for_continuous",
    "validate_urdf",
    "zero_missing_limits",
]


def read_urdf_text(path_or_xml: str | os.PathLike) -> tuple[str, Path | None]:
    """Return (xml text, file path or None) for a path or an XML string."""
    if isinstance(path_or_xml, os.PathLike) or (
        isinstance(path_or_xml, str) and not path_or_xml.lstrip().startswith("<")
    ):
        path = Path(path_or_xml)
        if not path.is_file():
            raise ValueError(f"URDF file not found: {str(path)!r} (pass a path or an XML string)")
        return path.read_text(encoding="utf-8"), path
    if isinstance(path_or_xml, bytes):
        return path_or_xml.decode("utf-8"), None
    if not isinstance(path_or_xml, str):
        raise ValueError(f"expected a URDF path or XML string, got {type(path_or_xml).__name__}")
    return path_or_xml, None


def validate_urdf(xml: str, where: str) -> None:
    """Parse the URDF with yourdfpy so malformed files fail with one clear message."""
    import yourdfpy
    from lxml import etree

    try:
        root = etree.fromstring(xml.encode("utf-8"))
    except etree.XMLSyntaxError as exc:
        raise ValueError(f"malformed URDF XML in {where}: {exc}") from None
    if root.tag != "robot":
        raise ValueError(f"invalid URDF in {where}: root element is <{root.tag}>, not <robot>")
    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(xml.encode("utf-8")),
            build_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
        )
    except Exception as exc:  # yourdfpy raises assorted errors on invalid structure
        raise ValueError(f"invalid URDF in {where}: {exc}") from None
    if urdf.robot is None or not urdf.robot.links:
        raise ValueError(f"invalid URDF in {where}: no <robot> with links")
    movable = [j for j in urdf.robot.joints if j.type in ("revolute", "prismatic", "continuous")]
    if not movable:
        raise ValueError(f"URDF in {where} has no movable joint (revolute or prismatic)")


def revolute_for_continuous(xml: str) -> tuple[str, tuple[str, ...]]:
    """Turn every ``continuous`` joint into a ``revolute`` one limited to [−π, π] rad.

    mpd_pin plans in joint angles, one value per joint (docs/design.md §1): a continuous
    joint's Pinocchio representation (cos θ, sin θ) would break ``nq == nv`` everywhere.
    Its dynamics are those of a revolute joint; [−π, π] covers every orientation once.
    Effort and velocity limits are kept. Returns the new XML and the converted names.
    """
    from lxml import etree

    root = etree.fromstring(xml.encode("utf-8"))
    names = []
    for joint in root.iter("joint"):
        if joint.get("type") != "continuous":
            continue
        joint.set("type", "revolute")
        limit = joint.find("limit")
        if limit is None:
            limit = etree.SubElement(joint, "limit", effort="0", velocity="0")
        limit.set("lower", repr(-math.pi))
        limit.set("upper", repr(math.pi))
        names.append(joint.get("name"))
    if not names:
        return xml, ()
    return etree.tostring(root, encoding="unicode"), tuple(names)


def zero_missing_limits(xml: str) -> str:
    """Give a ``<limit>`` without ``effort`` or ``velocity`` the value 0 (urdfdom refuses
    it otherwise): a zero limit is "not stated", which a scenario's ``[limits]`` table
    can supply (docs/design.md §7b)."""
    from lxml import etree

    root = etree.fromstring(xml.encode("utf-8"))
    changed = False
    for limit in root.iter("limit"):
        parent = limit.getparent()
        if parent is None or parent.tag != "joint":
            continue
        for attr in ("effort", "velocity"):
            if limit.get(attr) is None:
                limit.set(attr, "0")
                changed = True
    return etree.tostring(root, encoding="unicode") if changed else xml


def rename_joints_named_like_links(xml: str) -> str:
    """Rename a joint that has the name of a link to ``<name>_joint``.

    Pinocchio cannot lock such a joint (``buildReducedModel``: "several frames match"),
    as in example-robot-data's so100 (joint and link "gripper"). Mimic references follow.
    """
    from lxml import etree

    root = etree.fromstring(xml.encode("utf-8"))
    links = {link.get("name") for link in root.iter("link")}
    renamed = {}
    for joint in root.iter("joint"):
        name = joint.get("name")
        if name in links:
            renamed[name] = f"{name}_joint"
            joint.set("name", renamed[name])
    if not renamed:
        return xml
    for mimic in root.iter("mimic"):
        if mimic.get("joint") in renamed:
            mimic.set("joint", renamed[mimic.get("joint")])
    return etree.tostring(root, encoding="unicode")


def has_floating_joint(xml: str) -> bool:
    from lxml import etree

    root = etree.fromstring(xml.encode("utf-8"))
    return any(j.get("type") == "floating" for j in root.iter("joint"))


def check_srdf_links(srdf_path: str, model: pin.Model) -> None:
    """ValueError if the SRDF is malformed or disables pairs of links the model lacks
    (Pinocchio would silently keep those pairs)."""
    from lxml import etree

    try:
        root = etree.parse(srdf_path).getroot()
    except (OSError, etree.XMLSyntaxError) as exc:
        raise ValueError(f"malformed SRDF {srdf_path!r}: {exc}") from None
    unknown = sorted(
        {
            name
            for el in root.iter("disable_collisions")
            for name in (el.get("link1"), el.get("link2"))
            if name is None or not model.existBodyName(name)
        },
        key=str,
    )
    if unknown:
        raise ValueError(f"SRDF {srdf_path!r} names links the URDF does not have: {unknown}")


# ------------------------------------------------------- description packages (§1c)
def _package_roots(pkg: str, urdf_path: Path | None, package_dirs: Sequence[Path]) -> list[Path]:
    """Folders that may be the package ``pkg``, in search order (docs/design.md §1c).

    Each ``package_dirs`` entry ``d`` gives ``d/pkg`` (or ``d`` itself if it is named
    ``pkg``); then every ancestor folder of the URDF file named ``pkg``; then the URDF's
    folder ``/pkg``; then each ``ROS_PACKAGE_PATH`` entry (``e/pkg`` or ``e`` itself).
    """
    roots: list[Path] = []

    def add(d: Path) -> None:
        if d.name == pkg:
            roots.append(d)
        roots.append(d / pkg)

    for d in package_dirs:
        add(Path(d))
    if urdf_path is not None:
        folder = urdf_path.resolve().parent
        roots.extend(a for a in (folder, *folder.parents) if a.name == pkg)
        roots.append(folder / pkg)
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            add(Path(entry))
    return list(dict.fromkeys(roots))


def resolve_package_uri(
    uri: str, urdf_path: str | os.PathLike | None = None, package_dirs: Sequence[str] = ()
) -> Path:
    """The file a URDF mesh ``filename`` names (ValueError naming the URI and the folders
    searched if there is none).

    ``package://NAME/rest`` is looked up in the package folders of :func:`_package_roots`;
    ``file://`` and absolute paths are taken as they are; a relative path is relative to
    the URDF's folder, then to each of ``package_dirs`` (docs/design.md §1c).
    """
    upath = Path(urdf_path) if urdf_path is not None else None
    dirs = [Path(d) for d in package_dirs]
    rest = uri
    if uri.startswith("package://"):
        pkg, _, rest = uri[len("package://"):].partition("/")
        bases = _package_roots(pkg, upath, dirs)
    elif uri.startswith("file://"):
        bases, rest = [Path("/")], uri[len("file://"):]
    elif Path(uri).is_absolute():
        bases = [Path("/")]
    else:
        bases = ([upath.resolve().parent] if upath is not None else []) + dirs
    for base in bases:
        if (base / rest).is_file():
            return (base / rest).resolve()
    searched = ", ".join(str(b) for b in bases) or "no folder (no package_dirs)"
    hint = " (package_dirs or ROS_PACKAGE_PATH add folders)" if uri.startswith("package:") else ""
    raise ValueError(f"mesh {uri!r} could not be found; searched: {searched}{hint}")


def resolve_meshes(xml: str, urdf_path: Path | None, package_dirs: Sequence[str]) -> str:
    """Rewrite every ``<mesh filename>`` to the absolute path it names (or ValueError)."""
    from lxml import etree

    root = etree.fromstring(xml.encode("utf-8"))
    changed = False
    for mesh in root.iter("mesh"):
        uri = mesh.get("filename")
        if not uri:
            continue
        path = str(resolve_package_uri(uri, urdf_path, package_dirs))
        if path != uri:
            mesh.set("filename", path)
            changed = True
    return etree.tostring(root, encoding="unicode") if changed else xml


def expand_xacro(
    path: str | os.PathLike,
    args: Mapping[str, object] | None = None,
    package_dirs: Sequence[str] = (),
) -> str:
    """The URDF text of the xacro file ``path`` expanded in-process with ``args`` (xacro
    ``<xacro:arg>`` values; numbers and booleans are passed as text). ``$(find NAME)``
    gives the package folder of :func:`resolve_package_uri`. ValueError naming the file
    (and the line, when xacro reports one) on any xacro error (docs/design.md §1c).
    """
    import xml.parsers.expat

    import xacro
    from xacro import substitution_args as subst

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"xacro file not found: {str(path)!r}")
    mappings = {str(k): _xacro_text(v) for k, v in (args or {}).items()}

    def find(pkg: str) -> str:
        roots = _package_roots(pkg, path, [Path(d) for d in package_dirs])
        for r in roots:
            if r.is_dir():
                return str(r.resolve())
        raise ValueError(f"$(find {pkg}): no package folder {pkg!r}; searched: "
                         + ", ".join(str(r) for r in roots))

    saved = subst._eval_find, subst._eval_dict.get("find")
    subst._eval_find = subst._eval_dict["find"] = find
    try:
        xacro.init_stacks(str(path.resolve()))
        doc = xacro.parse(None, str(path.resolve()))
        xacro.process_doc(doc, mappings=mappings)
    except xml.parsers.expat.ExpatError as exc:
        where = (xacro.filestack or [None])[-1] or str(path)
        raise ValueError(f"xacro could not parse {where}: {exc}") from None
    except Exception as exc:  # XacroException, NameError, ValueError ... from xacro
        where = (xacro.filestack or [None])[-1] or str(path)
        msg = " ".join(str(exc).split()) or repr(exc)
        raise ValueError(f"xacro could not expand {where}: {msg}") from None
    finally:
        subst._eval_find, subst._eval_dict["find"] = saved
    return doc.toxml()


def _xacro_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, str)):
        return str(value)
    raise ValueError(f"xacro argument values must be strings, numbers or booleans, got {value!r}")
