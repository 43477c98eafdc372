"""cffi builder (API, out-of-line) for the firmware core: compiles the very
same firmware/src/*.c that the probe runs, plus the host-only batch loops.

Used by setup.py (cffi_modules); `python host/inclino/engines/_build_core.py` builds in
place for development."""
from __future__ import annotations

import pathlib

from cffi import FFI

ROOT = pathlib.Path(__file__).resolve().parents[3]
FW = ROOT / "firmware"
HERE = pathlib.Path(__file__).resolve().parent



def _by_path(name):
    """A module of host/inclino (fw_sources.py: firmware/sources.txt's reader;
    fw_cdef.py: the firmware's types for cffi), loaded by path: this script
    runs before the package is importable."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("_inclino_" + name[:-3], HERE.parent / name)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# the build "cffi_core" of the one source manifest, firmware/sources.txt
CORE_SOURCES = _by_path("fw_sources.py").sources("cffi_core", ROOT)

CDEF = _by_path("fw_cdef.py").TYPES_CDEF + """

extern const int32_t fx_atan_table[257];
int32_t fx_mul16(int16_t a, int16_t b);
int32_t fx_asr32(int32_t x, uint8_t n);
int32_t fx_asr32_rnd(int32_t x, uint8_t n);
int32_t fx_shl32_sat(int32_t x, uint8_t n, uint8_t *sat);
int32_t fx_add32_sat(int32_t a, int32_t b, uint8_t *sat);
int32_t fx_sub32_sat(int32_t a, int32_t b, uint8_t *sat);
int32_t fx_mul32_q31(int32_t a, int32_t b, uint8_t *sat);
uint32_t fx_div_frac_q20(uint32_t num, uint32_t den);
uint16_t fx_isqrt_u32(uint32_t x);
uint32_t fx_sqrt_u32_q8(uint32_t x);
int32_t fx_atan2_q16(int32_t y, int32_t x);
uint8_t corr_triad(const int32_t x[3], const corr_triad_t *c, int32_t out[3]);
void corr_identity(corr_triad_t *c);
int16_t corr_temp_dt(int32_t temp_q6, int16_t t_ref, uint8_t *sat);
void corr_temp_eval(int16_t dt, const corr_triad_t *c, const corr_tc_t *tc, corr_tt_t *tt, uint8_t *sat);
uint8_t corr_triad_temp(const int32_t x[3], const corr_triad_t *c, const corr_tt_t *tt, int32_t out[3]);
int8_t att_norm3(const int32_t v[3], int32_t out[3]);
void att_compute(const int32_t g[3], const int32_t b[3], att_t *a);
void survey_compute(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal, survey_t *s);
void survey_compute_temp(const int32_t acc[3], const int32_t mag[3], int32_t temp_q6, const corr_cal_t *cal,
                         survey_t *s);
typedef struct { int32_t gt_ref; int32_t gt_tol; int32_t bt_ref; int32_t bt_tol; int32_t dip_ref;
                 int32_t dip_tol; } qc_ref_t;
uint8_t qc_check(const att_t *a, const qc_ref_t *r);
void qc_default(qc_ref_t *r, int32_t bt_ref, int32_t dip_ref);
uint16_t crc16_update(uint16_t crc, const uint8_t *data, uint16_t n);
typedef struct { uint32_t serial; uint32_t time; uint8_t method; } calimg_info_t;
uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info);
uint16_t calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[192]);
uint16_t calimg_length(const uint8_t *buf);
typedef struct { uint8_t state; uint16_t pos; uint16_t crc; uint8_t ver; uint8_t seq; uint8_t cmd;
                 uint16_t len; uint8_t crc_hi; uint8_t payload[200]; uint8_t line[33]; uint8_t line_len;
               } proto_parser_t;
void proto_parser_init(proto_parser_t *p);
uint8_t proto_frame_feed(proto_parser_t *p, uint8_t byte);
uint8_t proto_parser_idle(proto_parser_t *p);
uint16_t proto_frame_encode(uint8_t seq, uint8_t cmd, const uint8_t *payload, uint16_t len,
                            uint8_t *out, uint16_t cap);
typedef struct {
    uint8_t (*identity)(uint8_t *out);
    uint8_t (*survey)(uint8_t *out);
    uint8_t (*survey_raw)(uint8_t *out);
    uint8_t (*raw)(uint8_t *out);
    uint8_t (*qcref_read)(uint8_t *out);
    uint8_t (*qcref_write)(const uint8_t *in);
    uint8_t (*set_average)(uint8_t n);
    uint8_t (*cal_read)(uint8_t slot, uint8_t *out);
    uint16_t (*cal_write)(const uint8_t *image, uint8_t force, uint8_t *out);
    uint8_t (*cal_activate)(uint8_t slot, uint32_t sequence, uint8_t *out);
    void (*reset)(void);
    void (*bootloader)(void);
    void (*text_identity)(char *out);
    void (*text_survey)(char *out);
    void (*send)(const uint8_t *data, uint16_t n);
} proto_app_t;
typedef struct { const proto_app_t *app; proto_parser_t parser; ...; } proto_t;
void proto_init(proto_t *p, const proto_app_t *app);
void proto_rx(proto_t *p, const uint8_t *data, uint16_t n);
void proto_idle(proto_t *p);
void proto_tick(proto_t *p, uint32_t now_ms);
"""


def _rel(p: pathlib.Path) -> str:
    try:
        return str(p.relative_to(pathlib.Path.cwd()))
    except ValueError:
        return str(p)


ffibuilder = FFI()
ffibuilder.cdef(CDEF + (HERE / "_core_batch.h").read_text())
ffibuilder.set_source(
    "inclino.engines._core",
    '#include "inclino/survey.h"\n#include "inclino/fx_math.h"\n#include "inclino/fx_ops.h"\n#include "inclino/qc.h"\n#include "inclino/calimg.h"\n#include "inclino/crc16.h"\n#include "inclino/proto_frame.h"\n#include "inclino/proto_cmd.h"\n#include "_core_batch.h"\n',
    sources=[_rel(s) for s in CORE_SOURCES] + [_rel(HERE / "_core_batch.c")],
    include_dirs=[_rel(FW / "include"), _rel(HERE)],
    extra_compile_args=["-std=c99", "-O2", "-Wall", "-Wextra"],
)

if __name__ == "__main__":
    ffibuilder.compile(tmpdir=str(HERE.parents[1]), verbose=False)
