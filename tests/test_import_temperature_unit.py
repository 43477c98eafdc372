"""A temperature column logged in K, F or raw counts (`[log] temperature_unit`,
docs/dataset.md): imported as degrees C by the datasheet's T = offset +
counts x lsb; a column out of the canonical range names the declaration that
reads it; a declaration without its column, or counts without their scale, is
refused in one line."""
import numpy as np
import pytest

from inclino.cli import main
from inclino.errors import DataError
from inclino.formats import dataset, importlog, sensor

ACC = '[accelerometer]\ncolumns = ["ax", "ay", "az"]\nunit = "g"\n'
# six faces and a few tilts, one row each; the last column a temperature in the log's own unit
FACES = [(0, 0, 1), (0, 0, -1), (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0.6, 0, 0.8), (0, 0.8, -0.6)]


def _files(tmp_path, temps, log_keys):
    lines = ["ax,ay,az,temp"] + [f"{a},{b},{c},{t}" for (a, b, c), t in zip(FACES, temps)]
    log, toml = tmp_path / "log.csv", tmp_path / "s.toml"
    log.write_text("\n".join(lines) + "\n")
    toml.write_text('[log]\ntemperature = "temp"\n' + log_keys + ACC)
    return log, toml


def _imported(tmp_path, temps, log_keys):
    log, toml = _files(tmp_path, temps, log_keys)
    ds, _ = importlog.import_log(str(log), sensor.load(str(toml)))
    return ds


def test_counts_are_read_by_the_datasheets_formula(tmp_path):
    """MPU-6050 (register map rev 4.2, 4.18): T = counts / 340 + 36.53."""
    counts = [-5000, -4000, -3000, -2000, 0, 1000, 2000, 3000]
    ds = _imported(tmp_path, counts, 'temperature_unit = "counts"\ntemperature_lsb = "1/340 C"\n'
                                     'temperature_offset = "36.53 C"\n')
    want = [c / 340.0 + 36.53 for c in counts]
    assert np.allclose(ds.columns["temp_c"], want, atol=1e-9)
    assert "counts" in ds.meta["temp_unit"]


@pytest.mark.parametrize("unit, logged, want", [
    ("K", [268.15, 298.15, 328.15] + [298.15] * 5, [-5.0, 25.0, 55.0] + [25.0] * 5),
    ("F", [23.0, 77.0, 131.0] + [77.0] * 5, [-5.0, 25.0, 55.0] + [25.0] * 5),
    ("C", [-5.0, 25.0, 55.0] + [25.0] * 5, [-5.0, 25.0, 55.0] + [25.0] * 5),
])
def test_kelvin_and_fahrenheit_are_degrees_c_in_the_dataset(tmp_path, unit, logged, want):
    ds = _imported(tmp_path, logged, f'temperature_unit = "{unit}"\n')
    assert np.allclose(ds.columns["temp_c"], want, atol=1e-9)
    assert ("temp_unit" in ds.meta) == (unit != "C")


def test_a_dataset_written_from_counts_reads_back_the_same_degrees(tmp_path):
    ds = _imported(tmp_path, [-340, 0, 340, 680, 0, 0, 0, 0],
                   'temperature_unit = "counts"\ntemperature_lsb = "1/340 C"\ntemperature_offset = 36.53\n')
    out = tmp_path / "run.csv"
    dataset.write_raw(str(out), ds)
    back = dataset.read_raw(str(out))
    assert np.allclose(back.columns["temp_c"], [35.53, 36.53, 37.53, 38.53, 36.53, 36.53, 36.53, 36.53])
    assert back.meta["temp_unit"] == ds.meta["temp_unit"]


def test_counts_out_of_range_name_the_declaration(tmp_path, capsys):
    """Raw counts mapped as degrees C: refused, with the key that reads them."""
    log, toml = _files(tmp_path, [-5000, -4000, -3000, -2000, 0, 1000, 2000, 3000], "")
    rc = main(["import", str(log), "--sensor", str(toml), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == DataError.exit_code
    assert "temp_c = -5000 out of range" in err and 'temperature_unit = "K"' in err
    assert "temperature_unit" in err and "temperature_lsb" in err
    assert not (tmp_path / "run.csv").exists()


@pytest.mark.parametrize("keys, said", [
    ('temperature_unit = "counts"\ntemperature_lsb = "1/340 C"\n', "needs temperature_lsb"),
    ('temperature_unit = "counts"\ntemperature_lsb = "0 C"\ntemperature_offset = 36.53\n', "> 0"),
    ('temperature_unit = "R"\n', "temperature_unit: C, K, F, or counts"),
    ('temperature_unit = "K"\ntemperature_offset = 3\n', 'goes with temperature_unit = "counts"'),
    ('temperature_unit = "counts"\ntemperature_lsb = "1/340 furlong"\ntemperature_offset = 1\n',
     "not a number of degrees C"),
])
def test_a_declaration_that_cannot_read_the_column_is_refused(tmp_path, capsys, keys, said):
    log, toml = _files(tmp_path, [25.0] * 8, keys)
    rc = main(["import", str(log), "--sensor", str(toml), "-o", str(tmp_path / "run.csv")])
    err = capsys.readouterr().err
    assert rc == DataError.exit_code and said in err and len(err.strip().splitlines()) == 1, err


def test_a_temperature_unit_without_a_temperature_column_is_refused(tmp_path, capsys):
    log, toml = tmp_path / "log.csv", tmp_path / "s.toml"
    log.write_text("ax,ay,az\n" + "\n".join(f"{a},{b},{c}" for a, b, c in FACES) + "\n")
    toml.write_text('[log]\ntemperature_unit = "K"\n' + ACC)
    rc = main(["import", str(log), "--sensor", str(toml), "-o", str(tmp_path / "run.csv")])
    assert rc == DataError.exit_code and "without a temperature column" in capsys.readouterr().err
