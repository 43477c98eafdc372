"""The bench technician's probe commands: identify, survey, download,
verify, flash.  A thin shell over inclino.link.serial_link and inclino.link.operations.

Exit statuses: 0 success; 1 verify found a mismatch; 2 bad input; 3
calibration refused (nothing written); 4 port, link or probe problem.
"""
from __future__ import annotations

import csv
import json
import sys
import time

from inclino.cli.paths import Input, Output
from inclino.cli.options import add_cal, add_json, add_port, command, deprecated, require
from inclino.errors import DataError


def _link(args):
    from inclino.link.serial_link import ProbeLink, check_link_options

    check_link_options(args.baud, args.timeout)
    return ProbeLink(args.port, baud=args.baud, timeout=args.timeout)


# IDENTIFY's self-test status word (firmware/src/app_main.c, docs/protocol.md): a bit a failed part
SELFTEST_BITS = (
    (0x0001, "accelerometer failed to start (ADIS16210 absent, wrong PROD_ID, no answer, self-test stuck or its "
             "configuration did not read back)"),
    (0x0002, "fluxgate ADC failed to start (ADS1256 absent, wrong ID, no DRDY or its configuration did not read "
             "back)"),
    (0x0004, "accelerometer self-test failed (ADIS16210 DIAG_STAT[5] after the automatic self-test, MSC_CTRL[10])"),
)


def selftest_text(word: int) -> list[str]:
    """What each set bit of the self-test status means; 0: every part passed."""
    if word == 0:
        return ["pass: the ADIS16210 passed its automatic self-test and the ADS1256 answered and self-calibrated"]
    out = [text for bit, text in SELFTEST_BITS if word & bit]
    rest = word & ~sum(bit for bit, _ in SELFTEST_BITS)
    if rest:
        out.append(f"bits 0x{rest:04X}: not defined by this host's protocol version")
    return out


def _cmd_identify(args) -> int:
    with _link(args) as link:
        i = link.identify()
    slot = {0: "A", 1: "B", 0xFF: "none (identity)"}.get(i.cal_slot, str(i.cal_slot))
    meaning = selftest_text(i.selftest)
    d = {"product": i.product, "firmware": ".".join(map(str, i.fw_version)), "protocol": i.proto_version,
         "serial": i.serial, "calibration_slot": slot, "calibration_sequence": i.cal_sequence,
         "calibration_crc": f"{i.cal_crc:04X}", "selftest": i.selftest, "selftest_meaning": meaning}
    if args.json:
        print(json.dumps(d, indent=2))
    else:
        for k, v in d.items():
            if k == "selftest_meaning":
                continue
            if k == "selftest":
                v = f"0x{v:04X}: " + "; ".join(meaning)
            print(f"{k:22s} {v}")
    return 0


def _rows(link, args):
    """The run's survey records.  A probe still streaming from a run whose
    link was lost (E_BUSY) is stopped first, once."""
    from inclino.link.serial_link import ProbeNak

    try:
        yield from _records(link, args)
    except ProbeNak as e:
        if e.code != 6 or getattr(link, "_stopped_once", False):  # E_BUSY
            raise
        link._stopped_once = True
        link.request("STOP")
        yield from _records(link, args)


def _records(link, args):
    if args.count == 1 and not args.stream:
        yield link.survey()
        return
    if args.stream:
        yield from link.stream(args.period_ms, args.count)
        return
    for _ in range(args.count):
        yield link.survey()
        if args.period_ms:
            time.sleep(args.period_ms / 1000.0)


_STDOUT_AS = {"table": "a table; --csv for CSV", "csv": "as CSV with --csv", "json": "as JSON lines with --json"}


def _survey_format(args) -> str:
    if args.json and args.csv:
        raise DataError("--json and --csv: give one")
    return "json" if args.json else "csv" if args.csv else "table"


