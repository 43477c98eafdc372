"""A triad logged to a file of its own (a phone's accelerometer and
magnetometer files, two sensors on two loggers): `[magnetometer] file =
...` reads it through the same description and pairs its samples with the
log's by time (docs/dataset.md, "Two files, one run")."""
import csv
import json
from pathlib import Path

import numpy as np
import pytest

from inclino.cli import main
from inclino.errors import DataError
from inclino.formats import dataset, importlog, sensor

REAL = Path(__file__).parent / "data" / "real"
BROAD = REAL / "broad"


def _with_acc():
    """BROAD's with_acc.toml without its [gyroscope] (the files split here
    carry no gyroscope columns)."""
    text = (BROAD / "with_acc.toml").read_text()
    return text[:text.index("[gyroscope]")] + text[text.index("[header]"):]


def _broad():
    with open(BROAD / "02.csv") as f:
        rows = list(csv.DictReader(f))
    return rows


def _write(path, names, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(names)
        w.writerows(rows)


ACC_COLS = ["acc_x", "acc_y", "acc_z"]
MAG_COLS = ["mag_x", "mag_y", "mag_z"]
POSE_COLS = ["inc_deg", "azi_deg", "tf_deg"]


def _split(tmp_path, drop=None):
    """BROAD's gimbal log 02 as two files: the accelerometer (and the poses)
    at every row, the magnetometer at every second row, its time stamp 1 ms
    late under its own column name (t_mag); rows `drop` (a slice) lost from
    the accelerometer's file."""
    rows = _broad()
    acc = [[r["t_s"]] + [r[c] for c in ACC_COLS + POSE_COLS] for r in rows]
    if drop is not None:
        del acc[drop]
    mag = [[f"{float(r['t_s']) + 0.001:.6f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
    _write(tmp_path / "acc.csv", ["t_s"] + ACC_COLS + POSE_COLS, acc)
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    return rows


def _toml(tmp_path, mag_extra="", log_extra=""):
    text = _with_acc()
    text = text.replace('[log]\n', '[log]\n' + log_extra)
    text = text.replace('[magnetometer]\n', '[magnetometer]\nfile = "mag.csv"\ntime = "t_mag"\n' + mag_extra)
    p = tmp_path / "s.toml"
    p.write_text(text)
    return sensor.load(str(p))


def _whole():
    """The single-file import of the same log: the reference."""
    return importlog.import_log(str(BROAD / "02.csv"), sensor.from_toml(_with_acc()))[0]


def test_a_magnetometer_in_its_own_file_is_paired_with_the_accelerometer_nearest_in_time(tmp_path):
    """Every second row's magnetometer, stamped 1 ms late: each is paired
    with the accelerometer row it was logged beside, the readings exactly
    those of the single-file import of the same rows."""
    rows = _split(tmp_path)
    ds, rep = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path))
    ref = _whole()
    idx = np.arange(0, len(rows), 2)
    assert len(ds) == len(idx) and rep.rows == len(idx)
    for c in dataset.ACC_COLS + dataset.MAG_COLS + ("t_s", "inc_deg", "azi_deg", "tf_deg"):
        np.testing.assert_array_equal(ds.columns[c], ref.columns[c][idx], err_msg=c)
    assert ds.meta["source"] == f"{tmp_path / 'acc.csv'} + {tmp_path / 'mag.csv'}"
    assert ds.meta["paired_log_sha256"] == importlog._sha256(str(tmp_path / "mag.csv"))
    assert "magnetometer" in ds.meta["pairing"] and "|dt| median 1 ms" in ds.meta["pairing"]
    assert any(n == ds.meta["pairing"] for n in rep.notes)
    assert ds.meta["mag_unit"] == "uT" and ds.meta["acc_unit"] == "m/s2"  # both triads' record


def test_the_log_may_hold_the_slower_triad(tmp_path):
    """The magnetometer's file the log, the accelerometer at twice its rate
    in the file of its own: each magnetometer row with its accelerometer."""
    rows = _split(tmp_path)
    text = _with_acc()
    text = text.replace('[accelerometer]\n', '[accelerometer]\nfile = "acc.csv"\ntime = "t_s"\n')
    text = text.replace('time = "t_s"\ntime_unit = "s"\n\n[accelerometer]', 'time = "t_mag"\ntime_unit = "s"\n\n'
                        '[accelerometer]')
    text = text.replace('[poses]\ninc = "inc_deg"\nazi = "azi_deg"\ntf = "tf_deg"\n', '')
    p = tmp_path / "s.toml"
    p.write_text(text)
    ds, _ = importlog.import_log(str(tmp_path / "mag.csv"), sensor.load(str(p)))
    ref = _whole()
    idx = np.arange(0, len(rows), 2)
    for c in dataset.ACC_COLS + dataset.MAG_COLS:
        np.testing.assert_array_equal(ds.columns[c], ref.columns[c][idx], err_msg=c)
    np.testing.assert_allclose(ds.columns["t_s"], ref.columns["t_s"][idx] + 0.001, atol=1e-9)  # the log's times
    assert ds.meta["pairing"].startswith("magnetometer (")


def test_a_gap_in_the_faster_file_drops_the_samples_in_it_and_counts_them(tmp_path):
    """Forty accelerometer rows lost: the twenty magnetometer samples logged
    in the gap have no partner within 3/4 of the accelerometer's period and
    are dropped, counted; every other pairs as before."""
    rows = _split(tmp_path, drop=slice(100, 140))
    ds, rep = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path))
    ref = _whole()
    idx = np.array([i for i in range(0, len(rows), 2) if not 100 <= i < 140])
    np.testing.assert_array_equal(ds.columns["mx_nT"], ref.columns["mx_nT"][idx])
    np.testing.assert_array_equal(ds.columns["ax_g"], ref.columns["ax_g"][idx])
    (why,) = [k for k in rep.dropped if "no accelerometer sample within" in k]
    assert rep.dropped[why] == 20 and why in ds.meta["rows_dropped"]


