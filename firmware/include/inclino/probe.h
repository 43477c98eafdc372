/*
 * probe.h - the probe application below the SCI protocol: start-up
 * self-test, acquisition, correction with the calibration held in flash,
 * attitude, survey QC against a stored reference, identity, and the
 * calibration and QC-reference storage calls the protocol layer makes.
 * docs/firmware-app.md describes the whole application; docs/flash.md the
 * flash layout.
 *
 * The protocol layer calls probe_init() once after reset (after hal_init),
 * then any of the functions below.  None of them blocks without a bound;
 * the slowest is probe_survey (about 5 ms per averaged sample).  All state
 * lives in this module and probe_init() re-initialises all of it (the
 * emulator restarts the firmware by calling it again).
 *
 * Status codes: 0 = PROBE_OK; module codes pass through unchanged so the
 * protocol can put one byte on the wire: ADIS_E_* 0x1x, ADS_E_* 0x2x,
 * ACQ_E_* 0x3x, CALSTORE_E_* 0x4x, PROBE_E_* 0x5x.
 */
#ifndef INCLINO_PROBE_H
#define INCLINO_PROBE_H

#include <stdint.h>

#include "inclino/calimg.h"
#include "inclino/qc.h"
#include "inclino/survey.h"

#define PROBE_PRODUCT_ID 0x16210001UL /* "inclino probe, ADIS16210 + ADS1256 fluxgate" */
#define PROBE_FW_VERSION 0x0100u      /* major.minor in the high/low byte: 1.0 */

/* Flash map (global addresses, P-Flash block 1; docs/flash.md) */
#define PROBE_ID_ADDR 0x7A0000UL    /* identity record (factory) */
#define PROBE_CAL_A_ADDR 0x7A0400UL /* calibration slot A */
#define PROBE_CAL_B_ADDR 0x7A0800UL /* calibration slot B */
#define PROBE_QC_A_ADDR 0x7A0C00UL  /* QC reference slot A */
#define PROBE_QC_B_ADDR 0x7A1000UL  /* QC reference slot B */

/* Identity record at PROBE_ID_ADDR, 16 bytes, big-endian: magic 0x494E4944
 * ("INID"), probe serial (u32), hardware revision (u16), 4 bytes 0xFF,
 * CRC-16/CCITT-FALSE of bytes 0..13.  Written once at manufacture. */
#define PROBE_ID_MAGIC 0x494E4944UL
#define PROBE_ID_SIZE 16u

/* QC reference record: 6 x int32 big-endian (gt_ref, gt_tol, bt_ref,
 * bt_tol, dip_ref, dip_tol; formats of qc_ref_t), tolerances >= 0. */
#define PROBE_QC_SIZE 24u

#define PROBE_N_DEFAULT 16u /* samples averaged per survey unless set */

/* Extra qc_flags bit: no QC reference stored; only G total was checked
 * (against 1 g, default tolerance). */
#define PROBE_QC_NO_REF 0x80u

/* Slot selectors for probe_cal_read */
#define PROBE_SLOT_A 0u
#define PROBE_SLOT_B 1u
#define PROBE_SLOT_ACTIVE 2u
#define PROBE_SLOT_NONE 0xFFu /* reported when the identity calibration runs */

/* Status codes */
#define PROBE_OK 0x00u
#define PROBE_E_ARG 0x51u    /* invalid argument */
#define PROBE_E_SERIAL 0x52u /* image for another probe serial (not forced): nothing written */
#define PROBE_E_NO_CAL 0x53u /* read of the active calibration while none is active */
#define PROBE_E_IMAGE 0x54u  /* calimg_parse refused the image: nothing written */

typedef struct {
    int32_t acc[3];  /* mean ADIS16210 counts, Q6 (2^-20 g; acq_avg_q6) */
    int32_t mag[3];  /* mean fluxgate ADC counts, Q6 (2^-6 nT) */
    int32_t temp_cc; /* temperature, 0.01 degC (from the whole-count mean) */
    uint8_t n;       /* samples averaged */
    int32_t temp_q6; /* TEMP_OUT mean, Q6 counts: the temperature the terms are evaluated at */
} probe_raw_t;

typedef struct {
    uint32_t product;      /* PROBE_PRODUCT_ID */
    uint16_t fw_version;   /* PROBE_FW_VERSION */
    uint32_t serial;       /* probe serial from the identity record, 0 if none */
    uint16_t hw_rev;       /* hardware revision from the identity record */
    uint8_t adis_status;   /* start-up result of the ADIS16210 (ADIS_OK or ADIS_E_*) */
    uint8_t ads_status;    /* start-up result of the ADS1256 (ADS_OK or ADS_E_*) */
    uint16_t adis_prod_id; /* PROD_ID read at start-up */
    uint8_t cal_slot;      /* PROBE_SLOT_A, _B or _NONE (identity calibration) */
    uint32_t cal_seq;      /* sequence number of the active slot (0: none) */
    uint16_t cal_crc;      /* CRC field (bytes 116..117) of the active image, 0 if none */
    uint32_t cal_serial;   /* probe serial written in the active image */
    uint32_t cal_time;     /* creation time of the active image (s since 1970) */
    uint8_t cal_method;    /* CALIMG_METHOD_* of the active image */
    uint8_t qc_slot;       /* slot of the stored QC reference, PROBE_SLOT_NONE if none */
} probe_identity_t;

