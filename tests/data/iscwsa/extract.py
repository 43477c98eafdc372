"""Extract the well paths and the total position covariance per station from
the ISCWSA MWD error-model example workbooks into iscwsa_examples.json.

    python tests/data/iscwsa/extract.py WORKBOOK_DIR

WORKBOOK_DIR holds the three workbooks as the ISCWSA issued them (copies are
in the welleng repository, github.com/jonnymaserati/welleng, reference/):
error-model-example-mwdrev4-iscwsa-1.xlsx, error-model-example-mwdrev5-iscwsa-1.xlsx,
error-model-example-mwdrev5-iscwsa-2.xlsx.  Read with openpyxl (a welleng
dependency), cached cell values (data_only).

Per workbook: the Wellpath sheet's header (latitude, G, total field, dip,
declination, convergence, azimuth reference, depth unit), its input well path
(MD, inclination, azimuth in the sheet's depth unit and degrees) and the
TOTALS sheet's covariance (NN, EE, VV, NE, NV, EV) at each station, as the
sheet gives them.
"""
import json
import os
import sys

FILES = {"iscwsa-1-rev4": ("error-model-example-mwdrev4-iscwsa-1.xlsx", "ISCWSA MWD Rev4"),
         "iscwsa-1-rev5": ("error-model-example-mwdrev5-iscwsa-1.xlsx", "ISCWSA MWD Rev5"),
         "iscwsa-2-rev5": ("error-model-example-mwdrev5-iscwsa-2.xlsx", "ISCWSA MWD Rev5")}


def extract(path):
    from openpyxl import load_workbook

    wb = load_workbook(path, data_only=True, read_only=True)
    rows = list(wb["Wellpath"].iter_rows(values_only=True))
    h = {r[0]: r[1] for r in rows[1:11] if r[0]}
    header = {"latitude_deg": h["Latitude (deg)"], "g_m_s2": h["G (m/s2)"], "b_total_nT": h["Btotal (nT)"],
              "dip_deg": h["Dip (deg)"], "declination_deg": h["Declination (deg)"],
              "convergence_deg": h["Convergence (deg)"], "azimuth_reference": h["Azimuth Ref"],
              "depth_unit": h["Depth Units"]}
    md, inc, azi = [], [], []
    for r in rows[2:]:
        if r[4] is None or (md and r[4] <= md[-1]):
            break
        md.append(float(r[4]))
        inc.append(float(r[5]))
        azi.append(float(r[6]))
    cov = []
    for r in list(wb["TOTALS"].iter_rows(values_only=True))[2:2 + len(md)]:
        cov.append([float(v) for v in r[1:7]])
    assert len(cov) == len(md)
    readme = [r[0:4] for r in wb["Readme"].iter_rows(values_only=True)][:3]
    return {"well": str(readme[1][1]), "model": str(readme[1][3]), "header": header,
            "md": md, "inc_deg": inc, "azi_deg": azi, "cov_nev": cov}


if __name__ == "__main__":
    d = sys.argv[1]
    out = {"source": "ISCWSA MWD error-model example workbooks (Wellpath and TOTALS sheets), as copied in "
                     "github.com/jonnymaserati/welleng reference/ (Apache-2.0 repository; the workbooks are "
                     "ISCWSA's public examples); extracted by tests/data/iscwsa/extract.py",
           "cov_columns": ["NN", "EE", "VV", "NE", "NV", "EV"]}
    for key, (fn, model) in FILES.items():
        out[key] = {"file": fn, "welleng_model": model, **extract(os.path.join(d, fn))}
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "iscwsa_examples.json"), "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
