/*
 * harness.c - the firmware core on the S08 instruction-set simulator.
 *
 * Reads commands from the simulator interface (simif.h), runs one core
 * function per command and writes its results back, all big-endian.  The
 * driver is host/inclino/mcu.py, which builds the byte streams, runs shc08 and
 * compares every result word with the golden model.
 *
 * Command byte: a letter below; with bit 7 set the call is "timed": the
 * harness stops the simulator just before and just after the call, and the
 * driver reads the simulator's cycle counter at both stops.  The inputs are
 * read into static buffers before the first stop and the results written
 * after the second, so the difference is the call alone plus a constant
 * overhead, measured with the empty command 'Z'.
 *
 *   'C' acc.m[9] acc.bias[3] mag.m[9] mag.bias[3] (i32)  -> nothing (load cal)
 *   'V' acc[3] (i16) mag[3] (i32)      -> survey_compute: g[3] b[3] inc azi gtf
 *                                         mtf gt bt dip (i32) flags (u16)
 *   'K' triad (u8: 0 acc, 1 mag) x[3]  -> corr_triad: out[3] (i32) sat (u8)
 *   'T' g[3] b[3] (i32)                -> att_compute: inc azi gtf mtf gt bt
 *                                         dip (i32) flags (u16)
 *   'M' a b (i32)                      -> fx_mul32_q31: r (i32) sat (u8)
 *   '3' a[3] b[3] (i32)                -> fx_dot3_q31: r (i32) sat (u8)
 *   'W' a[3] (i32)                     -> fx_dot3_q31(a, a): r (i32) sat (u8)
 *   'N' v[3] (i32)                     -> att_norm3: out[3] (i32) s (i8)
 *   'S' x (i32) n (u8)                 -> fx_asr32 (i32)
 *   'U' x (i32) n (u8)                 -> fx_asr32_rnd (i32)
 *   '+' a b (i32)                      -> fx_add32_sat: r (i32) sat (u8)
 *   '-' a b (i32)                      -> fx_sub32_sat: r (i32) sat (u8)
 *   'D' num den (u32)                  -> fx_div_frac_q20 (u32)
 *   'Q' x (u32)                        -> fx_sqrt_u32_q8 (u32)
 *   'R' x (u32)                        -> fx_isqrt_u32 (u16)
 *   'A' y x (i32)                      -> fx_atan2_q16 (i32)
 *   'P' a b (i16)                      -> fx_mul16 (i32)
 *   'Z'                                -> nothing (timing overhead)
 *   'E'                                -> 'e', then stops the simulator
 * An unknown command writes '?' and stops.
 *
 * Room is left for the protocol frame parser and the calibration-image
 * checker: each gets a command letter here and an encoder in mcu.py.
 */
#include <stdint.h>

#include "inclino/attitude.h"
#include "inclino/correct.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"
#include "inclino/survey.h"
#include "simif.h"

#define TIMED 0x80u

static corr_cal_t cal;
static survey_t sv;
static att_t at;
static int16_t in_acc[3];
static int32_t in_v[6];
static int32_t out_v[3];
static uint32_t in_u[2];
static uint32_t out_u;
static uint8_t out_sat;
static uint8_t timed;

/* two's complement reinterpretation without implementation-defined casts */
static int32_t s32(uint32_t u)
{
    return (u <= 0x7FFFFFFFUL) ? (int32_t)u : -(int32_t)(~u) - 1;
}

static uint32_t u32(int32_t v)
{
    return (uint32_t)v;
}

static int32_t rd_i32(void)
{
    return s32(sif_rd32());
}

static void wr_i32(int32_t v)
{
    sif_wr32(u32(v));
}

static void mark(void)
{
    if (timed != 0u) {
        sif_stop();
    }
}

static void rd_vec(int32_t *v, uint8_t n)
{
    uint8_t i;
    for (i = 0u; i < n; i++) {
        v[i] = rd_i32();
    }
}

static void wr_att(const att_t *a)
{
    wr_i32(a->inc);
    wr_i32(a->azi);
    wr_i32(a->gtf);
    wr_i32(a->mtf);
    wr_i32(a->gt);
    wr_i32(a->bt);
    wr_i32(a->dip);
    sif_wr16(a->flags);
}

static void load_cal(void)
{
    rd_vec(cal.acc.m, 9u);
    rd_vec(cal.acc.bias, 3u);
    rd_vec(cal.mag.m, 9u);
    rd_vec(cal.mag.bias, 3u);
}

