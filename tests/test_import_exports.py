"""Export formats of real tools read through a sensor description written
from the format's own documentation (docs/dataset.md), and the slips their
users make: phyphox's CSV exports (quoted "Time (s)" headers, numbers as
1.018390000E-2, semicolons with decimal commas in some locales), ArduPilot
DataFlash messages exported to CSV (an IMU message of two IMUs, I = 0 and 1,
one row each in turn), Arduino's Serial Plotter lines ("ax:0.01,ay:...").
The readings are a real log's (tests/data/real/xio_fusion, MIT; ngimu),
written out in each format."""
import csv
from pathlib import Path

import numpy as np
import pytest

from inclino.cli import main
from inclino.errors import DataError
from inclino.formats import importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
G = 9.80665


def _xio(n=3000):
    rows = list(csv.reader(open(REAL / "xio_fusion" / "sensor_data.csv")))[1:n + 1]
    return [[float(x) for x in r] for r in rows]


def _phyphox_number(x: float, comma: bool) -> str:
    m, e = f"{x:.9E}".split("E")  # phyphox writes 1.018390000E-2
    s = f"{m}E{int(e)}"
    return s.replace(".", ",") if comma else s


def _phyphox(tmp_path, comma: bool):
    """phyphox's Accelerometer.csv: "CSV (Comma, decimal point)" or "CSV
    (Semicolon, decimal comma)"."""
    sep = ";" if comma else ","
    p = tmp_path / "Accelerometer.csv"
    with open(p, "w", encoding="utf-8") as f:
        f.write(sep.join(['"Time (s)"', '"Acceleration x (m/s^2)"', '"Acceleration y (m/s^2)"',
                          '"Acceleration z (m/s^2)"']) + "\n")
        for r in _xio(600):
            f.write(sep.join([_phyphox_number(r[0], comma)] + [_phyphox_number(v * G, comma) for v in r[4:7]]) + "\n")
    return p


PHYPHOX = """name = "phyphox Accelerometer.csv"
[log]
time = "Time (s)"
time_unit = "s"
{log}
[accelerometer]
columns = ["Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
"""


def _desc(text):
    return sensor.from_toml(text)


@pytest.mark.parametrize("comma,log", [(False, ""), (True, 'decimal = ","')])
def test_phyphox_exports_import_as_the_numbers_written(tmp_path, comma, log):
    ds, _ = importlog.import_log(str(_phyphox(tmp_path, comma)), _desc(PHYPHOX.format(log=log)))
    src = np.array(_xio(600))
    assert len(ds) == 600
    # m/s^2 to g and the sign turned (reads = "up"): the x-io readings in g, to the 10 digits phyphox wrote
    assert np.allclose(ds.columns["ax_g"], -src[:, 4], rtol=1e-8, atol=1e-12)
    assert np.allclose(ds.columns["t_s"], src[:, 0], rtol=1e-9, atol=1e-12)


def test_a_decimal_comma_with_an_exponent_is_named_as_a_decimal_comma(tmp_path):
    # phyphox "CSV (Semicolon, decimal comma)" read with the point: '9,955750307E-3' was "a garbled or cut line?"
    with pytest.raises(DataError) as e:
        importlog.import_log(str(_phyphox(tmp_path, True)), _desc(PHYPHOX.format(log='decimal = "."')))
    assert 'decimal comma? set [log] decimal = ","' in str(e.value), e.value
    assert "garbled" not in str(e.value)


def test_a_decimal_comma_declared_on_a_comma_delimited_export_is_named(tmp_path, capsys):
    # read with decimal = ",", the comma export was split at whitespace: "no column 'Acceleration x (m/s^2)'"
    p = _phyphox(tmp_path, False)
    (tmp_path / "s.toml").write_text(PHYPHOX.format(log='decimal = ","'))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert 'decimal = "."' in err and "split at commas" in err, err
    assert not (tmp_path / "run.csv").exists()


