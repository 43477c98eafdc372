"""The real-data corpus (tests/data/real): every log imports through its
sensor description and reads back as a canonical dataset; the derived files
are the published ones."""
import json
from pathlib import Path

import numpy as np
import pytest

from inclino.cli import main
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
SAP6 = ("BB", "CF", "FG", "HC", "IB", "JG")

# (log, description, triads, rows)
CORPUS = [
    ("imucal_ferraris/annotated_session.csv", "imucal_ferraris/sensor.toml", "acc", 5596),
    ("ck_acc_mag/acc_mag_log.csv", "ck_acc_mag/sensor.toml", "both", 12000),
    ("ck_acc_mag/acc_log.csv", "ck_acc_mag/acc_only.toml", "acc", 16000),
    ("broad/05.csv", "broad/sensor.toml", "mag", 2861),
    ("broad/02.csv", "broad/sensor.toml", "mag", 2577),
    ("broad/05.csv", "broad/with_acc.toml", "both", 2861),
    ("micropython_fusion/mpudata.csv", "micropython_fusion/sensor.toml", "both", 2041),
    ("airbrakes_cx5/six_faces.csv", "airbrakes_cx5/sensor.toml", "acc", 4141),
    ("ngimu/sensors.csv", "ngimu/sensor.toml", "both", 499),
    ("pololu_minimu9/data_polulu.txt", "pololu_minimu9/sensor.toml", "both", 3653),
    ("xio_fusion/sensor_data.csv", "xio_fusion/sensor.toml", "both", 13514),
    ("yei_3space/data_yei.txt", "yei_3space/sensor.toml", "both", 2714),
    ("mikoff_mpu9150/imu0_rows5001-10900.log", "mikoff_mpu9150/sensor.toml", "acc", 5900),
] + [(f"sap6/{d}.csv", "sap6/sensor.toml", "both", 24) for d in SAP6]


def test_every_corpus_dataset_has_its_licence_source_and_description():
    for d in sorted(p for p in REAL.iterdir() if p.is_dir()):
        assert (d / "LICENSE").is_file(), d
        src = (d / "SOURCE.md").read_text(encoding="utf-8").lower()
        for word in ("repository", "commit", "licen"):
            assert word in src, (d, word)
        assert list(d.glob("*.toml")), d


@pytest.mark.parametrize("log,desc,triads,rows", CORPUS)
def test_corpus_imports_and_reads_back(tmp_path, log, desc, triads, rows, capsys):
    out = tmp_path / "run.csv"
    assert main(["import", str(REAL / log), "--sensor", str(REAL / desc), "-o", str(out)]) == 0
    ds = dataset.read_raw(str(out))
    assert len(ds) == rows and ds.triads == triads
    assert ds.meta["log_sha256"] and ds.meta["sensor_sha256"] and ds.meta["source"].endswith(Path(log).name)
    if ds.has_acc:  # the units and the gravity sign made g of the readings
        assert 0.9 < np.median(np.linalg.norm(ds.acc, axis=1)) < 1.1


def test_sap6_tables_are_the_published_json():
    for d in SAP6:
        js = json.loads((REAL / "sap6" / "original" / f"{d}.json").read_text())
        tab = np.loadtxt(REAL / "sap6" / f"{d}.csv", delimiter=",", skiprows=1)
        assert np.array_equal(tab[:, 2:5], np.array(js["grav"]))
        assert np.array_equal(tab[:, 5:8], np.array(js["mag"]))
        assert np.array_equal(tab[:, 1], np.repeat([0, 1, 2], 8))


def test_sap6_axis_maps_are_mag_cal_maps_turned_into_the_body_frame():
    """The description's maps are mag_cal's published ones (the .cfg's
    grav_axes/mag_axes) composed with the body frame (z = device Y, x =
    device Z, y = device X); gravity pointing down."""
    desc = sensor.load(str(REAL / "sap6" / "sensor.toml"))
    to_body = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]])  # body <- device
    for d in SAP6:
        cfg = json.loads((REAL / "sap6" / "original" / f"{d}.cfg").read_text())
        for key, triad, down in (("grav_axes", desc.acc, True), ("mag_axes", desc.mag, False)):
            s = cfg[key].upper()
            dev = np.zeros((3, 3))  # device <- sensor, mag_cal's Axes
            for i in range(3):
                dev[i, "XYZ".index(s[2 * i + 1])] = 1 if s[2 * i] == "+" else -1
            want = to_body @ dev
            v = np.array([[0.3, -0.5, 0.8]])
            assert np.allclose(triad.convert(v), v @ want.T * (1.0 if not down else 1.0 / sensor.STANDARD_GRAVITY)
                               * (1.0 if down else 1e3))
        assert desc.mag.det == -1 and desc.mag.reflection and desc.acc.det == 1


