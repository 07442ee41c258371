"""Benchmark: stream servoL at 500 Hz through RTDERobot (ur_rtde) to the RTDE emulator.

Reports how evenly the client loop keeps its 2 ms period (late = a cycle longer than
2 ms + `--late-margin`), how far the robot's clock advanced against the wall clock, and how
closely the reported TCP followed the streamed path. Last line: one JSON object.

    python scripts/bench_rtde.py --seconds 60          # the full minute
    python scripts/bench_rtde.py --seconds 5 --arm mujoco
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from tqdm import tqdm

from resus.acquisition.backends.rtde import RTDERobot, RTDERobotConfig
from sim.rtde.launch import launch


def run(seconds: float, arm: str, late_margin: float) -> dict[str, float]:
    with launch(arm=arm) as emulator, RTDERobot(RTDERobotConfig(emulator.host)) as robot:
        start = robot.tcp_pose()
        period = robot.control_period
        cycles = round(seconds / period)
        starts = np.empty(cycles + 1)
        errors = np.empty(cycles)
        robot_began, wall_began = robot.time(), time.perf_counter()
        for i in tqdm(range(cycles), desc="servoL 500 Hz", unit="cycle", mininterval=1.0):
            starts[i] = time.perf_counter()
            target = start.copy()
            target[0, 3] += 0.02 * np.sin(2 * np.pi * 0.25 * i * period)  # 20 mm, 0.25 Hz
            robot.servo_linear(target)
            errors[i] = np.linalg.norm(robot.tcp_pose()[:3, 3] - target[:3, 3])
            robot.wait_period()
        starts[cycles] = time.perf_counter()
        robot_elapsed, wall_elapsed = robot.time() - robot_began, starts[cycles] - wall_began
        robot.stop()
        emulator_late = emulator.log().count("behind")
    durations = np.diff(starts)
    late = durations > period + late_margin
    return {
        "arm": arm,
        "seconds": seconds,
        "cycles": cycles,
        "late_cycles": int(late.sum()),
        "late_fraction": float(late.mean()),
        "mean_cycle_ms": float(durations.mean() * 1e3),
        "p99_cycle_ms": float(np.percentile(durations, 99) * 1e3),
        "max_cycle_ms": float(durations.max() * 1e3),
        "robot_clock_over_wall": float(robot_elapsed / wall_elapsed),
        "tracking_error_median_mm": float(np.median(errors) * 1e3),
        "tracking_error_max_mm": float(errors.max() * 1e3),
        "emulator_lag_events": emulator_late,
    }


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawTextHelpFormatter
    )
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--arm", choices=("kinematic", "mujoco"), default="kinematic")
    parser.add_argument("--late-margin", type=float, default=0.002, help="seconds (default 2 ms)")
    args = parser.parse_args()
    print(json.dumps(run(args.seconds, args.arm, args.late_margin)))


if __name__ == "__main__":
    main()