@pytest.mark.parametrize("comma,declared,right", [(False, ";", ","), (False, "\\t", ","), (True, "\\t", ";")])
def test_a_declared_delimiter_the_header_does_not_split_at_is_named(tmp_path, comma, declared, right):
    log = f'delimiter = "{declared}"' + ('\ndecimal = ","' if comma else "")
    with pytest.raises(DataError) as e:
        importlog.import_log(str(_phyphox(tmp_path, comma)), _desc(PHYPHOX.format(log=log)))
    assert f'[log] delimiter = "{right}"' in str(e.value) and "every one of them" in str(e.value), e.value


# ---- ArduPilot DataFlash IMU messages of two IMUs --------------------------------------------------------------

ARDUPILOT = """name = "ArduPilot IMU message (mavlogdump --format csv)"
[log]
time = "TimeUS"
time_unit = "us"
{keep}
[accelerometer]
columns = ["AccX", "AccY", "AccZ"]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
"""


def _ardupilot(tmp_path, bias=(0.35, -0.2, 0.1)):
    """IMU rows of instance 0 and 1 in turn, 150 us apart: the second IMU
    reads the same motion with offsets of its own (m/s^2)."""
    p = tmp_path / "imu.csv"
    with open(p, "w") as f:
        f.write("timestamp,TimeUS,I,GyrX,GyrY,GyrZ,AccX,AccY,AccZ,EG,EA,T,GH,AH,GHz,AHz\n")
        for r in _xio(1500):
            tu = 60_000_000 + round(r[0] * 1e6)
            for inst in (0, 1):
                a = [v * G + (bias[k] if inst else 0.0) for k, v in enumerate(r[4:7])]
                f.write(f"{1.7e9 + tu / 1e6:.6f},{tu + 150 * inst},{inst},0,0,0,{a[0]:.6f},{a[1]:.6f},{a[2]:.6f},"
                        f"0,0,45.2,1,1,1000,1000\n")
    return p


def test_two_imus_taking_turns_in_one_log_are_refused_naming_the_keep(tmp_path, capsys):
    # read as one sensor, it was imported with "fix [log] time_unit = "ms"" (its rows 150 us apart in turn)
    p = _ardupilot(tmp_path)
    (tmp_path / "s.toml").write_text(ARDUPILOT.format(keep=""))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert "every 2 rows" in err and 'keep = { I = ["0"] }' in err and "time_unit" not in err, err
    assert not (tmp_path / "run.csv").exists()


def test_one_imu_kept_imports_without_a_word_on_interleaving(tmp_path):
    ds, rep = importlog.import_log(str(_ardupilot(tmp_path)), _desc(ARDUPILOT.format(keep='keep = { I = ["1"] }')))
    assert len(ds) == 1500 and rep.dropped == {"I not in [log].keep": 1500}
    src = np.array(_xio(1500))
    assert np.allclose(ds.columns["ay_g"], -(src[:, 5] * G - 0.2) / G, atol=1e-6)


def test_a_sensor_alone_never_reads_as_interleaved_on_the_corpus():
    # every real log of the corpus, its readings as logged: none comes back every 2-4 rows
    for d in ("xio_fusion", "ngimu", "mikoff_mpu9150", "imucal_ferraris", "qmc5883l", "micropython_fusion"):
        desc = sensor.load(str(REAL / d / "sensor.toml"))
        log = next(p for p in sorted((REAL / d).iterdir()) if p.suffix in (".csv", ".log", ".txt"))
        importlog.import_log(str(log), desc)


# ---- Arduino Serial Plotter: label:value cells -----------------------------------------------------------------

PLOTTER = """name = "Arduino Serial Plotter lines"
[log]
rate_hz = 50
[accelerometer]
columns = ["ax", "ay", "az"]
unit = "g"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
columns = ["mx", "my", "mz"]
unit = "uT"
axes = "x = mx, y = my, z = mz"
"""