def test_imucal_faces_get_their_poses():
    ds, rep = importlog.import_log(str(REAL / "imucal_ferraris" / "annotated_session.csv"),
                                   sensor.load(str(REAL / "imucal_ferraris" / "sensor.toml")))
    assert rep.dropped == {"no pose for label (part)": 3818}
    # every face reads about +1 g along the axis its pose puts down
    from inclino.engines import reference as ref

    C = ref.pose_matrix(ds.columns["inc_deg"], np.zeros(len(ds)), ds.columns["tf_deg"])
    down = C[:, :, 2]
    assert np.all(np.einsum("ni,ni->n", down, ds.acc) > 0.95)


def test_presets_load_and_cite_their_data_sheet():
    for name in sensor.presets():
        d = sensor.load(name)
        assert d.triads and d.source
        text = (sensor.PRESET_DIR / f"{name}.toml").read_text()
        assert text.lstrip().startswith("#")  # the data sheet facts are said where they are used
        for t in d.triads:
            assert t.det == 1  # a package's own axes, turned into its accelerometer's frame: a rotation
    assert sensor.default().name.startswith("ADIS16210")


def test_a_preset_with_overrides_imports_a_log(tmp_path):
    """An MPU-9250 log in counts with its own column names: the preset gives
    the scales and the magnetometer's axes (X_mag = Y_acc, Y_mag = X_acc,
    Z_mag = -Z_acc), the file only the columns."""
    g = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, -1.0, 0.0]])  # specific force (up), g
    b_acc = np.array([[20.0, 5.0, -40.0], [10.0, -30.0, 15.0], [-25.0, 12.0, 33.0]])  # field in acc axes, uT
    b_mag = np.column_stack([b_acc[:, 1], b_acc[:, 0], -b_acc[:, 2]])  # the AK8963's own axes
    log = tmp_path / "mpu.csv"
    rows = ["AX;AY;AZ;HX;HY;HZ"] + [";".join(str(int(round(v))) for v in np.concatenate([a * 16384, m / 0.15]))
                                    for a, m in zip(g, b_mag)]
    log.write_text("\n".join(rows) + "\n")
    desc = tmp_path / "mpu.toml"
    desc.write_text('preset = "mpu9250"\nname = "a breakout"\n[accelerometer]\ncolumns = ["AX", "AY", "AZ"]\n'
                    '[magnetometer]\ncolumns = ["HX", "HY", "HZ"]\n')
    ds, rep = importlog.import_log(str(log), sensor.load(str(desc)))
    assert np.allclose(ds.acc, -g, atol=1e-4)  # +1 g on the axis pointing down
    assert np.allclose(ds.mag, b_acc * 1000.0, atol=100.0)  # nT, in the accelerometer's frame
    assert ds.meta["mag_axes"] == "x = my, y = mx, z = -mz"


@pytest.mark.parametrize("toml, message", [
    ('[accelerometer]\ncolumns = ["a", "b", "c"]\nunit = "counts"\n', "needs lsb"),
    ('[magnetometer]\ncolumns = ["a", "b", "c"]\nunit = "counts"\n',
     "needs lsb, what one count is (e.g. lsb = '0.15 uT')"),
    ('[accelerometer]\ncolumns = ["a", "b", "c"]\nunit = "furlongs"\n', "unknown unit"),
    ('[accelerometer]\ncolumns = ["a", "b", "c"]\naxes = "x = ax, y = ax, z = az"\n', "uses a sensor axis twice"),
    ('[accelerometer]\ncolumns = ["a", "b", "c"]\nx = "-ax"\ny = "ay"\nz = "az"\n', "reflection"),
    ('[accelerometer]\ncolumns = ["a", "b"]\n', "three column names"),
    ('[magnetometer]\ncolumns = ["a", "b", "c"]\nreads = "up"\n', "only the accelerometer"),
    ('[accelerometer]\ncolumns = ["a", "b", "c"]\nreads = "sideways"\n', "'up'"),
    ('name = "x"\n', "describes no triad"),
    ('[acclerometer]\ncolumns = ["a", "b", "c"]\n', "unknown key(s) acclerometer"),
    ('[accelerometer\n', "not valid TOML"),
])
def test_a_bad_description_is_one_line_naming_the_key(toml, message):
    with pytest.raises(Exception) as e:
        sensor.from_toml(toml)
    assert message in str(e.value) and "\n" not in str(e.value)


