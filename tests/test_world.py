"""World, obstacles and hazards: construction, validation, geometry, plain data."""

import json
import math

import numpy as np
import pinocchio as pin
import pytest

from mpd_pin.world import Box, Cylinder, Hazard, Polygon, Sphere, World, shape_from_dict


def _scene():
    return World(
        [
            Box.planar((0.5, 0.3), 0.2, 0.1, angle=0.3, name="box"),
            Cylinder.planar((-0.4, 0.5), 0.1, name="post"),
            Polygon.planar([(0.0, -0.2), (0.3, -0.6), (-0.3, -0.6)], name="tri"),
            Sphere.planar((1.0, 1.0), 0.2),
            Box((0.1, 0.2, 0.3), (0.0, 0.0, 1.5), name="late", hidden=True),
        ],
        [Hazard(Polygon.planar([(0.9, -0.4), (1.2, -0.4), (1.05, -0.1)], name="hot"), 0.08)],
    )


def test_planar_box_section_and_pose():
    b = Box.planar((0.5, 0.3), 0.2, 0.1, angle=0.3, depth=0.8)
    assert b.size == (0.2, 0.8, 0.1)
    c, s = math.cos(0.3), math.sin(0.3)
    # local x turns towards +z like the arm's joints (axis −y)
    np.testing.assert_allclose(b.rotation_matrix @ [1, 0, 0], [c, 0, s], atol=1e-15)
    corners = {(round(0.5 + c * x - s * z, 12), round(0.3 + s * x + c * z, 12))
               for x in (-0.1, 0.1) for z in (-0.05, 0.05)}
    got = {tuple(np.round(p, 12)) for p in b.section_xz()}
    assert got == corners
    assert b.placement.isApprox(pin.SE3(b.rotation_matrix, np.array([0.5, 0.0, 0.3])))


def test_rotation_matrix_or_rpy():
    R = pin.rpy.rpyToMatrix(0.1, -0.4, 0.7)
    a = Box((1, 2, 3), (0.1, 0.2, 0.3), rotation=R)
    b = Box((1, 2, 3), (0.1, 0.2, 0.3), (0.1, -0.4, 0.7))
    np.testing.assert_allclose(a.rpy, b.rpy, atol=1e-12)
    np.testing.assert_allclose(a.rotation_matrix, R, atol=1e-12)
    with pytest.raises(ValueError, match="orthonormal"):
        Box((1, 1, 1), rotation=2 * np.eye(3))
    with pytest.raises(ValueError, match="orthonormal"):
        Box((1, 1, 1), rotation=np.diag([1.0, 1.0, -1.0]))  # a reflection


def test_planar_cylinder_axis_along_y():
    c = Cylinder.planar((0.2, -0.1), 0.15, depth=2.0)
    axis = c.rotation_matrix @ [0, 0, 1]
    assert abs(abs(axis[1]) - 1) < 1e-12
    sec = c.section_xz(n=256)
    r = np.hypot(sec[:, 0] - 0.2, sec[:, 1] + 0.1)
    assert r.max() <= 0.15 + 1e-12 and r.min() > 0.15 * math.cos(math.pi / 256) - 1e-12
    g = c.geometry()
    assert g.radius == 0.15 and g.halfLength == 1.0


def test_polygon_orientation_geometry_and_validation():
    cw = Polygon.planar([(0, 0), (0, 1), (1, 0)])
    ccw = Polygon.planar([(0, 0), (1, 0), (0, 1)])
    # stored counter-clockwise in (x, z), starting anywhere
    v = np.array(cw.vertices_xz)
    area2 = np.sum(v[:, 0] * np.roll(v[:, 1], -1) - np.roll(v[:, 0], -1) * v[:, 1])
    assert area2 > 0 and set(cw.vertices_xz) == set(ccw.vertices_xz)
    prism = Polygon.planar([(0, 0), (2, 0), (2, 1), (0, 1)], depth=0.5).geometry()
    assert prism.num_points == 8
    assert prism.computeVolume() == pytest.approx(2 * 1 * 0.5, rel=1e-12)
    tri = Polygon([(0, 0), (1, 0), (0, 1)], thickness=0.4).geometry()
    assert tri.computeVolume() == pytest.approx(0.5 * 0.4, rel=1e-12)
    bad = {
        "not convex": [(0, 0), (2, 0), (1, 0.2), (1, 2)],
        "simple": [(math.cos(a), math.sin(a)) for a in 4 * math.pi / 5 * np.arange(5)],  # star
        "collinear": [(0, 0), (1, 0), (2, 0), (1, 1)],
        "zero area": [(0, 0), (1, 1), (2, 2)],
        "repeated": [(0, 0), (0, 0), (1, 0), (0, 1)],
        "at least 3": [(0, 0), (1, 1)],
        "finite": [(0, 0), (1, np.nan), (0, 1)],
    }
    for what, verts in bad.items():
        with pytest.raises(ValueError) as err:
            Polygon.planar(verts)
        assert what.split()[0] in str(err.value) or what == "repeated", (what, err.value)
    with pytest.raises(ValueError):
        Polygon.planar([(0, 0), (1, 0), (0, 1)], depth=0.0)


