/*
 * survey_float.c - the survey computation of firmware/src/survey.c written
 * with `float`, for SDCC's software floating point on the S08.  It is the
 * baseline of the fixed-point/float cycle ratio of `inclino bench mcu`; it
 * lives outside firmware/ because the firmware holds no float.
 *
 * Same steps as survey_compute: range flags, correction of both triads
 * (M * (raw - b)), then inclination, azimuth, both toolfaces, G and B totals
 * and dip with atan2f/sqrtf, angles in degrees.  Same byte protocol as
 * firmware/sim/s08/harness.c (simif.h), with
 *   'C' acc.m[9] acc.bias[3] (g) mag.m[9] mag.bias[3] (nT), IEEE float32
 *   'V' acc[3] mag[3] (i32, Q6 counts) -> inc azi gtf mtf (deg) gt (g) bt (nT)
 *                                   dip (deg), float32, then flags (u16)
 *   'Z', 'E' and the timed bit 0x80 as in the harness.
 */
#include <math.h>
#include <stdint.h>

#include "simif.h"

#define TIMED 0x80u
#define RAD2DEG 57.29577951308232f
#define ACC_LSB_G (1.0f / 16384.0f)
#define Q6_ONE 64L

typedef union {
    float f;
    uint32_t u;
} fbits_t;

typedef struct {
    float m[9];
    float bias[3];
} ftriad_t;

typedef struct {
    float inc, azi, gtf, mtf, gt, bt, dip;
    uint16_t flags;
} fsurvey_t;

static ftriad_t cal_acc, cal_mag;
static int32_t in_acc[3];
static int32_t in_mag[3];
static fsurvey_t out;
static uint8_t timed;

static float rd_f(void)
{
    fbits_t b;
    b.u = sif_rd32();
    return b.f;
}

static void wr_f(float f)
{
    fbits_t b;
    b.f = f;
    sif_wr32(b.u);
}

static void mark(void)
{
    if (timed != 0u) {
        sif_stop();
    }
}

static void correct(const float x[3], const ftriad_t *c, float o[3])
{
    float d0 = x[0] - c->bias[0], d1 = x[1] - c->bias[1], d2 = x[2] - c->bias[2];
    o[0] = c->m[0] * d0 + c->m[1] * d1 + c->m[2] * d2;
    o[1] = c->m[3] * d0 + c->m[4] * d1 + c->m[5] * d2;
    o[2] = c->m[6] * d0 + c->m[7] * d1 + c->m[8] * d2;
}

static float wrap360(float a)
{
    return (a < 0.0f) ? a + 360.0f : a;
}

static void survey_float(const int32_t acc[3], const int32_t mag[3], fsurvey_t *s)
{
    float x[3], g[3], b[3];
    float h2, gt, bt, gdotb, cx, cy, cz;
    uint16_t flags = 0u;
    uint8_t i;

    for (i = 0u; i < 3u; i++) {
        int32_t a = acc[i];
        if (a > 27853L * Q6_ONE || a < -27853L * Q6_ONE) {
            flags |= 0x0002u;
        }
        if (a >= 32767L * Q6_ONE - Q6_ONE / 2 || a < -32768L * Q6_ONE + Q6_ONE / 2) {
            flags |= 0x0008u;
        }
        if (a > 32767L * Q6_ONE) {
            a = 32767L * Q6_ONE;
        } else if (a < -32768L * Q6_ONE) {
            a = -32768L * Q6_ONE;
        }
        x[i] = (float)a * (ACC_LSB_G / (float)Q6_ONE);
    }
    correct(x, &cal_acc, g);
    for (i = 0u; i < 3u; i++) {
        int32_t m = mag[i];
        if (m > 100000L * Q6_ONE || m < -100000L * Q6_ONE) {
            flags |= 0x0004u;
        }
        if (m >= 0xFFFFFL * Q6_ONE) {
            m = 0xFFFFFL * Q6_ONE;
            flags |= 0x0010u;
        } else if (m <= (-0xFFFFFL - 1) * Q6_ONE) {
            m = (-0xFFFFFL - 1) * Q6_ONE;
            flags |= 0x0010u;
        }
        x[i] = (float)m * (1.0f / (float)Q6_ONE);
    }
    correct(x, &cal_mag, b);

    h2 = g[0] * g[0] + g[1] * g[1];
    gt = sqrtf(h2 + g[2] * g[2]);
    bt = sqrtf(b[0] * b[0] + b[1] * b[1] + b[2] * b[2]);
    s->inc = atan2f(sqrtf(h2), g[2]) * RAD2DEG;
    s->gtf = wrap360(atan2f(g[1], -g[0]) * RAD2DEG);
    s->azi = wrap360(atan2f(gt * (g[0] * b[1] - g[1] * b[0]),
                            b[2] * h2 - g[2] * (g[0] * b[0] + g[1] * b[1])) *
                     RAD2DEG);
    s->mtf = wrap360(atan2f(-b[1], b[0]) * RAD2DEG);
    gdotb = g[0] * b[0] + g[1] * b[1] + g[2] * b[2];
    cx = g[1] * b[2] - g[2] * b[1];
    cy = g[2] * b[0] - g[0] * b[2];
    cz = g[0] * b[1] - g[1] * b[0];
    s->dip = atan2f(gdotb, sqrtf(cx * cx + cy * cy + cz * cz)) * RAD2DEG;
    s->gt = gt;
    s->bt = bt;
    if (s->inc < 0.5f || s->inc > 179.5f) {
        flags |= 0x0001u;
    }
    s->flags = flags;
}

static void rd_triad(ftriad_t *c)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        c->m[i] = rd_f();
    }
    for (i = 0u; i < 3u; i++) {
        c->bias[i] = rd_f();
    }
}

int main(void)
{
    uint8_t i;
    for (;;) {
        uint8_t cmd = sif_rd8();
        timed = (uint8_t)(cmd & TIMED);
        switch ((uint8_t)(cmd & (uint8_t)~TIMED)) {
        case 'C':
            rd_triad(&cal_acc);
            rd_triad(&cal_mag);
            break;
        case 'V':
            for (i = 0u; i < 3u; i++) {
                in_acc[i] = (int32_t)sif_rd32();
            }
            for (i = 0u; i < 3u; i++) {
                in_mag[i] = (int32_t)sif_rd32();
            }
            mark();
            survey_float(in_acc, in_mag, &out);
            mark();
            wr_f(out.inc);
            wr_f(out.azi);
            wr_f(out.gtf);
            wr_f(out.mtf);
            wr_f(out.gt);
            wr_f(out.bt);
            wr_f(out.dip);
            sif_wr16(out.flags);
            break;
        case 'Z':
            mark();
            mark();
            break;
        case 'E':
            sif_wr8((uint8_t)'e');
            sif_stop();
            break;
        default:
            sif_wr8((uint8_t)'?');
            sif_stop();
            break;
        }
    }
}
