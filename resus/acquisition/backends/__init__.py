"""The hardware behind the acquisition interface: the in-process MuJoCo UR3e and synthetic
probe (`simulated`, `render_process`), a UR3e through ur_rtde (`rtde`), and a scanner's video
through a frame grabber (`video`).
"""

from resus import lazy_exports

_EXPORTS = {
    "SimulatedRobot": "resus.acquisition.backends.simulated",
    "SimulatedProbe": "resus.acquisition.backends.simulated",
    "SimulatedProbeConfig": "resus.acquisition.backends.simulated",
    "RenderProcessProbe": "resus.acquisition.backends.render_process",
    "RTDERobot": "resus.acquisition.backends.rtde",
    "RTDERobotConfig": "resus.acquisition.backends.rtde",
    "VideoProbe": "resus.acquisition.backends.video",
    "VideoProbeConfig": "resus.acquisition.backends.video",
}
__all__ = sorted(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
