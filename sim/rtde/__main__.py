"""`python -m sim.rtde`: run the RTDE emulator until interrupted (see `sim.rtde.app`)."""

from sim.rtde.app import main

if __name__ == "__main__":
    main()
