"""`inclino bench emulator --json`: how fast the emulated probe runs.

Real-time factor = emulated seconds per wall second, unthrottled, with the
firmware acquiring continuously: back-to-back 16-sample surveys through the
real C and the register-level sensor models, every ADIS16210 frame and
ADS1256 byte emulated, the ADIS16210 producing its outputs at its own rate
(AVG_CNT = 4: 4250 / 16 = 265.6 SPS) and the ADS1256 converting at 1000 SPS.
Target: >= 100.

The figure is the median of `rounds` timed rounds of `surveys` surveys each
(one round is ~20 ms of wall time, so a single round is at the mercy of the
machine's other load); the slowest and fastest rounds are reported too.  The
HAL callbacks per survey are counted in one extra, untimed survey."""
from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from inclino.formats.jsonout import dumps


@dataclass
class EmulatorBench:
    scenario: str
    surveys: int                  # per round
    samples_per_survey: int
    rounds: int
    emulated_s: float             # emulated time of the median round
    wall_s: float                 # wall time of the median round
    realtime_factor: float        # median over the rounds
    realtime_factor_min: float
    realtime_factor_max: float
    samples_per_wall_s: float     # at the median
    adis_output_rate_sps: float   # the ADIS16210's output data rate during the run
    acquisition_rate_sps: float   # survey samples per emulated second
    hal_callbacks_per_survey: int
    hal_callbacks: dict = field(default_factory=dict)
    target_realtime_factor: float = 100.0

    @property
    def passed(self) -> bool:
        return self.realtime_factor >= self.target_realtime_factor

    def to_json(self) -> str:
        return dumps({**asdict(self), "pass": self.passed})


def bench(scenario: str = "typical", surveys: int = 20, samples: int = 16, rounds: int = 7) -> EmulatorBench:
    from inclino_emu import hal
    from inclino_emu.probe import EmulatedProbe

    p = EmulatedProbe(scenario)
    p.set_average(samples)
    p.move_to(30.0, 60.0, 90.0)
    p.survey()  # warm up
    runs = []
    for _ in range(rounds):
        t0, w0 = p.clock.now, time.perf_counter()
        for _ in range(surveys):
            if p.survey()["status"] != 0:
                raise RuntimeError("the emulated probe failed a survey")
        sim, wall = p.clock.now - t0, time.perf_counter() - w0
        runs.append((sim / wall, sim, wall))
    runs.sort()
    rtf, sim, wall = runs[len(runs) // 2]
    with hal.counting(p.board) as counter:
        p.survey()
    calls = {k: v for k, v in counter.counts.items() if v}
    return EmulatorBench(scenario, surveys, samples, rounds, sim, wall, rtf, runs[0][0], runs[-1][0],
                         surveys * samples / wall, 1.0 / p.adis.output_period_s(), surveys * samples / sim,
                         counter.total, calls)
