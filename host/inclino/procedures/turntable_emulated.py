"""The emulator's turntable over its control channel (`--bench HOST:PORT`):
the unattended implementation of the turntable interface (turntable.py)."""
from __future__ import annotations

import math

from inclino.errors import DataError
from inclino.procedures.poses import Step, wrap_deg
from inclino.procedures.turntable import TurntableError


class EmulatedTurntable:
    """The emulator's turntable over its control channel (HOST:PORT)."""

    unattended = True

    def __init__(self, spec: str, timeout: float = 10.0):
        host, sep, port = str(spec).rpartition(":")
        if not sep or not port.isdigit():
            raise DataError(f"--bench wants HOST:PORT, got {spec!r}")
        self.spec, self.timeout = spec, timeout
        try:
            from inclino_emu.control import ControlClient
        except ImportError as e:
            raise TurntableError(f"the emulator package is not installed: {e}")
        try:
            self.ctl = ControlClient(host or "127.0.0.1", int(port), timeout=timeout)
        except OSError as e:
            raise TurntableError(f"cannot reach the bench's control channel at {spec}: {e.strerror or e}") from None

    def call(self, cmd: str, **kw) -> dict:
        try:
            ans = self.ctl.call(cmd, **kw)
        except ConnectionError:
            # the channel closes connections idle for long (docs/emulator.md): the request was never
            # read, so it is sent again once on a new connection
            try:
                self.ctl.close()
                host, _, port = self.spec.rpartition(":")
                from inclino_emu.control import ControlClient

                self.ctl = ControlClient(host or "127.0.0.1", int(port), timeout=self.timeout)
                ans = self.ctl.call(cmd, **kw)
            except (OSError, ConnectionError, ValueError) as e:
                raise TurntableError(f"the bench's control channel at {self.spec} failed: {e}") from None
        except (OSError, ValueError) as e:
            raise TurntableError(f"the bench's control channel at {self.spec} failed: {e}") from None
        if not ans.get("ok"):
            raise TurntableError(f"the bench refused {cmd}: {ans.get('error', ans)}")
        return ans

    def move(self, step: Step, index: int, total: int) -> None:
        self.call("move", inc=step.inc, azi=wrap_deg(step.azi), tf=wrap_deg(step.tf))

    def world(self) -> dict:
        """Field total, dip and declination from the bench's truth (the true
        body vectors at the indicated pose)."""
        import numpy as np

        from inclino.engines import reference as ref

        t = self.call("truth")
        g, b, pose = (np.asarray(t[k], float) for k in ("g", "b", "pose"))
        F = float(np.linalg.norm(b))
        dip = math.degrees(math.atan2(float(g @ b), float(np.linalg.norm(np.cross(g, b)))))
        ned = ref.pose_matrix(*pose).T @ b
        dec = math.degrees(math.atan2(ned[1], ned[0]))
        return {"field_nT": round(F, 3), "dip_deg": round(dip, 6), "declination_deg": round(dec, 6)}

    def close(self) -> None:
        self.ctl.close()
