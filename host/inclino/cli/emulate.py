"""`inclino emulate`: the emulated probe on a pseudo-terminal until
interrupted (the emulator package, imported when the command runs)."""
from __future__ import annotations

from inclino.cli.options import command
from inclino.cli.paths import Input, Output
from inclino.errors import DataError, InclinoError


def _fix_for(e: Exception, args) -> str:
    """What to do about a start that failed for a reason the options chose."""
    if "Address already in use" in str(e):
        return (f" (another emulator or program listens on --control {args.control}: choose another port, "
                f"or 0 for any free one)")
    return ""


def _cmd_emulate(args) -> int:
    import signal
    import time

    from inclino.link.serial_link import BAUD_RANGE

    if not BAUD_RANGE[0] <= args.baud <= BAUD_RANGE[1]:
        raise DataError(f"--baud {args.baud}: a baud rate within {BAUD_RANGE[0]}-{BAUD_RANGE[1]}")
    if not 0 <= args.control <= 65535:
        raise DataError(f"--control {args.control}: a TCP port within 0-65535 (0: any free port)")
    for opt, v in (("--seed", args.seed), ("--tempco-draw", args.tempco_draw)):
        if v is not None and v < 0:
            raise DataError(f"{opt} {v}: a seed is an integer >= 0")

    try:
        from inclino_emu.runner import Emulator
    except ImportError as e:
        raise InclinoError(f"the emulator is not installed: {e}")
    try:
        emu = Emulator(scenario=args.scenario, seed=args.seed, baud=args.baud, link=args.link,
                       control_port=args.control, realtime=not args.unthrottled,
                       tempco_draw=args.tempco_draw)
    except FileNotFoundError as e:
        raise DataError(f"scenario not found: {e.filename or e}")
    except (OSError, ValueError, KeyError) as e:
        raise DataError(f"cannot start the emulator: {e}" + _fix_for(e, args))
    print(f"inclino emulator: probe on {emu.path}" + (f" (link {args.link})" if args.link else ""), flush=True)
    if emu.control_port is not None:
        print(f"control channel: 127.0.0.1:{emu.control_port} (JSON lines, docs/emulator.md)", flush=True)
    print(next_steps(args.link or emu.path, emu.control_port), flush=True)
    stop = {"now": False}

    def _term(*_):
        stop["now"] = True

    signal.signal(signal.SIGTERM, _term)
    try:  # Ctrl-C from here on, also while start() waits for the loop's thread (a host may already use it)
        emu.start()
        while not stop["now"] and emu.error is None:
            time.sleep(0.1)
    except KeyboardInterrupt:
        pass
    try:
        emu.stop()
    except RuntimeError as e:
        raise InclinoError(str(e))
    print("inclino emulator: stopped", flush=True)
    return 0


def next_steps(port: str, control: int | None) -> str:
    """The technician's loop on this probe, to try in another terminal
    (README, "Five minutes on the emulator")."""
    bench = f" --bench 127.0.0.1:{control}" if control is not None else ""
    lines = [f"inclino identify --port {port}",
             f"inclino survey --port {port} --count 3"]
    if bench:
        lines += [f"inclino acquire --port {port}{bench} --procedure twelve-position -o run.csv",
                  "inclino calibrate run.csv -o cal.json",
                  f"inclino download --port {port} --cal cal.json",
                  f"inclino verify --port {port} --cal cal.json",
                  f"inclino accept --port {port}{bench}"]
    return "next, in another terminal (Ctrl-C here stops the probe):\n" + "\n".join("  " + x for x in lines)


def add_emulate(sub):
    em = command(sub, "emulate", "run the emulated probe on a pseudo-terminal until interrupted",
                 "Run the emulated probe (the firmware's C against register-level models of the ADIS16210 and "
                 "the fluxgate's ADC, on a turntable in the Earth's field) on a pseudo-terminal until "
                 "interrupted, and print its port and the control channel's address: every probe command works "
                 "on that port as on a real probe, and acquire/accept --bench turn its turntable.",
                 ["inclino emulate", "inclino emulate --unthrottled --link /tmp/probe --scenario ideal --seed 3"])
    em.add_argument("--scenario", default="typical", action=Input,
                    help="built-in scenario name or TOML file (default %(default)s)")
    em.add_argument("--seed", type=int, default=None, help="override the scenario's seed")
    em.add_argument("--baud", type=int, default=115200, help="serial speed, bits/s (default %(default)s)")
    em.add_argument("--link", metavar="PATH", action=Output, help="also make this path a symlink to the pseudo-terminal")
    em.add_argument("--control", type=int, default=0,
                    help="control channel TCP port on 127.0.0.1 (default %(default)s: any free port)")
    em.add_argument("--unthrottled", action="store_true", help="run faster than real time")
    em.add_argument("--tempco-draw", type=int, metavar="N", default=None,
                    help="draw this probe's tempcos from the scenario's spread with seed N (docs/emulator.md)")
    em.set_defaults(func=_cmd_emulate)