def _cmd_survey(args) -> int:
    _validate(args)
    args.format = _survey_format(args)
    from inclino.errors import InclinoError
    from inclino.formats import survey_log as sl

    if args.md is not None and not (args.md == args.md and abs(args.md) < 1e6):
        raise DataError("--md must be a depth in m")
    if args.append and not (args.output or args.las):
        raise DataError("--append continues a file: give -o RUN.csv or --las RUN.las")
    if args.output == "-":
        raise DataError(f"-o -: the run goes to standard output anyway ({_STDOUT_AS[args.format]}); "
                        "-o names a CSV file to log it to")
    if args.output and args.output.lower().endswith((".json", ".jsonl", ".las")):
        raise DataError(f"-o {args.output}: -o writes the run as CSV (--las for LAS 2.0, --json for JSON "
                        "lines on standard output)")
    out = sys.stdout
    with _link(args) as link:
        ident = link.identify()
        log = sl.SurveyLog(ident, args.port, md=args.md, csv_path=args.output, las_path=args.las,
                           append=args.append)
        for note in log.notes:
            print(f"inclino: note: {note}", file=sys.stderr)
        first = True
        try:
            with _terminate_as_interrupt():
                for rec in _rows(link, args):
                    row = log.add(rec.to_units(), rec.count)
                    _print_row(args, log, row, first, out)
                    first = False
        except KeyboardInterrupt as e:
            raise KeyboardInterrupt("; ".join(x for x in (str(e), log.close()) if x)) from None
        except InclinoError as e:
            e.args = (f"{e}; {log.close()}",)
            raise
        kept = log.close()
    if args.output or args.las:
        print(f"inclino: {kept}", file=sys.stderr)
    return 0


def _print_row(args, log, row, first, out) -> None:
    """One reading on standard output: a table line, a CSV row (the header
    before the first) or a JSON line."""
    from inclino.formats import survey_log as sl

    if args.format == "csv":
        w = csv.writer(out, lineterminator="\n")
        if first:
            for line in sl.header_lines(log.header, sl.qc_checked(row["qc"])):
                print(line, file=out)
            w.writerow(log.columns)
        start = sl.parse_utc(log.header["start_utc"], "header")
        w.writerow(sl.csv_row({**row, "utc_s": row["utc"] - start}, log.columns))
    elif args.format == "json":
        print(json.dumps({**{k: v for k, v in row.items() if k != "utc"}, "utc": sl.utc_iso(row["utc"]),
                          "qc_checked": sl.qc_checked(row["qc"]),
                          "probe": {k: log.header[k] for k in sl.MATCH_KEYS}}), file=out)
    else:
        if first:
            if row["qc"] & sl.QC_NO_REF:
                print(f"QC: {sl.NO_REF_TEXT}", file=out)
            md = f"{'MD m':>9} " if args.md is not None else ""
            print(f"{md}{'t s':>8} {'inc':>9} {'azi':>9} {'tf':>9} {'G total':>8} {'B total':>9} {'dip':>8}  QC",
                  file=out)
        md = f"{row['md_m']:9.2f} " if args.md is not None else ""
        print(f"{md}{row['t_s']:8.3f} {row['inc_deg']:9.4f} {row['azi_deg']:9.4f} {row['tf_deg']:9.4f} "
              f"{row['gt_g']:8.5f} {row['bt_nT']:9.1f} {row['dip_deg']:8.3f}  {sl.qc_text(row['qc'], short=True)}"
              + ("  near-vertical" if row["flags"] & 1 else ""), file=out)
    out.flush()


class _terminate_as_interrupt:
    """SIGTERM and SIGHUP (a closed terminal) end the run as Ctrl-C does, so
    what was logged is written; the previous handlers come back after."""

    def __enter__(self):
        import signal

        self.old = {}
        for name in ("SIGTERM", "SIGHUP"):
            sig = getattr(signal, name, None)
            if sig is None:
                continue
            try:
                self.old[sig] = signal.signal(sig, self._raise)
            except (ValueError, OSError):  # not the main thread
                pass
        return self

    @staticmethod
    def _raise(signum, frame):
        raise KeyboardInterrupt("terminated by a signal")

    def __exit__(self, *exc):
        import signal

        for sig, h in self.old.items():
            signal.signal(sig, h)


class _Progress:
    def __init__(self, total: int, desc: str, enabled: bool):
        self.bar = None
        if enabled:
            from tqdm import tqdm

            self.bar = tqdm(total=total, desc=desc, unit="step", file=sys.stderr, leave=False)

    def __call__(self, name: str):
        if self.bar is not None:
            self.bar.set_postfix_str(name)
            self.bar.update(1)

    def close(self):
        if self.bar is not None:
            self.bar.close()


def _cmd_download(args) -> int:
    from inclino.link import operations as calops
    from inclino.formats.calfile import Calibration

    from inclino.link.serial_link import check_link_options

    check_link_options(args.baud, args.timeout)
    require(args, "cal", "--cal CAL.json", "the calibration to write")
    cal = Calibration.load(args.cal)  # a refused file fails here, before the port is opened
    cal.check()
    refusal = calops.report_refusal(cal)
    if refusal and not args.force:
        from inclino.errors import CalibrationError

        raise CalibrationError(f"{refusal}; nothing written (use --force to download it anyway)")
    prog = _Progress(5, "download", not args.quiet and sys.stderr.isatty())
    try:
        with _link(args) as link:
            r = calops.download(link, cal, force=args.force, progress=prog)
    finally:
        prog.close()
    if args.json:
        print(r.to_json())
    else:
        print(download_line(r))
    return 0