def test_the_lag_applies_to_the_rows_as_paired(tmp_path):
    """[magnetometer] lag = 1: the magnetometer's paired row i + 1 with the
    accelerometer's row i (the checks name lags in rows as imported)."""
    rows = _split(tmp_path)
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path, mag_extra="lag = 1\n"))
    ref = _whole()
    idx = np.arange(0, len(rows), 2)
    np.testing.assert_array_equal(ds.columns["ax_g"], ref.columns["ax_g"][idx[:-1]])
    np.testing.assert_array_equal(ds.columns["mx_nT"], ref.columns["mx_nT"][idx[1:]])
    assert ds.meta["mag_lag_rows"] == "1"


def test_the_magnetometers_own_time_unit(tmp_path):
    """The magnetometer's file timed in ms: its own time_unit."""
    rows = _broad()
    _split(tmp_path)
    mag = [[f"{(float(r['t_s']) + 0.001) * 1e3:.3f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path, mag_extra='time_unit = "ms"\n'))
    np.testing.assert_array_equal(ds.columns["mx_nT"], _whole().columns["mx_nT"][::2])


def test_both_files_timed_by_date_times(tmp_path):
    """Both files stamped with ISO 8601 date-times: paired on them, the
    rows' t_s in seconds from the first row kept, as for one file."""
    rows = _broad()
    stamp = lambda s: f"2024-05-01T12:{int(s // 60):02d}:{s % 60:06.3f}"  # noqa: E731
    acc = [[stamp(float(r["t_s"]))] + [r[c] for c in ACC_COLS + POSE_COLS] for r in rows]
    mag = [[stamp(float(r["t_s"]) + 0.001)] + [r[c] for c in MAG_COLS] for r in rows[::2]]
    _write(tmp_path / "acc.csv", ["t_s"] + ACC_COLS + POSE_COLS, acc)
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path))
    ref = _whole()
    np.testing.assert_array_equal(ds.columns["mx_nT"], ref.columns["mx_nT"][::2])
    t = ref.columns["t_s"][::2]
    np.testing.assert_allclose(ds.columns["t_s"], t - t[0], atol=6e-4)  # stamped to the ms
    assert ds.meta["time_unit"] == "date-time"


def test_the_command_lines_static_declaration_wins_as_for_one_file(tmp_path):
    _split(tmp_path)
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path, log_extra="static = false\n"), static=True)
    assert ds.meta["static"] == "true"


