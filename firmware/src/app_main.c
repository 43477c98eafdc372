/* app_main.c - the probe's main loop and the protocol's view of the
 * application; contracts in app_main.h, record layouts in docs/protocol.md. */
#include "inclino/app_main.h"
#include "inclino/adis16210.h"
#include "inclino/ads1256.h"
#include "inclino/be_bytes.h"
#include "inclino/calimg.h"
#include "inclino/fx_ops.h"
#include "inclino/hal.h"
#include "inclino/probe.h"
#include "inclino/proto_cmd.h"
#include "inclino/text_fmt.h"
#include "inclino/tx_queue.h"

static proto_t proto;
static uint8_t txq_buf[APP_TX_QUEUE];
static tx_queue_t txq;
static uint32_t last_rx_ms;
static uint8_t restart;

/* ------------------------------------------------------------ transmit queue */
static void send(const uint8_t *data, uint16_t n)
{
    tx_queue_put(&txq, data, n);
}

/* ------------------------------------------------------------ records */
static uint8_t err_code(uint8_t st)
{
    switch (st & 0xF0u) {
    case 0x10u:
    case 0x20u:
    case 0x30u:
        return PERR_SENSOR;
    case 0x40u:
        return PERR_FLASH;
    default:
        return (st == PROBE_E_ARG) ? PERR_ARGUMENT : PERR_STATE;
    }
}

static uint8_t a_identity(uint8_t out[PROTO_IDENTITY_LEN])
{
    probe_identity_t id;
    static const char prod[] = APP_PRODUCT;
    uint8_t i;
    uint16_t st = 0u;
    probe_identity(&id);
    for (i = 0u; i < 16u; i++) {
        out[i] = 0u;
    }
    for (i = 0u; i < (uint8_t)(sizeof prod - 1u); i++) {
        out[i] = (uint8_t)prod[i];
    }
    be_put_u16(out + 16, id.fw_version);
    out[18] = 0u;
    out[19] = PROTO_VERSION;
    be_put_u32(out + 20, id.serial);
    out[24] = id.cal_slot;
    be_put_u32(out + 25, id.cal_seq);
    be_put_u16(out + 29, id.cal_crc);
    out[31] = id.cal_method;
    if (id.adis_status != ADIS_OK) {
        st |= (id.adis_status == ADIS_E_SELF_TEST) ? 0x0004u : 0x0001u;
    }
    if (id.ads_status != ADS_OK) {
        st |= 0x0002u;
    }
    be_put_u16(out + 32, st);
    return 0u;
}

static uint8_t a_survey(uint8_t out[PROTO_SURVEY_LEN])
{
    survey_t s;
    probe_raw_t r;
    uint8_t qc = 0u;
    uint8_t st = probe_survey(&s, &qc);
    if (st != PROBE_OK) {
        return err_code(st);
    }
    probe_last_raw(&r);
    be_put_u32(out, hal_millis());
    be_put_u32(out + 4, (uint32_t)s.att.inc);
    be_put_u32(out + 8, (uint32_t)s.att.azi);
    be_put_u32(out + 12, (uint32_t)s.att.gtf);
    be_put_u32(out + 16, (uint32_t)s.att.mtf);
    be_put_u32(out + 20, (uint32_t)s.att.gt);
    be_put_u32(out + 24, (uint32_t)s.att.bt);
    be_put_u32(out + 28, (uint32_t)s.att.dip);
    be_put_u16(out + 32, s.att.flags);
    out[34] = qc;
    out[35] = r.n;
    return 0u;
}

static void raw_record(const probe_raw_t *r, uint8_t out[PROTO_RAW_LEN])
{
    uint8_t i;
    int32_t t = r->temp_cc;
    for (i = 0u; i < 3u; i++) {
        be_put_u32(out + 4u * i, (uint32_t)r->acc[i]);
        be_put_u32(out + 12u + 4u * i, (uint32_t)r->mag[i]);
    }
    if (t > 32767) {
        t = 32767;
    } else if (t < -32768) {
        t = -32768;
    }
    be_put_u16(out + 24, (uint16_t)(int16_t)t);
    out[26] = r->n;
    be_put_u32(out + 27, (uint32_t)r->temp_q6);
}

static uint8_t a_survey_raw(uint8_t out[PROTO_SURVEY_RAW_LEN])
{
    probe_raw_t r;
    uint8_t st = a_survey(out);
    if (st != 0u) {
        return st;
    }
    probe_last_raw(&r);
    raw_record(&r, out + PROTO_SURVEY_LEN);
    return 0u;
}