@pytest.mark.parametrize(
    "make",
    [
        lambda: Box((1, -1, 1)),
        lambda: Box((1, 0, 1)),
        lambda: Box((1, 1)),
        lambda: Box((1, 1, 1), (0, np.nan, 0)),
        lambda: Box((1, 1, 1), rpy=(0, 0, np.inf)),
        lambda: Box.planar((0, 0), -0.1, 0.2),
        lambda: Box.planar((0, 0), 0.1, 0.2, angle=np.nan),
        lambda: Cylinder(0.0, 1.0),
        lambda: Cylinder(0.1, -1.0),
        lambda: Cylinder.planar((np.nan, 0), 0.1),
        lambda: Sphere(-0.1),
        lambda: Sphere(np.nan),
        lambda: Sphere("big"),
        lambda: Hazard(Sphere(0.1), -0.01),
        lambda: Hazard(Sphere(0.1), np.nan),
        lambda: Hazard("box", 0.1),
        lambda: Box((1, 1, 1), name=3),
        lambda: Box((1, 1, 1), hidden="yes"),
        lambda: World([Box((1, 1, 1), name="a"), Sphere(1.0, name="a")]),
        lambda: World(["box"]),
        lambda: World(hazards=[Box((1, 1, 1))]),
    ],
)
def test_bad_input(make):
    with pytest.raises(ValueError):
        make()


def test_reveal_known_and_version():
    w = _scene()
    assert w.names == ["box", "post", "tri", "sphere3", "late", "hot"]
    assert w.hidden_names() == ["late"]
    assert not w.is_known("late") and w.is_known("box")
    assert [o.name for o in w.known().obstacles] == ["box", "post", "tri", "sphere3"]
    assert w.geometry_model().ngeoms == 5 and w.geometry_model(include_hidden=True).ngeoms == 6
    assert w.geometry_model(hazards=False).ngeoms == 4
    v = w.version
    assert w.reveal("late") == ["late"] and w.version == v + 1
    assert w.reveal("late") == [] and w.version == v + 1  # no change, no new version
    assert w.reveal("box") == []  # not hidden: nothing to reveal
    assert w.is_known("late") and w.hidden_names() == []
    known = w.known()
    assert "late" in known and not known["late"].hidden
    w.reset()
    # include_hidden: everything, all marked known; same content as the revealed world
    everything = w.known(include_hidden=True)
    assert everything.names == w.names and everything.hidden_names() == []
    assert everything.fingerprint() == known.fingerprint() != w.known().fingerprint()
    assert w.hidden_names() == ["late"]  # the world itself is unchanged
    assert w.hidden_names() == ["late"] and w.version == v + 2
    with pytest.raises(ValueError, match="no obstacle named"):
        w.reveal("nope")
    with pytest.raises(KeyError):
        w["nope"]


def test_plain_data_round_trip_and_fingerprint():
    w = _scene()
    d = w.to_dict()
    text = json.dumps(d)  # plain data only
    w2 = World.from_dict(json.loads(text))
    assert w2.obstacles == w.obstacles and w2.hazards == w.hazards
    assert w2.fingerprint() == w.fingerprint()
    assert len(w.fingerprint()) == 64 and int(w.fingerprint(), 16) >= 0
    # stable across processes: depends on values only (no -0.0, no ids)
    assert Box.planar((0, 0), 1, 1).to_dict()["rpy"] == [0.0, 0.0, 0.0]
    assert json.dumps(Box.planar((0, 0), 1, 1).to_dict()).count("-0.0") == 0
    # any change changes it
    moved = World.from_dict({**d, "obstacles": [{**d["obstacles"][0], "position": [0.5, 0, 0.31]},
                                                *d["obstacles"][1:]]})
    assert moved.fingerprint() != w.fingerprint()
    w.reveal("late")
    assert w.fingerprint() != w2.fingerprint()
    assert World.from_dict(w.to_dict()).is_known("late")
    for bad in (
        {"obstacles": [{"type": "torus"}]},
        {"obstacles": [{"type": "box", "size": [1, 1, 1], "colour": "red"}]},
        {"obstacles": [{"type": "box"}]},
        {"obstacles": [{"type": "sphere", "radius": -1}]},
        {"hazards": [{"type": "box", "size": [1, 1, 1]}]},
        {"hazards": [{"type": "hazard", "clearance": 0.1}]},
        {"obstacles": [], "walls": []},
        {"revealed": ["ghost"]},
        "not a mapping",
    ):
        with pytest.raises(ValueError):
            World.from_dict(bad)
    assert isinstance(shape_from_dict(Sphere(0.3).to_dict()), Sphere)


def test_sections():
    s = Sphere(0.5, (0.0, 0.3, 0.0))
    sec = s.section_xz(n=64)
    assert np.hypot(sec[:, 0], sec[:, 1]).max() == pytest.approx(0.4)
    assert Sphere(0.5, (0.0, 0.6, 0.0)).section_xz() is None
    # a box lying across the plane and one that misses it
    assert Box((1, 0.2, 1), (0, 0.5, 0)).section_xz() is None
    tilted = Box((1, 1, 1), (0, 0, 0), (0.0, 0.0, math.pi / 4))  # yaw 45°: section is wider
    sec = tilted.section_xz()
    assert sec[:, 0].max() == pytest.approx(math.sqrt(2) / 2)
    h = Hazard(Sphere.planar((0.1, 0.2), 0.1, name="z"), 0.05)
    assert h.name == "z" and not h.hidden and h.to_dict()["clearance"] == 0.05
