"""The papers' measured tables, transcribed (one CSV text per table, each
with its source).

They are kept as CSV text inside this module rather than as separate data
files because the package ships only Python modules (a data file would need
a package-data entry in pyproject.toml); `table(name)` parses one,
`write_tables(dir)` writes them out as .csv files.  The transcriptions are
from the plain-text copies in the project's seeds (Ren 2014: Sensors
14(6):9256-9270 as published; Li 2021: Drilling Engineering 48(5):76-82).
Every number is as printed; what had to be read rather than copied is said
in the table's notes.
"""
from __future__ import annotations

import csv
import io
import os

TABLES = {
    "li2021_table2": {
        "source": "Li Zhong, Li Yang, Zhao Yanlai, Application of the twelve-position calibration method for the "
                  "borehole inclinometer, Drilling Engineering 2021, 48(5):76-82, Table 2 (error calibration "
                  "parameters of the inclinometer sensors)",
        "notes": "Values after A/D conversion (counts), as the table's note says. 'installation error' holds two "
                 "numbers per axis: row X = (e_xy, e_xz), row Y = (e_yx, e_yz), row Z = (e_zx, e_zy) -- the "
                 "reading under which Table 3 follows from Table 2 (docs/calibration.md).",
        "csv": """sensor,axis,bias_counts,scale,install_1,install_2
mag,X,-188.795,0.9514,0.0312,0.0306
mag,Y,129.94,0.9716,-0.0076,0.0399
mag,Z,-314.095,0.9067,0.0062,-0.0566
acc,X,-17.5863,0.9998,0.0046,-0.0013
acc,Y,-46.3725,0.9977,-0.0074,-0.0606
acc,Z,-6.8975,0.9977,0.0019,0.0585
""",
    },
    "li2021_table4": {
        "source": "Li Zhong, Li Yang, Zhao Yanlai, Application of the twelve-position calibration method for the "
                  "borehole inclinometer, Drilling Engineering 2021, 48(5):76-82, "
                  "Table 4: borehole inclination (drift angle) errors before and after correction, degrees",
        "notes": "The printed header lists inclinations 2, 5, 10 ... 80 and an RMS column, but each row has 11 "
                 "numbers; the 11th is read as the 90 deg column: the text's RMS (about 0.5 deg before, 0.06 "
                 "after) and maxima (0.57, 0.09) are those of the 11 numbers (the RMS column itself is lost). "
                 "The azimuth and toolface of these checks are not given.",
        "csv": """state,2,5,10,20,30,40,50,60,70,80,90
before,-0.41,-0.43,-0.5,-0.56,-0.51,-0.5,-0.56,-0.57,-0.54,-0.54,-0.47
after,-0.01,0.05,0.01,-0.02,0.06,0.09,0.05,0.05,0.07,0.06,0.09
""",
    },
    "li2021_table5": {
        "source": "Li Zhong, Li Yang, Zhao Yanlai, Application of the twelve-position calibration method for the "
                  "borehole inclinometer, Drilling Engineering 2021, 48(5):76-82, "
                  "Table 5: azimuth errors before and after correction, degrees, at inclinations 2-90 deg and "
                  "azimuths 0-300 deg",
        "notes": "The last column is the paper's RMS over the row's six azimuths (it equals the RMS of the six "
                 "transcribed values in every row: a check of the transcription). The toolface is not given.",
        "csv": """inclination,state,0,60,120,180,240,300,rms
2,before,30.06,24.37,17.23,16.39,16.13,22.71,21.75
2,after,-0.85,-1.06,-0.78,0.43,0.84,0.33,0.76
5,before,17.41,11.60,4.44,2.84,1.91,9.10,9.59
5,after,-0.04,-0.47,0.04,0.63,0.51,0.47,0.43
10,before,13.72,8.42,1.42,-0.79,-1.58,5.04,6.95
10,after,0.16,-0.09,0.17,0.48,0.81,0.40,0.43
20,before,11.39,7.00,0.85,-2.06,-3.92,2.60,5.86
20,after,0.07,-0.01,0.35,0.52,0.71,0.42,0.42
30,before,10.23,6.94,1.31,-2.28,-5.06,1.30,5.58
30,after,0.11,0.22,0.36,0.54,0.67,0.41,0.43
40,before,9.36,7.02,2.04,-2.25,-5.78,0.39,5.47
40,after,0.17,0.21,0.44,0.65,0.67,0.48,0.48
50,before,8.65,7.32,2.69,-2.34,-6.19,-0.32,5.47
50,after,0.29,0.31,0.46,0.63,0.77,0.56,0.53
60,before,7.90,7.70,3.46,-2.38,-6.56,-0.88,5.52
60,after,0.31,0.48,0.78,0.73,0.72,0.65,0.63
70,before,7.32,8.05,3.64,-2.58,-6.58,-1.26,5.53
70,after,0.44,0.58,0.67,0.77,0.82,0.73,0.68
80,before,6.70,8.23,3.71,-2.85,-6.31,-1.41,5.42
80,after,0.50,0.65,0.76,0.84,0.98,0.80,0.77
90,before,6.18,8.24,3.40,-3.28,-5.86,-1.30,5.24
90,after,0.60,0.79,0.82,0.85,1.00,0.83,0.82
""",
    },
    "ren2014_table1": {
        "source": "Ren Y., Wang Y., Wang M., Wu S., Wei B., A Measuring System for Well Logging Attitude and a "
                  "Method of Sensor Calibration, Sensors (MDPI), published 23 May 2014, "
                  "Table 1 (tilt angle measurement data), degrees",
        "notes": "Signed tilts on a turntable tilting both ways; at each tilt eight azimuths (0-315 by 45) were "
                 "read and the table gives the reading with the largest deviation. dev0: no accelerometer "
                 "calibration, dev: after the paper's calibration; errors are reading minus standard (the "
                 "printed header calls the before-error column z_err0 and the after-error v_err).",
        "csv": """standard,dev0,err0,dev,err
3,2.76,-0.24,2.91,-0.09
15,14.73,-0.27,14.93,-0.07
30,29.71,-0.29,29.98,-0.02
60,59.62,-0.38,59.95,-0.05
-3,-3.28,-0.28,-3.03,-0.03
-15,-15.33,-0.33,-15.06,-0.06
-30,-30.37,-0.37,-30.08,-0.08
-60,-60.40,-0.40,-60.03,-0.03
""",
    },
    "ren2014_table2": {
        "source": "Ren Y., Wang Y., Wang M., Wu S., Wei B., A Measuring System for Well Logging Attitude and a "
                  "Method of Sensor Calibration, Sensors (MDPI), published 23 May 2014, "
                  "Table 2 (azimuth angle measurement data), degrees",
        "notes": "At each azimuth the reading with the largest deviation over the tilts. daz0: after the "
                 "traditional ellipse-fit compensation of the fluxgate; daz: after the paper's calibration. "
                 "Printed as 41.73 -> -3.27 and 87.89 -> -2.12 (sic: 87.89 - 90 = -2.11); the error columns are "
                 "kept as printed.",
        "csv": """standard,daz0,err0,daz,err
0,0.85,0.85,0.57,0.57
45,41.73,-3.27,45.14,0.14
90,87.89,-2.12,91.35,1.35
135,131.45,-3.55,136.19,1.19
180,184.11,4.11,181.36,1.36
225,228.05,3.05,223.98,-1.02
270,273.4,3.4,269.12,-0.88
315,318.20,3.2,313.81,-1.19
""",
    },
}


def table(name: str):
    """(rows as a list of dicts with floats where the cell is a number,
    source, notes)."""
    t = TABLES[name]
    rows = []
    for r in csv.DictReader(io.StringIO(t["csv"])):
        out = {}
        for k, v in r.items():
            try:
                out[k] = float(v)
            except ValueError:
                out[k] = v
        rows.append(out)
    return rows, t["source"], t["notes"]


def write_tables(outdir: str) -> list:
    os.makedirs(outdir, exist_ok=True)
    paths = []
    for name, t in TABLES.items():
        p = os.path.join(outdir, f"{name}.csv")
        with open(p, "w", encoding="utf-8", newline="") as f:
            f.write(f"# source={t['source']}\n# notes={t['notes']}\n{t['csv']}")
        paths.append(p)
    return paths
