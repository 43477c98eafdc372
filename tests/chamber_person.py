"""A person at the emulated chamber and turntable, for the guided
procedures' tests (acquire --procedure temperature, accept --temperatures):
answers each prompt through the emulator's control channel."""
import re


class PersonAtChamber:
    """An operator: sets each announced pose on the (emulated) table and each
    announced set point on the (emulated) chamber; real-time waits become
    `advance` requests."""

    def __init__(self, ctl):
        self.ctl, self.said, self.poses, self.setpoints = ctl, [], [], []

    def say(self, m):
        self.said.append(m)

    def readline(self):
        m = self.said[-1]
        p = re.search(r"set inclination ([-0-9.]+) deg, azimuth ([-0-9.]+) deg, toolface ([-0-9.]+) deg", m)
        c = re.search(r"set the chamber to ([-0-9.]+) degC \(ramp ([0-9.]+) degC/min\)", m)
        if p:
            pose = [float(x) for x in p.groups()]
            self.ctl.call("move", inc=pose[0], azi=pose[1], tf=pose[2])
            self.poses.append(pose)
        elif c:
            self.ctl.call("chamber", setpoint_c=float(c.group(1)), rate_c_per_min=float(c.group(2)))
            self.setpoints.append(float(c.group(1)))
        else:
            raise AssertionError(f"unexpected prompt {m!r}")
        return "\n"

    def sleep(self, s):
        self.ctl.call("advance", s=s)
