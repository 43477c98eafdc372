"""`inclino emulate`: the emulated probe on a pseudo-terminal with a control
channel, running until interrupted.

    emu = Emulator(scenario="typical", baud=115200, link="/tmp/probe", control_port=5555)
    emu.start()          # background thread; emu.path is the serial port
    ...
    emu.stop()

Time: with `realtime=True` (the default) emulated time follows the wall
clock, so the SCI runs at its baud rate as a real probe's would; with
`realtime=False` the emulator runs as fast as it can (emulated time still
advances by the firmware's own waits and the byte times).
"""
from __future__ import annotations

import math
import threading
import time
from dataclasses import asdict

from .control import ControlServer
from .probe import EmulatedProbe
from .serial_pty import PtyLink

MAX_STEP_S = 0.02
MAX_ADVANCE_S = 86400.0   # one `advance` request: at most a day of emulated time
ADVANCE_QUANTUM_S = 0.01  # the firmware's idle loop runs every 10 ms of a fast-forward,
ADVANCE_MAX_POLLS = 20000  # or every s / 20000 for a long one (bounded wall time)


def _number(r: dict, key: str) -> float:
    """A finite number argument (not a bool, not NaN or infinite)."""
    v = r[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"{key} must be a number")
    v = float(v)
    if not math.isfinite(v):
        raise ValueError(f"{key} must be finite")
    return v


class _Device:
    def __init__(self, probe: EmulatedProbe):
        self.probe = probe

    def sci_write(self, data: bytes) -> None:
        self.probe.sci_push(data)

    def sci_read(self) -> bytes:
        return self.probe.sci_pull()


class Emulator:
    def __init__(self, scenario="typical", seed: int | None = None, baud: int = 115200,
                 link: str | None = None, control_port: int | None = 0, realtime: bool = True,
                 serial: int | None = None, tempco_draw: int | None = None):
        if tempco_draw is not None:  # one probe of the scenario's tempco spread
            from .scenario import Scenario, load_scenario
            sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
            scenario = sc.draw_tempcos(tempco_draw)
        self.probe = EmulatedProbe(scenario, seed=seed, baud=float(baud), serial=serial)
        self.probe.poll = self.probe.lib.app_main_poll
        self.pty = PtyLink(baud=baud, link_path=link, throttle=False)  # the probe's SCI times the bytes
        self.path = self.pty.path
        self.realtime = realtime
        self.control = None
        if control_port is not None:
            self.control = ControlServer(self._handlers(), control_port)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        self._device = _Device(self.probe)
        self._lock = threading.Lock()

    @property
    def control_port(self) -> int | None:
        return self.control.port if self.control else None

    # ------------------------------------------------------------ control
    def _handlers(self):
        p = self.probe

        def move(r):
            p.move_to(float(r["inc"]), float(r["azi"]), float(r["tf"]))

        def temperature(r):
            t = r.get("temp_c")
            p.set_temperature(None if t is None else float(t))

        def truth(r):
            g, b = p.truth()
            pose = p.phys.trajectory(p.clock.now)  # the turntable's indicated pose
            return {"t": p.clock.now, "g": [float(x) for x in g], "b": [float(x) for x in b],
                    "pose": [float(x) for x in pose], "temp_c": float(p.phys.temperature(p.clock.now))}

        def chamber(r):
            """Set (setpoint_c, rate_c_per_min) or just report the thermal chamber."""
            if "rate_c_per_min" in r and "setpoint_c" not in r:
                raise ValueError("rate_c_per_min needs a setpoint_c")
            sp = _number(r, "setpoint_c") if "setpoint_c" in r else None
            rate = _number(r, "rate_c_per_min") if r.get("rate_c_per_min") is not None else None
            ch = p.phys.chamber(p.clock.now)
            if sp is not None:
                ch.set(p.clock.now, sp, rate)
                p.phys.invalidate()
            return {"t": p.clock.now, **ch.state(p.clock.now)}

        def advance(r):
            """Fast-forward emulated time by s seconds (the firmware idles through it)."""
            s = _number(r, "s")
            if not 0.0 < s <= MAX_ADVANCE_S:
                raise ValueError(f"s must be within (0, {MAX_ADVANCE_S:g}] seconds")
            p.step(s, quantum=max(ADVANCE_QUANTUM_S, s / ADVANCE_MAX_POLLS))
            return {"t": p.clock.now, "temp_c": float(p.phys.temperature(p.clock.now))}

        def faults(r):
            f = self.pty.faults
            for k in ("bit_error_rate", "drop_rate", "dup_rate"):
                if k in r:
                    v = float(r[k])
                    if not 0.0 <= v <= 1.0:
                        raise ValueError(f"{k} must be within [0, 1]")
                    setattr(f, k, v)
            if "disconnected" in r:
                f.disconnected = bool(r["disconnected"])
            if "seed" in r:
                import random
                f._rng = random.Random(int(r["seed"]))
            return {"faults": {k: getattr(f, k) for k in ("bit_error_rate", "drop_rate", "dup_rate",
                                                           "disconnected")}, "counts": dict(f.counts)}

        def power_cut(r):
            n = int(r["n"])
            if n < 1:
                raise ValueError("n counts flash operations from 1")
            p.cut_power_at(n, str(r.get("mode", "random")))

        def power_cycle(r):
            return {"boot_status": p.power_cycle()}

        def status(r):
            return {"t": p.clock.now, "power_cuts": p.power_cuts, "restarts": p.restarts,
                    "boot_status": p.boot_status, "bytes_to_host": self.pty.bytes_to_host,
                    "bytes_to_probe": self.pty.bytes_to_probe, "tx_dropped": int(p.lib.app_main_tx_dropped()),
                    "flash_ops": getattr(p.flash, "ops", None)}

        return {"move": move, "temperature": temperature, "truth": truth, "faults": faults,
                "power_cut": power_cut, "power_cycle": power_cycle, "status": status,
                "chamber": chamber, "advance": advance}

    # ------------------------------------------------------------ loop
    def run_once(self, dt: float) -> None:
        """Advance the emulator by dt seconds of emulated time."""
        with self._lock:
            self.pty.pump(self._device, 0.0)
            self.probe.step(dt)
            self.pty.pump(self._device, 0.0)

    def run(self) -> None:
        """Run until stop() (or KeyboardInterrupt in the caller's thread)."""
        try:
            t_wall = time.monotonic()
            while not self._stop.is_set():
                if self.control:
                    with self._lock:
                        self.control.poll(0.0)
                if self.realtime:
                    now = time.monotonic()
                    dt = min(now - t_wall, MAX_STEP_S)
                    t_wall = now
                    if dt <= 0.0005:
                        time.sleep(0.0005)
                        continue
                else:
                    dt = 0.005
                self.run_once(dt)
        except BaseException as e:  # reported by stop()
            self.error = e

    def start(self) -> "Emulator":
        self._thread = threading.Thread(target=self.run, name="inclino-emulator", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=5)
        if self.control:
            self.control.close()
        self.pty.close()
        if self.error is not None:
            raise RuntimeError(f"the emulator stopped on an error: {self.error!r}") from self.error

    def __enter__(self):
        return self.start()

    def __exit__(self, *exc):
        self.stop()
