/* test_core.c - C unit tests of the firmware core against independent
 * references (exact 64-bit integer products, libm in double).  Host only:
 * this file is not firmware and may use double.  Exit status 0 = pass. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>

#include "inclino/attitude.h"
#include "inclino/correct.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"
#include "inclino/survey.h"
#include "inclino/tx_queue.h"

static int failures;
static int checks;

#define CHECK(cond, ...)                                                                           \
    do {                                                                                           \
        checks++;                                                                                  \
        if (!(cond)) {                                                                             \
            failures++;                                                                            \
            printf("FAIL %s:%d: ", __FILE__, __LINE__);                                            \
            printf(__VA_ARGS__);                                                                   \
            printf("\n");                                                                          \
        }                                                                                          \
    } while (0)

static uint32_t lcg_state = 12345u;
static uint32_t lcg(void)
{
    lcg_state = lcg_state * 1664525u + 1013904223u;
    return lcg_state;
}

static double wrap180(double d)
{
    while (d > 180.0) d -= 360.0;
    while (d <= -180.0) d += 360.0;
    return d;
}

static void test_ops(void)
{
    int32_t xs[] = {0, 1, -1, 2, -2, 3, -3, 12345, -12345, FX_INT32_MAX, FX_INT32_MIN};
    unsigned i, n;
    uint8_t sat;
    for (i = 0; i < sizeof xs / sizeof xs[0]; i++) {
        for (n = 0; n < 31; n++) {
            int64_t x = xs[i];
            int64_t p = (int64_t)1 << n;
            int64_t fl = (x >= 0) ? x / p : -((-x + p - 1) / p);
            int64_t rn = (x + (p >> 1) >= 0) ? (x + (p >> 1)) / p : -((-(x + (p >> 1)) + p - 1) / p);
            CHECK(fx_asr32(xs[i], (uint8_t)n) == fl, "asr32(%ld,%u)", (long)xs[i], n);
            if (n > 0) {
                CHECK(fx_asr32_rnd(xs[i], (uint8_t)n) == rn, "asr32_rnd(%ld,%u)", (long)xs[i], n);
            }
        }
    }
    sat = 0;
    CHECK(fx_add32_sat(FX_INT32_MAX, 1, &sat) == FX_INT32_MAX && sat == 1, "add sat");
    sat = 0;
    CHECK(fx_sub32_sat(FX_INT32_MIN, 1, &sat) == FX_INT32_MIN && sat == 1, "sub sat");
    sat = 0;
    CHECK(fx_shl32_sat(-3, 30, &sat) == FX_INT32_MIN && sat == 1, "shl sat");
    sat = 0;
    CHECK(fx_shl32_sat(-1, 30, &sat) == -(int32_t)0x40000000L && sat == 0, "shl exact");
    sat = 0;
    CHECK(fx_mul32_q31(FX_INT32_MIN, FX_INT32_MIN, &sat) == FX_INT32_MAX && sat == 1, "mul32 sat");
    for (i = 0; i < 200000; i++) {
        int32_t a = (int32_t)lcg(), b = (int32_t)lcg();
        int64_t exact2 = (int64_t)a * b; /* a*b/2^31 compared as a*b - r*2^31 */
        int64_t r;
        sat = 0;
        r = fx_mul32_q31(a, b, &sat);
        if (sat) continue;
        {
            /* error e = r - a*b/2^31 must satisfy -8 < e < 2 */
            int64_t d = r * ((int64_t)1 << 31) - exact2;
            CHECK(d > -8 * ((int64_t)1 << 31) && d < 2 * ((int64_t)1 << 31), "mul32 bound a=%ld b=%ld",
                  (long)a, (long)b);
        }
    }
}

