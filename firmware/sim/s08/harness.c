/*
 * harness.c - the firmware core on the S08 instruction-set simulator.
 *
 * Reads commands from the simulator interface (simif.h), runs one core
 * function per command and writes its results back, all big-endian.  The
 * driver is host/inclino/s08/ (toolchain.py builds the image, harness.py the
 * byte streams, simulator.py runs shc08); the tests compare every result
 * word with the golden model.
 *
 * Command byte: a letter below; with bit 7 set the call is "timed": the
 * harness stops the simulator just before and just after the call, and the
 * driver reads the simulator's cycle counter at both stops.  The inputs are
 * read into static buffers before the first stop and the results written
 * after the second, so the difference is the call alone plus a constant
 * overhead, measured with the empty command 'Z'.
 *
 *   'C' acc.m[9] acc.bias[3] mag.m[9] mag.bias[3] (i32)  -> nothing (load cal,
 *                                         no temperature terms)
 *   'H' t_ref (i16) t_order (u8), then for acc and mag: c1[3] (i32) c2[3]
 *       (i16) r1[3] (i32) r2[3] (i16)  -> nothing (the loaded cal's
 *                                         temperature terms)
 *   'V' acc[3] mag[3] (i32, Q6 counts) -> survey_compute: g[3] b[3] inc azi gtf
 *                                         mtf gt bt dip (i32) flags (u16)
 *   'Y' acc[3] mag[3] temp_q6 (i32)    -> survey_compute_temp: as 'V'
 *   'e' triad (u8) dt (i16)            -> corr_temp_eval of the loaded terms:
 *                                         beff[3] e[3] (i32) sat (u8); kept
 *                                         for 'k'
 *   'k' triad (u8) x[3] (i32)          -> corr_triad_temp with the terms of
 *                                         the last 'e': out[3] (i32) sat (u8)
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
 *   'I'                                -> nothing: proto_parser_init
 *   'F' n (u16) bytes[n]               -> proto_frame_feed on each byte, in
 *                                         order; one record per event (below),
 *                                         then 0x00.  Timed: the bytes are fed
 *                                         between the stops, the codes kept,
 *                                         and only the count of events (u16)
 *                                         is written.
 *   'L'                                -> proto_parser_idle (u8)
 *   'G' seq cmd (u8) n (u16) payload[n] cap (u16)
 *                                      -> proto_frame_encode: m (u16) out[m]
 *   'X' n (u16) bytes[n]               -> calimg_parse(bytes, n): status (u8),
 *                                         then the outputs (set before the
 *                                         call to 0x25A5A5A5 coefficients,
 *                                         0xA5A5A5A5 serial and time, 0xA5
 *                                         method: untouched on an error):
 *                                         acc.m[9] acc.bias[3] mag.m[9]
 *                                         mag.bias[3] (i32) serial time (u32)
 *                                         method (u8)
 *   'J' n (u16) bytes[n]               -> calimg_parse(bytes, n): status (u8),
 *                                         then the temperature fields (set
 *                                         before the call to 0x25A5A5A5 /
 *                                         0x25A5, 0xA5 order): t_order (u8)
 *                                         t_ref (i16), acc then mag: c1[3]
 *                                         (i32) c2[3] (i16) r1[3] (i32)
 *                                         r2[3] (i16)
 *   'B' acc.m[9] acc.bias[3] mag.m[9] mag.bias[3] (i32) serial time (u32)
 *       method (u8)                    -> calimg_build (version 1): image[120]
 *   'Z'                                -> nothing (timing overhead)
 *   'E'                                -> 'e', then stops the simulator
 * An unknown command writes '?' and stops.  n and cap are at most
 * HBUF_SIZE (256); a longer stream is fed as several 'F' commands (the
 * parser keeps its state between them).
 *
 * Event records of 'F' (the PF_* code, then the fields it makes valid):
 *   PF_FRAME   1 ver seq cmd (u8) len (u16) payload[len]
 *   PF_BAD_CRC 2 seq cmd (u8)
 *   PF_BAD_LEN 3
 *   PF_LINE    4 n (u8) line[n] (without the NUL)
 */
#include <stdint.h>

#include "inclino/attitude.h"
#include "inclino/calimg.h"
#include "inclino/correct.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"
#include "inclino/proto_frame.h"
#include "inclino/survey.h"
#include "simif.h"

#define TIMED 0x80u
#define HBUF_SIZE 256u

