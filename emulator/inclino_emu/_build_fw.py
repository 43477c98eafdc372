"""cffi builder (API, out-of-line) of the firmware application for the
emulator: the module `inclino_emu._fw` compiles the same firmware/src C the
probe runs -- the fixed-point core, the ADIS16210 and ADS1256 drivers,
acquisition, calibration storage, the application (probe.c) -- with the
hardware abstraction layer (firmware/include/inclino/hal.h) implemented as
`extern "Python+C"` callbacks, which emulator/inclino_emu/hal.py binds to the register
models, the flash model and the SCI byte queues.

Used by setup.py (cffi_modules).  Another firmware module joins by adding
its sources to firmware/sources.txt and its declarations to EXTRA_CDEF /
EXTRA_INCLUDES below.
"""
from __future__ import annotations

import pathlib

from cffi import FFI

ROOT = pathlib.Path(__file__).resolve().parents[2]
FW = ROOT / "firmware"



def _by_path(name):
    """A module of host/inclino (fw_sources.py: firmware/sources.txt's reader;
    fw_cdef.py: the firmware's types for cffi), loaded by path: this script
    runs before the packages are importable."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("_inclino_" + name[:-3], ROOT / "host" / "inclino" / name)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# the build "cffi_fw" of the one source manifest, firmware/sources.txt: the
# core, the command layer, the application and the serial bootloader
FW_SOURCES = _by_path("fw_sources.py").sources("cffi_fw", ROOT)

INCLUDES = ["inclino/hal.h", "inclino/survey.h", "inclino/qc.h", "inclino/calimg.h",
            "inclino/crc16.h", "inclino/adis16210.h", "inclino/ads1256.h", "inclino/acquire.h",
            "inclino/calstore.h", "inclino/probe.h"]
EXTRA_INCLUDES: list[str] = ["inclino/app_main.h", "inclino/boot.h", "inclino/boot_main.h", "inclino/crc32.h"]
EXTRA_CDEF = """
/* app_main.h: the main loop (SCI protocol on top of probe.h) */
uint8_t app_main_init(void);
void app_main_poll(void);
uint32_t app_main_tx_dropped(void);
uint8_t app_main_restart_requested(void);
uint8_t probe_cal_slot(uint8_t slot, uint8_t *valid, uint32_t *seq);
uint8_t probe_cal_pending(uint8_t *slot, uint32_t *seq);

/* boot.h, boot_main.h: the serial bootloader */
typedef struct { uint32_t addr; uint32_t len; uint32_t crc; } boot_range_t;
typedef struct { uint32_t entry; uint32_t total; uint32_t hdr_crc; uint8_t count;
                 boot_range_t range[8]; } boot_app_t;
uint32_t crc32_update(uint32_t crc, const uint8_t *data, uint16_t n);
uint8_t boot_crc32_flash(uint32_t addr, uint32_t len, uint32_t *crc);
uint8_t boot_area(uint32_t addr, uint32_t len);
uint16_t boot_desc_build(boot_app_t *app, uint8_t *out, uint8_t *commit);
uint8_t boot_app_check(boot_app_t *app);
uint8_t boot_select(uint8_t request);
uint8_t boot_main_init(void);
void boot_main_poll(void);
uint32_t boot_main_tx_dropped(void);
uint8_t boot_main_restart_requested(void);
"""

HAL_CDEF = """
extern "Python+C" void hal_init(void);
extern "Python+C" void hal_spi_select(uint8_t dev);
extern "Python+C" void hal_spi_deselect(void);
extern "Python+C" uint16_t hal_spi_xfer16(uint16_t out);
extern "Python+C" uint8_t hal_spi_xfer8(uint8_t out);
extern "Python+C" uint8_t hal_adc_drdy(void);
extern "Python+C" uint32_t hal_millis(void);
extern "Python+C" void hal_delay_us(uint16_t us);
extern "Python+C" int16_t hal_sci_getc(void);
extern "Python+C" uint8_t hal_sci_putc(uint8_t byte);
extern "Python+C" uint8_t hal_flash_read(uint32_t addr, uint8_t *dst, uint16_t n);
extern "Python+C" uint8_t hal_flash_program(uint32_t addr, const uint8_t *data);
extern "Python+C" uint8_t hal_flash_erase(uint32_t addr);
"""

APP_CDEF = _by_path("fw_cdef.py").TYPES_CDEF + """
typedef struct { int32_t gt_ref; int32_t gt_tol; int32_t bt_ref; int32_t bt_tol; int32_t dip_ref;
                 int32_t dip_tol; } qc_ref_t;
typedef struct { uint32_t serial; uint32_t time; uint8_t method; } calimg_info_t;

void survey_compute(const int32_t acc[3], const int32_t mag[3], const corr_cal_t *cal, survey_t *s);
void survey_compute_temp(const int32_t acc[3], const int32_t mag[3], int32_t temp_q6, const corr_cal_t *cal,
                         survey_t *s);
