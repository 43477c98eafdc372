"""The firmware's data structures as cffi declares them, one copy for both
cffi builds (the core, host/inclino/engines/_build_core.py, and the emulated
probe, emulator/inclino_emu/_build_fw.py), which load this file by path
before the packages are importable.  They mirror correct.h (corr_triad_t,
corr_tc_t, corr_cal_t, corr_tt_t), attitude.h (att_t) and survey.h
(survey_t); cffi's API mode checks them against those headers when it
compiles."""

TYPES_CDEF = """
typedef struct { int32_t m[9]; int32_t bias[3]; } corr_triad_t;
typedef struct { int32_t c1[3]; int16_t c2[3]; int32_t r1[3]; int16_t r2[3]; } corr_tc_t;
typedef struct { corr_triad_t acc; corr_triad_t mag; corr_tc_t acc_tc; corr_tc_t mag_tc; int16_t t_ref;
                 uint8_t t_order; } corr_cal_t;
typedef struct { int32_t beff[3]; int32_t e[3]; } corr_tt_t;
typedef struct { int32_t inc; int32_t azi; int32_t gtf; int32_t mtf; int32_t gt; int32_t bt;
                 int32_t dip; uint16_t flags; } att_t;
typedef struct { int32_t g[3]; int32_t b[3]; att_t att; } survey_t;
"""