def _plotter(tmp_path, sep=",", garble=None):
    rows = list(csv.reader(open(REAL / "ngimu" / "sensors.csv")))[1:]
    p = tmp_path / "plot.txt"
    with open(p, "w", newline="") as f:
        for i, r in enumerate(rows):
            line = sep.join(f"{k}:{v}" for k, v in zip(("ax", "ay", "az", "mx", "my", "mz"), r[4:10]))
            f.write((garble(line) if garble is not None and i == 7 else line) + "\r\n")
    return p, np.array([[float(x) for x in r[4:10]] for r in rows])


@pytest.mark.parametrize("sep", [",", " ", "\t"])
def test_serial_plotter_lines_import_by_their_labels(tmp_path, sep):
    # every cell "ax:0.0231": was "'ax:0.02310539' is not a number; a garbled or cut line?"
    p, src = _plotter(tmp_path, sep)
    ds, _ = importlog.import_log(str(p), _desc(PLOTTER))
    assert len(ds) == len(src)  # the first line is a sample, not a header
    assert np.array_equal(ds.columns["az_g"], -src[:, 2])
    assert np.allclose(ds.columns["mx_nT"], src[:, 3] * 1000, rtol=1e-14)


def test_a_serial_plotter_line_cut_is_refused_or_dropped(tmp_path, capsys):
    p, src = _plotter(tmp_path, garble=lambda s: s.replace("az:", "a", 1))
    (tmp_path / "s.toml").write_text(PLOTTER)
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert ":8:" in err and "'az:'" in err, err
    ds, rep = importlog.import_log(str(p), _desc(PLOTTER), drop_bad_rows=True)
    assert len(ds) == len(src) - 1 and any("line 8" in k for k in rep.dropped), rep.dropped


# ---- two ROS topics in one file (PlotJuggler's CSV export): a row for each sample of either -------------------

PLOTJUGGLER = """name = "PlotJuggler CSV of /imu/data and /imu/mag"
[log]
time = "__time"
time_unit = "s"
[accelerometer]
columns = ["/imu/data/linear_acceleration/x", "/imu/data/linear_acceleration/y", "/imu/data/linear_acceleration/z"]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
{file}
columns = ["/imu/mag/magnetic_field/x", "/imu/mag/magnetic_field/y", "/imu/mag/magnetic_field/z"]
unit = "T"
axes = "x = mx, y = my, z = mz"
"""


def _plotjuggler(tmp_path, mag_after=0.0013, together=0):
    """sensor_msgs/Imu at 100 Hz and MagneticField (tesla) at each new x-io
    magnetometer reading (about 20 Hz), `mag_after` s after the IMU sample of
    the same instant (every `together`-th at that instant): one row a
    message, the other topic's cells empty (a row of both where the two
    stamps coincide)."""
    rows = _xio(3000)
    events, m = [], 0
    for k, r in enumerate(rows):
        t = 1.7e9 + r[0]
        events.append((t, 0, [v * G for v in r[4:7]]))
        if k == 0 or r[7:10] != rows[k - 1][7:10]:
            events.append((t + (0.0 if together and m % together == 0 else mag_after), 1, [v * 1e-6 for v in r[7:10]]))
            m += 1
    events.sort(key=lambda e: (e[0], e[1]))
    p = tmp_path / "pj.csv"
    with open(p, "w") as f:
        f.write("__time," + ",".join(f"/imu/data/linear_acceleration/{c}" for c in "xyz") + ","
                + ",".join(f"/imu/mag/magnetic_field/{c}" for c in "xyz") + "\n")
        prev = None
        for t, kind, v in events:
            cells = [repr(x) for x in v]
            if prev is not None and kind == 1 and f"{t:.6f}" == prev[0]:  # one stamp: the same row
                prev[4:7] = cells
                continue
            if prev is not None:
                f.write(",".join(prev) + "\n")
            prev = [f"{t:.6f}"] + (cells + [""] * 3 if kind == 0 else [""] * 3 + cells)
        f.write(",".join(prev) + "\n")
    new = sum(1 for k, r in enumerate(rows) if k == 0 or r[7:10] != rows[k - 1][7:10])
    return p, new


