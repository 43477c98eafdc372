/* probe.c - the probe application; contracts in probe.h. */
#include "inclino/probe.h"
#include "inclino/acquire.h"
#include "inclino/adis16210.h"
#include "inclino/ads1256.h"
#include "inclino/be_bytes.h"
#include "inclino/calstore.h"
#include "inclino/correct.h"
#include "inclino/crc16.h"
#include "inclino/hal.h"
#include "inclino/id_record.h"

static uint8_t cal_check(const uint8_t *p, uint16_t len);
static uint8_t qc_rec_check(const uint8_t *p, uint16_t len);

static const calstore_cfg_t cal_cfg = {
    {PROBE_CAL_A_ADDR, PROBE_CAL_B_ADDR}, CALIMG_SIZE, cal_check, CALIMG_SIZE_V1};
static const calstore_cfg_t qc_cfg = {
    {PROBE_QC_A_ADDR, PROBE_QC_B_ADDR}, PROBE_QC_SIZE, qc_rec_check, 0u};

static struct {
    calstore_t cal_store;
    calstore_t qc_store;
    corr_cal_t cal;
    calimg_info_t cal_info;
    uint16_t cal_crc;
    qc_ref_t qc;
    uint8_t have_qc;
    uint32_t serial;
    uint16_t hw_rev;
    uint8_t adis_status;
    uint8_t ads_status;
    uint16_t adis_prod_id;
    uint8_t n_avg;
    probe_raw_t last_raw;
} P;

static uint8_t cal_check(const uint8_t *p, uint16_t len)
{
    corr_cal_t c;
    calimg_info_t i;
    return calimg_parse(p, len, &c, &i);
}

static void qc_decode(const uint8_t *p, qc_ref_t *r)
{
    r->gt_ref = be_get_i32(p);
    r->gt_tol = be_get_i32(p + 4);
    r->bt_ref = be_get_i32(p + 8);
    r->bt_tol = be_get_i32(p + 12);
    r->dip_ref = be_get_i32(p + 16);
    r->dip_tol = be_get_i32(p + 20);
}

static uint8_t qc_rec_check(const uint8_t *p, uint16_t len)
{
    qc_ref_t r;
    if (len != PROBE_QC_SIZE) {
        return 1u;
    }
    qc_decode(p, &r);
    return (uint8_t)(r.gt_tol < 0 || r.bt_tol < 0 || r.dip_tol < 0);
}

void probe_id_build(uint32_t serial, uint16_t hw_rev, uint8_t buf[PROBE_ID_SIZE])
{
    uint16_t crc;
    uint8_t i;
    be_put_u32(buf, PROBE_ID_MAGIC);
    be_put_u32(buf + 4, serial);
    be_put_u16(buf + 8, hw_rev);
    for (i = 10u; i < 14u; i++) {
        buf[i] = 0xFFu;
    }
    crc = crc16_update(CRC16_INIT, buf, 14u);
    be_put_u16(buf + 14, crc);
}

static void load_identity(void)
{
    (void)id_record_read(&P.serial, &P.hw_rev); /* 0, 0 without a valid record */
}

static void use_identity_cal(void)
{
    corr_identity(&P.cal.acc);
    corr_identity(&P.cal.mag);
    corr_tc_clear(&P.cal.acc_tc);
    corr_tc_clear(&P.cal.mag_tc);
    P.cal.t_ref = 0;
    P.cal.t_order = 0u;
    P.cal_info.serial = 0u;
    P.cal_info.time = 0u;
    P.cal_info.method = CALIMG_METHOD_IDENTITY;
    P.cal_crc = 0u;
}

