"""The simulator: phantoms, synthetic ultrasound, the MuJoCo UR3e and the RTDE emulator.

`sim` knows nothing of `resus`: the pipeline imports the simulator, never the other way round.
"""
