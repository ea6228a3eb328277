"""path.png of a non-planar arm (issue 23 item 5): the arm's links, its base, the obstacles
beneath the lines and the labelled ends, checked on the matplotlib artists.

References are independent of the plotting code: joint and end-effector positions from
Pinocchio's ``forwardKinematics`` and ``updateFramePlacements``, the base from the URDF's
mount placement, obstacle heights from the scenario's box parameters.
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
import pytest  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

import mpd_pin as mp  # noqa: E402
from mpd_pin.app.kinds import load_scenario  # noqa: E402
from mpd_pin.viz.plots import plot_arm_path  # noqa: E402
from mpd_pin.world import Box, Cylinder, World  # noqa: E402

TRACE = "end-effector trace (travelled)"
MIN_LINK_WIDTH = 3.0  # points: thicker than every other line of the figure

# A two-joint arm mounted off the origin: world -> base_link at BASE, the first joint
# (about z, so not planar) MOUNT_Z above it.
BASE = np.array([0.2, -0.1, 0.05])
MOUNT_Z = 0.3


def offset_arm() -> mp.Arm:
    xml = mp.planar_arm_urdf([0.5, 0.4], [1.0, 1.0])
    xml = xml.replace(
        '<link name="base_link"/>',
        '<link name="world"/><link name="base_link"/>'
        '<joint name="mount" type="fixed"><parent link="world"/><child link="base_link"/>'
        f'<origin xyz="{BASE[0]} {BASE[1]} {BASE[2]}" rpy="0 0 0"/></joint>',
        1,
    )
    first = '<origin xyz="0.0 0.0 0.0" rpy="0.0 0.0 0.0"/>\n    <axis xyz="0.0 -1.0 0.0"/>'
    assert first in xml
    xml = xml.replace(
        first, f'<origin xyz="0 0 {MOUNT_Z}" rpy="0 0 0"/>\n    <axis xyz="0 0 1"/>', 1
    )
    return mp.Arm.from_urdf(xml)


def fk_points(arm, q) -> np.ndarray:
    """Joint origins then the "ee" frame if the model has one (m), by Pinocchio directly."""
    model = arm.model
    data = model.createData()
    pin.forwardKinematics(model, data, np.asarray(q, float))
    pin.updateFramePlacements(model, data)
    pts = [data.oMi[j].translation for j in range(1, model.njoints)]
    if model.existFrame("ee"):
        pts.append(data.oMf[model.getFrameId("ee")].translation)
    return np.array(pts)


def line_xyz(ln) -> np.ndarray:
    return np.column_stack([np.asarray(c, float) for c in ln.get_data_3d()])


def thick_lines(ax) -> list:
    return [ln for ln in ax.get_lines() if ln.get_linewidth() >= MIN_LINK_WIDTH]


def labelled(ax, label) -> list:
    return [ln for ln in ax.get_lines() if ln.get_label() == label]


@pytest.fixture(scope="module")
def offset_scene():
    arm = offset_arm()
    world = World((Box((0.3, 0.3, 0.2), position=(0.5, 0.4, 0.1), name="crate"),
                   Cylinder(0.05, 0.6, position=(-0.3, 0.2, 0.3), name="pole")))
    Q = np.array([[0.0, 0.3], [0.8, -0.4], [1.6, 0.9]])
    fig = plot_arm_path(arm, world, Q, node_times=[0.0, 1.0, 2.0])
    fig.canvas.draw()
    yield {"arm": arm, "Q": Q, "ax": fig.axes[0]}
    plt.close(fig)


@pytest.fixture(scope="module")
def ur5():
    scn = load_scenario("ur5")
    s, g = np.asarray(scn.start, float), np.asarray(scn.goal, float)
    Q = s + np.linspace(0.0, 1.0, 5)[:, None] * (g - s)
    Qm = s + np.linspace(0.0, 1.0, 80)[:, None] * (g - s)
    fig = plot_arm_path(scn.arm, scn.world, Q, Q_motion=Qm, title="ur5")
    fig.canvas.draw()
    yield {"scn": scn, "Q": Q, "Qm": Qm, "ax": fig.axes[0]}
    plt.close(fig)


def test_links_are_thick_lines_one_per_pose_at_forward_kinematics(offset_scene):
    arm, Q, ax = offset_scene["arm"], offset_scene["Q"], offset_scene["ax"]
    poses = [ln for ln in thick_lines(ax) if ln.get_gid() != "pedestal"]
    assert len(poses) == len(Q)
    for ln, q in zip(poses, Q, strict=True):
        np.testing.assert_allclose(line_xyz(ln), fk_points(arm, q), atol=1e-12)
    # the legend names them once
    assert len(labelled(ax, "arm at each path node")) == 1


def test_base_marker_and_pedestal_at_the_mount(offset_scene):
    arm, ax = offset_scene["arm"], offset_scene["ax"]
    (base,) = labelled(ax, "base")
    np.testing.assert_allclose(line_xyz(base), [BASE], atol=1e-12)
    # the pedestal joins the base to the first joint, whose origin is MOUNT_Z above it
    (pedestal,) = [ln for ln in thick_lines(ax) if ln.get_gid() == "pedestal"]
    first_joint = fk_points(arm, pin.neutral(arm.model))[0]
    np.testing.assert_allclose(first_joint, BASE + [0.0, 0.0, MOUNT_Z], atol=1e-12)
    np.testing.assert_allclose(line_xyz(pedestal), [BASE, first_joint], atol=1e-12)


def test_obstacles_translucent_and_drawn_below_every_line(offset_scene):
    ax = offset_scene["ax"]
    assert ax.computed_zorder is False  # else mplot3d re-sorts solids over the lines
    solids = [c for c in ax.collections if isinstance(c, Poly3DCollection)]
    assert {c.get_gid() for c in solids} == {"crate", "pole"}
    lowest_line = min(ln.get_zorder() for ln in ax.get_lines())
    for c in solids:
        assert c.get_zorder() < lowest_line
        assert np.all(c.get_facecolor()[:, 3] <= 0.3)  # the arm shows through


def test_start_and_goal_labels_boxed_on_top(offset_scene):
    arm, Q, ax = offset_scene["arm"], offset_scene["Q"], offset_scene["ax"]
    top = max(a.get_zorder() for a in [*ax.get_lines(), *ax.collections])
    for label, q in (("start", Q[0]), ("goal", Q[-1])):
        (text,) = [t for t in ax.texts if t.get_text().strip() == label]
        np.testing.assert_allclose(text.get_position_3d(), fk_points(arm, q)[-1], atol=1e-12)
        box = text.get_bbox_patch()
        assert box is not None
        np.testing.assert_allclose(box.get_facecolor()[:3], (1.0, 1.0, 1.0))
        assert text.get_zorder() > top


def test_equal_scale_on_every_axis(offset_scene):
    ax = offset_scene["ax"]
    spans = np.array([np.ptp(ax.get_xlim()), np.ptp(ax.get_ylim()), np.ptp(ax.get_zlim())])
    aspect = np.asarray(ax.get_box_aspect(), float)
    np.testing.assert_allclose(aspect / aspect.max(), spans / spans.max(), rtol=1e-9)


def test_ur5_trace_above_the_table_and_drawn_over_it(ur5):
    scn, Qm, ax = ur5["scn"], ur5["Qm"], ur5["ax"]
    (trace,) = labelled(ax, TRACE)
    xyz = line_xyz(trace)
    expected = np.array([fk_points(scn.arm, q)[-1] for q in Qm])
    np.testing.assert_allclose(xyz, expected, atol=1e-12)
    (table_box,) = [o for o in scn.world if o.name == "table"]
    table_top = table_box.position[2] + table_box.size[2] / 2.0
    assert table_top <= 0.0
    assert np.all(xyz[:, 2] >= 0.0)
    (table,) = [c for c in ax.collections if c.get_gid() == "table"]
    assert ax.computed_zorder is False
    assert trace.get_zorder() > table.get_zorder()
    for ln in thick_lines(ax):  # and so are the arm's links
        assert ln.get_zorder() > table.get_zorder()
        assert np.all(line_xyz(ln)[:, 2] >= 0.0)


def test_planar_figure_keeps_its_legend_only_ends():
    """Planar arms keep their figure: the ends are named in the legend, not written."""
    arm = mp.builtin_arm("planar_3link")
    fig = plot_arm_path(arm, None, np.array([[0.2, 0.3, 0.2], [1.0, -0.2, 0.4]]))
    ax = fig.axes[0]
    assert not [t for t in ax.texts if t.get_text().strip() in ("start", "goal")]
    assert {"start", "goal"} <= {ln.get_label() for ln in ax.get_lines()}
    plt.close(fig)
