"""An RTDE emulator: UR's dashboard, RTDE and script protocols served from the simulated UR3e.

The unmodified ur_rtde 1.6.5 client (`rtde_control`, `rtde_receive`, `dashboard_client`)
drives it as it would a real e-Series controller. It is not a URScript interpreter: it
recognises ur_rtde's uploaded `rtde_control` program and runs its register protocol natively.

    protocol    RTDE packets, field types, the output/input variable table
    commands    ur_rtde's command ids and which of them are implemented
    motion      setpoint generators for moves, speeds, stops and servoing
    arm         the arm interface and the pure-kinematic arm; mujoco_arm: the MuJoCo one
    controller  robot, safety and program state; the register protocol
    dashboard   the dashboard server's replies
    faults      injected faults (dropped link, protective stop, latency, jitter)
    server      sockets and the 500 Hz control loop;  app: the process;  launch: for tests
"""