static corr_cal_t cal;
static survey_t sv;
static att_t at;
static int32_t in_acc[3];
static int32_t in_v[6];
static int32_t out_v[3];
static uint32_t in_u[2];
static uint32_t out_u;
static uint8_t out_sat;
static uint8_t timed;
static proto_parser_t pp;
static uint8_t hbuf[HBUF_SIZE]; /* bytes in: stream, payload or image */
static uint8_t hout[HBUF_SIZE]; /* bytes out: event codes or a frame */
static corr_cal_t pcal;         /* calimg_parse / calimg_build */
static calimg_info_t pinfo;
static uint16_t hn;

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

static void wr_vec(const int32_t *v, uint8_t n)
{
    uint8_t i;
    for (i = 0u; i < n; i++) {
        wr_i32(v[i]);
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

static int16_t rd_i16(void);

static void load_cal(void)
{
    rd_vec(cal.acc.m, 9u);
    rd_vec(cal.acc.bias, 3u);
    rd_vec(cal.mag.m, 9u);
    rd_vec(cal.mag.bias, 3u);
    cal.t_order = 0u;
}

static void rd_tc(corr_tc_t *t)
{
    uint8_t i;
    rd_vec(t->c1, 3u);
    for (i = 0u; i < 3u; i++) {
        t->c2[i] = rd_i16();
    }
    rd_vec(t->r1, 3u);
    for (i = 0u; i < 3u; i++) {
        t->r2[i] = rd_i16();
    }
}

static void wr_tc(const corr_tc_t *t)
{
    uint8_t i;
    wr_vec(t->c1, 3u);
    for (i = 0u; i < 3u; i++) {
        sif_wr16((uint16_t)t->c2[i]);
    }
    wr_vec(t->r1, 3u);
    for (i = 0u; i < 3u; i++) {
        sif_wr16((uint16_t)t->r2[i]);
    }
}

static void load_temp(void)
{
    cal.t_ref = rd_i16();
    cal.t_order = sif_rd8();
    rd_tc(&cal.acc_tc);
    rd_tc(&cal.mag_tc);
}

static void do_survey(uint8_t with_temp)
{
    uint8_t i;
    int32_t t = 0;
    rd_vec(in_acc, 3u);
    rd_vec(in_v, 3u);
    if (with_temp != 0u) {
        t = rd_i32();
    }
    mark();
    if (with_temp != 0u) {
        survey_compute_temp(in_acc, in_v, t, &cal, &sv);
    } else {
        survey_compute(in_acc, in_v, &cal, &sv);
    }
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

static corr_tt_t tt_h;

static void do_temp_eval(void)
{
    uint8_t which = sif_rd8();
    int16_t dt = rd_i16();
    out_sat = 0u;
    mark();
    if (which != 0u) {
        corr_temp_eval(dt, &cal.mag, &cal.mag_tc, &tt_h, &out_sat);
    } else {
        corr_temp_eval(dt, &cal.acc, &cal.acc_tc, &tt_h, &out_sat);
    }
    mark();
    wr_vec(tt_h.beff, 3u);
    wr_vec(tt_h.e, 3u);
    sif_wr8(out_sat);
}

static void do_triad_temp(void)
{
    uint8_t which = sif_rd8();
    uint8_t i;
    rd_vec(in_v, 3u);
    mark();
    out_sat = corr_triad_temp(in_v, (which != 0u) ? &cal.mag : &cal.acc, &tt_h, out_v);
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

/* n (u16), then n bytes into hbuf; n is clamped to HBUF_SIZE (the extra
 * bytes are read and dropped, so the stream stays in step) */
static void rd_bytes(void)
{
    uint16_t i;
    uint16_t n = sif_rd16();
    hn = (n <= HBUF_SIZE) ? n : HBUF_SIZE;
    for (i = 0u; i < n; i++) {
        uint8_t b = sif_rd8();
        if (i < HBUF_SIZE) {
            hbuf[i] = b;
        }
    }
}

static void wr_event(uint8_t ev)
{
    uint16_t i;
    sif_wr8(ev);
    if (ev == PF_FRAME) {
        sif_wr8(pp.ver);
        sif_wr8(pp.seq);
        sif_wr8(pp.cmd);
        sif_wr16(pp.len);
        for (i = 0u; i < pp.len; i++) {
            sif_wr8(pp.payload[i]);
        }
    } else if (ev == PF_BAD_CRC) {
        sif_wr8(pp.seq);
        sif_wr8(pp.cmd);
    } else if (ev == PF_LINE) {
        uint8_t n = 0u;
        while (n < PROTO_LINE_MAX && pp.line[n] != 0u) {
            n++;
        }
        sif_wr8(n);
        for (i = 0u; i < n; i++) {
            sif_wr8(pp.line[i]);
        }
    } else {
        /* PF_BAD_LEN: no fields */
    }
}

static void do_feed(void)
{
    uint16_t i;
    rd_bytes();
    if (timed != 0u) {
        uint16_t events = 0u;
        mark();
        for (i = 0u; i < hn; i++) {
            hout[i] = proto_frame_feed(&pp, hbuf[i]);
        }
        mark();
        for (i = 0u; i < hn; i++) {
            if (hout[i] != PF_NONE) {
                events++;
            }
        }
        sif_wr16(events);
        return;
    }
    for (i = 0u; i < hn; i++) {
        uint8_t ev = proto_frame_feed(&pp, hbuf[i]);
        if (ev != PF_NONE) {
            wr_event(ev);
        }
    }
    sif_wr8(0u);
}

static void do_encode(void)
{
    uint16_t i, cap, m;
    uint8_t seq = sif_rd8();
    uint8_t fcmd = sif_rd8();
    rd_bytes();
    cap = sif_rd16();
    if (cap > HBUF_SIZE) {
        cap = HBUF_SIZE;
    }
    mark();
    m = proto_frame_encode(seq, fcmd, hbuf, hn, hout, cap);
    mark();
    sif_wr16(m);
    for (i = 0u; i < m; i++) {
        sif_wr8(hout[i]);
    }
}

static void fill_parsed(void)
{
    uint8_t i;
    for (i = 0u; i < 9u; i++) {
        pcal.acc.m[i] = (int32_t)0x25A5A5A5L;
        pcal.mag.m[i] = (int32_t)0x25A5A5A5L;
    }
    for (i = 0u; i < 3u; i++) {
        pcal.acc.bias[i] = (int32_t)0x25A5A5A5L;
        pcal.mag.bias[i] = (int32_t)0x25A5A5A5L;
    }
    pinfo.serial = 0xA5A5A5A5UL;
    pinfo.time = 0xA5A5A5A5UL;
    pinfo.method = 0xA5u;
}

static void do_parse_image(void)
{
    uint8_t st;
    rd_bytes();
    fill_parsed();
    mark();
    st = calimg_parse(hbuf, hn, &pcal, &pinfo);
    mark();
    sif_wr8(st);
    wr_vec(pcal.acc.m, 9u);
    wr_vec(pcal.acc.bias, 3u);
    wr_vec(pcal.mag.m, 9u);
    wr_vec(pcal.mag.bias, 3u);
    sif_wr32(pinfo.serial);
    sif_wr32(pinfo.time);
    sif_wr8(pinfo.method);
}

static void fill_tc(corr_tc_t *t)
{
    uint8_t i;
    for (i = 0u; i < 3u; i++) {
        t->c1[i] = (int32_t)0x25A5A5A5L;
        t->c2[i] = (int16_t)0x25A5;
        t->r1[i] = (int32_t)0x25A5A5A5L;
        t->r2[i] = (int16_t)0x25A5;
    }
}

static void do_parse_temp(void)
{
    uint8_t st;
    rd_bytes();
    pcal.t_order = 0xA5u;
    pcal.t_ref = (int16_t)0x25A5;
    fill_tc(&pcal.acc_tc);
    fill_tc(&pcal.mag_tc);
    mark();
    st = calimg_parse(hbuf, hn, &pcal, &pinfo);
    mark();
    sif_wr8(st);
    sif_wr8(pcal.t_order);
    sif_wr16((uint16_t)pcal.t_ref);
    wr_tc(&pcal.acc_tc);
    wr_tc(&pcal.mag_tc);
}

static void do_build_image(void)
{
    uint8_t i;
    rd_vec(pcal.acc.m, 9u);
    rd_vec(pcal.acc.bias, 3u);
    rd_vec(pcal.mag.m, 9u);
    rd_vec(pcal.mag.bias, 3u);
    pinfo.serial = sif_rd32();
    pinfo.time = sif_rd32();
    pinfo.method = sif_rd8();
    pcal.t_order = 0u; /* version 1 */
    mark();
    (void)calimg_build(&pcal, &pinfo, hout);
    mark();
    for (i = 0u; i < (uint8_t)CALIMG_SIZE_V1; i++) {
        sif_wr8(hout[i]);
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
        case 'H':
            load_temp();
            break;
        case 'V':
            do_survey(0u);
            break;
        case 'Y':
            do_survey(1u);
            break;
        case 'e':
            do_temp_eval();
            break;
        case 'k':
            do_triad_temp();
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
        case 'I':
            proto_parser_init(&pp);
            break;
        case 'F':
            do_feed();
            break;
        case 'L':
            sif_wr8(proto_parser_idle(&pp));
            break;
        case 'G':
            do_encode();
            break;
        case 'X':
            do_parse_image();
            break;
        case 'J':
            do_parse_temp();
            break;
        case 'B':
            do_build_image();
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