def test_two_topics_one_to_a_row_are_named_with_the_file_that_pairs_them(tmp_path, capsys):
    # was "no usable data rows (... dropped: 3000 for a missing value in magnetometer ..., 594 ...)"
    p, new = _plotjuggler(tmp_path)
    (tmp_path / "s.toml").write_text(PLOTJUGGLER.format(file=""))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert f"{new} rows hold no accelerometer reading and 3000 no magnetometer reading, 0 both" in err, err
    assert '[magnetometer] file = "pj.csv"' in err, err
    # the fix as written: the magnetometer's rows of the same file, each paired with the IMU's nearest sample
    ds, rep = importlog.import_log(str(p), _desc(PLOTJUGGLER.format(file='file = "pj.csv"')))
    assert len(ds) == new
    xio = _xio(3000)
    mags = np.array([r[7:10] for k, r in enumerate(xio) if k == 0 or r[7:10] != xio[k - 1][7:10]])
    assert np.allclose(ds.columns["mx_nT"], mags[:, 0] * 1000, rtol=1e-12)


def test_a_few_stamps_in_common_keep_a_few_rows_and_say_why(tmp_path):
    # the two topics stamped on one instant now and then (one in 10): the rows of both are a coincidence, the
    # rest of the magnetometer's samples dropped with only a count
    p, new = _plotjuggler(tmp_path, together=10)
    ds, rep = importlog.import_log(str(p), _desc(PLOTJUGGLER.format(file="")))
    assert len(ds) == (new + 9) // 10
    assert any("two streams in one file" in n and 'file = "pj.csv"' in n for n in rep.notes), rep.notes


def test_every_sample_stamped_with_its_partner_is_read_row_by_row_without_a_note(tmp_path):
    # each magnetometer sample on an IMU sample's instant: every one shares a row, nothing to pair
    p, new = _plotjuggler(tmp_path, mag_after=0.0)
    ds, rep = importlog.import_log(str(p), _desc(PLOTJUGGLER.format(file="")))
    assert len(ds) == new and not any("two streams" in n for n in rep.notes), rep.notes


# ---- Xsens MT Manager export: a preamble of // lines, the magnetometer in a.u. ---------------------------------

XSENS = """name = "Xsens MTi via MT Manager export"
[log]
{comment}
time = "SampleTimeFine"
time_unit = "1/10000 s"
[accelerometer]
columns = ["Acc_X", "Acc_Y", "Acc_Z"]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
columns = ["Mag_X", "Mag_Y", "Mag_Z"]
unit = "{mag_unit}"
axes = "x = mx, y = my, z = mz"
[header]
{field}
"""
XSENS_PREAMBLE = ["// General information:", "//  MT Manager version: 2022.0.0", "// Device information:",
                  "//  ProductCode: MTi-3-8A7G6", "// Device settings:", "//  Filter Profile: general(1.00)",
                  "// Update Rate: 100.0Hz"]


def _xsens(tmp_path):
    """The x-io readings as an Xsens export writes them: tab-separated, its
    magnetometer divided by its own field (a.u.), its 10 kHz sample time."""
    rows = np.array(_xio(1500))
    field = np.median(np.linalg.norm(rows[:, 7:10], axis=1))
    p = tmp_path / "MT_012345_000.txt"
    with open(p, "w") as f:
        f.write("\n".join(XSENS_PREAMBLE) + "\n")
        f.write("\t".join(["PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Mag_X", "Mag_Y", "Mag_Z"])
                + "\n")
        for i, r in enumerate(rows):
            cells = [str(i), str(10_000_000 + round(r[0] * 1e4))] + [f"{v * G:.6f}" for v in r[4:7]] + \
                    [f"{v / field:.6f}" for v in r[7:10]]
            f.write("\t".join(cells) + "\n")
    return p