uint8_t qc_check(const att_t *a, const qc_ref_t *r);
void qc_default(qc_ref_t *r, int32_t bt_ref, int32_t dip_ref);
uint16_t crc16_update(uint16_t crc, const uint8_t *data, uint16_t n);
uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info);
uint16_t calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[192]);
uint16_t calimg_length(const uint8_t *buf);

/* adis16210.h */
typedef struct { int16_t acc[3]; uint16_t temp_raw; } adis_sample_t;
uint16_t adis_frame(uint16_t out);
uint16_t adis_read_reg(uint8_t addr);
void adis_write_reg(uint8_t addr, uint16_t value);
uint8_t adis_init(uint16_t *prod_id);
uint8_t adis_self_test(void);
uint8_t adis_read(adis_sample_t *s);
int32_t adis_temp_centi_c(uint16_t raw);

/* ads1256.h */
uint8_t ads_wait_drdy(uint16_t timeout_us);
uint8_t ads_read_regs(uint8_t reg, uint8_t n, uint8_t *out);
uint8_t ads_write_regs(uint8_t reg, uint8_t n, const uint8_t *in);
void ads_command(uint8_t cmd);
uint8_t ads_init(void);
uint8_t ads_read_channel(uint8_t mux, int32_t *code);
int32_t ads_sign_extend24(uint32_t raw);

/* acquire.h */
typedef struct { int32_t acc[3]; int32_t mag[3]; uint16_t temp_raw; int32_t temp_q6; int32_t temp_cc;
                 uint8_t n; } acq_result_t;
int32_t acq_avg(int32_t sum, uint8_t n);
int32_t acq_avg_q6(int32_t sum, uint8_t n);
uint8_t acq_run(uint8_t n, acq_result_t *out);

/* calstore.h */
typedef uint8_t (*calstore_check_t)(const uint8_t *payload, uint16_t len);
typedef struct { uint32_t base[2]; uint16_t payload_len; calstore_check_t check; uint16_t alt_len; }
    calstore_cfg_t;
typedef struct {
    const calstore_cfg_t *cfg; uint8_t active; uint32_t active_seq; uint16_t active_crc;
    uint8_t pending; uint32_t pending_seq; uint16_t pending_crc; uint16_t pending_len; uint8_t state[2];
    uint32_t seq[2]; uint16_t len[2]; uint8_t last_flash; } calstore_t;
uint8_t calstore_boot(calstore_t *cs, const calstore_cfg_t *cfg);
uint8_t calstore_write(calstore_t *cs, const uint8_t *payload, uint16_t len);
uint8_t calstore_activate(calstore_t *cs);
uint8_t calstore_read(const calstore_t *cs, uint8_t slot, uint8_t *dst);
uint16_t calstore_flash_ops(const calstore_cfg_t *cfg);

/* probe.h */
typedef struct { int32_t acc[3]; int32_t mag[3]; int32_t temp_cc; uint8_t n; int32_t temp_q6; } probe_raw_t;
typedef struct {
    uint32_t product; uint16_t fw_version; uint32_t serial; uint16_t hw_rev; uint8_t adis_status;
    uint8_t ads_status; uint16_t adis_prod_id; uint8_t cal_slot; uint32_t cal_seq; uint16_t cal_crc;
    uint32_t cal_serial; uint32_t cal_time; uint8_t cal_method; uint8_t qc_slot; } probe_identity_t;
uint8_t probe_init(void);
uint8_t probe_set_average(uint8_t n);
uint8_t probe_raw(probe_raw_t *r);
uint8_t probe_survey(survey_t *s, uint8_t *qc_flags);
void probe_last_raw(probe_raw_t *r);
void probe_identity(probe_identity_t *id);
void probe_active_cal(corr_cal_t *cal);
uint8_t probe_cal_write(const uint8_t *img, uint8_t force);
uint8_t probe_cal_activate(void);
uint8_t probe_cal_read(uint8_t slot, uint8_t *img);
uint8_t probe_qc_get(qc_ref_t *r);
uint8_t probe_qc_set(const qc_ref_t *r);
void probe_id_build(uint32_t serial, uint16_t hw_rev, uint8_t *buf);
"""


def _rel(p: pathlib.Path) -> str:
    try:
        return str(p.relative_to(pathlib.Path.cwd()))
    except ValueError:
        return str(p)


ffibuilder = FFI()
ffibuilder.cdef(HAL_CDEF + APP_CDEF + EXTRA_CDEF)
ffibuilder.set_source(
    "inclino_emu._fw",
    "".join(f'#include "{h}"\n' for h in INCLUDES + EXTRA_INCLUDES),
    sources=[_rel(s) for s in FW_SOURCES],
    include_dirs=[_rel(FW / "include")],
    extra_compile_args=["-std=c99", "-O2", "-Wall", "-Wextra"],
)

if __name__ == "__main__":
    ffibuilder.compile(tmpdir=str(ROOT / "build" / "fw"), verbose=False)
