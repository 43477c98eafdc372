"""Checks before any fit on slips that logs of sensors outside the corpus
showed (docs/dataset.md, "Checks before any fit"): a time column stamped in
Unix time and declared in a unit 1000x too large, which neither the row rate
nor the turning tells on a log read at rest, and a magnetometer beside a
magnet, whose field no unit makes the earth's."""
from pathlib import Path

import numpy as np
import pytest

from inclino import checks
from inclino.cli import main
from inclino.formats import importlog, sensor


def _faces_log(path, t_col, n_hold=300):
    """A MEMS accelerometer (+1 g on the axis up) held still on its six
    faces, n_hold rows each, with 2 mg of noise: each row read at rest."""
    rng = np.random.default_rng(7)
    faces = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)
    a = np.repeat(faces, n_hold, axis=0) * 1.01 + [0.02, -0.01, 0.015] + rng.normal(0, 0.002, (6 * n_hold, 3))
    lines = ["t,ax,ay,az"] + [f"{t_col[i]},{a[i, 0]:.6f},{a[i, 1]:.6f},{a[i, 2]:.6f}" for i in range(len(a))]
    path.write_text("\n".join(lines) + "\n")
    return len(a)


def _desc(unit):
    return sensor.from_toml(f'''name = "six faces"
[log]
time = "t"
time_unit = "{unit}"
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
''')


def _time_findings(rep):
    return [f for f in rep.findings if f.check == "time"]


def test_unix_nanoseconds_declared_microseconds_are_named_on_a_log_read_at_rest(tmp_path):
    # stamps in Unix ns at 250 rows/s from 2024-10-28 20:31:49 UTC; declared "us", every row reads 4 s apart: a
    # plausible logger of a static sensor, and its first row 54 800 years after 1970
    start_s = 1_730_147_509
    n = 6 * 300
    t_ns = [start_s * 10**9 + i * 4_000_000 for i in range(n)]
    _faces_log(tmp_path / "log.csv", t_ns)
    for static in (True, False):
        ds, _ = importlog.import_log(str(tmp_path / "log.csv"), _desc("us"), static=static)
        rep = checks.run(ds, declared_static=static)
        (f,) = _time_findings(rep)
        assert f.level == "warning" and f.figures["looks_like"] == "ns"
        assert 'time_unit = "ns"' in f.message and "2024-10-28 20:31:49 UTC" in f.message
        assert abs(f.figures["unix_time_s"] - start_s) < 1.0
        # declared as logged: nothing said about the time
        ds, _ = importlog.import_log(str(tmp_path / "log.csv"), _desc("ns"), static=static)
        assert _time_findings(checks.run(ds, declared_static=static)) == []


def test_unix_milliseconds_declared_seconds_are_named(tmp_path):
    start_s = 1_700_000_000
    t_ms = [start_s * 1000 + i * 10 for i in range(6 * 300)]
    _faces_log(tmp_path / "log.csv", t_ms)
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), _desc("s"), static=True)
    (f,) = _time_findings(checks.run(ds, declared_static=True))
    assert f.figures["looks_like"] == "ms" and 'time_unit = "ms"' in f.message


def test_an_uptime_counter_is_not_taken_for_a_unix_time(tmp_path):
    # a board's microsecond counter 21 days after power-up (1.8e12 us): read as us it is 1.8e6 s, which in ms
    # would be a Unix time of 2027, but nothing tells an uptime from it: no finding
    t_us = [1_800_000_000_000 + i * 10_000 for i in range(6 * 300)]
    _faces_log(tmp_path / "log.csv", t_us)
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), _desc("us"), static=True)
    assert _time_findings(checks.run(ds, declared_static=True)) == []