static uint8_t a_raw(uint8_t out[PROTO_RAW_LEN])
{
    probe_raw_t r;
    uint8_t st = probe_raw(&r);
    if (st != PROBE_OK) {
        return err_code(st);
    }
    raw_record(&r, out);
    return 0u;
}

static uint8_t a_qcref_read(uint8_t out[PROTO_QCREF_LEN])
{
    qc_ref_t r;
    (void)probe_qc_get(&r); /* without a stored reference: the defaults */
    be_put_u32(out, (uint32_t)r.gt_ref);
    be_put_u32(out + 4, (uint32_t)r.gt_tol);
    be_put_u32(out + 8, (uint32_t)r.bt_ref);
    be_put_u32(out + 12, (uint32_t)r.bt_tol);
    be_put_u32(out + 16, (uint32_t)r.dip_ref);
    be_put_u32(out + 20, (uint32_t)r.dip_tol);
    return 0u;
}

static uint8_t a_qcref_write(const uint8_t in[PROTO_QCREF_LEN])
{
    qc_ref_t r;
    uint8_t st;
    r.gt_ref = be_get_i32(in);
    r.gt_tol = be_get_i32(in + 4);
    r.bt_ref = be_get_i32(in + 8);
    r.bt_tol = be_get_i32(in + 12);
    r.dip_ref = be_get_i32(in + 16);
    r.dip_tol = be_get_i32(in + 20);
    st = probe_qc_set(&r);
    return (st == PROBE_OK) ? 0u : err_code(st);
}

static uint8_t a_set_average(uint8_t n)
{
    return (probe_set_average(n) == PROBE_OK) ? 0u : PERR_ARGUMENT;
}

static uint8_t a_cal_read(uint8_t slot, uint8_t *out)
{
    uint8_t valid = 0u;
    uint32_t seq = 0u;
    uint8_t st = probe_cal_slot(slot, &valid, &seq);
    if (st == PROBE_OK) {
        st = probe_cal_read(slot, out + 6);
    }
    if (st != PROBE_OK) {
        return err_code(st);
    }
    out[0] = slot;
    out[1] = valid;
    be_put_u32(out + 2, seq);
    return 0u;
}

static uint16_t a_cal_write(const uint8_t *image, uint8_t force, uint8_t out[7])
{
    corr_cal_t c;
    calimg_info_t info;
    uint8_t slot = 0u;
    uint32_t seq = 0u;
    uint8_t st = calimg_parse(image, CALIMG_SIZE, &c, &info);
    if (st != CALIMG_OK) {
        return (uint16_t)(PERR_IMAGE | ((uint16_t)st << 8));
    }
    st = probe_cal_write(image, force);
    if (st == PROBE_E_SERIAL) {
        return PERR_SERIAL;
    }
    if (st != PROBE_OK) {
        return (uint16_t)(err_code(st) | ((uint16_t)st << 8));
    }
    (void)probe_cal_pending(&slot, &seq);
    out[0] = slot;
    be_put_u32(out + 1, seq);
    /* the CRC field of either version (calimg_parse checked the length) */
    out[5] = image[calimg_length(image) - 4u];
    out[6] = image[calimg_length(image) - 3u];
    return 0u;
}

static uint8_t a_cal_activate(uint8_t slot, uint32_t seq, uint8_t out[5])
{
    uint8_t ps = 0u;
    uint32_t pq = 0u;
    uint8_t st;
    if (!probe_cal_pending(&ps, &pq) || ps != slot || pq != seq) {
        return PERR_STATE; /* only the slot just written and verified can be activated */
    }
    st = probe_cal_activate();
    if (st != PROBE_OK) {
        return err_code(st);
    }
    out[0] = slot;
    be_put_u32(out + 1, seq);
    return 0u;
}

static void a_reset(void)
{
    restart = 1u;
}

static void a_bootloader(void)
{
    restart = 2u;
}

/* ------------------------------------------------------------ text console */

/* v / 2^q with `dec` decimals (dec <= 4, q <= 16), rounded half up. */
static char *put_fixed(char *o, int32_t v, uint8_t q, uint8_t dec)
{
    static const uint16_t p10[5] = {1u, 10u, 100u, 1000u, 10000u};
    uint32_t a, ip, fr;
    if (v < 0) {
        *o++ = '-';
        a = 0u - (uint32_t)v;
    } else {
        a = (uint32_t)v;
    }
    ip = a >> q;
    fr = a & (((uint32_t)1u << q) - 1u);
    fr = (fr * p10[dec] + ((uint32_t)1u << q >> 1)) >> q;
    if (fr >= p10[dec]) {
        fr -= p10[dec];
        ip++;
    }
    o = txt_put_uint(o, ip);
    if (dec != 0u) {
        *o++ = '.';
        for (uint8_t k = dec; k != 0u; k--) {
            *o++ = (char)('0' + (fr / p10[k - 1u]) % 10u);
        }
    }
    return o;
}

