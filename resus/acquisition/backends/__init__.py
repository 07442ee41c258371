"""The hardware behind the acquisition interface: the in-process MuJoCo UR3e and synthetic
probe (`simulated`, `render_process`), a UR3e through ur_rtde (`rtde`), a scanner's video
through a frame grabber (`video`), and IMAGE frames from an OpenIGTLink server such as PLUS
(`igtl`).
"""

from resus import lazy_exports

__getattr__, __dir__, __all__ = lazy_exports(
    __name__,
    """
igtl: IgtlProbe IgtlProbeConfig ProbeLinkLost TrackedFrame
render_process: RenderProcessProbe
rtde: RTDERobot RTDERobotConfig
simulated: SimulatedProbe SimulatedProbeConfig SimulatedRobot
video: VideoProbe VideoProbeConfig
""",
)
