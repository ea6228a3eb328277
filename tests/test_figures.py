"""The artists of the figures (issue 17 points 3 and 6): path.png of paper 000 and the
paper-002 figures, checked on the matplotlib objects (labels, positions, limits, extents).

References are independent of the plotting code: end-effector positions from Pinocchio's
frame placement, obstacle extents from the shapes' parameters, the clearance band from the
distance of its outline to the hazard triangle (point–segment distances, plain numpy).
"""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
import pytest  # noqa: E402

import mpd_pin as mp  # noqa: E402
from mpd_pin.twolink import plots as tp  # noqa: E402
from mpd_pin.twolink.ik import TwoLinkKinematics  # noqa: E402
from mpd_pin.twolink.moving import (  # noqa: E402
    MovingObstacle,
    MovingScene,
    back_and_forth,
    static,
)
from mpd_pin.viz.plots import Detection, plot_arm_path, plot_cumulative_energy  # noqa: E402
from mpd_pin.world import Box, Cylinder, Hazard, Polygon, World  # noqa: E402

TRI = [(0.4, -0.55), (0.7, -0.55), (0.55, -0.3)]
CLEARANCE = 0.12


def ee(arm, q) -> np.ndarray:
    data = arm.model.createData()
    pin.framesForwardKinematics(arm.model, data, np.asarray(q, float))
    return data.oMf[arm.model.getFrameId("ee")].translation.copy()


def lines_labelled(ax, label):
    return [ln for ln in ax.get_lines() if ln.get_label() == label]


def legend_texts(ax) -> list[str]:
    leg = ax.get_legend()
    assert leg is not None
    return [t.get_text() for t in leg.get_texts()]


@pytest.fixture(scope="module")
def scene():
    arm = mp.builtin_arm("planar_3link")
    world = World(
        (
            Box.planar((0.0, 0.75), 0.2, 0.5, name="divider"),  # case1: spans z 0.5 … 1.0 m
            Cylinder.planar((0.37, 0.55), 0.05, name="newcomer", hidden=True),
            Hazard(Polygon.planar(TRI, name="hot"), CLEARANCE),
            Box.planar((1.5, 0.0), 0.2, 0.2, name="far"),  # outside the reach (1.2 m)
        )
    )
    Q = np.array([[0.2, 0.3, 0.2], [0.9, 0.1, -0.3], [1.6, -0.2, -0.5], [2.6, -0.4, -0.6]])
    initial = np.array([[0.2, 0.3, 0.2], [0.5, 0.5, 0.1], [2.6, -0.4, -0.6]])
    times = [0.0, 1.0, 2.0, 3.0]
    det = Detection(Q[1], 1.0, ("newcomer",))
    fig = plot_arm_path(arm, world, Q, other_paths={"initial plan": initial}, node_times=times,
                        detections=[det], title="test")
    fig.canvas.draw()
    yield {"arm": arm, "world": world, "Q": Q, "fig": fig, "ax": fig.axes[0], "det": det}
    plt.close(fig)


def test_start_and_goal_markers_at_the_end_effector(scene):
    arm, Q, ax = scene["arm"], scene["Q"], scene["ax"]
    for label, q in (("start", Q[0]), ("goal", Q[-1])):
        (ln,) = lines_labelled(ax, label)
        p = ee(arm, q)
        np.testing.assert_allclose(np.c_[ln.get_xdata(), ln.get_ydata()], [[p[0], p[2]]],
                                   atol=1e-12)
        assert label in legend_texts(ax)


def test_pose_shading_explained_by_a_time_colour_bar(scene):
    fig, ax = scene["fig"], scene["ax"]
    cbars = [a for a in fig.axes if a is not ax]
    assert len(cbars) == 1
    cax = cbars[0]
    assert "time along path (s)" in cax.get_ylabel()
    assert cax.get_ylim() == pytest.approx((0.0, 3.0))
    # The poses are coloured by that bar: later nodes darker (smaller summed RGB).
    (first,) = lines_labelled(ax, "arm at each path node")
    assert "arm at each path node" in legend_texts(ax)
    poses = [ln for ln in ax.get_lines() if ln.get_marker() == "o"
             and ln.get_linestyle() == "-" and len(ln.get_xdata()) == 4]
    assert len(poses) == 4 and poses[0] is first
    bright = [sum(matplotlib.colors.to_rgb(ln.get_color())) for ln in poses]
    assert all(a > b for a, b in zip(bright, bright[1:], strict=False))