def test_an_xsens_export_imports_with_its_preamble_as_comments(tmp_path):
    ds, _ = importlog.import_log(str(_xsens(tmp_path)), _desc(XSENS.format(
        comment='comment = "//"', mag_unit="field", field="field_nT = 49500")))
    assert len(ds) == 1500
    b = np.median(np.linalg.norm(np.stack([ds.columns[c] for c in ("mx_nT", "my_nT", "mz_nT")], 1), axis=1))
    assert abs(b - 49500) < 5


def test_the_preamble_read_as_the_header_names_the_comment_mark(tmp_path, capsys):
    # with the default comment "#" the export was "no column 'Acc_X' (the log's columns: //, General, information:)"
    p = _xsens(tmp_path)
    (tmp_path / "s.toml").write_text(XSENS.format(comment="", mag_unit="field", field="field_nT = 49500"))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert f":{len(XSENS_PREAMBLE) + 1}: this line names" in err and '[log] comment = "//"' in err, err


def test_a_preamble_without_a_mark_names_the_skip_rows(tmp_path):
    p = _xsens(tmp_path)
    lines = p.read_text().splitlines()
    p.write_text("\n".join([x.lstrip("/ ") for x in lines[:len(XSENS_PREAMBLE)]] + lines[len(XSENS_PREAMBLE):]) + "\n")
    with pytest.raises(DataError) as e:
        importlog.import_log(str(p), _desc(XSENS.format(comment="", mag_unit="field", field="field_nT = 49500")))
    assert f"[log] skip_rows = {len(XSENS_PREAMBLE)}" in str(e.value), e.value


@pytest.mark.parametrize("unit,field", [("G", "field_nT = 49500"), ("uT", "field_nT = 49500"), ("G", "")])
def test_field_normalised_readings_declared_in_a_unit_of_field_name_unit_field(tmp_path, unit, field):
    # Xsens' a.u. declared G was "+102 % from the header's field_nT: the lsb or range setting looks 2x off"
    from inclino import checks

    ds, _ = importlog.import_log(str(_xsens(tmp_path)), _desc(XSENS.format(
        comment='comment = "//"', mag_unit=unit, field=field)))
    errors = [f for f in checks.run(ds).findings if f.level == "error" and f.check == "units"]
    assert len(errors) == 1 and 'unit = "field"' in errors[0].message, [f.message for f in errors]
    assert abs(errors[0].figures["logged_abs"] - 1.0) < 0.05


# the time unit of a tick counter: SampleTimeFine counts 100 us ticks (a 10 kHz clock)

def _time_findings(ds):
    from inclino import checks

    return [f for f in checks.run(ds).findings if f.check == "time"]


@pytest.mark.parametrize("declared", ["us", "s", "ns"])
def test_a_10khz_tick_counter_declared_in_another_unit_names_the_tick(tmp_path, declared):
    # declared "us" it was told time_unit = "ms" (10 rows/s, 33 deg/s): every rate 10x slow when followed
    ds, _ = importlog.import_log(str(_xsens(tmp_path)), _desc(XSENS.format(
        comment='comment = "//"', mag_unit="field", field="field_nT = 49500").replace('"1/10000 s"', f'"{declared}"')))
    found = _time_findings(ds)
    assert len(found) == 1 and f'time_unit = "100 us" (declared "{declared}")' in found[0].message, found
    assert "read as 100 us: 99 rows/s" in found[0].message and '"ms"' not in found[0].message, found[0].message
    assert found[0].figures["looks_like"] == "100 us" and "also_fits" not in found[0].figures


