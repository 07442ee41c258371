"""Scan planning: check a trajectory on the UR3e in a scene before it touches anyone.

`planner.check_plan` runs every check and returns a `PlanAnalysis`; each check says PASS or
FAIL, where on the path it fails (time, arc length, waypoint) and what to change.

- `checks`: the result types (`Place`, `CheckResult`).
- `sampling`: the path and the frames sampled in time.
- `joint_path`: inverse kinematics along the path with one continuous solution.
- `robot_checks`: reach, joint limits, IK branch flips, joint speeds, torques, singularities,
  collisions.
- `imaging_checks`: safety limits, frame spacing, stationary or back-tracking stretches.
- `force`: the contact force a simulated scan of the plan reads (the emulator's servo and force
  controller, a stream that stalls), and its check.
- `coverage`: target vessels in the field of view.
- `holes`: the expected hole fraction of the reconstruction grid.
- `report`: Markdown and PNG report.
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
checks: CheckResult
planner: PlanAnalysis PlanSettings check_plan
report: write_report
""",
)