static void do_survey(void)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        uint16_t u = sif_rd16();
        in_acc[i] = (u <= 0x7FFFu) ? (int16_t)u : (int16_t)(-(int16_t)(~u & 0x7FFFu) - 1);
    }
    rd_vec(in_v, 3u);
    mark();
    survey_compute(in_acc, in_v, &cal, &sv);
    mark();
    for (i = 0u; i < 3u; i++) {
        wr_i32(sv.g[i]);
    }
    for (i = 0u; i < 3u; i++) {
        wr_i32(sv.b[i]);
    }
    wr_att(&sv.att);
}

static void do_triad(void)
{
    uint8_t which = sif_rd8();
    uint8_t i;
    rd_vec(in_v, 3u);
    mark();
    out_sat = corr_triad(in_v, (which != 0u) ? &cal.mag : &cal.acc, out_v);
    mark();
    for (i = 0u; i < 3u; i++) {
        wr_i32(out_v[i]);
    }
    sif_wr8(out_sat);
}

static void do_att(void)
{
    rd_vec(in_v, 6u);
    mark();
    att_compute(&in_v[0], &in_v[3], &at);
    mark();
    wr_att(&at);
}

static int16_t rd_i16(void)
{
    uint16_t u = sif_rd16();
    return (u <= 0x7FFFu) ? (int16_t)u : (int16_t)(-(int16_t)(~u & 0x7FFFu) - 1);
}

static void do_mul16(void)
{
    int16_t a = rd_i16();
    int16_t b = rd_i16();
    int32_t r;
    mark();
    r = fx_mul16(a, b);
    mark();
    wr_i32(r);
}

/* one or two 32-bit operands into in_u */
static void rd_u(uint8_t n)
{
    uint8_t i;
    for (i = 0u; i < n; i++) {
        in_u[i] = sif_rd32();
    }
}

int main(void)
{
    for (;;) {
        uint8_t cmd = sif_rd8();
        timed = (uint8_t)(cmd & TIMED);
        switch ((uint8_t)(cmd & (uint8_t)~TIMED)) {
        case 'C':
            load_cal();
            break;
        case 'V':
            do_survey();
            break;
        case 'K':
            do_triad();
            break;
        case 'T':
            do_att();
            break;
        case 'P':
            do_mul16();
            break;
        case 'M':
            rd_vec(in_v, 2u);
            out_sat = 0u;
            mark();
            out_v[0] = fx_mul32_q31(in_v[0], in_v[1], &out_sat);
            mark();
            wr_i32(out_v[0]);
            sif_wr8(out_sat);
            break;
        case '3':
            rd_vec(in_v, 6u);
            out_sat = 0u;
            mark();
            out_v[0] = fx_dot3_q31(&in_v[0], &in_v[3], &out_sat);
            mark();
            wr_i32(out_v[0]);
            sif_wr8(out_sat);
            break;
        case 'W':
            rd_vec(in_v, 3u);
            out_sat = 0u;
            mark();
            out_v[0] = fx_dot3_q31(in_v, in_v, &out_sat);
            mark();
            wr_i32(out_v[0]);
            sif_wr8(out_sat);
            break;
        case 'N':
            rd_vec(in_v, 3u);
            mark();
            out_sat = (uint8_t)att_norm3(in_v, out_v);
            mark();
            wr_i32(out_v[0]);
            wr_i32(out_v[1]);
            wr_i32(out_v[2]);
            sif_wr8(out_sat);
            break;
        case 'S':
        case 'U':
            rd_vec(in_v, 1u);
            out_sat = sif_rd8();
            mark();
            out_v[0] = (cmd & 0x7Fu) == (uint8_t)'S' ? fx_asr32(in_v[0], out_sat)
                                                     : fx_asr32_rnd(in_v[0], out_sat);
            mark();
            wr_i32(out_v[0]);
            break;
        case '+':
        case '-':
            rd_vec(in_v, 2u);
            out_sat = 0u;
            mark();
            out_v[0] = (cmd & 0x7Fu) == (uint8_t)'+' ? fx_add32_sat(in_v[0], in_v[1], &out_sat)
                                                     : fx_sub32_sat(in_v[0], in_v[1], &out_sat);
            mark();
            wr_i32(out_v[0]);
            sif_wr8(out_sat);
            break;
        case 'D':
            rd_u(2u);
            mark();
            out_u = fx_div_frac_q20(in_u[0], in_u[1]);
            mark();
            sif_wr32(out_u);
            break;
        case 'Q':
            rd_u(1u);
            mark();
            out_u = fx_sqrt_u32_q8(in_u[0]);
            mark();
            sif_wr32(out_u);
            break;
        case 'R':
            rd_u(1u);
            mark();
            out_u = fx_isqrt_u32(in_u[0]);
            mark();
            sif_wr16((uint16_t)out_u);
            break;
        case 'A':
            rd_vec(in_v, 2u);
            mark();
            out_v[0] = fx_atan2_q16(in_v[0], in_v[1]);
            mark();
            wr_i32(out_v[0]);
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