def _mag_log(path, radius_uT, centre_uT, n=400, seed=5):
    """A magnetometer turned through every direction, its readings on a
    sphere of radius_uT about centre_uT, 0.3 uT of noise, logged in uT."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    m = d * radius_uT + centre_uT + rng.normal(0, 0.3, (n, 3))
    path.write_text("mx,my,mz\n" + "".join(f"{x:.3f},{y:.3f},{z:.3f}\n" for x, y, z in m))


_MAG = '''name = "HMC5883L in uT"
[magnetometer]
columns = ["mx", "my", "mz"]
unit = "uT"
axes = "x = mx, y = my, z = mz"
'''


def test_a_field_no_unit_explains_names_a_magnet_not_the_unit(tmp_path):
    # 190 uT, 4.2x a geomagnetic field: the factor of no unit (mG, the nearest, makes it 19 000 nT, 0.42x, and had
    # been advised first: it imports with a warning, every reading 10x too small)
    _mag_log(tmp_path / "m.csv", 190.0, [40.0, -90.0, 560.0])
    ds, _ = importlog.import_log(str(tmp_path / "m.csv"), sensor.from_toml(_MAG))
    (f,) = [f for f in checks.run(ds).findings if f.check == "units"]
    assert f.level == "error"
    assert "a magnet or steel near the sensor" in f.message and "not uT" not in f.message
    near = f.figures["magnet"]
    assert near["nearest_unit"] == "mG" and abs(near["nearest_nT"] / f.figures["field_nT"] - 0.1) < 1e-9


def test_a_unit_slip_is_still_named_as_the_unit(tmp_path):
    # 45 uT logged in mG (450) and declared uT: 10x, the factor of mG: the unit is named, no magnet
    _mag_log(tmp_path / "m.csv", 450.0, [30.0, -20.0, 10.0])
    ds, _ = importlog.import_log(str(tmp_path / "m.csv"), sensor.from_toml(_MAG))
    (f,) = [f for f in checks.run(ds).findings if f.check == "units"]
    assert f.level == "error" and "a magnet" not in f.message and "look like mG" in f.message


def _rig_log(path, hand_mg, seed=11, holds=30, hold_rows=100, between=12):
    """An accelerometer (scale errors 3 %, offsets 20-40 mg, 2 mg noise)
    held at `holds` random orientations for hold_rows rows each, with
    `between` rows stepping from one to the next; those carry hand_mg of
    acceleration (0: each a station read at rest, as a rig's short stops)."""
    rng = np.random.default_rng(seed)
    S = np.diag([1.03, 0.98, 1.01])
    b = np.array([0.03, -0.02, 0.04])
    d = rng.normal(size=(holds, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    rows = []
    for i in range(holds):
        rows += [(d[i], 0.0)] * hold_rows
        if i + 1 < holds:
            for k in range(1, between + 1):
                u = d[i] + (d[i + 1] - d[i]) * k / (between + 1)
                rows.append((u / np.linalg.norm(u), hand_mg * 1e-3))
    a = np.array([S @ u + b + rng.normal(0, 0.002, 3) + rng.normal(0, s, 3) / np.sqrt(3) for u, s in rows])
    path.write_text("ax,ay,az\n" + "".join(f"{x:.6f},{y:.6f},{z:.6f}\n" for x, y, z in a))


_ACC = '''name = "accelerometer in g"
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
'''


def _static_moving(rep):
    return [f for f in rep.findings if f.check == "motion" and f.level == "warning"]


def test_a_log_declared_static_whose_rows_between_holds_move_is_warned(tmp_path):
    # 50 mg of a hand's acceleration on the 12 rows between each pair of holds: declared static, each such row
    # would be fitted as a station read at rest
    _rig_log(tmp_path / "a.csv", hand_mg=50.0)
    ds, _ = importlog.import_log(str(tmp_path / "a.csv"), sensor.from_toml(_ACC), static=True)
    (f,) = _static_moving(checks.run(ds, declared_static=True))
    assert abs(f.figures["rows_moving"] - 29 * 12) <= 12 and f.figures["holds"] == 30  # (a step's edge row may join a hold)
    assert f.figures["moving_misfit_g"] > 3 * f.figures["held_misfit_g"] and "drop the declaration" in f.message
    # not declared static: the holds are found and the moving rows left out, nothing to warn of
    ds, _ = importlog.import_log(str(tmp_path / "a.csv"), sensor.from_toml(_ACC))
    assert _static_moving(checks.run(ds)) == []


def test_a_rigs_short_stations_read_at_rest_are_not_taken_for_motion(tmp_path):
    # the same steps read at rest (no acceleration): short stations, as the declaration says
    _rig_log(tmp_path / "a.csv", hand_mg=0.0)
    ds, _ = importlog.import_log(str(tmp_path / "a.csv"), sensor.from_toml(_ACC), static=True)
    assert _static_moving(checks.run(ds, declared_static=True)) == []


def _numbered(header):
    return sensor.from_toml(f'''name = "numbered columns"
[log]
header = {header}
[accelerometer]
columns = [1, 2, 3]
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
''')


def test_a_data_row_read_as_the_header_is_said(tmp_path):
    # a log without a header line, header = true (the default) and the columns by number: its first row was read
    # as the names and dropped in silence
    rng = np.random.default_rng(2)
    a = rng.normal(size=(200, 3))
    a /= np.linalg.norm(a, axis=1)[:, None]
    (tmp_path / "a.txt").write_text("".join(f"{x:.5f} {y:.5f} {z:.5f}\n" for x, y, z in a))
    ds, rep = importlog.import_log(str(tmp_path / "a.txt"), _numbered("true"))
    assert len(ds) == 199
    (note,) = [n for n in rep.notes if "a data row" in n]
    assert f"{a[0, 0]:.5f}" in note and "header = false" in note
    ds, rep = importlog.import_log(str(tmp_path / "a.txt"), _numbered("false"))
    assert len(ds) == 200 and not any("a data row" in n for n in rep.notes)
    # a header of column indices (pandas writes 0, 1, 2) is a header
    (tmp_path / "b.csv").write_text("0,1,2\n" + "".join(f"{x:.5f},{y:.5f},{z:.5f}\n" for x, y, z in a))
    ds, rep = importlog.import_log(str(tmp_path / "b.csv"), _numbered("true"))
    assert len(ds) == 200 and not any("a data row" in n for n in rep.notes)


def test_a_data_row_of_whole_counts_read_as_the_header_is_said(tmp_path):
    # a magnetometer logged in whole counts without a header line ("-163 64 1": no fraction, no exponent), read
    # with header = true and the columns by number: its first row was taken for the names in silence; whole
    # numbers are a header only as column indices (0, 1, 2 or 1, 2, 3)
    rng = np.random.default_rng(3)
    m = rng.normal(size=(200, 3))
    m = np.rint(170.0 * m / np.linalg.norm(m, axis=1)[:, None] + [-69, 85, -130]).astype(int)
    (tmp_path / "m.txt").write_text("".join(f"{x} {y} {z}\n" for x, y, z in m))
    desc = sensor.from_toml('''name = "whole counts"
[log]
header = true
rate_hz = 10
[magnetometer]
columns = [1, 2, 3]
unit = "counts"
lsb = "0.1 uT"
axes = "x = mx, y = my, z = mz"
''')
    ds, rep = importlog.import_log(str(tmp_path / "m.txt"), desc)
    assert len(ds) == 199
    (note,) = [n for n in rep.notes if "a data row" in n]
    assert f"{m[0, 0]}, {m[0, 1]}, {m[0, 2]}" in note and "header = false" in note
    # column indices from 1 are a header, as from 0
    (tmp_path / "i.txt").write_text("1 2 3\n" + "".join(f"{x} {y} {z}\n" for x, y, z in m))
    ds, rep = importlog.import_log(str(tmp_path / "i.txt"), desc)
    assert len(ds) == 200 and not any("a data row" in n for n in rep.notes)


@pytest.mark.parametrize("acc_cols, mag_cols, named", [
    ("[1, 2, 3]", "[1, 2, 3]", "[magnetometer].columns[1] and [accelerometer].columns[1] both read column 1"),
    ("[1, 2, 3]", "[4, 5, 5]", "[magnetometer].columns[3] and [magnetometer].columns[2] both read column 5"),
    ('["ax", "ay", "az"]', '["mx", "ay", "mz"]', "both read column 2 ('ay')"),
])
def test_one_column_read_as_two_sensor_axes_is_refused(tmp_path, capsys, acc_cols, mag_cols, named):
    # a magnetometer's columns copied into the accelerometer's table imported with exit 0, the "accelerometer"
    # the magnetometer itself (its dip -90 deg on every row); a column typed twice made one axis a copy of another
    rng = np.random.default_rng(4)
    g = rng.normal(size=(100, 3))
    g /= np.linalg.norm(g, axis=1)[:, None]
    b = 30.0 * rng.normal(size=(100, 3))
    header = "ax,ay,az,mx,my,mz\n" if "ax" in acc_cols else ""
    (tmp_path / "log.csv").write_text(header + "".join(
        ",".join(f"{v:.5f}" for v in (*a, *m)) + "\n" for a, m in zip(g, b)))
    (tmp_path / "d.toml").write_text(f'''name = "six columns"
[log]
header = {"true" if header else "false"}
rate_hz = 10
[accelerometer]
columns = {acc_cols}
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
columns = {mag_cols}
unit = "uT"
axes = "x = mx, y = my, z = mz"
''')
    rc = main(["import", str(tmp_path / "log.csv"), "--sensor", str(tmp_path / "d.toml"),
               "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and named in err and "one column is one sensor axis" in err, err
    assert not (tmp_path / "run.csv").exists()


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-be", "utf-32"])
def test_a_log_in_utf16_or_utf32_with_its_mark_imports_as_in_utf8(tmp_path, encoding):
    # a serial log redirected by Windows PowerShell is UTF-16 with a byte-order mark: it was refused as "not UTF-8
    # text (byte 0xFF at column 1)"; the mark says how to read it, and the rows are the UTF-8 log's
    xio = Path(__file__).parent / "data" / "real" / "xio_fusion"
    text = (xio / "sensor_data.csv").read_text(encoding="utf-8")
    data = text.encode(encoding)
    if encoding == "utf-16-be":
        data = b"\xfe\xff" + data  # the big-endian codec writes no mark of its own
    (tmp_path / "log.csv").write_bytes(data)
    desc = sensor.load(str(xio / "sensor.toml"))
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), desc)
    ref, _ = importlog.import_log(str(xio / "sensor_data.csv"), desc)
    assert len(ds) == len(ref) == 13514
    for c in ("t_s", "ax_g", "ay_g", "az_g", "mx_nT", "my_nT", "mz_nT"):
        assert np.array_equal(ds.columns[c], ref.columns[c]), c


def test_a_utf16_log_cut_inside_a_character_is_one_line_naming_utf16(tmp_path, capsys):
    xio = Path(__file__).parent / "data" / "real" / "xio_fusion"
    data = (xio / "sensor_data.csv").read_text(encoding="utf-8").encode("utf-16")
    (tmp_path / "log.csv").write_bytes(data[:20001])  # an odd byte count: the last character cut in half
    rc = main(["import", str(tmp_path / "log.csv"), "--sensor", str(xio / "sensor.toml"),
               "-o", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "not UTF-16 text" in err and "Traceback" not in err, err


@pytest.mark.parametrize("sep, line, fix", [
    (",", 'delimiter = ";"', '[log] delimiter = ","'),
    (",", 'decimal = ","', 'makes the comma the decimal mark'),
    (";", 'delimiter = ","', '[log] delimiter = ";"'),
    ("\t", 'delimiter = ";"', '[log] delimiter = "\\t"'),
])
def test_a_header_split_at_the_wrong_delimiter_is_named_with_the_delimiter(tmp_path, capsys, sep, line, fix):
    # x-io's comma-separated log declared delimiter = ";" was told "no column 'Accelerometer X (g)'" and shown its
    # whole header line as its one column; declared decimal = "," its names were split at their spaces
    xio = Path(__file__).parent / "data" / "real" / "xio_fusion"
    rows = (xio / "sensor_data.csv").read_text().splitlines()[:200]
    (tmp_path / "log.csv").write_text("\n".join(r.replace(",", sep) for r in rows) + "\n")
    (tmp_path / "d.toml").write_text((xio / "sensor.toml").read_text().replace("[log]\n", f"[log]\n{line}\n", 1))
    rc = main(["import", str(tmp_path / "log.csv"), "--sensor", str(tmp_path / "d.toml"),
               "-o", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and fix in err, err
    assert "the header line names" in err and "split at" in err


@pytest.mark.parametrize("preamble, skip, fix", [("", 1, "skip_rows = 0"),
                                                 ("logger v1.2\nstarted\n", 3, "skip_rows = 2")])
def test_skip_rows_that_skip_the_header_line_are_named(tmp_path, capsys, preamble, skip, fix):
    # x-io's log with skip_rows = 1 read its first data row as the names and was told to number its columns
    xio = Path(__file__).parent / "data" / "real" / "xio_fusion"
    rows = (xio / "sensor_data.csv").read_text().splitlines()[:200]
    (tmp_path / "log.csv").write_text(preamble + "\n".join(rows) + "\n")
    desc = (xio / "sensor.toml").read_text()
    (tmp_path / "d.toml").write_text(desc.replace("[log]\n", f"[log]\nskip_rows = {skip}\n", 1))
    rc = main(["import", str(tmp_path / "log.csv"), "--sensor", str(tmp_path / "d.toml"),
               "-o", str(tmp_path / "r.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "skips this line, the header line" in err, err
    assert err.rstrip().endswith(fix), err
    # the skip_rows it names imports the log
    (tmp_path / "d.toml").write_text(desc.replace("[log]\n", f"[log]\n{fix}\n", 1))
    ds, _ = importlog.import_log(str(tmp_path / "log.csv"), sensor.load(str(tmp_path / "d.toml")))
    assert len(ds) == 199
