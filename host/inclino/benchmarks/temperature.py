"""The fixed-point loss of the temperature path (`inclino bench accuracy
--json`, its "temperature" section; docs/fixed-point.md).

A probe with the typical calibration and the typical scenario's tempcos
(first order the scenario's values, second order its spread) is put at each
test temperature; its raw readings are those of the exact model
(effects.from_reference_temperature).  The firmware (survey_compute_temp
through the C, image version 2) is scored against float64 applying the same
terms (the CAL.json block: raw_ref = b + (raw - b - bias(T)) / (1 + s(T)))
on the same counts and the same temperature reading (TEMP_OUT mean in Q6
counts).  Sources of the difference:
  truncation: float64 with the firmware's form (1/(1+s) expanded to second
    order) against the exact division, same float coefficients;
  coefficient_quantisation: the image's terms (dequantised) against the
    float ones, both in the firmware's form (M, b quantised in both: their
    loss is the accuracy bench's headline);
  algorithm: the C against float64 with the dequantised coefficients of the
    whole image, in the firmware's form: the fixed-point arithmetic alone.
The gain of applying the terms at all (float without them) is reported
beside it.
"""
from __future__ import annotations

import numpy as np

from inclino.formats import caltemp
from inclino.engines import firmware as core, reference
from inclino.formats.calfile import Calibration

TEMPS_C = (-40.0, -5.0, 25.0, 55.0, 85.0, 125.0)
TARGETS = {"inc_max_deg": 0.01, "azi_max_deg": 0.01, "inc_rms_deg": 0.003, "azi_rms_deg": 0.003}


def typical_block(t_ref_c: float = 25.0) -> dict:
    """A CAL.json temperature block with the typical scenario's tempcos:
    first order its values, second order its spread (so both orders and
    both signs are exercised)."""
    from inclino.model import scenario

    sc = scenario.load_scenario("typical")
    spread = sc.tempco_spread
    out = {"t_ref_c": t_ref_c, "order": 2, "span_c": [-5.0, 55.0]}
    for tri in ("acc", "mag"):
        m = getattr(sc, tri)
        s2b = np.asarray(spread[tri]["bias_tempco"][1], float)
        s2s = np.asarray(spread[tri]["scale_tempco"][1], float)
        sign = np.array([1.0, -1.0, 1.0])
        out[tri] = {"bias": [np.asarray(m.bias_tempco.c, float).tolist(), (sign * s2b).tolist()],
                    "scale_ppm": [np.asarray(m.scale_tempco.ppm, float).tolist(), (-sign * s2s).tolist()]}
    out["applied_by_firmware"] = True
    return out


def _tempcos(block, tri):
    from inclino.model import effects as fx

    c1, c2, p1, p2 = caltemp._terms(block, tri)
    tr = float(block["t_ref_c"])
    return fx.BiasTempco(c1, tr, c2), fx.ScaleTempco(p1 * 1e6, tr, p2 * 1e6)


def _att(g, b):
    a = reference.attitude(g, b)
    return {"inc_deg": a["inc"], "azi_deg": a["azi"]}


def _stats(a, b, inc):
    d_inc = np.abs(a["inc_deg"] - b["inc_deg"])
    d_azi = np.abs(reference.angle_diff(a["azi_deg"], b["azi_deg"]))
    hi = (inc >= 5.0) & (inc <= 175.0)
    return {"inc_max_deg": float(d_inc.max()), "inc_rms_deg": float(np.sqrt(np.mean(d_inc ** 2))),
            "azi_max_deg": float(d_azi[hi].max()), "azi_rms_deg": float(np.sqrt(np.mean(d_azi[hi] ** 2)))}