static void test_math(void)
{
    unsigned i;
    double worst = 0.0;
    for (i = 0; i < 100000; i++) {
        uint32_t x = lcg();
        uint32_t y = fx_isqrt_u32(x);
        uint32_t q = fx_sqrt_u32_q8(x);
        CHECK((uint64_t)y * y <= x && ((uint64_t)y + 1) * ((uint64_t)y + 1) > x, "isqrt %lu", (unsigned long)x);
        CHECK(fabs((double)q - 256.0 * sqrt((double)x)) < 1.0, "sqrt_q8 %lu", (unsigned long)x);
    }
    for (i = 0; i < 200000; i++) {
        int32_t y = (int32_t)lcg(), x = (int32_t)lcg();
        double ref, got, e;
        if (i % 4 == 1) y >>= (lcg() % 31u);
        if (i % 4 == 2) x >>= (lcg() % 31u);
        ref = atan2((double)y, (double)x) * 180.0 / 3.14159265358979323846;
        got = fx_atan2_q16(y, x) / 65536.0;
        CHECK(got >= 0.0 && got < 360.0, "atan2 range");
        e = fabs(wrap180(got - ref));
        if (e > worst) worst = e;
    }
    CHECK(worst <= 0.0003, "atan2 worst error %.6g deg", worst);
    CHECK(fx_atan2_q16(0, 0) == 0, "atan2(0,0)");
    CHECK(fx_atan2_q16(5, 5) == FX_DEG(45), "atan2 45");
    CHECK(fx_atan2_q16(7, 0) == FX_DEG(90), "atan2 90");
    CHECK(fx_atan2_q16(0, -7) == FX_DEG(180), "atan2 180");
    CHECK(fx_atan2_q16(-7, 0) == FX_DEG(270), "atan2 270");
    CHECK(fx_div_frac_q20(1, 3) == 349525u, "div 1/3");
    CHECK(fx_div_frac_q20(0xFFFFFFFEu, 0xFFFFFFFFu) == (1u << 20), "div near 1 rounds up");
}

/* pose -> ideal Q6 readings (an averaged acquisition), then the whole survey
   must give the pose back */