/* Load the active calibration slot into RAM; identity when none. */
static void load_cal(void)
{
    uint8_t img[CALIMG_SIZE];
    use_identity_cal();
    if (P.cal_store.active == CALSTORE_SLOT_NONE) {
        return;
    }
    if (calstore_read(&P.cal_store, P.cal_store.active, img) != CALSTORE_OK ||
        calimg_parse(img, CALIMG_SIZE, &P.cal, &P.cal_info) != CALIMG_OK) {
        /* changed since the scan: do not trust it */
        P.cal_store.active = CALSTORE_SLOT_NONE;
        P.cal_store.active_seq = 0u;
        use_identity_cal();
        return;
    }
    P.cal_crc = be_get_u16(img + calimg_length(img) - 4u); /* parsed: 120 or 192 */
}

static void load_qc(void)
{
    uint8_t rec[PROBE_QC_SIZE];
    P.have_qc = 0u;
    qc_default(&P.qc, 0, 0);
    if (P.qc_store.active == CALSTORE_SLOT_NONE ||
        calstore_read(&P.qc_store, P.qc_store.active, rec) != CALSTORE_OK) {
        return;
    }
    qc_decode(rec, &P.qc);
    P.have_qc = 1u;
}

uint8_t probe_init(void)
{
    P.n_avg = PROBE_N_DEFAULT;
    P.last_raw.acc[0] = 0;
    P.last_raw.acc[1] = 0;
    P.last_raw.acc[2] = 0;
    P.last_raw.mag[0] = 0;
    P.last_raw.mag[1] = 0;
    P.last_raw.mag[2] = 0;
    P.last_raw.temp_cc = 0;
    P.last_raw.temp_q6 = 0;
    P.last_raw.n = 0u;
    load_identity();
    (void)calstore_boot(&P.cal_store, &cal_cfg);
    load_cal();
    (void)calstore_boot(&P.qc_store, &qc_cfg);
    load_qc();

    P.adis_prod_id = 0u;
    P.adis_status = adis_init(&P.adis_prod_id);
    if (P.adis_status == ADIS_OK) {
        P.adis_status = adis_self_test();
        /* let the self-test force leave the output filter */
        hal_delay_us(ADIS_PERIOD_US);
        hal_delay_us(ADIS_PERIOD_US);
    }
    P.ads_status = ads_init();
    return (P.adis_status != ADIS_OK) ? P.adis_status : P.ads_status;
}

uint8_t probe_set_average(uint8_t n)
{
    if (n == 0u || n > ACQ_N_MAX) {
        return PROBE_E_ARG;
    }
    P.n_avg = n;
    return PROBE_OK;
}

uint8_t probe_raw(probe_raw_t *r)
{
    acq_result_t a;
    uint8_t st;
    uint8_t k;
    if (P.adis_status != ADIS_OK) {
        return P.adis_status;
    }
    if (P.ads_status != ADS_OK) {
        return P.ads_status;
    }
    st = acq_run(P.n_avg, &a);
    if (st != ACQ_OK) {
        return st;
    }
    for (k = 0u; k < 3u; k++) {
        r->acc[k] = a.acc[k];
        r->mag[k] = a.mag[k];
    }
    r->temp_cc = a.temp_cc;
    r->temp_q6 = a.temp_q6;
    r->n = a.n;
    P.last_raw = *r;
    return PROBE_OK;
}

uint8_t probe_survey(survey_t *s, uint8_t *qc_flags)
{
    probe_raw_t r;
    qc_ref_t def;
    uint8_t st = probe_raw(&r);
    uint8_t f;
    if (st != PROBE_OK) {
        return st;
    }
    survey_compute_temp(r.acc, r.mag, r.temp_q6, &P.cal, s);
    if (P.have_qc) {
        f = qc_check(&s->att, &P.qc);
    } else {
        qc_default(&def, 0, 0);
        f = (uint8_t)((qc_check(&s->att, &def) & (QC_F_GT | QC_F_UNDEFINED)) | PROBE_QC_NO_REF);
    }
    *qc_flags = f;
    return PROBE_OK;
}

void probe_last_raw(probe_raw_t *r)
{
    *r = P.last_raw;
}