def test_limits_contain_every_obstacle_band_and_the_reach(scene):
    ax = scene["ax"]
    (x0, x1), (z0, z1) = ax.get_xlim(), ax.get_ylim()
    # From the shapes' parameters: divider x ±0.1, z 0.5 … 1.0; far box x 1.4 … 1.6.
    assert x0 <= -0.1 and x1 >= 1.6 and z0 <= -1.2 and z1 >= 1.2
    reach = 0.4 * 3  # planar_3link: three 0.4 m links
    assert x0 <= -reach and z0 <= -reach and z1 >= reach
    assert z1 >= 1.0  # the divider's top (case1's was clipped at ~0.78 m)
    # The hazard's clearance band reaches 0.12 m below the triangle's base.
    assert z0 <= -0.55 - CLEARANCE


def test_clearance_band_is_the_hazard_grown_by_its_clearance(scene):
    ax = scene["ax"]
    (band,) = [p for p in ax.patches if p.get_gid() == "hot:clearance"]
    assert "clearance band (0.12 m)" in band.get_label()
    assert band.get_label() in legend_texts(ax)
    xy = band.get_xy()
    tri = np.array(TRI)

    def dist(p):  # distance of point p to the (filled) triangle, from its three edges
        d = []
        for a, b in zip(tri, np.roll(tri, -1, axis=0), strict=True):
            s = np.clip(np.dot(p - a, b - a) / np.dot(b - a, b - a), 0.0, 1.0)
            d.append(np.linalg.norm(p - (a + s * (b - a))))
        return min(d)

    # The outline (vertices and edge midpoints) is at the clearance from the triangle, up to
    # the 48-gon's approximation of the disc: c·cos(π/48) ≤ distance ≤ c.
    mid = (xy + np.roll(xy, -1, axis=0)) / 2.0
    d = np.array([dist(p) for p in np.concatenate([xy, mid])])
    assert np.all(d <= CLEARANCE + 1e-12) and np.all(d >= CLEARANCE * np.cos(np.pi / 48) - 1e-12)
    assert np.sum(np.isclose(d[: len(xy)], CLEARANCE, rtol=1e-12)) >= len(xy) - 4
    # Obstacles without a clearance get no band.
    assert {p.get_gid() for p in ax.patches if str(p.get_gid()).endswith(":clearance")} == {
        "hot:clearance"}


def test_detection_marked_where_and_when(scene):
    arm, ax, det = scene["arm"], scene["ax"], scene["det"]
    (mark,) = lines_labelled(ax, "new obstacle detected (arm's node)")
    p = ee(arm, det.q)
    np.testing.assert_allclose([mark.get_xdata()[0], mark.get_ydata()[0]], [p[0], p[2]],
                               atol=1e-12)
    (note,) = [t for t in ax.texts if t.get_gid() == "detection"]
    assert "newcomer detected" in note.get_text() and "t = 1.00 s" in note.get_text()
    # The annotation is inside the figure.
    renderer = scene["fig"].canvas.get_renderer()
    fb = scene["fig"].bbox
    bb = note.get_window_extent(renderer)
    assert fb.x0 <= bb.x0 and bb.x1 <= fb.x1 and fb.y0 <= bb.y0 and bb.y1 <= fb.y1


def test_initial_plan_and_its_poses_in_the_legend(scene):
    texts = legend_texts(scene["ax"])
    assert "initial plan: end effector" in texts
    assert "initial plan: arm poses" in texts
    assert "end-effector trace (travelled)" in texts
    assert {"x (m)", "z (m)"} == {scene["ax"].get_xlabel(), scene["ax"].get_ylabel()}


def test_without_node_times_the_bar_counts_nodes():
    arm = mp.builtin_arm("planar_3link")
    Q = np.array([[0.2, 0.3, 0.2], [1.0, 0.0, 0.0], [2.6, -0.4, -0.6]])
    fig = plot_arm_path(arm, None, Q)
    try:
        (cax,) = [a for a in fig.axes if a is not fig.axes[0]]
        assert "node along path" in cax.get_ylabel()
        assert cax.get_ylim() == pytest.approx((0.0, 2.0))
    finally:
        plt.close(fig)


def test_app_passes_the_detection_of_the_replan_scenario(tmp_path, monkeypatch):
    """write_plots gives path.png the node and time where the hidden obstacle was revealed."""
    from mpd_pin.app import outputs
    from mpd_pin.app.kinds import load_scenario
    from mpd_pin.app.plan import plan_path, prepare
    from mpd_pin.app.verify import verify_path
    from mpd_pin.viz import plots

    scn = load_scenario("replan")
    setup = prepare(scn, show_progress=False)
    plan = plan_path(scn, setup)
    check = verify_path(setup.drive, setup.roadmap, plan.path, scn.options.dt, plan.energy)
    seen = {}
    real = plots.plot_arm_path

    def spy(*args, **kwargs):
        seen.update(kwargs)
        fig = real(*args, **kwargs)
        seen["fig"] = fig
        fig.canvas.draw()
        seen["texts"] = [t.get_text() for t in fig.axes[0].texts if t.get_gid() == "detection"]
        return fig

    monkeypatch.setattr(plots, "plot_arm_path", spy)
    outputs.write_plots(tmp_path, scn, setup, plan, check)
    (ev,) = plan.execution.replans
    (det,) = seen["detections"]
    assert det.names == tuple(ev.revealed) == ("newcomer",)
    np.testing.assert_array_equal(det.q, setup.roadmap.nodes[ev.node])
    assert plan.path[ev.step] == ev.node  # the travelled path passes the detection node
    # The arm is at travelled[k] at the k-th node time: ev.step one-second edges in.
    assert det.t == pytest.approx(check.series["node_times"][ev.step])
    assert det.t == pytest.approx(ev.step * scn.options.duration)
    assert seen["texts"] == [f"newcomer detected\nat t = {det.t:.2f} s"]
    assert (tmp_path / "path.png").stat().st_size > 10_000



