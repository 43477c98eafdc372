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
