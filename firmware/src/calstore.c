/* calstore.c - A/B slot storage; contracts and layout in calstore.h. */
#include "inclino/calstore.h"
#include "inclino/be_bytes.h"
#include "inclino/crc16.h"
#include "inclino/hal.h"

#define HDR_LEN 8u
#define COMMIT_LEN 8u

static uint8_t cfg_ok(const calstore_cfg_t *cfg)
{
    return (uint8_t)(cfg != 0 && cfg->payload_len >= HAL_FLASH_PHRASE &&
                     cfg->payload_len <= CALSTORE_PAYLOAD_MAX &&
                     (cfg->payload_len % HAL_FLASH_PHRASE) == 0u &&
                     (cfg->alt_len % HAL_FLASH_PHRASE) == 0u && cfg->alt_len < cfg->payload_len &&
                     (cfg->base[0] % HAL_FLASH_SECTOR) == 0u &&
                     (cfg->base[1] % HAL_FLASH_SECTOR) == 0u && cfg->base[0] != cfg->base[1]);
}

/*
 * Check one slot as at boot.  Out: *seq (header sequence, 0 when the header
 * is missing), *crc (slot CRC).  Returns CALSTORE_ST_*.
 */
static uint8_t slot_check_len(const calstore_cfg_t *cfg, uint8_t slot, uint16_t len, uint32_t *seq,
                              uint16_t *crc)
{
    uint8_t hdr[HDR_LEN];
    uint8_t buf[CALSTORE_PAYLOAD_MAX];
    uint8_t com[COMMIT_LEN];
    uint32_t base = cfg->base[slot];
    uint16_t c;
    uint32_t s;

    *seq = 0u;
    *crc = 0u;
    if (hal_flash_read(base, hdr, HDR_LEN) != HAL_FLASH_OK ||
        hal_flash_read(base + HDR_LEN, buf, len) != HAL_FLASH_OK ||
        hal_flash_read(base + HDR_LEN + len, com, COMMIT_LEN) != HAL_FLASH_OK) {
        return CALSTORE_ST_UNREADABLE;
    }
    s = be_get_u32(hdr + 4);
    if (be_get_u32(hdr) != CALSTORE_HDR_MAGIC || s == 0u || s == 0xFFFFFFFFUL) {
        return CALSTORE_ST_EMPTY;
    }
    *seq = s;
    if (be_get_u16(com) != CALSTORE_COMMIT_MAGIC) {
        return CALSTORE_ST_UNCOMMITTED;
    }
    c = crc16_update(CRC16_INIT, hdr, HDR_LEN);
    c = crc16_update(c, buf, len);
    if (be_get_u16(com + 2) != c || be_get_u32(com + 4) != s) {
        return CALSTORE_ST_BAD_CRC;
    }
    *crc = c;
    if (cfg->check != 0 && cfg->check(buf, len) != 0u) {
        return CALSTORE_ST_BAD_PAYLOAD;
    }
    return CALSTORE_ST_VALID;
}

/* A slot at payload_len, else (alt_len set) at alt_len; *len the length
 * found valid (payload_len when neither is: its state is reported). */
static uint8_t slot_check(const calstore_cfg_t *cfg, uint8_t slot, uint32_t *seq, uint16_t *crc,
                          uint16_t *len)
{
    uint8_t st = slot_check_len(cfg, slot, cfg->payload_len, seq, crc);
    *len = cfg->payload_len;
    if (st != CALSTORE_ST_VALID && st != CALSTORE_ST_EMPTY && st != CALSTORE_ST_UNREADABLE &&
        cfg->alt_len != 0u) {
        uint32_t s2;
        uint16_t c2;
        if (slot_check_len(cfg, slot, cfg->alt_len, &s2, &c2) == CALSTORE_ST_VALID) {
            *seq = s2;
            *crc = c2;
            *len = cfg->alt_len;
            return CALSTORE_ST_VALID;
        }
    }
    return st;
}

uint8_t calstore_boot(calstore_t *cs, const calstore_cfg_t *cfg)
{
    uint8_t i;
    uint16_t crc[2];

    cs->cfg = cfg;
    cs->active = CALSTORE_SLOT_NONE;
    cs->active_seq = 0u;
    cs->active_crc = 0u;
    cs->pending = CALSTORE_SLOT_NONE;
    cs->pending_seq = 0u;
    cs->pending_crc = 0u;
    cs->last_flash = HAL_FLASH_OK;
    cs->state[0] = CALSTORE_ST_UNREADABLE;
    cs->state[1] = CALSTORE_ST_UNREADABLE;
    cs->seq[0] = 0u;
    cs->seq[1] = 0u;
    cs->pending_len = 0u;
    cs->len[0] = 0u;
    cs->len[1] = 0u;
    if (!cfg_ok(cfg)) {
        return CALSTORE_E_ARG;
    }
    for (i = 0u; i < 2u; i++) {
        cs->state[i] = slot_check(cfg, i, &cs->seq[i], &crc[i], &cs->len[i]);
        if (cs->state[i] == CALSTORE_ST_VALID &&
            (cs->active == CALSTORE_SLOT_NONE || cs->seq[i] > cs->active_seq)) {
            cs->active = i;
            cs->active_seq = cs->seq[i];
            cs->active_crc = crc[i];
        }
    }
    return CALSTORE_OK;
}

static uint8_t program(calstore_t *cs, uint32_t addr, const uint8_t *p)
{
    uint8_t r = hal_flash_program(addr, p);
    if (r != HAL_FLASH_OK) {
        cs->last_flash = r;
        return CALSTORE_E_FLASH;
    }
    return CALSTORE_OK;
}

