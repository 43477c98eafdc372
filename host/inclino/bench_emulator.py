"""`inclino bench emulator --json`: how fast the emulated probe runs.

Real-time factor = emulated seconds per wall second, unthrottled, with the
firmware acquiring continuously (back-to-back surveys through the real C and
the register-level sensor models, every ADIS16210 and ADS1256 transfer
emulated).  Target: >= 100."""
from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass


@dataclass
class EmulatorBench:
    scenario: str
    surveys: int
    samples_per_survey: int
    emulated_s: float
    wall_s: float
    realtime_factor: float
    samples_per_wall_s: float
    target_realtime_factor: float = 100.0

    @property
    def passed(self) -> bool:
        return self.realtime_factor >= self.target_realtime_factor

    def to_json(self) -> str:
        return json.dumps({**asdict(self), "pass": self.passed}, indent=2)


def bench(scenario: str = "typical", surveys: int = 20, samples: int = 16) -> EmulatorBench:
    from inclino_emu.probe import EmulatedProbe

    p = EmulatedProbe(scenario)
    p.set_average(samples)
    p.move_to(30.0, 60.0, 90.0)
    p.survey()  # warm up
    t0, w0 = p.clock.now, time.perf_counter()
    for _ in range(surveys):
        if p.survey()["status"] != 0:
            raise RuntimeError("the emulated probe failed a survey")
    sim, wall = p.clock.now - t0, time.perf_counter() - w0
    return EmulatorBench(scenario, surveys, samples, sim, wall, sim / wall, surveys * samples / wall)
