"""Held-out probes: errors drawn here at random (not by the calibration code
nor the emulator's scenarios), readings as `inclino acquire` writes them
(float means of n quantised samples), the CLI run on the files.

* a fit as good as a float64 affine least-squares fit with the same poses
  passes (exit 0): the verdict judges the firmware's arithmetic on identical
  inputs, not the rounding of the input;
* `inclino attitude --cal --engine firmware` on the check grid is within
  1.1x of `--engine reference` (the Q6 means keep the averaged resolution);
* field recalibration with `--prior` (the same probe's turntable
  calibration) after bias/scale drift is within 1.5x of a fresh turntable
  calibration on the check grid.
"""
import csv
import json

import numpy as np
import pytest

from inclino.engines import reference as ref
from inclino.formats.calfile import Calibration
from inclino.calib.runs import li2021_grid
from inclino.cli import main
from inclino.formats.dataset import RawDataset, write_raw

F, DIP = 50000.0, 60.0
SIGMA_ACC, SIGMA_MAG, N_AVG = 50e-6, 3.0, 16


def _probe(rng):
    def A(scale, mis):
        return np.diag(1 + rng.normal(0, scale, 3)) + rng.normal(0, mis, (3, 3)) * (1 - np.eye(3))
    return {"Aa": A(0.01, 0.01), "ca": rng.normal(0, 0.02, 3), "Am": A(0.02, 0.02), "cm": rng.normal(0, 500, 3)}


def _drifted(p, rng):
    q = dict(p)
    q["Aa"] = np.diag(1 + rng.uniform(-0.005, 0.005, 3)) @ p["Aa"]
    q["Am"] = np.diag(1 + rng.uniform(-0.005, 0.005, 3)) @ p["Am"]
    q["ca"] = p["ca"] + rng.uniform(-0.002, 0.002, 3)
    q["cm"] = p["cm"] + rng.uniform(-300, 300, 3)
    return q


def _readings(p, I, A, T, rng):
    g, b = ref.body_vectors(I, A, T, F, DIP)
    ra = (g @ p["Aa"].T + p["ca"]) / ref.ACC_LSB_G
    rm = b @ p["Am"].T + p["cm"]
    n = len(I)
    acc = np.round(ra[:, None] + rng.normal(0, SIGMA_ACC / ref.ACC_LSB_G, (n, N_AVG, 3))).mean(1) * ref.ACC_LSB_G
    mag = np.round(rm[:, None] + rng.normal(0, SIGMA_MAG, (n, N_AVG, 3))).mean(1)
    return acc, mag


