"""Two-link arm among obstacles moving on known trajectories (paper 002, docs/design.md §6).

Pipeline (:func:`plan_dynamic`): analytic IK with elbow-up/down branches
(:mod:`.ik`, eqs. 3–6) → free-Cartesian-space maps of a workspace grid at
every motion sample (:mod:`.fcs`, Coal via the package's world) → D* on the
8-connected grid of end-effector cells, executed sample by sample with the
paper's *stop* and *return backward* cases (:mod:`.grid_dstar`,
:mod:`.planner`) → PSO over via points of the D* motion joined by a cubic
spline (:mod:`.pso`). Scenario files of ``kind = "dynamic2link"``
(:mod:`.scenario`) run end to end with :func:`run_dynamic_scenario`.

Units: m, rad, s. Motion samples are ``Ts`` apart (0.01 s in the paper).
"""

from .fcs import FCSMap, FreeCartesianSpace, Grid
from .grid_dstar import GridDStar, build_state_graph
from .ik import (
    BRANCHES,
    IKSolution,
    TwoLinkKinematics,
    forward_kinematics,
    inverse_kinematics,
    link_lengths,
)
from .moving import (
    MovingObstacle,
    MovingScene,
    PolylineTrajectory,
    SampledCollisionChecker,
    back_and_forth,
    square,
    static,
    straight,
)
from .planner import (
    DStarMotion,
    DynamicPlanResult,
    DynamicProblem,
    TrappedError,
    execute_dstar,
    plan_dynamic,
)
from .pso import PSOOptions, PSOResult, SmoothedMotion, ViaPointSmoother, path_length, pso_minimize
from .run import run_dynamic_scenario
from .scenario import DynamicScenario, parse_dynamic_scenario

__all__ = [
    "BRANCHES",
    "DStarMotion",
    "DynamicPlanResult",
    "DynamicProblem",
    "DynamicScenario",
    "FCSMap",
    "FreeCartesianSpace",
    "Grid",
    "GridDStar",
    "IKSolution",
    "MovingObstacle",
    "MovingScene",
    "PSOOptions",
    "PSOResult",
    "PolylineTrajectory",
    "SampledCollisionChecker",
    "SmoothedMotion",
    "TrappedError",
    "TwoLinkKinematics",
    "ViaPointSmoother",
    "back_and_forth",
    "build_state_graph",
    "execute_dstar",
    "forward_kinematics",
    "inverse_kinematics",
    "link_lengths",
    "parse_dynamic_scenario",
    "path_length",
    "plan_dynamic",
    "pso_minimize",
    "run_dynamic_scenario",
    "square",
    "static",
    "straight",
]