def test_a_tick_counter_declared_as_its_tick_imports_without_a_word_on_time(tmp_path):
    ds, _ = importlog.import_log(str(_xsens(tmp_path)), _desc(XSENS.format(
        comment='comment = "//"', mag_unit="field", field="field_nT = 49500").replace('"1/10000 s"', '"100 us"')))
    assert ds.meta["time_unit"] == "100 us" and not _time_findings(ds)
    src = np.array(_xio(1500))
    assert np.allclose(ds.columns["t_s"], 1000.0 + np.round(src[:, 0] * 1e4) * 1e-4, rtol=0, atol=1e-9)


def test_two_units_the_rows_cannot_tell_apart_are_both_named(tmp_path):
    # millis() at 20 rows/s declared us: read as ms the x-io hand turns at 66 deg/s, as 100 us ticks at 657 deg/s,
    # both where real hands turn; naming one alone would pick it on a factor of 10 nothing in the rows shows
    rows = np.array(_xio(1500))
    p = tmp_path / "millis.csv"
    with open(p, "w") as f:
        f.write("t_ms,ax,ay,az,mx,my,mz\n")
        for r in rows:
            f.write(f"{round(r[0] * 5000)}," + ",".join(f"{v:.6f}" for v in r[4:10]) + "\n")
    ds, _ = importlog.import_log(str(p), _desc(
        '[log]\ntime = "t_ms"\ntime_unit = "us"\n[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "g"\n'
        'reads = "up"\naxes = "x = ax, y = ay, z = az"\n[magnetometer]\ncolumns = ["mx", "my", "mz"]\nunit = "uT"\n'
        'axes = "x = mx, y = my, z = mz"\n'))
    found = _time_findings(ds)
    assert len(found) == 1, found
    m = found[0].message
    assert "read as ms: 20 rows/s, 65.7 deg/s, or read as 100 us: 200 rows/s, 657 deg/s" in m, m
    assert "nothing in the rows tells these apart" in m and '[log] time_unit = "ms" (declared "us"), or "100 us"' in m
    assert found[0].figures["looks_like"] == "ms" and found[0].figures["also_fits"] == ["100 us"]


# ---- ROS: the stamp in two columns, whole seconds and nanoseconds ---------------------------------------------
# `ros2 topic echo --csv` writes every field of a message in order, no header line: sensor_msgs/Imu is
# header.stamp.sec, .nanosec, header.frame_id, orientation x y z w, its covariance (9), angular_velocity x y z, its
# covariance (9), linear_acceleration x y z (columns 29-31), its covariance (9); sensor_msgs/MagneticField is
# header (3 columns), magnetic_field x y z in tesla (4-6), its covariance (9).  A ROS 1 bag read by bagpy
# (message_by_topic) names its columns: Time (the bag's receive time, float seconds), header.seq,
# header.stamp.secs, header.stamp.nsecs, header.frame_id, ...

T0_NS = 1_700_000_000 * 10**9 + 987_654_321  # the first stamp: the fraction of a second at the float64 edge
COV = ",".join(["0.0"] * 9)

ROS2 = """name = "ros2 topic echo --csv /imu/data, /imu/mag"
[log]
header = false
{time}
[accelerometer]
columns = [29, 30, 31]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
[magnetometer]
file = "mag.csv"
columns = [4, 5, 6]
unit = "T"
axes = "x = mx, y = my, z = mz"
"""


def _stamp(r, after_ns=0):
    """A row's stamp in integer nanoseconds: the x-io row's time, from T0_NS,
    with a jitter of its own in the last digits (a stamp's nanoseconds)."""
    return T0_NS + round(r[0] * 1e9) + (int(r[0] * 1e4) * 7919) % 997 + after_ns