def test_import_bad_input_is_one_line_exit_2(tmp_path, capsys):
    log = tmp_path / "log.csv"
    log.write_text("ax,ay,az\n0.1,0.2,0.97\n0.1,oops,0.97\n")
    desc = tmp_path / "d.toml"
    desc.write_text('[accelerometer]\ncolumns = ["ax", "ay", "az"]\n')
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert ":3:" in err and "ay" in err and err.count("\n") == 1
    desc.write_text('[accelerometer]\ncolumns = ["ax", "ay", "AZZ"]\n')
    assert main(["import", str(log), "--sensor", str(desc), "-o", str(tmp_path / "o.csv")]) == 2
    assert "no column 'AZZ'" in capsys.readouterr().err
    assert main(["import", str(log), "--sensor", "nosuchpreset", "-o", str(tmp_path / "o.csv")]) == 2
    assert "not a preset" in capsys.readouterr().err


@pytest.mark.parametrize("acc_unit,acc_factor", [("m/s^2", 9.80665), ("m/s²", 9.80665), ("m s^-2", 9.80665),
                                                  ("M/S2", 9.80665), ("m/s/s", 9.80665), ("milli-g", 1000.0),
                                                  ("mg", 1000.0), ("G", 1.0), ("cm/s^2", 980.665)])
@pytest.mark.parametrize("mag_unit,mag_factor", [("µT", 1e-3), ("μT", 1e-3), ("microtesla", 1e-3), ("uT", 1e-3),
                                                  ("mG", 1e-2), ("milligauss", 1e-2), ("Gauss", 1e-5),
                                                  ("nT", 1.0)])
