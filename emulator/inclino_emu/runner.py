"""`inclino emulate`: the emulated probe on a pseudo-terminal with a control
channel, running until interrupted.

    emu = Emulator(scenario="typical", baud=115200, link="/tmp/probe", control_port=5555)
    emu.start()          # background thread; emu.path is the serial port
    ...
    emu.stop()

Time: with `realtime=True` (the default) emulated time follows the wall
clock, so the SCI runs at its baud rate as a real probe's would; with
`realtime=False` the emulator runs as fast as it can (emulated time still
advances by the firmware's own waits and the byte times), and while nothing
comes from the host it waits for it (IDLE_WAIT_S per 5 ms step) rather than
spinning.

The control channel's `advance` fast-forwards emulated time in either mode:
a slice of at most ADVANCE_SLICE_S of wall time per turn of the loop, the
serial side served between slices; in real time the pacing then goes on
from the new emulated time (the jump is not waited for).
"""
from __future__ import annotations

import select
import threading
import time
from dataclasses import asdict

from .control import IDLE_TIMEOUT_S, ArgError, ControlServer, Pending, boolean, choice, integer, known, number
from .probe import EmulatedProbe
from .serial_pty import PtyLink
from inclino.model.world import CHAMBER_MAX_RATE_C_PER_MIN, CHAMBER_RANGE_C