def test_a_file_on_a_clock_of_its_own_is_paired_through_its_time_offset(tmp_path):
    """A second logger started 12.5 s after the first, each timing its rows
    from its own start: time_offset = "12.5 s" moves its times onto the
    log's, and the pairs are those of the single-file import; the header
    says so."""
    rows = _split(tmp_path)
    mag = [[f"{float(r['t_s']) + 0.001 - 12.5:.6f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path, mag_extra='time_offset = "12.5 s"\n'))
    ref = _whole()
    idx = [i for i in range(0, len(rows), 2)]
    np.testing.assert_array_equal(ds.columns["mx_nT"], ref.columns["mx_nT"][idx])
    np.testing.assert_array_equal(ds.columns["ax_g"], ref.columns["ax_g"][idx])
    assert "times moved by +12.5 s (time_offset)" in ds.meta["pairing"]
    # the file timed in ms: a plain number is in its own time unit
    mag = [[f"{(float(r['t_s']) + 0.001 - 12.5) * 1e3:.3f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    ms, _ = importlog.import_log(str(tmp_path / "acc.csv"), _toml(tmp_path, mag_extra='time_unit = "ms"\n'
                                                                                       'time_offset = 12500\n'))
    np.testing.assert_array_equal(ms.columns["mx_nT"], ref.columns["mx_nT"][idx])


def test_a_shift_between_the_files_clocks_is_named_by_the_checks(tmp_path, capsys):
    """The magnetometer's clock a sample late (two files whose clocks
    differ by one of its periods): the rows as paired are out of step by a
    row, which the checks name before any fit; in step, nothing is said
    of the pairing."""
    rows = _broad()
    _split(tmp_path)
    _toml(tmp_path)
    args = ["import", str(tmp_path / "acc.csv"), "--sensor", str(tmp_path / "s.toml"), "-o",
            str(tmp_path / "run.csv"), "--json"]
    assert main(args) == 0
    out = json.loads(capsys.readouterr().out)
    assert not [f for f in out["checks"]["findings"] if f["check"] == "row-alignment" and f["level"] != "note"]
    t = [float(r["t_s"]) for r in rows]
    mag = [[f"{t[i - 2] + 0.001:.6f}"] + [rows[i][c] for c in MAG_COLS] for i in range(2, len(rows), 2)]
    _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    rc = main(args)
    out = json.loads(capsys.readouterr().out)
    named = [f for f in out["checks"]["findings"] if f["check"] == "row-alignment" and f["level"] != "note"]
    assert rc == 0 and [f["figures"]["lag_to_write"] for f in named] == [-1], named


@pytest.mark.parametrize("case,err", [
    ("no_overlap", "do not overlap the log's"),
    ("backwards", "the time column goes back at data row"),
    ("missing", "no file"),
    ("clock", "must be timed on one clock"),
])
def test_files_that_cannot_be_paired_are_refused_with_one_line(tmp_path, capsys, case, err):
    rows = _split(tmp_path)
    if case == "no_overlap":
        mag = [[f"{float(r['t_s']) + 1e4:.6f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
        _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    elif case == "backwards":
        mag = [[f"{float(r['t_s']):.6f}"] + [r[c] for c in MAG_COLS] for r in rows[::2]]
        mag[5][0], mag[6][0] = mag[6][0], mag[5][0]
        _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    elif case == "missing":
        (tmp_path / "mag.csv").unlink()
    elif case == "clock":
        mag = [[f"2024-05-01T12:00:{float(r['t_s']):06.3f}"] + [r[c] for c in MAG_COLS] for r in rows[::2][:20]]
        _write(tmp_path / "mag.csv", ["t_mag"] + MAG_COLS, mag)
    _toml(tmp_path)
    out = tmp_path / "run.csv"
    rc = main(["import", str(tmp_path / "acc.csv"), "--sensor", str(tmp_path / "s.toml"), "-o", str(out)])
    e = capsys.readouterr().err
    assert rc == 2 and err in e and len(e.strip().splitlines()) == 1 and "Traceback" not in e, e
    assert not out.exists()


def _rows_apart(tmp_path, lost=0, nan_row=None):
    """BROAD's log 02 as two files without a common time: the
    magnetometer's every row, no time column, its first `lost` lines lost,
    row `nan_row` of it a missing value."""
    rows = _split(tmp_path)
    mag = [[r[c] for c in MAG_COLS] for r in rows][lost:]
    if nan_row is not None:
        mag[nan_row][1] = "NaN"
    _write(tmp_path / "mag.csv", MAG_COLS, mag)
    return rows


def test_files_without_a_common_time_are_paired_row_by_row(tmp_path):
    """`time = false` (or no time column in the log): row i with row i, as
    two files pasted side by side; a missing value in one file drops its
    partner, and every later row stays paired."""
    rows = _rows_apart(tmp_path, nan_row=10)
    ds, rep = importlog.import_log(str(tmp_path / "acc.csv"), _rows_toml(tmp_path))
    ref = _whole()
    idx = np.array([i for i in range(len(rows)) if i != 10])
    for c in dataset.ACC_COLS + dataset.MAG_COLS + ("t_s",):
        np.testing.assert_array_equal(ds.columns[c], ref.columns[c][idx], err_msg=c)
    assert "row by row, in order" in ds.meta["pairing"]
    # the column that had no value is named, and its line (the names' line, then row 10 of the data: line 12)
    assert rep.dropped["magnetometer file: a missing value in magnetometer y ('mag_y') (line 12)"] == 1
    assert rep.dropped["rows without a partner in the other file (past its end, or dropped there)"] == 1


def _rows_toml(tmp_path, extra=""):
    t = _with_acc()
    t = t.replace('[magnetometer]\n', '[magnetometer]\nfile = "mag.csv"\ntime = false\n' + extra)
    (tmp_path / "s.toml").write_text(t)
    return sensor.load(str(tmp_path / "s.toml"))


def test_a_line_lost_from_one_file_is_named_and_the_lag_it_names_pairs_the_rows(tmp_path, capsys):
    """The magnetometer's file a line short at its start: every row after
    it a row out of step, named by the checks with the lag to write; with
    that lag the rows are those of the single-file import."""
    _rows_apart(tmp_path, lost=1)
    _rows_toml(tmp_path)
    assert main(["import", str(tmp_path / "acc.csv"), "--sensor", str(tmp_path / "s.toml"), "-o",
                 str(tmp_path / "run.csv"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (f,) = [f for f in out["checks"]["findings"] if f["check"] == "row-alignment" and f["level"] != "note"]
    k = f["figures"]["lag_to_write"]
    assert k == -1, f
    ds, _ = importlog.import_log(str(tmp_path / "acc.csv"), _rows_toml(tmp_path, f"lag = {k}\n"))
    ref = _whole()
    np.testing.assert_array_equal(ds.columns["mx_nT"], ref.columns["mx_nT"][1:-1])
    np.testing.assert_array_equal(ds.columns["ax_g"], ref.columns["ax_g"][1:-1])


@pytest.mark.parametrize("text,err", [
    ('[accelerometer]\ncolumns = [1, 2, 3]\nfile = "a.csv"\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\n'
     '[log]\ntime = 7\n', "both triads name a file of their own"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\ntime = 1\n',
     "needs its time column"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\n'
     'time_unit = "ms"\n', "without a time column"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\ntime = true\n'
     '[log]\ntime = 7\n', "or false"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\ntime = 4\n', "only for a triad logged to a file of its own"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\n'
     'time_offset = "1 s"\n', "time_offset without a time column"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\n[magnetometer]\ncolumns = [4, 5, 6]\nfile = "b.csv"\n'
     'time_offset = "1 kg"\n[log]\ntime = 7\n', "unknown unit"),
    ('[accelerometer]\ncolumns = [1, 2, 3]\nfile = ""\n[log]\ntime = 4\n', "the path of the file"),
])
def test_descriptions_that_cannot_pair_two_files_are_refused(text, err):
    with pytest.raises(DataError, match=err):
        sensor.from_toml(text)


def test_a_description_whose_only_triad_is_in_another_file_is_refused(tmp_path):
    _split(tmp_path)
    p = tmp_path / "m.toml"
    p.write_text('[log]\ntime = "t_s"\n[magnetometer]\ncolumns = ["mag_x", "mag_y", "mag_z"]\nunit = "uT"\n'
                 'file = "mag.csv"\ntime = "t_mag"\n')
    with pytest.raises(DataError, match="holds no other triad"):
        importlog.import_log(str(tmp_path / "acc.csv"), sensor.load(str(p)))