/*
 * probe_init - (re)start the application: read the identity record, load
 *   the calibration (newest valid slot, else identity) and the QC
 *   reference, start and self-test both parts (adis_init, adis_self_test,
 *   ads_init).  Returns PROBE_OK, or the first part's error (both parts are
 *   tried; each one's status is in probe_identity).  Calibration and QC
 *   loading never fail: a missing or invalid record means identity / no
 *   reference.  Takes about 0.5 s (ADIS16210 start-up and self-test).
 */
uint8_t probe_init(void);

/*
 * probe_set_average - samples averaged by probe_survey and probe_raw:
 *   n = 1..ACQ_N_MAX (64).  Returns PROBE_OK or PROBE_E_ARG.
 */
uint8_t probe_set_average(uint8_t n);

/*
 * probe_raw - one averaged acquisition, no correction.  Out: *r.  Returns
 *   PROBE_OK, a part's start-up error (the part is not used after a failed
 *   start-up; probe_init retries), or an acquisition error.
 */
uint8_t probe_raw(probe_raw_t *r);

/*
 * probe_survey - acquire (as probe_raw), correct with the active
 *   calibration, compute the attitude (survey_compute) and check it against
 *   the QC reference (qc_check).  Out: *s; *qc_flags = QC_F_* bits, plus
 *   PROBE_QC_NO_REF when no reference is stored.  Both written only on
 *   PROBE_OK.  The raw readings used are kept for probe_last_raw.
 */
uint8_t probe_survey(survey_t *s, uint8_t *qc_flags);

/*
 * probe_last_raw - the raw readings of the last successful probe_survey or
 *   probe_raw (zeros with n = 0 before the first).  Lets the host check that
 *   the correction is what the calibration file predicts.
 */
void probe_last_raw(probe_raw_t *r);

/*
 * probe_identity - product, firmware version, serial, part statuses and
 *   the active calibration's slot, sequence and CRC.  Never fails.
 */
void probe_identity(probe_identity_t *id);

/*
 * probe_active_cal - the coefficients in use (identity when no slot is
 *   active).
 */
void probe_active_cal(corr_cal_t *cal);

/*
 * probe_cal_write - store a calibration image (its length field's bytes:
 *   120 for version 1, 192 for version 2; img has room for CALIMG_SIZE)
 *   in the inactive slot, verified, not yet in use.  Refused before
 *   anything is written: an image calimg_parse rejects (PROBE_E_IMAGE), an
 *   image whose probe serial differs from this probe's (PROBE_E_SERIAL)
 *   unless force is non-zero or this probe has no serial.  Flash errors:
 *   CALSTORE_E_*.  Takes 1 erase + 16 phrase programs (version 1), 1 erase
 *   + 25 (version 2); the activation 1 more.
 */
uint8_t probe_cal_write(const uint8_t img[CALIMG_SIZE], uint8_t force);

/*
 * probe_cal_activate - commit the image written by the last successful
 *   probe_cal_write since start-up and use it from now on (1 phrase
 *   program).  Returns PROBE_OK or CALSTORE_E_* (NOT_PENDING when there is
 *   nothing to commit); on error the previous calibration stays in use.
 */
uint8_t probe_cal_activate(void);

/*
 * probe_cal_read - the image bytes of slot PROBE_SLOT_A, PROBE_SLOT_B (as
 *   stored, valid or not) or PROBE_SLOT_ACTIVE.  Out: img[CALIMG_SIZE]
 *   (a version 1 slot: its 120 bytes, then its commit record and 0xFF).
 *   Returns PROBE_OK, PROBE_E_ARG, PROBE_E_NO_CAL (ACTIVE while the
 *   identity calibration runs), CALSTORE_E_READ.
 */
uint8_t probe_cal_read(uint8_t slot, uint8_t img[CALIMG_SIZE]);

/*
 * probe_cal_slot - what slot PROBE_SLOT_A or PROBE_SLOT_B holds: *valid = 1
 *   when it is complete and committed (CALSTORE_ST_VALID at boot or after
 *   activation), *seq its header sequence (0 when empty).  Returns PROBE_OK
 *   or PROBE_E_ARG.
 */
uint8_t probe_cal_slot(uint8_t slot, uint8_t *valid, uint32_t *seq);

/*
 * probe_cal_pending - the slot and sequence written by the last successful
 *   probe_cal_write and not yet activated.  Returns 1 when there is one.
 */
uint8_t probe_cal_pending(uint8_t *slot, uint32_t *seq);

/*
 * probe_qc_get - the QC reference in use.  Returns PROBE_OK, or
 *   PROBE_E_NO_CAL when none is stored (*r then holds qc_default(r, 0, 0)).
 */
uint8_t probe_qc_get(qc_ref_t *r);

/*
 * probe_qc_set - store a QC reference (tolerances >= 0, else PROBE_E_ARG)
 *   in its own A/B slots and use it at once (write + activate: 1 erase + 4
 *   programs).  Returns PROBE_OK, PROBE_E_ARG or CALSTORE_E_*.
 */
uint8_t probe_qc_set(const qc_ref_t *r);

/*
 * probe_id_build - encode an identity record (factory tool, emulator).
 *   Out: buf[PROBE_ID_SIZE].
 */
void probe_id_build(uint32_t serial, uint16_t hw_rev, uint8_t buf[PROBE_ID_SIZE]);

#endif /* INCLINO_PROBE_H */