def download_line(r) -> str:
    """The one line `inclino download` prints for a DownloadResult."""
    notes = ([f"{r.retries} link retr{'y' if r.retries == 1 else 'ies'}"] if r.retries else []) + r.events
    return (f"downloaded: slot {r.slot}, sequence {r.sequence}, image CRC {r.image_crc:04X}"
            + (" (" + "; ".join(notes) + ")" if notes else ""))


def _cmd_verify(args) -> int:
    from inclino.link import operations as calops
    from inclino.formats.calfile import Calibration

    if not 1 <= args.surveys <= 1000:
        raise DataError(f"--surveys {args.surveys}: surveys to check, 1-1000")
    require(args, "cal", "--cal CAL.json", "the calibration to check against")
    cal = Calibration.load(args.cal)
    with _link(args) as link:
        r = calops.verify(link, cal, surveys=args.surveys)
    if args.json:
        print(r.to_json())
    else:
        if r.slot == "none":
            print(f"verdict: FAIL: {r.mismatches[0]}")
            return 1
        print(f"storage: {'pass' if r.storage_ok else 'FAIL'} (slot {r.slot}, sequence {r.sequence}); "
              f"correction: {'pass' if r.correction_ok else 'FAIL'} ({r.checks} surveys checked bit for bit)")
        for m in r.mismatches[:10]:
            print(f"  {m}")
        if len(r.mismatches) > 10:
            print(f"  ... {len(r.mismatches) - 10} more (--json lists every differing field)")
        print(verify_conclusion(r))
    return 0 if r.ok else 1


def verify_conclusion(r) -> str:
    """`inclino verify`'s last line: the verdict and what decided it."""
    bad = sum(1 for m in r.mismatches if m.startswith("survey "))
    if r.ok:
        return (f"verdict: PASS: slot {r.slot} holds the file's coefficients and {r.checks} of {r.checks} surveys "
                "are the file's correction bit for bit")
    why = ([] if r.storage_ok else [f"slot {r.slot} does not hold the file's coefficients"]) + \
        ([] if r.correction_ok else [f"{bad or 'some'} of {r.checks} surveys differ from the file's correction"])
    return "verdict: FAIL: " + "; ".join(why)


def _cmd_ports(args) -> int:
    from inclino.link.ports import list_ports
    from inclino.link.serial_link import check_link_options

    check_link_options(115200, args.timeout)
    r = list_ports(identify=args.identify, timeout=args.timeout, only=args.devices)
    if args.json:
        print(r.to_json())
        return 0
    if not r.ports:
        print("no serial ports found")
    for p in r.ports:
        what = ", ".join(x for x in (p.description, p.hwid) if x)
        line = f"{p.device:20s} {what}"
        if p.held_by:
            line += f"  [in use by {', '.join(p.held_by)}]"
        if p.probe is not None:
            line += ("  probe: " + (p.probe["error"] if "error" in p.probe else
                                    f"{p.probe['product']} serial {p.probe['serial']} fw {p.probe['firmware']}"))
        print(line.rstrip())
    print(f"INCLINO_PORT: {r.env_port or '(not set)'}")
    return 0