MAX_STEP_S = 0.02
MAX_ADVANCE_S = 86400.0   # one `advance` request: at most a day of emulated time
ADVANCE_QUANTUM_S = 0.01  # the firmware's idle loop runs every 10 ms of a fast-forward,
ADVANCE_MAX_POLLS = 20000  # or every s / 20000 for a long one (bounded wall time)
ADVANCE_SLICE_S = 0.02     # wall time an `advance` runs before the loop serves the serial side again
# unthrottled: after IDLE_STEPS steps with nothing on the line or the control
# channel, the loop waits for the host (at most IDLE_WAIT_S per step) instead of
# spinning: idle emulated time then runs at 5 ms per ms at least, and an idle
# emulator no longer takes a core (and the GIL) from the host it serves
IDLE_STEPS = 4
IDLE_WAIT_S = 0.001
# baud rates the S12X's SCI makes at a 40 MHz bus (SBR = 40 MHz / (16 baud), 1..8191)
BAUD_RANGE = (300, 2_500_000)
# temperatures the control channel accepts: the ADIS16210's rated range with margin
TEMP_RANGE_C = (-55.0, 125.0)


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
                 serial: int | None = None, tempco_draw: int | None = None, hold_idle: bool = False,
                 control_idle_s: float = IDLE_TIMEOUT_S):
        if isinstance(baud, bool) or not isinstance(baud, int) or not BAUD_RANGE[0] <= baud <= BAUD_RANGE[1]:
            raise ValueError(f"baud rate {baud} is not within {BAUD_RANGE[0]}-{BAUD_RANGE[1]}")
        if control_port is not None and (isinstance(control_port, bool) or not isinstance(control_port, int)
                                         or not 0 <= control_port <= 65535):
            raise ValueError(f"control port {control_port} is not within 0-65535")
        if tempco_draw is not None:  # one probe of the scenario's tempco spread
            from inclino.model.scenario import Scenario, load_scenario
            sc = scenario if isinstance(scenario, Scenario) else load_scenario(scenario)
            scenario = sc.draw_tempcos(tempco_draw)
        self.probe = EmulatedProbe(scenario, seed=seed, baud=float(baud), serial=serial)
        self.probe.poll = self.probe.lib.app_main_poll
        self.pty = PtyLink(baud=baud, link_path=link, throttle=False)  # the probe's SCI times the bytes
        self.path = self.pty.path
        self.realtime = realtime
        self.control = None
        if control_port is not None:
            self.control = ControlServer(self._handlers(), control_port, idle_timeout=control_idle_s)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None
        self._device = _Device(self.probe)
        self._lock = threading.Lock()
        self.pacing = {"max_ahead_s": 0.0}   # real time: how far a single step ran ahead of the wall clock
        self.idle_s = 0.0   # unthrottled: emulated seconds spent waiting for the host (active_s)
        self.hold_idle = bool(hold_idle)  # unthrottled: stop the clock while idle (run())
        self._was_idle = False
        self._last_idle = False
        self._jumped = 0.0   # emulated seconds `advance` moved the clock since the loop last looked

    @property
    def control_port(self) -> int | None:
        return self.control.port if self.control else None

    # ------------------------------------------------------------ control
    def _handlers(self):
        p = self.probe

        def move(r):
            """Turn the table to a pose; the emulated clock runs through the
            move (world.TurntableMotion: the axes' rate and settling)."""
            known(r, "inc", "azi", "tf")
            to = (number(r, "inc", 0.0, 180.0, " deg"), number(r, "azi", 0.0, 360.0, " deg"),
                  number(r, "tf", 0.0, 360.0, " deg"))
            frm = tuple(float(x) for x in p.phys.trajectory(p.clock.now))
            d = float(p.phys.scenario.world.turntable.motion.duration(frm, to))
            p.move_to(*to)
            if d > 0.0:
                self._run_for(d)
            return {"t": p.clock.now, "move_s": d}

        def temperature(r):
            known(r, "temp_c")
            t = None if r.get("temp_c") is None else number(r, "temp_c", *TEMP_RANGE_C, " degC")
            p.set_temperature(t)

        def truth(r):
            known(r)
            g, b = p.truth()
            pose = p.phys.trajectory(p.clock.now)  # the turntable's indicated pose
            return {"t": p.clock.now, "g": [float(x) for x in g], "b": [float(x) for x in b],
                    "pose": [float(x) for x in pose], "temp_c": float(p.phys.temperature(p.clock.now))}

        def chamber(r):
            """Set (setpoint_c, rate_c_per_min) or just report the thermal chamber."""
            known(r, "setpoint_c", "rate_c_per_min")
            if "rate_c_per_min" in r and "setpoint_c" not in r:
                raise ArgError("rate_c_per_min needs a setpoint_c")
            sp = number(r, "setpoint_c", *CHAMBER_RANGE_C, " degC") if "setpoint_c" in r else None
            rate = (number(r, "rate_c_per_min", 0.0, CHAMBER_MAX_RATE_C_PER_MIN, " degC/min")
                    if r.get("rate_c_per_min") is not None else None)
            ch = p.phys.chamber(p.clock.now)
            if sp is not None:
                ch.set(p.clock.now, sp, rate)
                p.phys.invalidate()
            return {"t": p.clock.now, **ch.state(p.clock.now)}

        def advance(r):
            """Fast-forward emulated time by s seconds (the firmware idles
            through it), a slice of wall time per turn of the loop: the
            serial side is served between slices; answered when done."""
            known(r, "s")
            s = number(r, "s", 0.0, MAX_ADVANCE_S, " s")
            if s <= 0.0:
                raise ArgError(f"s must be within (0, {MAX_ADVANCE_S:g}] seconds")
            t_end = p.clock.now + s
            quantum = max(ADVANCE_QUANTUM_S, s / ADVANCE_MAX_POLLS)

            def step():
                w0 = time.monotonic()
                while p.clock.now < t_end and time.monotonic() - w0 < ADVANCE_SLICE_S:
                    before = p.clock.now
                    p.step(min(t_end - p.clock.now, 50 * quantum), quantum=quantum)
                    self._jumped += p.clock.now - before
                if p.clock.now < t_end:
                    return None
                return {"t": p.clock.now, "temp_c": float(p.phys.temperature(p.clock.now))}
            return Pending(step)

        def faults(r):
            known(r, "bit_error_rate", "drop_rate", "dup_rate", "disconnected", "seed")
            f = self.pty.faults
            new = {k: number(r, k, 0.0, 1.0) for k in ("bit_error_rate", "drop_rate", "dup_rate") if k in r}
            disc = boolean(r, "disconnected") if "disconnected" in r else None
            seed = integer(r, "seed", 0, 2**63 - 1) if "seed" in r else None
            for k, v in new.items():     # every argument checked before anything changes
                setattr(f, k, v)
            if disc is not None:
                f.disconnected = disc
            if seed is not None:
                import random
                f._rng = random.Random(seed)
            return {"faults": {k: getattr(f, k) for k in ("bit_error_rate", "drop_rate", "dup_rate",
                                                           "disconnected")}, "counts": dict(f.counts)}

        def power_cut(r):
            known(r, "n", "mode")
            if "n" in r and isinstance(r["n"], int) and not isinstance(r["n"], bool) and r["n"] < 1:
                raise ArgError("n counts flash operations from 1")
            n = integer(r, "n", 1, 1_000_000)
            p.cut_power_at(n, choice(r, "mode", ("random", "none", "full"), "random"))

        def power_cycle(r):
            known(r)
            return {"boot_status": p.power_cycle()}

        def status(r):
            known(r)
            return {"t": p.clock.now, "active_s": self.active_s, "power_cuts": p.power_cuts, "restarts": p.restarts,
                    "boot_status": p.boot_status, "bytes_to_host": self.pty.bytes_to_host,
                    "bytes_to_probe": self.pty.bytes_to_probe, "tx_dropped": int(p.lib.app_main_tx_dropped()),
                    "flash_ops": getattr(p.flash, "ops", None),
                    "control": {"clients": self.control.clients, **self.control.stats}}

        return {"move": move, "temperature": temperature, "truth": truth, "faults": faults,
                "power_cut": power_cut, "power_cycle": power_cycle, "status": status,
                "chamber": chamber, "advance": advance}

    def _run_for(self, s: float) -> None:
        """Run s seconds of emulated time in one go (the firmware idles
        through it): a chamber wait, a turntable move."""
        self.probe.step(s, quantum=max(ADVANCE_QUANTUM_S, s / ADVANCE_MAX_POLLS))

    @property
    def active_s(self) -> float:
        """The emulated time the probe and the bench were doing something:
        the clock less the time the unthrottled emulator ran while nothing
        was on the line and the firmware was idle, waiting for the host.
        Unthrottled, that idle time depends only on how fast the host
        computes, so active_s is the bench time of a run (turntable moves,
        chamber waits, the probe's readings, the bytes on the line);
        in real time it is the clock."""
        return self.probe.clock.now - self.idle_s

    # ------------------------------------------------------------ loop
    def run_once(self, dt: float, release: bool = True) -> bool:
        """Advance the emulator by dt seconds of emulated time.  release:
        pass what the probe sent to the host right away (else at the next
        call, once the wall clock has caught up: real-time mode).  Returns
        whether any byte moved between the host and the probe.  An
        unthrottled step in which no byte moved either way, the probe's SCI
        held nothing and the firmware made no long call counts as idle
        (active_s; self._last_idle)."""
        with self._lock:
            pty, sci, clk = self.pty, self.probe.sci, self.probe.clock
            n0 = (pty.bytes_to_probe, pty.bytes_to_host)
            quiet = not (sci.rx or sci.tx or sci.out or pty._to_host)
            t0 = clk.now
            pty.pump(self._device, 0.0)
            self.probe.step(dt)
            if release:
                pty.pump(self._device, 0.0)
            moved = (pty.bytes_to_probe, pty.bytes_to_host) != n0
            idle = (not self.realtime and quiet and not moved and not (sci.rx or sci.tx or sci.out)
                    and clk.now - t0 <= dt + 1e-12)
            if idle:
                self.idle_s += clk.now - t0
            self._last_idle = idle
            return moved

    def _wait_for_host(self, timeout: float) -> bool:
        """Block until the host writes to the line or the control channel, at
        most timeout; whether something came."""
        fds = [self.pty.master] + (self.control.fileobjs() if self.control else [])
        try:
            r, _, _ = select.select(fds, [], [], timeout)
        except (OSError, ValueError):  # a descriptor closed under us (stop()): the loop ends
            time.sleep(timeout)
            return True
        return bool(r)

    def run(self) -> None:
        """Run until stop() (or KeyboardInterrupt in the caller's thread).

        Real time: emulated time is paced to the wall clock, also while the
        firmware is inside a long call (a survey, a flash command) that
        advanced the clock in one go: the loop then waits, and the bytes the
        probe sent in that call reach the host only when the wall clock has
        reached the emulated instant.  An emulator that falls behind by more
        than MAX_STEP_S does not catch up (the lag is dropped).

        Unthrottled with hold_idle: after a step in which nothing happened
        (run_once's idle test: no byte either way, the firmware idle) the
        clock stops until the host sends a byte or a control request runs,
        so emulated time is the bench's time (turntable moves, chamber
        waits, readings, bytes) and not how long the host took to think;
        the chamber does not drift while the host computes.  Not for a
        probe that should act on its own while the host is silent (a
        stream's frames, the protocol's idle timeout)."""
        try:
            clk = self.probe.clock
            t_wall0, t_emu0 = time.monotonic(), clk.now
            idle = 0
            while not self._stop.is_set():
                asked = False
                if self.control:
                    with self._lock:
                        n0 = self.control.stats["requests"] + self.control.stats["accepted"]
                        self.control.poll(0.0)
                        asked = self.control.stats["requests"] + self.control.stats["accepted"] != n0
                        if self._jumped:  # an advance's slice ran: what the probe said meanwhile goes out
                            self.pty.pump(self._device, 0.0)
                    if self._jumped:   # an advance moved the clock: pacing goes on from there
                        t_emu0 += self._jumped
                        self._jumped = 0.0
                        asked = True
                if self.realtime:
                    target = t_emu0 + (time.monotonic() - t_wall0)
                    ahead = clk.now - target
                    if ahead > -0.0005:   # emulated time is at or ahead of the wall clock: wait
                        time.sleep(min(max(ahead, 0.0005), 0.002))
                        continue
                    if -ahead > MAX_STEP_S:   # fallen behind: do not catch up
                        t_wall0, t_emu0 = time.monotonic() - MAX_STEP_S, clk.now
                        target = clk.now + MAX_STEP_S
                    self.run_once(target - clk.now, release=False)
                    self.pacing["max_ahead_s"] = max(self.pacing["max_ahead_s"], clk.now - (
                        t_emu0 + (time.monotonic() - t_wall0)))
                elif self.hold_idle and self._was_idle and not asked and not self._wait_for_host(IDLE_WAIT_S):
                    continue  # the clock holds until the host sends something
                else:
                    moved = self.run_once(0.005)
                    self._was_idle = self._last_idle
                    if moved or asked:
                        idle = 0
                    else:
                        idle += 1
                        if idle >= IDLE_STEPS:
                            self._wait_for_host(IDLE_WAIT_S)
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