static void test_survey(void)
{
    const double d2r = 3.14159265358979323846 / 180.0;
    corr_cal_t cal;
    survey_t s;
    double worst_i = 0, worst_a = 0, worst_t = 0;
    int inc, azi, tf;
    corr_identity(&cal.acc);
    corr_identity(&cal.mag);
    for (inc = 0; inc <= 180; inc += 5) {
        for (azi = 0; azi < 360; azi += 30) {
            for (tf = 15; tf < 360; tf += 60) {
                double I = inc * d2r, A = azi * d2r, T = tf * d2r, dip = 60 * d2r, F = 50000.0;
                /* body = Rz(T) Ry(I) Rz(A) world; gravity [0,0,1], field F[cos dip, 0, sin dip] */
                double w[3] = {F * cos(dip), 0.0, F * sin(dip)};
                double v1[3] = {cos(A) * w[0] + sin(A) * w[1], -sin(A) * w[0] + cos(A) * w[1], w[2]};
                double v2[3] = {cos(I) * v1[0] - sin(I) * v1[2], v1[1], sin(I) * v1[0] + cos(I) * v1[2]};
                double bb[3] = {cos(T) * v2[0] + sin(T) * v2[1], -sin(T) * v2[0] + cos(T) * v2[1], v2[2]};
                double gg[3] = {cos(T) * -sin(I), -sin(T) * -sin(I), cos(I)};
                int32_t acc[3];
                int32_t mag[3];
                int k;
                for (k = 0; k < 3; k++) {
                    acc[k] = (int32_t)lround(gg[k] * 16384.0 * CORR_IN_ONE);
                    mag[k] = (int32_t)lround(bb[k] * CORR_IN_ONE);
                }
                survey_compute(acc, mag, &cal, &s);
                if (fabs(s.att.inc / 65536.0 - inc) > worst_i) worst_i = fabs(s.att.inc / 65536.0 - inc);
                if (inc >= 5 && inc <= 175) {
                    double ea = fabs(wrap180(s.att.azi / 65536.0 - azi));
                    double et = fabs(wrap180(s.att.gtf / 65536.0 - tf));
                    if (ea > worst_a) worst_a = ea;
                    if (et > worst_t) worst_t = et;
                }
                CHECK(fabs(s.att.dip / 65536.0 - 60.0) < 0.02, "dip at %d %d %d: %g", inc, azi, tf,
                      s.att.dip / 65536.0);
                CHECK(fabs(s.att.bt / 256.0 - 50000.0) < 2.0, "bt %g", s.att.bt / 256.0);
                CHECK(fabs(s.att.gt / 134217728.0 - 1.0) < 1e-4, "gt %g", s.att.gt / 134217728.0);
                CHECK(((s.att.flags & ATT_F_NEAR_VERTICAL) != 0) == (inc == 0 || inc == 180),
                      "near-vertical flag at I=%d", inc);
            }
        }
    }
    /* input quantisation alone limits these; the fixed-point part is far smaller */
    CHECK(worst_i < 0.01, "inclination worst %g", worst_i);
    CHECK(worst_a < 0.05, "azimuth worst %g", worst_a);
    CHECK(worst_t < 0.05, "toolface worst %g", worst_t);
    {
        int32_t acc[3] = {0, 0, 0};
        int32_t mag[3] = {0, 0, 0};
        survey_compute(acc, mag, &cal, &s);
        CHECK((s.att.flags & (ATT_F_ZERO_GRAVITY | ATT_F_ZERO_FIELD)) == (ATT_F_ZERO_GRAVITY | ATT_F_ZERO_FIELD),
              "zero flags");
    }
    {
        int32_t acc[3] = {32767L * CORR_IN_ONE, -32768L * CORR_IN_ONE, 0};
        int32_t mag[3] = {200000L * CORR_IN_ONE, 0, -(int32_t)0x7FFFFFFFL};
        survey_compute(acc, mag, &cal, &s);
        CHECK((s.att.flags & ATT_F_ACC_SATURATED) && (s.att.flags & ATT_F_ACC_OVERRANGE) &&
                  (s.att.flags & ATT_F_MAG_SATURATED) && (s.att.flags & ATT_F_MAG_OVERRANGE),
              "range flags %x", s.att.flags);
    }
}

/* the SCI transmitter for tx_queue_drain: takes `sci_room` more bytes */
static uint8_t sci_line[64];
static uint16_t sci_sent, sci_room;
uint8_t hal_sci_putc(uint8_t byte)
{
    if (sci_room == 0u || sci_sent >= sizeof sci_line) {
        return 0u;
    }
    sci_room--;
    sci_line[sci_sent++] = byte;
    return 1u;
}

static void test_tx_queue(void)
{
    uint8_t buf[8], msg[6] = {1, 2, 3, 4, 5, 6};
    tx_queue_t q;
    uint16_t i;
    tx_queue_init(&q, buf, 8u);
    tx_queue_put(&q, msg, 5u);
    tx_queue_put(&q, msg, 4u); /* 3 free: dropped whole */
    CHECK(q.len == 5u && q.dropped == 4u, "drop whole answer: len %u dropped %lu", q.len,
          (unsigned long)q.dropped);
    sci_room = 3u;
    tx_queue_drain(&q); /* the transmitter refuses the 4th byte: it stays queued */
    CHECK(sci_sent == 3u && q.len == 2u, "partial drain");
    tx_queue_put(&q, msg + 1, 5u); /* wraps round the end of buf */
    sci_room = 100u;
    tx_queue_drain(&q);
    CHECK(q.len == 0u && sci_sent == 10u, "drained %u", sci_sent);
    for (i = 0u; i < 10u; i++) {
        static const uint8_t want[10] = {1, 2, 3, 4, 5, 2, 3, 4, 5, 6};
        CHECK(sci_line[i] == want[i], "byte %u: %u", i, sci_line[i]);
    }
}

int main(void)
{
    test_tx_queue();
    test_ops();
    test_math();
    test_survey();
    printf("%d passed, %d failed\n", checks - failures, failures);
    return failures != 0;
}
