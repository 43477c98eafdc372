"""`inclino bench link --json`: how well the host and the probe use the
serial link, measured on the emulated probe through its pseudo-terminal at
115 200 baud.

* stream: surveys streamed back to back (one sample per survey) use this
  fraction of the link's raw byte rate (baud / 10), counted on the probe's own
  clock between the first and the last frame (the survey records' time
  stamps).  Target >= 0.90.
* download: bytes on the wire (both directions) of a calibration download
  with its read-back verification, against the minimum: the 120-byte image
  crossing the wire once each way, each time in one frame (2 x 128 bytes).
  Target <= 1.5.  The same ratio for download followed by `verify`.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass

from inclino.link.protocol import OVERHEAD, SurveyRecord
from inclino.formats.jsonout import dumps

IMAGE = 120


@dataclass
class LinkBench:
    baud: int
    stream_frames: int
    stream_bytes_per_s: float
    stream_link_fraction: float
    download_bytes: int
    download_min_bytes: int
    download_ratio: float
    download_verify_bytes: int
    download_verify_ratio: float
    target_stream_fraction: float = 0.90
    target_download_ratio: float = 1.5

    @property
    def passed(self) -> bool:
        return (self.stream_link_fraction >= self.target_stream_fraction
                and self.download_ratio <= self.target_download_ratio)

    def to_json(self) -> str:
        return dumps({**asdict(self), "pass": self.passed})


def bench(baud: int = 115200, frames: int = 200) -> LinkBench:
    import numpy as np

    from inclino.link import operations as calops
    from inclino.formats.calfile import Calibration
    from inclino.link.serial_link import ProbeLink
    from inclino_emu.runner import Emulator

    emu = Emulator("typical", baud=baud, control_port=None, realtime=False).start()
    try:
        with ProbeLink(emu.path, baud=baud, timeout=2.0) as link:
            link.set_average(1)
            recs = list(link.stream(period_ms=1, count=frames, timeout=5.0))
            span_s = (recs[-1].t_ms - recs[0].t_ms) / 1000.0
            frame_bytes = SurveyRecord.FMT.size + OVERHEAD
            rate = (len(recs) - 1) * frame_bytes / span_s
            link.set_average(16)
            serial = link.identify().serial
            A = np.eye(3) * 1.01
            cal = Calibration(acc_m=A.tolist(), mag_m=A.tolist(), acc_b=[0.001, 0.0, 0.0],
                              mag_b=[10.0, 0.0, 0.0], method="joint", probe_serial=str(serial))
            r = calops.download(link, cal)
            o0, i0 = link.stats.bytes_out, link.stats.bytes_in
            v = calops.verify(link, cal, surveys=1)
            if not (r.ok and v.ok):
                raise RuntimeError("the benchmark's download did not verify")
            dv = r.bytes_out + r.bytes_in + (link.stats.bytes_out - o0) + (link.stats.bytes_in - i0)
    finally:
        emu.stop()
    minimum = 2 * (IMAGE + OVERHEAD)
    d = r.bytes_out + r.bytes_in
    return LinkBench(baud, len(recs), rate, rate / (baud / 10.0), d, minimum, d / minimum, dv, dv / minimum)