def add_parser(sub) -> None:
    p = command(sub, "ports", "list the serial ports a probe may be on (and $INCLINO_PORT)",
                "List the serial devices (USB adapters, on-board UARTs) and the pseudo-terminals no session uses "
                "(an emulated probe), with any program that holds each open, and the port $INCLINO_PORT gives "
                "every command as its default. Listing opens no port; --identify asks each free one for the "
                "probe's identity (opening it exclusively, as every command does).",
                ["inclino ports", "inclino ports --identify /dev/ttyUSB0 /dev/ttyUSB1"])
    p.add_argument("devices", nargs="*", action=Input, metavar="DEVICE", help="only these ports")
    p.add_argument("--identify", action="store_true",
                   help="ask each port no other program holds for the probe's identity (opens it)")
    p.add_argument("--timeout", type=float, default=0.3, help="seconds to wait for each answer (default %(default)g)")
    add_json(p)
    p.set_defaults(func=_cmd_ports)

    p = command(sub, "identify", "product, firmware, serial and active calibration of the probe",
                "Ask the probe who it is: product, firmware and protocol version, serial number, the active "
                "calibration (slot, sequence, image CRC) and the self-test result with its meaning. The first "
                "thing to run on a new port: exit 4 says the port, the baud rate or the probe is wrong.",
                ["inclino identify --port /dev/ttyUSB0", "inclino identify --port /dev/pts/5 --json"])
    add_port(p)
    add_json(p)
    p.set_defaults(func=_cmd_identify)

    p = command(sub, "survey", "surveys from the probe: a live table, CSV or JSON lines; LAS export",
                "Take surveys from the probe (inclination, azimuth, toolface, G total, B total, dip and the QC "
                "verdict against the probe's reference), one at a time every --period-ms or streamed by the "
                "probe, printed as a table, CSV (--csv) or JSON lines (--json), each with the run's UTC start, "
                "the probe serial, firmware and calibration; -o and --las also log the run to CSV and LAS 2.0 "
                "as it goes (--append continues a log), and --md tags the station's measured depth for "
                "`inclino trajectory`.",
                ["inclino survey --port /dev/ttyUSB0 --count 5",
                 "inclino survey --port /dev/ttyUSB0 --md 120.5 --count 3 -o stations.csv --append",
                 "inclino survey --port /dev/ttyUSB0 --stream --period-ms 100 --count 0 --json"])
    add_port(p)
    p.add_argument("--count", type=int, default=1,
                   help="surveys to take (0 with --stream: until interrupted; default %(default)s)")
    p.add_argument("--period-ms", type=int, default=0, help="milliseconds between surveys (default %(default)s)")
    deprecated(p, "--period", "--period-ms", type=int)
    p.add_argument("--stream", action="store_true", help="let the probe stream at --period-ms (>= 1 ms)")
    p.add_argument("--csv", action="store_true", help="print CSV (a header, then one row a survey)")
    add_json(p, "print JSON lines (one object a survey)")
    deprecated(p, "--format", "--csv or --json", dest="format", choices=("table", "csv", "json"),
               apply=lambda ns, v: (setattr(ns, "csv", v == "csv"), setattr(ns, "json", v == "json")))
    p.add_argument("-o", "--output", metavar="RUN.csv", action=Output,
                   help="also write the run as CSV to this file, row by row (never replaces a file: --append)")
    p.add_argument("--las", metavar="RUN.las", action=Output, help="also write the run as LAS 2.0 to this file (at checkpoints and "
                                                    "at any exit, Ctrl-C included; never replaces a file: --append)")
    p.add_argument("--append", action="store_true", help="continue the existing -o/--las file of the same probe, "
                                                         "calibration and columns (one header; a mismatch is refused)")
    p.add_argument("--md", type=float, help="measured depth of the station, m: an md_m column (DEPT index in "
                                            "LAS) for inclino trajectory")
    p.set_defaults(func=_cmd_survey)

    p = command(sub, "download", "write a calibration into the probe, read it back, activate it",
                "Write a calibration file into the probe's inactive slot, read it back byte for byte, activate "
                "it and confirm; the probe keeps its previous calibration when any step fails. A file made "
                "for another probe serial, or whose own fit report did not pass, is refused (exit 3, nothing "
                "written) unless --force.",
                "inclino download --port /dev/ttyUSB0 --cal cal.json")
    add_port(p)
    add_cal(p, "the calibration to write (inclino calibrate -o)", positional_alias=True)
    p.add_argument("--force", action="store_true",
                   help="accept a file made for another probe serial, or whose fit report did not pass")
    add_json(p)
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=_cmd_download)

    p = command(sub, "verify", "check the stored calibration and the probe's correction against a file",
                "Check that the probe holds this calibration (the stored image, byte for byte) and applies it: "
                "--surveys surveys taken with their raw counts, corrected on the host with the firmware's own "
                "arithmetic and compared with the probe's result bit for bit. Exit 1 on any difference.",
                "inclino verify --port /dev/ttyUSB0 --cal cal.json --surveys 5")
    add_port(p)
    add_cal(p, "the calibration the probe should hold", positional_alias=True)
    p.add_argument("--surveys", type=int, default=3, help="surveys to check bit for bit, 1-1000 (default %(default)s)")
    add_json(p)
    p.set_defaults(func=_cmd_verify)