def temperature_loss(field_nT=50000.0, dip_deg=60.0, cal: Calibration | None = None, block: dict | None = None,
                     temps_c=TEMPS_C, inc_step=3.0, azi_step=10.0, tf_step=60.0) -> dict:
    """Per test temperature: the headline (C vs float64 with the same
    terms) and its sources; the worst over the temperatures, the targets
    (the accuracy bench's, for I >= 5 deg) and the verdict."""
    from inclino.model import effects as fx

    from inclino.model.typical_probe import _raw_for, typical_calibration

    base = cal or typical_calibration()
    block = block or typical_block()
    cal = Calibration(acc_m=base.acc_m, acc_b=base.acc_b, mag_m=base.mag_m, mag_b=base.mag_b,
                      temperature=dict(block, applied_by_firmware=True))
    fc = cal.to_fixed()
    ft = fc.temp
    cq = Calibration.from_fixed(fc)
    # the accuracy bench's sphere (bench.sphere_poses), coarser
    I, A, T = (g.ravel() for g in np.meshgrid(np.arange(0.0, 180.0 + 1e-9, inc_step), np.arange(0.0, 360.0, azi_step),
                                              np.arange(0.0, 360.0, tf_step) + 7.0, indexing="ij"))
    g_true, b_true = reference.body_vectors(I, A, T, field_nT, dip_deg)
    ga_ref, bm_ref = _raw_for(cal, g_true, b_true)
    per = {}
    for tc in temps_c:
        tq = caltemp.temp_c_to_q6(np.full(len(I), tc))
        t_read = caltemp.q6_to_temp_c(tq)  # the temperature the probe reads (Q6 counts)
        raw = {}
        for tri, r0, b in (("acc", ga_ref, cal.acc_b), ("mag", bm_ref, cal.mag_b)):
            bt, st = _tempcos(block, tri)
            raw[tri] = fx.from_reference_temperature(r0, tc, b, bt, st)
        acc_c = reference.readings_acc(raw["acc"])
        mag_c = reference.readings_mag(raw["mag"])
        acc_g = acc_c / 64.0 * reference.ACC_LSB_G  # the same counts, in units
        mag_n = mag_c / 64.0 * reference.MAG_LSB_NT
        fw = core.survey(acc_c, mag_c, fc, temp_q6=tq)
        fixed = {"inc_deg": fw["inc"] / 65536.0, "azi_deg": fw["azi"] / 65536.0}

        def corrected(c: Calibration, form: str, tcal=None):
            out = []
            for tri, rw, m, b in (("acc", acc_g, c.acc_m, c.acc_b), ("mag", mag_n, c.mag_m, c.mag_b)):
                if form == "none":
                    d = rw - np.asarray(b)
                elif form == "exact":
                    bt, st = _tempcos(block, tri)
                    d = fx.to_reference_temperature(rw, t_read, b, bt, st) - np.asarray(b)
                else:  # the firmware's form with the coefficients of tcal (FixedTemp)
                    d = caltemp.apply_float(rw, t_read, b, tcal, tri)
                out.append(d @ np.asarray(m, float).T)
            return _att(*out)

        ref_exact = corrected(cal, "exact")
        ref_form = corrected(cal, "form", _float_temp(block))
        ref_formq = corrected(cal, "form", ft)
        ref_all_q = corrected(cq, "form", ft)
        ref_none = corrected(cal, "none")
        per[f"{tc:g}"] = {
            "fixed_vs_float": _stats(fixed, ref_exact, I),
            "sources": {"truncation": _stats(ref_form, ref_exact, I),
                        "coefficient_quantisation": _stats(ref_formq, ref_form, I),
                        "algorithm": _stats(fixed, ref_all_q, I)},
            "float_without_terms_vs_with": _stats(ref_none, ref_exact, I),
        }
    worst = {k: max(p["fixed_vs_float"][k] for p in per.values()) for k in TARGETS}
    passed = all(worst[k] <= v for k, v in TARGETS.items())
    return {"poses_per_temperature": int(len(I)), "temperatures_c": [float(t) for t in temps_c],
            "terms": {"t_ref_c": block["t_ref_c"], "acc": block["acc"], "mag": block["mag"]},
            "temperature_resolution_c": caltemp.TEMP_DEG_PER_COUNT / 64.0,
            "per_temperature": per, "worst": worst, "targets": dict(TARGETS), "pass": passed}


def _float_temp(block):
    """A stand-in FixedTemp carrying the float coefficients (the firmware's
    form without quantisation) for caltemp.apply_float."""
    class _F:
        pass

    f = _F()
    f.t_ref = float(block["t_ref_c"]) * 2 ** caltemp.T_REF_FRAC
    for tri in ("acc", "mag"):
        c1, c2, r1, r2 = caltemp.firmware_coefficients(block, tri)
        for k, v, q in (("c1", c1, caltemp.C1_FRAC[tri]), ("c2", c2, caltemp.C2_FRAC[tri]),
                        ("r1", r1, caltemp.R1_FRAC), ("r2", r2, caltemp.R2_FRAC)):
            setattr(f, f"{tri}_{k}", np.asarray(v) * 2.0 ** q)
    return f