static const char hexd[] = "0123456789ABCDEF";

static void t_identity(char *out)
{
    probe_identity_t id;
    char *o = out;
    probe_identity(&id);
    o = txt_put_str(o, APP_PRODUCT " fw ");
    o = txt_put_uint(o, (uint32_t)(id.fw_version >> 8));
    *o++ = '.';
    o = txt_put_uint(o, (uint32_t)(id.fw_version & 0xFFu));
    o = txt_put_str(o, " serial ");
    o = txt_put_uint(o, id.serial);
    if (id.cal_slot == PROBE_SLOT_NONE) {
        o = txt_put_str(o, " cal none");
    } else {
        o = txt_put_str(o, (id.cal_slot == PROBE_SLOT_A) ? " cal A#" : " cal B#");
        o = txt_put_uint(o, id.cal_seq);
        o = txt_put_str(o, " crc ");
        for (uint8_t k = 0u; k < 4u; k++) {
            *o++ = hexd[(id.cal_crc >> (12u - 4u * k)) & 0xFu];
        }
    }
    if (id.adis_status != ADIS_OK || id.ads_status != ADS_OK) {
        o = txt_put_str(o, " SENSOR FAULT");
    }
    *o = '\0';
}

static void t_survey(char *out)
{
    survey_t s;
    uint8_t qc = 0u;
    char *o = out;
    if (probe_survey(&s, &qc) != PROBE_OK) {
        (void)txt_put_str(o, "ERROR sensor");
        o[12] = '\0';
        return;
    }
    o = txt_put_str(o, "INC ");
    o = put_fixed(o, s.att.inc, 16u, 4u);
    o = txt_put_str(o, " AZI ");
    o = put_fixed(o, s.att.azi, 16u, 4u);
    o = txt_put_str(o, " TF ");
    o = put_fixed(o, s.att.gtf, 16u, 4u);
    o = txt_put_str(o, " GT ");
    o = put_fixed(o, fx_asr32_rnd(s.att.gt, 11u), 16u, 4u); /* Q27 -> Q16 g */
    o = txt_put_str(o, " BT ");
    o = put_fixed(o, s.att.bt, 8u, 1u);
    o = txt_put_str(o, " DIP ");
    o = put_fixed(o, s.att.dip, 16u, 3u);
    o = txt_put_str(o, ((qc & 0x7Fu) == 0u) ? " QC PASS" : " QC FAIL");
    *o = '\0';
}

/* compile-time check (C99): the product string fits its 16 bytes */
typedef char app_product_fits[(sizeof(APP_PRODUCT) <= 17u) ? 1 : -1];

static const proto_app_t app = {a_identity,   a_survey,       a_survey_raw,  a_raw,
                                a_qcref_read, a_qcref_write,  a_set_average, a_cal_read,
                                a_cal_write,  a_cal_activate, a_reset,       a_bootloader,
                                t_identity,   t_survey,       send};

/* ------------------------------------------------------------ main loop */
uint8_t app_main_init(void)
{
    uint8_t st;
    hal_init();
    st = probe_init();
    proto_init(&proto, &app);
    tx_queue_init(&txq, txq_buf, (uint16_t)APP_TX_QUEUE);
    restart = 0u;
    last_rx_ms = hal_millis();
    return st;
}

void app_main_poll(void)
{
    uint8_t buf[16];
    uint16_t n = 0u;
    int16_t c;
    uint32_t now;

    while (n < (uint16_t)sizeof buf && (c = hal_sci_getc()) >= 0) {
        buf[n++] = (uint8_t)c;
    }
    now = hal_millis();
    if (n != 0u) {
        last_rx_ms = now;
        proto_rx(&proto, buf, n);
    } else if ((uint32_t)(now - last_rx_ms) >= PROTO_IDLE_MS) {
        proto_idle(&proto);
        last_rx_ms = now;
    }
    if (txq.len < APP_TX_QUEUE / 2u) { /* keep the stream from outrunning the line */
        proto_tick(&proto, now);
    }
    tx_queue_drain(&txq);
}

uint32_t app_main_tx_dropped(void)
{
    return txq.dropped;
}

uint8_t app_main_restart_requested(void)
{
    return (txq.len == 0u) ? restart : 0u; /* only once the answer has gone out */
}