def _validate(args) -> None:
    from inclino.link.serial_link import check_link_options

    check_link_options(args.baud, args.timeout)
    if args.count < 0:
        raise DataError(f"--count {args.count}: surveys to take, >= 0 (0 only with --stream)")
    if args.period_ms < 0:
        raise DataError(f"--period-ms {args.period_ms}: milliseconds, >= 0")
    if args.stream:
        if not 1 <= args.period_ms <= 65535:
            raise DataError(f"--period-ms {args.period_ms}: the probe streams at 1-65535 ms")
        if args.count > 65535:
            raise DataError(f"--count {args.count}: the probe streams at most 65535 surveys (0: until "
                            "interrupted)")
    else:
        if args.count == 0:
            raise DataError("--count 0 (until interrupted) needs --stream")
        if args.period_ms > 86_400_000:
            raise DataError(f"--period-ms {args.period_ms}: at most 86400000 ms (a day)")


def _cmd_flash(args) -> int:
    from inclino.boot.flashing import flash
    from inclino.link.serial_link import check_link_options

    check_link_options(args.baud, args.timeout)
    if not 1 <= args.attempts <= 10:
        raise DataError(f"--attempts {args.attempts}: whole flashes to start, 1-10")
    if args.readback:
        from inclino.formats import safeio

        safeio.check_output(args.readback, [args.image])  # before the probe is touched
    cb, close = (None, lambda: None) if args.json else _tqdm_progress()
    try:
        res = flash(args.port, args.image, progress=cb, attempts=args.attempts, run=not args.no_run,
                    baud=args.baud, timeout=args.timeout, readback_path=args.readback)
    finally:
        close()
    print(res.to_json() if args.json else _text(res))
    return 0 if res.ok else 1


def add_flash(subparsers) -> None:
    p = command(subparsers, "flash", "program an S-record image through the probe's bootloader, verify every range",
                "Program a firmware image (S-records) through the probe's serial bootloader: erase, program, "
                "read back and CRC-check every range, then commit and start the application. A flash cut "
                "short is started again (--attempts); nothing is committed until every range verified, so a "
                "failure leaves the probe in its bootloader, never with a half-written application.",
                ["inclino flash app.s19 --port /dev/ttyUSB0",
                 "inclino flash app.s19 --port /dev/ttyUSB0 --readback probe.s19 --json"])
    p.add_argument("image", action=Input, help="S-record file (S2/S3 records with MC9S12XEP100 global addresses)")
    add_port(p, timeout=0.5)
    p.add_argument("--attempts", type=int, default=2,
                   help="whole flashes to start at most when one is cut short, 1-10 (default %(default)s)")
    p.add_argument("--no-run", action="store_true", help="leave the probe in its bootloader")
    p.add_argument("--readback", metavar="FILE.s19", action=Output, help="also write what was read back as S-records")
    add_json(p)
    p.set_defaults(func=_cmd_flash)


def _tqdm_progress():
    """One progress bar per phase on stderr (inclino.progress: a bar on a
    terminal; off one, a status line when a phase starts, every
    INCLINO_PROGRESS_PERIOD seconds, and when it ends)."""
    from inclino import progress

    bars = {}

    def cb(phase: str, done: int, total: int):
        bar = bars.get(phase)
        if bar is None:
            for b in bars.values():
                b.close()
            unit = "sector" if phase == "erase" else "B"
            bar = bars[phase] = progress.bar(total, f"flash {phase}", unit=unit, leave=True, delay=0)
        bar.update(done - bar.n)

    def close():
        for b in bars.values():
            b.close()

    return cb, close


def _text(res) -> str:
    lines = [f"{'range':>18} {'bytes':>7}  {'CRC file':>8}  {'CRC probe':>9}  read-back  verdict"]
    for r in res.ranges:
        lines.append(f"0x{r.addr:06X}-0x{r.addr + r.length - 1:06X} {r.length:7d}  {r.crc_expected:08X}  "
                     f"{'-' if r.crc_probe is None else format(r.crc_probe, '08X'):>9}  "
                     f"{'ok' if r.readback_ok else 'DIFFERS':9s}  {'pass' if r.passed else 'FAIL'}")
    for e in res.events:
        lines.append(f"note: {e}")
    verdict = "flashed and verified" if res.ok else "NOT flashed: verification failed, nothing committed"
    lines.append(f"{verdict}: {res.bytes_image} bytes in {len(res.ranges)} range(s), "
                 f"{res.sectors_erased} sectors erased, serial {res.serial}, {res.attempts} attempt(s), "
                 f"{res.retries} link retries, {res.bytes_on_wire} bytes on the wire, {res.duration_s:.1f} s"
                 + ("; application running" if res.app_running else ""))
    return "\n".join(lines)