def _write(path, p, rng, rows=300, poses=True):
    u = rng.normal(size=(rows, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    I, A, T = np.degrees(np.arccos(u[:, 2])), rng.uniform(0, 360, rows), rng.uniform(0, 360, rows)
    acc, mag = _readings(p, I, A, T, rng)
    cols = {"ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2], "mx_nT": mag[:, 0], "my_nT": mag[:, 1],
            "mz_nT": mag[:, 2]}
    if poses:
        cols.update({"inc_deg": I, "azi_deg": A, "tf_deg": T})
    write_raw(str(path), RawDataset(cols, {"field_nT": F, "dip_deg": DIP, "probe_serial": "77",
                                           "samples_averaged": float(N_AVG)}))
    return I, A, T, acc, mag


def _ls_calibration(I, A, T, acc, mag) -> Calibration:
    """float64 affine least squares with the poses (the reference fit)."""
    g, b = ref.body_vectors(I, A, T, F, DIP)
    out = []
    for raw, true in ((acc, g), (mag, b)):
        W = np.linalg.lstsq(np.c_[raw, np.ones(len(raw))], true, rcond=None)[0]
        M = W[:3].T
        out += [M, -np.linalg.solve(M, W[3])]
    return Calibration(acc_m=out[0].tolist(), acc_b=out[1].tolist(), mag_m=out[2].tolist(), mag_b=out[3].tolist())


def _grid_csv(path, p, rng):
    I, A, T = li2021_grid((0.0, 120.0, 240.0))
    acc, mag = _readings(p, I, A, T, rng)
    cols = {"inc_deg": I, "azi_deg": A, "tf_deg": T, "ax_g": acc[:, 0], "ay_g": acc[:, 1], "az_g": acc[:, 2],
            "mx_nT": mag[:, 0], "my_nT": mag[:, 1], "mz_nT": mag[:, 2]}
    write_raw(str(path), RawDataset(cols, {"field_nT": F, "dip_deg": DIP}))
    return A


def _attitude_azi_rms(tmp_path, grid, cal, engine, azi_true, capsys):
    out = tmp_path / f"att-{engine}.csv"
    capsys.readouterr()
    assert main(["attitude", str(grid), "--cal", str(cal), "--engine", engine, "-o", str(out)]) == 0
    with open(out) as f:
        azi = np.array([float(r["azi_deg"]) for r in csv.DictReader(f)])
    return float(np.sqrt(np.mean(ref.angle_diff(azi, azi_true) ** 2)))


def test_held_out_probe_passes_and_the_firmware_keeps_the_resolution(tmp_path, capsys, rng):
    p = _probe(rng)
    run = tmp_path / "run.csv"
    I, A, T, acc, mag = _write(run, p, rng)
    rc = main(["calibrate", str(run), "-o", str(tmp_path / "cal.json"), "--json"])
    d = json.loads(capsys.readouterr().out)
    rep = d["report"]
    grid = tmp_path / "grid.csv"
    azi_true = _grid_csv(grid, p, rng)
    ls = _ls_calibration(I, A, T, acc, mag)
    ls.save(str(tmp_path / "ls.json"))
    joint_ref = _attitude_azi_rms(tmp_path, grid, tmp_path / "cal.json", "reference", azi_true, capsys)
    ls_ref = _attitude_azi_rms(tmp_path, grid, tmp_path / "ls.json", "reference", azi_true, capsys)
    joint_fw = _attitude_azi_rms(tmp_path, grid, tmp_path / "cal.json", "firmware", azi_true, capsys)
    # the fit is as good as float64 least squares ...
    assert joint_ref <= 1.2 * ls_ref, (joint_ref, ls_ref)
    # ... and passes; the arithmetic check compares identical inputs
    assert rc == 0, rep["reasons"]
    q = rep["quantisation"]
    assert q["fw_azi_max_deg"] < 0.002 and q["input_resolution"]["samples_averaged"] == N_AVG
    # the firmware on the grid's averaged readings is as good as float64
    assert joint_fw <= 1.1 * joint_ref, (joint_fw, joint_ref)


def test_field_recalibration_with_a_prior_meets_a_fresh_turntable_calibration(tmp_path, capsys, rng):
    p = _probe(rng)
    _write(tmp_path / "old.csv", p, rng)
    assert main(["calibrate", str(tmp_path / "old.csv"), "-o", str(tmp_path / "prior.json")]) == 0
    q = _drifted(p, rng)
    _write(tmp_path / "new.csv", q, rng)
    assert main(["calibrate", str(tmp_path / "new.csv"), "-o", str(tmp_path / "fresh.json")]) == 0
    _write(tmp_path / "field.csv", q, rng, rows=200, poses=False)
    capsys.readouterr()
    rc = main(["calibrate", str(tmp_path / "field.csv"), "--prior", str(tmp_path / "prior.json"),
               "-o", str(tmp_path / "field.json"), "--json"])
    d = json.loads(capsys.readouterr().out)
    assert rc == 0, d["report"]["reasons"]
    assert d["report"]["mode"] == "invariants" and d["report"]["uncertainty"]["prior"] is True
    grid = tmp_path / "grid.csv"
    azi_true = _grid_csv(grid, q, rng)
    fresh = _attitude_azi_rms(tmp_path, grid, tmp_path / "fresh.json", "reference", azi_true, capsys)
    field = _attitude_azi_rms(tmp_path, grid, tmp_path / "field.json", "reference", azi_true, capsys)
    stale = _attitude_azi_rms(tmp_path, grid, tmp_path / "prior.json", "reference", azi_true, capsys)
    assert field <= 1.5 * fresh, (field, fresh)
    assert stale > 2 * field  # the drift mattered: the prior alone is worse