# ------------------------------------------------------------------ energy.png marks
def vertical_lines(ax) -> dict[float, object]:
    """x (s) -> line, for each line at one x spanning the axes' full height (display)."""
    out = {}
    for ln in ax.get_lines():
        x, y = np.asarray(ln.get_xdata(), float), np.asarray(ln.get_ydata(), float)
        if len(x) != 2 or x[0] != x[1]:
            continue
        ys = ln.get_transform().transform(np.column_stack([x, y]))[:, 1]
        if np.allclose(sorted(ys), [ax.bbox.y0, ax.bbox.y1]):
            out[float(x[0])] = ln
    return out


@pytest.fixture(scope="module")
def energy_curves():
    t = np.linspace(0.0, 6.0, 61)
    E = np.column_stack([0.4 * t, 0.1 * t**2])
    return t, E, ["j1", "j2"], (t, 0.7 * t**1.5, "shortest joint-space path")


def test_energy_marks_a_dashed_line_and_its_label_at_each_time(energy_curves):
    t, E, names, compare = energy_curves
    marks = [(1.5, "replan: obstacle 'crate' sensed"), (4.25, "replan: obstacle 'pole' sensed")]
    fig = _agg(plot_cumulative_energy(t, E, names, compare=compare, marks=marks))
    ax = fig.axes[0]
    lines = vertical_lines(ax)
    assert sorted(lines) == [1.5, 4.25]
    renderer = fig.canvas.get_renderer()
    for tm, label in marks:
        assert lines[tm].get_linestyle() == "--"
        (text,) = [tx for tx in ax.texts if tx.get_text() == label]
        assert text.xy[0] == tm
        # written just left of its line, inside the axes
        x_line = ax.transData.transform((tm, 0.0))[0]
        box = text.get_window_extent(renderer)
        assert x_line - 20 < box.x1 <= x_line
        assert ax.bbox.y0 <= box.y0 and box.y1 <= ax.bbox.y1
    # the curves and their legend are those of the figure without marks
    plain = _agg(plot_cumulative_energy(t, E, names, compare=compare))
    assert legend_texts(ax) == legend_texts(plain.axes[0])
    plt.close(fig)
    plt.close(plain)


def test_energy_without_marks_has_no_vertical_line(energy_curves):
    t, E, names, compare = energy_curves
    fig = _agg(plot_cumulative_energy(t, E, names, compare=compare))
    ax = fig.axes[0]
    assert vertical_lines(ax) == {}
    assert len(ax.texts) == 0
    assert len(ax.get_lines()) == len(names) + 2  # per joint, total, compared total
    plt.close(fig)


# ------------------------------------------------------------------ paper 002
@pytest.fixture(scope="module")
def twolink():
    kin = TwoLinkKinematics(mp.builtin_arm("planar_2link"))
    scene = MovingScene(
        [MovingObstacle("shuttle", 0.1, back_and_forth((-0.3, 0.3), (-0.3, 0.9), 1.0)),
         MovingObstacle("rock", 0.12, static((0.5, -0.4)))], ts=0.01)
    q = np.column_stack([np.linspace(0.0, 1.5, 21), np.linspace(0.3, 0.9, 21)])
    pts = np.array([kin.fk(qk) for qk in q])
    return kin, scene, q, pts


def inside_figure(fig, artist) -> bool:
    renderer = fig.canvas.get_renderer()
    bb = artist.get_window_extent(renderer)
    fb = fig.bbox
    return fb.x0 <= bb.x0 and bb.x1 <= fb.x1 and fb.y0 <= bb.y0 and bb.y1 <= fb.y1


def _agg(fig):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    FigureCanvasAgg(fig)
    fig.canvas.draw()
    return fig


def test_obstacle_motion_title_inside_the_figure(twolink):
    kin, scene, _, _ = twolink
    fig = _agg(tp.plot_obstacle_motion(kin, scene, 1.01))
    ax = fig.axes[0]
    assert ax.get_title().startswith("obstacle motion over 1.01 s")
    assert inside_figure(fig, ax.title)
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x (m)", "z (m)")


