/*
 * calimg.h - the calibration image: the bytes a calibration download writes
 * into a flash slot and the probe checks before it uses them.  Big-endian
 * (the HCS12X's order), a multiple of the 8-byte flash phrase.  Two
 * versions, told apart by the version and length fields:
 *
 *   offset size field
 *     0     4  magic 0x4943414C ("ICAL")
 *     4     2  format version: 1 (CALIMG_VERSION_1) or 2 (CALIMG_VERSION)
 *     6     2  total length in bytes: 120 (CALIMG_SIZE_V1) or 192 (CALIMG_SIZE)
 *     8     4  probe serial number
 *    12     4  creation time, seconds since 1970-01-01 UTC
 *    16     1  method (CALIMG_METHOD_*)
 *    17     1  version 1: reserved, 0; version 2: order of the temperature
 *              terms, 0..2 (0: none)
 *    18     2  version 1: reserved, 0; version 2: t_ref, int16 Q7 degC,
 *              -40..125 degC
 *    20    96  coefficients, int32 each: acc M[9] (Q29), acc b[3] (Q29 g),
 *              mag M[9] (Q29), mag b[3] (Q10 nT)
 *   version 1:
 *   116     2  CRC-16/CCITT-FALSE of bytes 0..115
 *   118     2  padding 0xFFFF (not covered by the CRC)
 *   version 2: the temperature terms (correct.h corr_tc_t), acc then mag,
 *   36 bytes per triad:
 *   116    12  c1[3] int32 (Q38 g/degC; Q19 nT/degC)
 *   128     6  c2[3] int16 (Q31 g/degC^2; Q12 nT/degC^2)
 *   134    12  r1[3] int32 (Q38 /degC)
 *   146     6  r2[3] int16 (Q31 /degC^2)
 *   152    36  the same for mag
 *   188     2  CRC-16/CCITT-FALSE of bytes 0..187
 *   190     2  padding 0xFFFF
 * A version 1 image decodes with no temperature terms (t_order 0).
 */
#ifndef INCLINO_CALIMG_H
#define INCLINO_CALIMG_H

#include <stdint.h>

#include "inclino/correct.h"

#define CALIMG_MAGIC 0x4943414CUL
#define CALIMG_VERSION 2u
#define CALIMG_SIZE 192u /* the largest image (version 2): buffers are this size */
#define CALIMG_CRC_OFFSET 188u
#define CALIMG_VERSION_1 1u
#define CALIMG_SIZE_V1 120u
#define CALIMG_CRC_OFFSET_V1 116u
#define CALIMG_T_REF_MIN (-40 * 128) /* Q7 degC */
#define CALIMG_T_REF_MAX (125 * 128)

#define CALIMG_METHOD_IDENTITY 0u
#define CALIMG_METHOD_REN2014 1u
#define CALIMG_METHOD_LI2021 2u
#define CALIMG_METHOD_GUO2009 3u
#define CALIMG_METHOD_JOINT 4u

/* calimg_parse results */
#define CALIMG_OK 0u
#define CALIMG_E_LENGTH 1u  /* buffer shorter than CALIMG_SIZE or length field wrong */
#define CALIMG_E_MAGIC 2u   /* not a calibration image (erased flash reads 0xFF) */
#define CALIMG_E_VERSION 3u /* another format version */
#define CALIMG_E_CRC 4u     /* CRC mismatch: torn or corrupt */
#define CALIMG_E_RANGE 5u   /* a coefficient outside the accepted range */

typedef struct {
    uint32_t serial;
    uint32_t time;
    uint8_t method;
} calimg_info_t;

/*
 * calimg_parse - check an image and decode it.
 *   In: buf, len bytes.  Out: *cal and *info, written only when the result
 *   is CALIMG_OK (nothing is touched otherwise).
 *   Checks, in order: length (len >= the length field, which is 120 or
 *   192), magic, version (1 with 120 bytes, 2 with 192), CRC, ranges:
 *   every bias within +-2^30 (2 g; 2^20 nT), every diagonal element of M
 *   in [1/4, 4) (a smaller or negative scale means a wrong or swapped
 *   axis); version 2: order 0..2, t_ref within -40..125 degC, |c1| and
 *   |r1| <= 2^30 and c2, r2 not -2^15 (corr_temp_eval's sums and products
 *   stay within int32 without saturating), the
 *   second-order ones 0 below order 2 and all 0 at order 0.  A version 1
 *   image decodes with t_order = 0 and all terms 0.  Singularity
 *   is the host's check (it has the floating point to compute a condition
 *   number); an image whose diagonal passes but whose matrix is singular
 *   produces flagged surveys (zero vectors), never a crash.
 */
uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info);

/*
 * calimg_build - encode cal and info into buf[CALIMG_SIZE] with its CRC
 *   (the inverse of calimg_parse; used by tests): version 1 (120 bytes,
 *   the rest of buf 0xFF) when cal->t_order is 0, else version 2.
 *   Returns the image's length.
 */
uint16_t calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[CALIMG_SIZE]);

/*
 * calimg_length - the length field of an image (len >= 8), 0 when it is
 *   neither 120 nor 192 (what calimg_parse would refuse).
 */
uint16_t calimg_length(const uint8_t *buf);

#endif /* INCLINO_CALIMG_H */