/* Compare flash at addr with ref[n] (n a multiple of 8); ref == 0: 0xFF. */
static uint8_t compare(uint32_t addr, const uint8_t *ref, uint16_t n)
{
    uint8_t ph[HAL_FLASH_PHRASE];
    uint16_t off;
    uint8_t j;
    for (off = 0u; off < n; off = (uint16_t)(off + HAL_FLASH_PHRASE)) {
        if (hal_flash_read(addr + off, ph, HAL_FLASH_PHRASE) != HAL_FLASH_OK) {
            return CALSTORE_E_READ;
        }
        for (j = 0u; j < HAL_FLASH_PHRASE; j++) {
            if (ph[j] != ((ref != 0) ? ref[off + j] : 0xFFu)) {
                return CALSTORE_E_VERIFY;
            }
        }
    }
    return CALSTORE_OK;
}

uint8_t calstore_write(calstore_t *cs, const uint8_t *payload, uint16_t len)
{
    const calstore_cfg_t *cfg = cs->cfg;
    uint8_t hdr[HDR_LEN];
    uint8_t target;
    uint32_t base;
    uint32_t seq;
    uint16_t off;
    uint8_t r;

    if (!cfg_ok(cfg) || len == 0u || (len != cfg->payload_len && len != cfg->alt_len)) {
        return CALSTORE_E_ARG;
    }
    if (cfg->check != 0 && cfg->check(payload, len) != 0u) {
        return CALSTORE_E_PAYLOAD;
    }
    cs->pending = CALSTORE_SLOT_NONE;
    target = (cs->active == CALSTORE_SLOT_A) ? CALSTORE_SLOT_B : CALSTORE_SLOT_A;
    seq = (cs->active == CALSTORE_SLOT_NONE) ? 1UL : cs->active_seq + 1UL;
    base = cfg->base[target];

    /* the target is no longer what the boot scan saw */
    cs->state[target] = CALSTORE_ST_EMPTY;
    cs->seq[target] = 0u;
    r = hal_flash_erase(base);
    if (r != HAL_FLASH_OK) {
        cs->last_flash = r;
        return CALSTORE_E_FLASH;
    }
    r = compare(base, 0, (uint16_t)(HDR_LEN + cfg->payload_len + COMMIT_LEN));
    if (r != CALSTORE_OK) {
        return (r == CALSTORE_E_VERIFY) ? CALSTORE_E_ERASE : r;
    }
    be_put_u32(hdr, CALSTORE_HDR_MAGIC);
    be_put_u32(hdr + 4, seq);
    r = program(cs, base, hdr);
    for (off = 0u; r == CALSTORE_OK && off < len; off = (uint16_t)(off + HAL_FLASH_PHRASE)) {
        r = program(cs, base + HDR_LEN + off, payload + off);
    }
    if (r == CALSTORE_OK) {
        r = compare(base, hdr, HDR_LEN);
    }
    if (r == CALSTORE_OK) {
        r = compare(base + HDR_LEN, payload, len);
    }
    if (r != CALSTORE_OK) {
        return r;
    }
    cs->state[target] = CALSTORE_ST_UNCOMMITTED;
    cs->seq[target] = seq;
    cs->pending = target;
    cs->pending_seq = seq;
    cs->pending_len = len;
    cs->len[target] = len;
    cs->pending_crc = crc16_update(crc16_update(CRC16_INIT, hdr, HDR_LEN), payload, len);
    return CALSTORE_OK;
}

uint8_t calstore_activate(calstore_t *cs)
{
    const calstore_cfg_t *cfg = cs->cfg;
    uint8_t com[COMMIT_LEN];
    uint8_t slot = cs->pending;
    uint32_t seq;
    uint16_t crc;
    uint8_t r;

    if (slot == CALSTORE_SLOT_NONE || !cfg_ok(cfg)) {
        return CALSTORE_E_NOT_PENDING;
    }
    cs->pending = CALSTORE_SLOT_NONE;
    be_put_u16(com, CALSTORE_COMMIT_MAGIC);
    be_put_u16(com + 2, cs->pending_crc);
    be_put_u32(com + 4, cs->pending_seq);
    r = program(cs, cfg->base[slot] + HDR_LEN + cs->pending_len, com);
    cs->state[slot] = slot_check(cfg, slot, &seq, &crc, &cs->len[slot]);
    cs->seq[slot] = seq;
    if (r != CALSTORE_OK) {
        return r;
    }
    if (cs->state[slot] != CALSTORE_ST_VALID || seq != cs->pending_seq) {
        return CALSTORE_E_VERIFY;
    }
    cs->active = slot;
    cs->active_seq = seq;
    cs->active_crc = crc;
    return CALSTORE_OK;
}

uint8_t calstore_read(const calstore_t *cs, uint8_t slot, uint8_t *dst)
{
    const calstore_cfg_t *cfg = cs->cfg;
    if (slot > CALSTORE_SLOT_B || !cfg_ok(cfg)) {
        return CALSTORE_E_ARG;
    }
    if (hal_flash_read(cfg->base[slot] + HDR_LEN, dst, cfg->payload_len) != HAL_FLASH_OK) {
        return CALSTORE_E_READ;
    }
    return CALSTORE_OK;
}

uint16_t calstore_flash_ops(const calstore_cfg_t *cfg)
{
    return (uint16_t)(3u + cfg->payload_len / HAL_FLASH_PHRASE);
}