def test_motion_panels_have_axis_labels_with_units(twolink):
    kin, scene, q, pts = twolink
    fig = _agg(tp.plot_arm_snapshots(kin, scene, q, [0, 5, 10, 15, 20], points=pts,
                                     title="env: PSO-smoothed motion"))
    axes = [a for a in fig.axes if a.get_visible()]
    assert len(axes) == 5
    bottom = {a.get_xlabel() for a in axes if a.get_subplotspec().is_last_row()}
    left = {a.get_ylabel() for a in axes if a.get_subplotspec().is_first_col()}
    assert bottom == {"x (m)"} and left == {"z (m)"}
    for a in axes:  # every visible label is inside the figure
        for lab in (a.xaxis.label, a.yaxis.label):
            if lab.get_text():
                assert inside_figure(fig, lab)
    assert inside_figure(fig, fig._suptitle)


def test_pso_cost_curve_from_iteration_zero_with_infeasible_start_marked(twolink):
    kin, scene, _, pts = twolink
    inf = float("inf")
    curve = [inf] * 8 + [2.3] * 5 + [1.9] * 3  # as env2: no feasible particle before it. 8
    fig = _agg(tp.plot_paths(kin, scene, pts, pts, curve))
    ax2 = fig.axes[1]
    assert ax2.get_xlim()[0] <= 0.0
    assert ax2.get_xlabel().startswith("iteration") and ax2.get_ylabel().endswith("(m)")
    (span,) = [p for p in ax2.patches if p.get_gid() == "no_feasible_particle"]
    x = span.get_patch_transform().transform(span.get_path().vertices)[:, 0]  # data x
    assert min(x) == pytest.approx(-0.5) and max(x) == pytest.approx(7.5)
    assert "iterations 0–7: no feasible particle (cost = ∞)" in legend_texts(ax2)
    (best,) = lines_labelled(ax2, "best path length so far")
    y = np.asarray(best.get_ydata(), float)
    assert np.all(np.isnan(y[:8])) and y[8] == 2.3 and len(y) == 16
    for ax in fig.axes:
        assert inside_figure(fig, ax.title)
    # A curve feasible from the start has no shaded span.
    fig = _agg(tp.plot_paths(kin, scene, pts, pts, [2.0, 1.9]))
    assert not [p for p in fig.axes[1].patches if p.get_gid() == "no_feasible_particle"]


def test_fcs_panels_labelled(twolink):
    from mpd_pin.twolink.fcs import FreeCartesianSpace, Grid
    from mpd_pin.twolink.moving import SampledCollisionChecker

    kin, scene, q, _ = twolink
    R = kin.l1 + kin.l2
    fcs = FreeCartesianSpace(kin, Grid(-R, R, -R, R, 0.1),
                             SampledCollisionChecker(kin.arm, scene))
    fig = _agg(tp.plot_fcs_maps(fcs, [0, 10], q=q))
    bottom = {a.get_xlabel() for a in fig.axes if a.get_subplotspec().is_last_row()}
    left = {a.get_ylabel() for a in fig.axes if a.get_subplotspec().is_first_col()}
    assert bottom == {"x (m)"} and left == {"z (m)"}
    assert inside_figure(fig, fig._suptitle)


def test_a_saved_figure_is_drawn_once_and_keeps_its_tight_layout(energy_curves, tmp_path):
    """mpd_pin.viz.layout.tight: the layout of tight_layout, and no second draw in savefig
    (a layout engine left on the figure costs one more draw, 30 ms a figure)."""
    from matplotlib.figure import Figure
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    t, E, names, compare = energy_curves
    fig = plot_cumulative_energy(t, E, names, compare=compare)
    params = vars(fig.subplotpars).copy()
    draws = []
    original = Figure.draw

    def counted(self, renderer):
        draws.append(self)
        return original(self, renderer)

    Figure.draw = counted
    try:
        fig.savefig(tmp_path / "once.png", dpi=60)
        assert len(draws) == 1
        # with the placeholder engine matplotlib's tight_layout leaves behind: two draws,
        # the same pixels
        fig.set_layout_engine(PlaceHolderLayoutEngine(True, True))
        fig.savefig(tmp_path / "twice.png", dpi=60)
        assert len(draws) == 3
    finally:
        Figure.draw = original
    from PIL import Image

    once = np.asarray(Image.open(tmp_path / "once.png"))
    twice = np.asarray(Image.open(tmp_path / "twice.png"))
    assert once.shape == twice.shape and (once == twice).all()
    # tight_layout moved the axes off matplotlib's default subplot parameters
    default = Figure().subplotpars
    assert params["left"] != default.left and params["bottom"] != default.bottom
    plt.close(fig)