def _ros2(tmp_path, n=600):
    rows = _xio(n)
    with open(tmp_path / "imu.csv", "w") as f:
        for r in rows:
            ns = _stamp(r)
            a = [v * G for v in r[4:7]]
            f.write(f"{ns // 10**9},{ns % 10**9},imu_link,0.0,0.0,0.0,1.0,{COV},0.0,0.0,0.0,{COV},"
                    f"{a[0]!r},{a[1]!r},{a[2]!r},{COV}\n")
    mags = [(k, r) for k, r in enumerate(rows) if k == 0 or r[7:10] != rows[k - 1][7:10]]
    with open(tmp_path / "mag.csv", "w") as f:
        for _, r in mags:
            ns = _stamp(r, after_ns=1_300_000)  # 1.3 ms after the IMU sample of its instant
            f.write(f"{ns // 10**9},{ns % 10**9},imu_link,{r[7] * 1e-6!r},{r[8] * 1e-6!r},{r[9] * 1e-6!r},{COV}\n")
    return rows, mags


def test_a_ros2_stamp_in_two_columns_is_read_whole_and_pairs_two_topics(tmp_path):
    # before, a description could name one time column: the sec column alone was refused at pairing
    rows, mags = _ros2(tmp_path)
    ds, rep = importlog.import_log(str(tmp_path / "imu.csv"), _desc(ROS2.format(time="time = [1, 2]")))
    assert len(ds) == len(mags) and ds.meta["time_unit"] == "s + ns"
    assert np.allclose(ds.columns["mx_nT"], [r[7] * 1000 for _, r in mags], rtol=1e-12)
    # the rows are the magnetometer's (the slower), each with the IMU sample of its instant
    assert np.allclose(ds.columns["ax_g"], [-r[4] for k, r in mags], rtol=1e-12)
    # t_s from the first row paired, the log's (IMU) stamps to well within a nanosecond (1 ps: counted from
    # the log's first whole second while paired, then from the first row)
    ns = np.array([_stamp(r) for r in rows])[[k for k, _ in mags]]
    assert np.max(np.abs(ds.columns["t_s"] - (ns - ns[0]) / 1e9)) < 1e-12


BAGPY = """name = "bagpy message_by_topic of /imu/data"
[log]
time = {time}
[accelerometer]
columns = ["linear_acceleration.x", "linear_acceleration.y", "linear_acceleration.z"]
unit = "m/s2"
reads = "up"
axes = "x = ax, y = ay, z = az"
"""


def _bagpy(tmp_path, n=1500):
    rows = _xio(n)
    p = tmp_path / "imu-data.csv"
    with open(p, "w") as f:
        f.write("Time,header.seq,header.stamp.secs,header.stamp.nsecs,header.frame_id,orientation.x,orientation.y,"
                "orientation.z,orientation.w,orientation_covariance,angular_velocity.x,angular_velocity.y,"
                "angular_velocity.z,angular_velocity_covariance,linear_acceleration.x,linear_acceleration.y,"
                "linear_acceleration.z,linear_acceleration_covariance\n")
        cov = '"(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)"'
        for k, r in enumerate(rows):
            ns = _stamp(r)
            a = [v * G for v in r[4:7]]
            f.write(f"{(ns + 2_500_000) / 1e9:.9f},{k},{ns // 10**9},{ns % 10**9},imu_link,0.0,0.0,0.0,1.0,{cov},"
                    f"0.0,0.0,0.0,{cov},{a[0]!r},{a[1]!r},{a[2]!r},{cov}\n")
    return p, np.array([_stamp(r) for r in rows])


