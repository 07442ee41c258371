"""Benchmark: a servo-streamed 10 s scan in force mode on the default phantom.

Streams one servo_linear target per 2 ms control period, sweeping 80 mm along the phantom's y
while force mode holds 5 N along the probe axis, and reports simulated seconds per wall second
(best of several runs; the machine is shared, so single timings are noisy) and the force seen.
The last line printed is one JSON object with the figures.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from tqdm import tqdm

from sim.robot import CONTROL_PERIOD, SimulatedUR3e, load_scene_config

FORCE = 5.0
SWEEP = 0.08


def scan_once(robot: SimulatedUR3e, duration: float) -> tuple[float, np.ndarray]:
    """Run one streamed sweep; returns wall seconds and the probe-axis force per period.

    The targets are computed before the clock starts: the figure is the robot's own cost.
    """
    start_y = -0.5 * SWEEP
    periods = round(duration / CONTROL_PERIOD)
    targets = [
        robot.probe_pose_on_skin(0.0, start_y + SWEEP * (i + 1) / periods) for i in range(periods)
    ]
    robot.reset()
    robot.move_linear(robot.probe_pose_on_skin(0.0, start_y, 0.003))
    robot.zero_ft_sensor()
    robot.force_mode(robot.tcp_pose(), [0, 0, 1, 0, 0, 0], [0, 0, FORCE, 0, 0, 0])
    robot.step(1000)
    forces = np.empty(periods)
    began = time.perf_counter()
    for i, target in enumerate(targets):
        robot.servo_linear(target)
        robot.step()
        forces[i] = robot.tcp_wrench()[:3] @ robot.tcp_pose()[:3, 2]
    return time.perf_counter() - began, forces


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--duration", type=float, default=10.0, help="simulated scan time (s)")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    robot = SimulatedUR3e(load_scene_config())
    scan_once(robot, 0.1)  # compile the numba kernels outside the timing
    walls = []
    for _ in tqdm(range(args.repeats), desc="scans"):
        wall, forces = scan_once(robot, args.duration)
        walls.append(wall)
    figures = {
        "simulated_s": args.duration,
        "wall_s_best": round(min(walls), 3),
        "sim_s_per_wall_s_best": round(args.duration / min(walls), 2),
        "sim_s_per_wall_s_all": [round(args.duration / w, 2) for w in walls],
        "force_target_n": FORCE,
        "force_mean_n": round(float(forces.mean()), 3),
        "force_min_n": round(float(forces.min()), 3),
        "force_max_n": round(float(forces.max()), 3),
        "protective_stop": robot.is_protective_stopped(),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