def test_units_as_people_spell_them_import_to_g_and_nT(tmp_path, acc_unit, acc_factor, mag_unit, mag_factor):
    """The same readings written in another unit, with that unit's usual
    spelling in the description, import to the same g and nT."""
    ds0 = importlog.import_log(str(REAL / "sap6" / "BB.csv"), sensor.load(str(REAL / "sap6" / "sensor.toml")))[0]
    raw = np.column_stack([-ds0.acc[:, [2, 1, 0]] * [1, 1, -1] * acc_factor, ds0.mag * mag_factor])
    # sensor axes: a = (z, y, -x) of the body, read up; m = body axes
    log = tmp_path / "log.csv"
    log.write_text("ax,ay,az,mx,my,mz\n" + "\n".join(",".join(f"{v:.9g}" for v in r) for r in raw) + "\n",
                   encoding="utf-8")
    desc = sensor.from_toml(f'[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "{acc_unit}"\nreads = "up"\n'
                            f'axes = "x = -az, y = ay, z = ax"\n[magnetometer]\ncolumns = ["mx", "my", "mz"]\n'
                            f'unit = "{mag_unit}"\n')
    ds = importlog.import_log(str(log), desc)[0]
    assert np.allclose(ds.acc, ds0.acc, rtol=1e-6, atol=1e-9)
    assert np.allclose(ds.mag, ds0.mag, rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize("axes", ['"x = -ay, y = ax, z = az"', '"-y, x, z"', '"-Y+X+Z"', '["-acc_y", "acc_x", "acc_z"]',
                                  '"x = -acc_y, y = acc_x, z = acc_z"'])
def test_axis_maps_as_people_write_them_mean_the_same_map(axes):
    d = sensor.from_toml(f'[accelerometer]\ncolumns = ["acc_x", "acc_y", "acc_z"]\naxes = {axes}\n')
    assert d.acc.axes_text() == "x = -ay, y = ax, z = az"


@pytest.mark.parametrize("axes", ['"-Y-X+Z"', '"x = acc_y, y = acc_x, z = acc_z"'])
def test_a_left_handed_map_in_any_spelling_is_refused_with_the_fix(axes):
    with pytest.raises(Exception) as e:
        sensor.from_toml(f'[accelerometer]\ncolumns = ["acc_x", "acc_y", "acc_z"]\naxes = {axes}\n')
    msg = str(e.value)
    assert "reflection" in msg and "reflection = true" in msg and "\n" not in msg


def test_a_log_with_decimal_commas_and_iso_time_stamps_imports(tmp_path):
    """A log as a spreadsheet in a comma-decimal locale writes it: semicolons,
    decimal commas, ISO 8601 time stamps."""
    ds0 = importlog.import_log(str(REAL / "sap6" / "BB.csv"), sensor.load(str(REAL / "sap6" / "sensor.toml")))[0]
    lines = ["time;gx;gy;gz;mx;my;mz"]
    for i, (a, m) in enumerate(zip(ds0.acc, ds0.mag)):
        stamp = f"2024-05-01T12:00:{i * 2.5:06.3f}Z"
        cells = [f"{v:.9g}".replace(".", ",") for v in list(a) + list(m / 1000.0)]
        lines.append(";".join([stamp] + cells))
    log = tmp_path / "locale.csv"
    log.write_text("\n".join(lines) + "\n", encoding="utf-8")
    desc = sensor.from_toml('[log]\ndecimal = ","\ntime = "time"\n[accelerometer]\ncolumns = ["gx", "gy", "gz"]\n'
                            '[magnetometer]\ncolumns = ["mx", "my", "mz"]\nunit = "µT"\n')
    ds = importlog.import_log(str(log), desc)[0]
    assert np.allclose(ds.acc, ds0.acc, rtol=1e-6) and np.allclose(ds.mag, ds0.mag, rtol=1e-6)
    assert np.allclose(ds.columns["t_s"], 2.5 * np.arange(len(ds0)))


def test_decimal_comma_with_a_comma_delimiter_is_one_line():
    with pytest.raises(Exception) as e:
        sensor.from_toml('[log]\ndecimal = ","\ndelimiter = ","\n[accelerometer]\ncolumns = ["a", "b", "c"]\n')
    assert "decimal" in str(e.value) and "delimiter" in str(e.value)


def test_a_units_line_under_the_header_is_dropped_and_counted(tmp_path):
    body = (REAL / "sap6" / "BB.csv").read_text().splitlines()
    log = tmp_path / "units.csv"
    log.write_text("\n".join([body[0], "n,n,m/s2,m/s2,m/s2,uT,uT,uT"] + body[1:]) + "\n")
    ds, rep = importlog.import_log(str(log), sensor.load(str(REAL / "sap6" / "sensor.toml")))
    assert len(ds) == 24 and rep.dropped == {"a second header line (units or descriptions)": 1}
    log.write_text("\n".join([body[0]] + body[1:3] + ["n,n,m/s2,m/s2,m/s2,uT,uT,uT"] + body[3:]) + "\n")
    with pytest.raises(Exception) as e:  # text among the data is still an error naming the row
        importlog.import_log(str(log), sensor.load(str(REAL / "sap6" / "sensor.toml")))
    assert ":4:" in str(e.value) and "not a number" in str(e.value)


def test_a_decimal_reading_in_a_decimal_unit_is_written_as_the_decimal_it_means(tmp_path):
    """0.27356 G is 27356 nT: the canonical file says 27356.0, not the binary
    product 27356.000000000004; the header's 0.14 mG is 14.0 nT.  Values
    without a unit conversion pass bit for bit."""
    out = tmp_path / "ck.csv"
    assert main(["import", str(REAL / "ck_acc_mag" / "acc_mag_log.csv"), "--sensor",
                 str(REAL / "ck_acc_mag" / "sensor.toml"), "-o", str(out)]) == 0
    text = out.read_text()
    assert "# mag_lsb_nT=14.0\n" in text
    data = [line.split(",") for line in text.splitlines() if not line.startswith("#")]
    rows = [dict(zip(data[0], r)) for r in data[1:]]
    assert rows[1]["my_nT"] == "27356.0" and rows[1]["ax_g"] == "0.0936042"
    # every field value is a whole number of the 14 nT quantum, written without binary noise
    assert all(r[c].endswith(".0") for r in rows for c in dataset.MAG_COLS)
    raw = np.loadtxt(REAL / "ck_acc_mag" / "acc_mag_log.csv", delimiter=",", skiprows=1)
    ds = dataset.read_raw(str(out))
    assert np.array_equal(ds.acc, -raw[:, :3])   # g in g: no conversion, bit for bit
    assert np.allclose(ds.mag, raw[:, 3:] * 1e5, rtol=1e-15, atol=0)


def test_the_ck_description_is_what_its_data_say():
    """CK's triads share one frame (no other signed permutation of the
    magnetometer's axes comes close to the declared map's dip spread), and
    with the source's gravity sign (+1 g on the axis pointing up: its
    document's accelerometer senses (0, 0, -G) in NED) the dip is about
    -18 deg: turning the sign turns it, nothing in the description makes
    it +64 deg."""
    from inclino import checks
    from inclino.calib.ellipsoid import signed_permutations
    from inclino.checks import _dip, _robust_std, _unit_dirs

    ds = importlog.import_log(str(REAL / "ck_acc_mag" / "acc_mag_log.csv"),
                              sensor.load(str(REAL / "ck_acc_mag" / "sensor.toml")))[0]
    ug, _ = _unit_dirs(ds.acc, 1.0)
    ub, _ = _unit_dirs(ds.mag, 50_000.0)
    spread = {tuple(P.ravel()): _robust_std(_dip(ug, ub @ P.T)) for P in signed_permutations()}
    declared = spread.pop(tuple(np.eye(3).ravel()))
    spread.pop(tuple(-np.eye(3).ravel()))  # the same map with every sign turned: the same spread, the dip's sign
    assert declared * 5 < min(spread.values())
    rep = checks.run(ds)
    assert rep.mag_to_acc is None and -20.0 < rep.noise["dip_deg"] < -15.0


def test_garbled_serial_lines_are_refused_or_dropped_and_counted(tmp_path, capsys):
    """A line cut short and a line with a garbled cell in CK's real log (as
    a serial link drops bytes): refused naming the line and the option by
    default; with --drop-bad-rows (or [log] bad_rows = "drop") the rest of
    the log imports as it does without those lines, the lines counted and
    named; more than 5 % of the rows malformed is still refused."""
    body = (REAL / "ck_acc_mag" / "acc_mag_log.csv").read_text().splitlines()
    desc = str(REAL / "ck_acc_mag" / "sensor.toml")
    cut = body[101].rsplit(",", 4)[0]          # data line 101 (file line 102) loses its last four cells
    garbled = body[201].replace(",", ",-\x7f", 1)  # a cell that is not a number
    log = tmp_path / "garbled.csv"
    log.write_text("\n".join(body[:101] + [cut] + body[102:201] + [garbled] + body[202:]) + "\n")
    out = tmp_path / "o.csv"
    assert main(["import", str(log), "--sensor", desc, "-o", str(out)]) == 2
    err = capsys.readouterr().err
    assert ":102:" in err and "--drop-bad-rows" in err and err.count("\n") == 1 and not out.exists()
    assert main(["import", str(log), "--sensor", desc, "-o", str(out), "--drop-bad-rows"]) == 0
    assert "dropped 2 row(s): malformed: cells missing or not a number (lines 102, 202)" in capsys.readouterr().out
    clean = tmp_path / "clean.csv"
    clean.write_text("\n".join(body[:101] + body[102:201] + body[202:]) + "\n")
    ref, _ = importlog.import_log(str(clean), sensor.load(desc))
    got = dataset.read_raw(str(out))
    assert len(got) == len(ref) == len(body) - 3
    assert np.array_equal(got.acc, ref.acc) and np.array_equal(got.mag, ref.mag)
    # the description's own switch does the same
    d = sensor.load(desc)
    d.bad_rows = "drop"
    ds, rep = importlog.import_log(str(log), d)
    assert len(ds) == len(ref) and sum(rep.dropped.values()) == 2
    # a description that does not fit the log is not mended by dropping lines
    many = tmp_path / "many.csv"
    many.write_text("\n".join(body[:1] + [r.rsplit(",", 1)[0] if i % 10 == 0 else r
                                          for i, r in enumerate(body[1:])]) + "\n")
    assert main(["import", str(many), "--sensor", desc, "-o", str(out), "--drop-bad-rows"]) == 2
    assert "does not fit the log" in capsys.readouterr().err
