"""Render the default scan scene (robot pressing the probe on the phantom) to docs/scene.png.

Run with an offscreen OpenGL backend, e.g. `MUJOCO_GL=egl python scripts/render_scene.py`.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib.pyplot as plt
import mujoco
import numpy as np

from sim.robot import SimulatedUR3e, load_scene_config

FORCE = 5.0


def render(scene_path: str | None, output: Path, width: int, height: int) -> None:
    """Settle the probe on the phantom at 5 N in force mode and save one rendered frame."""
    robot = SimulatedUR3e(load_scene_config(scene_path))
    robot.move_linear(robot.probe_pose_on_skin(0.0, 0.0, 0.005))
    robot.zero_ft_sensor()
    robot.force_mode(robot.tcp_pose(), [0, 0, 1, 0, 0, 0], [0, 0, FORCE, 0, 0, 0])
    robot.step(1000)
    camera = mujoco.MjvCamera()
    camera.lookat[:] = 0.5 * robot.phantom_to_base[:3, 3] + np.array([-0.02, 0.0, 0.12])
    camera.distance, camera.azimuth, camera.elevation = 0.95, 125.0, -22.0
    with mujoco.Renderer(robot.model, height, width) as renderer:
        renderer.update_scene(robot.data, camera)
        image = renderer.render()
    output.parent.mkdir(parents=True, exist_ok=True)
    plt.imsave(output, image)
    force = -robot.tcp_wrench()[2]
    print(f"wrote {output} ({width} x {height}); probe force {force:.2f} N")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scene", default=None, help="scene YAML (default: the default scene)")
    parser.add_argument("--output", type=Path, default=Path("docs/scene.png"))
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=720)
    args = parser.parse_args()
    render(args.scene, args.output, args.width, args.height)


if __name__ == "__main__":
    main()
