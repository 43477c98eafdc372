"""The serial ports a probe may be on (`inclino ports`): pyserial's list of
the machine's serial devices (USB adapters, on-board UARTs) and the free
pseudo-terminals an emulated probe sits on (`inclino emulate`), each with
what holds it open.  Listing opens no port; `identify=True` then asks each
port that no other program holds for the probe's identity (IDENTIFY),
opening it exclusively as every command does."""
from __future__ import annotations

import glob
import os
from dataclasses import asdict, dataclass, field

from inclino.formats.jsonout import dumps


@dataclass
class Port:
    device: str
    description: str = ""
    hwid: str = ""
    held_by: list = field(default_factory=list)  # "name (pid N)" of other programs holding it open
    probe: dict | None = None  # identify=True: product, serial, firmware; or {"error": one line}


@dataclass
class PortList:
    ports: list
    env_port: str | None = None  # $INCLINO_PORT

    def to_json(self) -> str:
        return dumps(asdict(self))


def _pseudo_terminals() -> list[str]:
    """Pseudo-terminals that are no session's terminal (an emulator's)."""
    out = []
    for p in sorted(glob.glob("/dev/pts/[0-9]*"), key=lambda s: int(s.rsplit("/", 1)[1])):
        try:
            fd = os.open(p, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError:
            continue
        try:
            os.tcgetpgrp(fd)
            continue  # a shell's terminal: never a probe
        except OSError:
            out.append(p)
        finally:
            os.close(fd)
    return out


def list_ports(identify: bool = False, timeout: float = 0.3, only=None) -> PortList:
    """The candidate ports (`only`: just these devices, listed or not)."""
    from serial.tools import list_ports as lp

    from inclino.link.serial_link import port_holders

    seen, ports = set(), []
    for info in sorted(lp.comports(include_links=True), key=lambda i: i.device):
        if info.device in seen:
            continue
        seen.add(info.device)
        ports.append(Port(info.device, info.description if info.description != "n/a" else "",
                          info.hwid if info.hwid != "n/a" else ""))
    for p in _pseudo_terminals():
        if p not in seen:
            ports.append(Port(p, "pseudo-terminal (an emulated probe: inclino emulate)"))
    if only:
        known = {p.device: p for p in ports}
        ports = [known.get(d) or known.get(os.path.realpath(d)) or Port(d) for d in only]
    for port in ports:
        port.held_by = [f"{n} (pid {pid})" for pid, n in port_holders(port.device)]
        if identify and not port.held_by:
            port.probe = _identify(port.device, timeout)
    return PortList(ports, os.environ.get("INCLINO_PORT") or None)


def _identify(device: str, timeout: float) -> dict:
    from inclino.errors import InclinoError
    from inclino.link.serial_link import ProbeLink

    try:
        with ProbeLink(device, timeout=timeout, retries=1) as link:
            i = link.identify()
    except InclinoError as e:
        return {"error": str(e)}
    return {"product": i.product, "serial": i.serial, "firmware": ".".join(map(str, i.fw_version))}
