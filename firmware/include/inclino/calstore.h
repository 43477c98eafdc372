/*
 * calstore.h - power-safe storage of a record (the calibration image, the
 * QC reference) in two flash slots A and B.  Layout, write order and the
 * power-cut argument: docs/flash.md.
 *
 * A slot is one flash sector (HAL_FLASH_SECTOR bytes) at a global address:
 *
 *   offset      size  content
 *   0           4     header magic 0x49534C54 ("ISLT"), big-endian
 *   4           4     sequence number (1, 2, ...), big-endian
 *   8           L     payload (L = payload length, a multiple of 8)
 *   8 + L       2     commit magic 0x434D ("CM")
 *   10 + L      2     CRC-16/CCITT-FALSE of bytes 0 .. 8 + L - 1
 *   12 + L      4     sequence number again
 *
 * Writing (calstore_write) erases the slot that is not active, checks the
 * erase, programs the header phrase and the payload phrases, and reads them
 * back.  Activating (calstore_activate) programs the commit phrase -- the
 * last write of all -- and checks the whole slot.  At boot (calstore_boot)
 * a slot is valid when header magic, commit magic, both sequence numbers,
 * the CRC and the payload check all agree; the valid slot with the highest
 * sequence number is active (A on a tie, which the write order never
 * produces), else none.  A power cut at any program or erase step leaves
 * either the old active slot (the commit of the new one is missing or
 * wrong) or the complete new one: never a mix.
 *
 * Status codes 0x40..0x4F (0 = CALSTORE_OK).
 */
#ifndef INCLINO_CALSTORE_H
#define INCLINO_CALSTORE_H

#include <stdint.h>

#define CALSTORE_SLOT_A 0u
#define CALSTORE_SLOT_B 1u
#define CALSTORE_SLOT_NONE 0xFFu

#define CALSTORE_HDR_MAGIC 0x49534C54UL
#define CALSTORE_COMMIT_MAGIC 0x434Du
#define CALSTORE_PAYLOAD_MAX 192u /* the calibration image version 2, 24 phrases */

/* Slot states (calstore_info_t.state) */
#define CALSTORE_ST_VALID 0u       /* complete, committed, checked */
#define CALSTORE_ST_EMPTY 1u       /* header magic missing (erased or torn erase) */
#define CALSTORE_ST_UNCOMMITTED 2u /* header present, commit missing or torn */
#define CALSTORE_ST_BAD_CRC 3u     /* commit present but CRC or sequence disagree */
#define CALSTORE_ST_BAD_PAYLOAD 4u /* CRC good, payload check failed */
#define CALSTORE_ST_UNREADABLE 5u  /* flash read failed */

/* Status codes */
#define CALSTORE_OK 0x00u
#define CALSTORE_E_ARG 0x41u         /* bad slot, bad configuration */
#define CALSTORE_E_PAYLOAD 0x42u     /* the payload check refused the record: nothing written */
#define CALSTORE_E_FLASH 0x43u       /* a program or erase command failed (see last_flash) */
#define CALSTORE_E_ERASE 0x44u       /* the erased slot does not read 0xFF */
#define CALSTORE_E_VERIFY 0x45u      /* read back differs from what was programmed */
#define CALSTORE_E_NOT_PENDING 0x46u /* activate without a verified write since boot */
#define CALSTORE_E_READ 0x47u        /* a flash read failed */

/*
 * Payload check: returns 0 when the payload (len bytes) is acceptable.
 * Used before writing and at boot.
 */
typedef uint8_t (*calstore_check_t)(const uint8_t *payload, uint16_t len);

typedef struct {
    uint32_t base[2];       /* global flash address of slot A and B, sector-aligned */
    uint16_t payload_len;   /* bytes, multiple of 8, 8..CALSTORE_PAYLOAD_MAX */
    calstore_check_t check; /* payload check (may be NULL: any payload) */
    /* a second, shorter payload length a slot may hold (a multiple of 8,
     * 8..payload_len - 8), or 0: none.  The calibration's is the version 1
     * image (120 bytes): slots written before version 2 still load, and a
     * version 1 download is still written as 120 bytes.  The commit record
     * follows the slot's own payload; a slot is read at payload_len first,
     * then at alt_len. */
    uint16_t alt_len;
} calstore_cfg_t;

typedef struct {
    const calstore_cfg_t *cfg;
    uint8_t active;      /* CALSTORE_SLOT_* */
    uint32_t active_seq; /* sequence number of the active slot, 0 if none */
    uint16_t active_crc; /* slot CRC (commit record) of the active slot */
    uint8_t pending;     /* slot written and verified, not yet committed */
    uint32_t pending_seq;
    uint16_t pending_crc;
    uint16_t pending_len; /* payload length of the pending slot */
    uint8_t state[2];     /* CALSTORE_ST_* of slot A, B (boot scan, then kept) */
    uint32_t seq[2];      /* header sequence of slot A, B (0 when empty) */
    uint16_t len[2];      /* payload length of slot A, B (payload_len unless alt_len was found) */
    uint8_t last_flash;   /* HAL_FLASH_* of the last failed flash command */
} calstore_t;

/*
 * calstore_boot - scan both slots of cfg and pick the active one (see
 *   above).  Out: *cs, fully (re)initialised.  Returns CALSTORE_OK or
 *   CALSTORE_E_ARG (bad cfg).  Reads at most 2 x (16 + payload_len) bytes.
 */
uint8_t calstore_boot(calstore_t *cs, const calstore_cfg_t *cfg);

/*
 * calstore_write - write payload (len bytes: cfg->payload_len, or
 *   cfg->alt_len when it is not 0) into the slot that is not active (A
 *   when none is) with sequence active_seq + 1: check, erase (1 erase),
 *   verify erased, program header and payload (1 + len / 8 programs), read
 *   back and compare.  On success the slot is pending: calstore_activate
 *   commits it.  The active slot is not touched.  Returns CALSTORE_OK,
 *   CALSTORE_E_ARG (another len), CALSTORE_E_PAYLOAD (nothing written),
 *   CALSTORE_E_FLASH, CALSTORE_E_ERASE, CALSTORE_E_VERIFY.
 */
uint8_t calstore_write(calstore_t *cs, const uint8_t *payload, uint16_t len);

/*
 * calstore_activate - program the commit phrase of the pending slot (one
 *   program), read the whole slot back and check it as at boot; on success
 *   it becomes the active slot.  The pending state is cleared in every case
 *   (a failed commit needs a new calstore_write).  Returns CALSTORE_OK,
 *   CALSTORE_E_NOT_PENDING, CALSTORE_E_FLASH, CALSTORE_E_VERIFY.
 */
uint8_t calstore_activate(calstore_t *cs);

/*
 * calstore_read - copy cfg->payload_len bytes from the payload of slot A
 *   or B as they are in flash (valid or not) into dst[cfg->payload_len]
 *   (a slot holding alt_len bytes: its payload, then its commit record and
 *   erased bytes).  Returns CALSTORE_OK,
 *   CALSTORE_E_ARG, CALSTORE_E_READ.
 */
uint8_t calstore_read(const calstore_t *cs, uint8_t slot, uint8_t *dst);

/*
 * calstore_flash_ops - program + erase commands one write and activation
 *   of payload_len bytes take for this configuration: 1 erase + 1 header
 *   + payload_len / 8 payload + 1 commit (alt_len / 8 for a shorter one).
 */
uint16_t calstore_flash_ops(const calstore_cfg_t *cfg);

#endif /* INCLINO_CALSTORE_H */