void probe_identity(probe_identity_t *id)
{
    id->product = PROBE_PRODUCT_ID;
    id->fw_version = PROBE_FW_VERSION;
    id->serial = P.serial;
    id->hw_rev = P.hw_rev;
    id->adis_status = P.adis_status;
    id->ads_status = P.ads_status;
    id->adis_prod_id = P.adis_prod_id;
    id->cal_slot = P.cal_store.active;
    id->cal_seq = P.cal_store.active_seq;
    id->cal_crc = P.cal_crc;
    id->cal_serial = P.cal_info.serial;
    id->cal_time = P.cal_info.time;
    id->cal_method = P.cal_info.method;
    id->qc_slot = P.have_qc ? P.qc_store.active : PROBE_SLOT_NONE;
}

void probe_active_cal(corr_cal_t *cal)
{
    *cal = P.cal;
}

uint8_t probe_cal_write(const uint8_t img[CALIMG_SIZE], uint8_t force)
{
    corr_cal_t c;
    calimg_info_t info;
    if (calimg_parse(img, CALIMG_SIZE, &c, &info) != CALIMG_OK) {
        return PROBE_E_IMAGE;
    }
    if (force == 0u && P.serial != 0u && info.serial != P.serial) {
        return PROBE_E_SERIAL;
    }
    /* a version 1 image keeps its 120-byte slot (calstore alt_len) */
    return calstore_write(&P.cal_store, img, calimg_length(img));
}

uint8_t probe_cal_activate(void)
{
    uint8_t st = calstore_activate(&P.cal_store);
    if (st == CALSTORE_OK) {
        load_cal();
    }
    return st;
}

uint8_t probe_cal_read(uint8_t slot, uint8_t img[CALIMG_SIZE])
{
    if (slot == PROBE_SLOT_ACTIVE) {
        if (P.cal_store.active == CALSTORE_SLOT_NONE) {
            return PROBE_E_NO_CAL;
        }
        slot = P.cal_store.active;
    }
    if (slot > PROBE_SLOT_B) {
        return PROBE_E_ARG;
    }
    return calstore_read(&P.cal_store, slot, img);
}

uint8_t probe_cal_slot(uint8_t slot, uint8_t *valid, uint32_t *seq)
{
    if (slot > PROBE_SLOT_B) {
        return PROBE_E_ARG;
    }
    *valid = (uint8_t)(P.cal_store.state[slot] == CALSTORE_ST_VALID);
    *seq = P.cal_store.seq[slot];
    return PROBE_OK;
}

uint8_t probe_cal_pending(uint8_t *slot, uint32_t *seq)
{
    if (P.cal_store.pending == CALSTORE_SLOT_NONE) {
        return 0u;
    }
    *slot = P.cal_store.pending;
    *seq = P.cal_store.pending_seq;
    return 1u;
}

uint8_t probe_qc_get(qc_ref_t *r)
{
    *r = P.qc;
    return P.have_qc ? PROBE_OK : PROBE_E_NO_CAL;
}

uint8_t probe_qc_set(const qc_ref_t *r)
{
    uint8_t rec[PROBE_QC_SIZE];
    uint8_t st;
    if (r->gt_tol < 0 || r->bt_tol < 0 || r->dip_tol < 0) {
        return PROBE_E_ARG;
    }
    be_put_u32(rec, (uint32_t)r->gt_ref);
    be_put_u32(rec + 4, (uint32_t)r->gt_tol);
    be_put_u32(rec + 8, (uint32_t)r->bt_ref);
    be_put_u32(rec + 12, (uint32_t)r->bt_tol);
    be_put_u32(rec + 16, (uint32_t)r->dip_ref);
    be_put_u32(rec + 20, (uint32_t)r->dip_tol);
    st = calstore_write(&P.qc_store, rec, PROBE_QC_SIZE);
    if (st == CALSTORE_OK) {
        st = calstore_activate(&P.qc_store);
    }
    if (st == CALSTORE_OK) {
        load_qc();
    }
    return st;
}