def test_a_ros1_stamp_in_two_columns_is_joined_exactly_from_the_first_row(tmp_path):
    p, ns = _bagpy(tmp_path)
    ds, _ = importlog.import_log(str(p), _desc(BAGPY.format(time='["header.stamp.secs", "header.stamp.nsecs"]')))
    exact = (ns - ns[0]) / 1e9
    assert np.array_equal(ds.columns["t_s"], exact)
    # sec + nsec x 1e-9 in float64 (an epoch's seconds) rounds each stamp to 0.24 us: what the join keeps
    naive = (ns // 10**9 + (ns % 10**9) * 1e-9)
    assert np.max(np.abs((naive - naive[0]) - exact)) > 1e-7


def test_a_stamp_in_whole_seconds_alone_names_the_line_that_reads_it_whole(tmp_path, capsys):
    # time = the secs column alone: every row's time cut to its second, imported with exit 0 in silence
    p, _ = _bagpy(tmp_path)
    (tmp_path / "s.toml").write_text(BAGPY.format(time='"header.stamp.secs"'))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert '[log] time = ["header.stamp.secs", "header.stamp.nsecs"]' in err and "whole seconds" in err, err
    assert not (tmp_path / "run.csv").exists()


def test_a_ros2_stamp_in_whole_seconds_alone_names_the_columns_by_number(tmp_path):
    # time = the sec column: "most rows share their time stamp with the row before: nothing to pair by", no cause
    _ros2(tmp_path)
    with pytest.raises(DataError) as e:
        importlog.import_log(str(tmp_path / "imu.csv"), _desc(ROS2.format(time='time = 1\ntime_unit = "s"')))
    assert "whole seconds" in str(e.value) and "[log] time = [1, 2]" in str(e.value), e.value


def test_a_whole_second_column_beside_a_sample_index_is_no_split_stamp(tmp_path):
    # the column after the seconds counts samples within the second (0 ... 99), not nanoseconds: no stamp named
    rows = _xio(600)
    p = tmp_path / "gps.csv"
    with open(p, "w") as f:
        f.write("gps_s,sample,ax,ay,az\n")
        for k, r in enumerate(rows):
            f.write(f"{1_400_000_000 + k // 100},{k % 100},{r[4]},{r[5]},{r[6]}\n")
    ds, _ = importlog.import_log(str(p), _desc('[log]\ntime = "gps_s"\n[accelerometer]\ncolumns = ["ax", "ay", "az"]\n'
                                               'unit = "g"\nreads = "up"\naxes = "x = ax, y = ay, z = az"\n'))
    assert len(ds) == 600


def test_a_triad_file_of_its_own_takes_its_stamp_in_two_columns_too(tmp_path):
    rows, mags = _ros2(tmp_path)
    text = ROS2.format(time="time = [1, 2]").replace('file = "mag.csv"', 'file = "mag.csv"\ntime = [1, 2]')
    ds, _ = importlog.import_log(str(tmp_path / "imu.csv"), _desc(text))
    assert len(ds) == len(mags) and ds.meta["time_unit"] == "s + ns"


@pytest.mark.parametrize("time,words", [
    ('["header.stamp.nsecs", "header.stamp.secs"]',
     ['is no nanoseconds of a second', 'swapped', '[log] time = ["header.stamp.secs", "header.stamp.nsecs"]']),
    ('["header.stamp.secs", "Time"]', ["is no nanoseconds of a second", "not the stamp's nanoseconds column"]),
    ('["Time", "header.stamp.nsecs"]', ["is no whole second"]),
    ('["header.stamp.secs", "header.stamp.nanosec"]',
     ["[log].time[2] (nanoseconds)", "no column 'header.stamp.nanosec'"]),
])
def test_a_wrong_pairing_of_the_stamp_columns_is_one_line(tmp_path, capsys, time, words):
    p, _ = _bagpy(tmp_path, 300)
    (tmp_path / "s.toml").write_text(BAGPY.format(time=time))
    rc = main(["import", str(p), "--sensor", str(tmp_path / "s.toml"), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == 2 and len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert all(w in err for w in words), err


@pytest.mark.parametrize("log,words", [
    ('time = ["a", "b"]\ntime_unit = "ms"', ["two columns", "leave time_unit out"]),
    ('time = ["a"]', ["[whole seconds, nanoseconds]"]),
    ('time = ["a", "b"]\nrate_hz = 100', ["rate_hz and time"]),
])
def test_a_stamp_in_two_columns_is_described_as_such(log, words):
    with pytest.raises(DataError) as e:
        _desc(f"[log]\n{log}\n[accelerometer]\ncolumns = [\"x\", \"y\", \"z\"]\n")
    assert all(w in str(e.value) for w in words), e.value
