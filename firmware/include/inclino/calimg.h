/*
 * calimg.h - the calibration image: the bytes a calibration download writes
 * into a flash slot and the probe checks before it uses them.  Big-endian
 * (the HCS12X's order), fixed size CALIMG_SIZE (a multiple of the 8-byte
 * flash phrase):
 *
 *   offset size field
 *     0     4  magic 0x4943414C ("ICAL")
 *     4     2  format version (CALIMG_VERSION)
 *     6     2  total length in bytes (CALIMG_SIZE)
 *     8     4  probe serial number
 *    12     4  creation time, seconds since 1970-01-01 UTC
 *    16     1  method (CALIMG_METHOD_*)
 *    17     3  reserved, 0
 *    20    96  coefficients, int32 each: acc M[9] (Q29), acc b[3] (Q29 g),
 *              mag M[9] (Q29), mag b[3] (Q10 nT)
 *   116     2  CRC-16/CCITT-FALSE of bytes 0..115
 *   118     2  padding 0xFFFF (not covered by the CRC)
 */
#ifndef INCLINO_CALIMG_H
#define INCLINO_CALIMG_H

#include <stdint.h>

#include "inclino/correct.h"

#define CALIMG_MAGIC 0x4943414CUL
#define CALIMG_VERSION 1u
#define CALIMG_SIZE 120u
#define CALIMG_CRC_OFFSET 116u

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
 *   Checks, in order: length, magic, version, CRC, ranges: every bias within
 *   +-2^30 (2 g; 2^20 nT), every diagonal element of M in [1/4, 4) (a
 *   smaller or negative scale means a wrong or swapped axis).  Singularity
 *   is the host's check (it has the floating point to compute a condition
 *   number); an image whose diagonal passes but whose matrix is singular
 *   produces flagged surveys (zero vectors), never a crash.
 */
uint8_t calimg_parse(const uint8_t *buf, uint16_t len, corr_cal_t *cal, calimg_info_t *info);

/*
 * calimg_build - encode cal and info into buf[CALIMG_SIZE] with its CRC
 *   (the inverse of calimg_parse; used by the probe to report its
 *   calibration and by tests).
 */
void calimg_build(const corr_cal_t *cal, const calimg_info_t *info, uint8_t buf[CALIMG_SIZE]);

#endif /* INCLINO_CALIMG_H */
