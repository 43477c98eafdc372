/* attitude.c - attitude from corrected vectors; contracts in attitude.h. */
#include "inclino/attitude.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"

#define NORM_LO ((uint32_t)1u << 29)
#define NORM_HI ((uint32_t)1u << 30)

/* A port may supply att_norm3 (same result bits) and build this file with
 * -DATT_PORT_NORM3: the S08 port has it in assembly (firmware/port/s08). */
#ifndef ATT_PORT_NORM3
static uint32_t abs_u32(int32_t v)
{
    return (v < 0) ? (0u - (uint32_t)v) : (uint32_t)v;
}

/* v * 2^n for |v| * 2^n < 2^30 (exact, no saturation possible): whole
 * bytes first, on the magnitude (no shift of a negative value) */
static int32_t shl_in_range(int32_t v, uint8_t n)
{
    uint32_t u = abs_u32(v);
    while (n >= 8u) {
        u <<= 8;
        n = (uint8_t)(n - 8u);
    }
    u <<= n;
    return (v < 0) ? -(int32_t)u : (int32_t)u;
}

int8_t att_norm3(const int32_t v[3], int32_t out[3])
{
    /* the OR of the magnitudes has the leading bit of the largest one, and
     * the shift depends only on that bit */
    uint32_t m = abs_u32(v[0]) | abs_u32(v[1]) | abs_u32(v[2]);
    int8_t s = 0;
    uint8_t i;

    if (m == 0u) {
        for (i = 0u; i < 3u; i++) {
            out[i] = 0;
        }
        return 0;
    }
    if (m >= NORM_HI) {
        s = (m >= (NORM_HI << 1)) ? (int8_t)-2 : (int8_t)-1;
        for (i = 0u; i < 3u; i++) {
            out[i] = fx_asr32_rnd(v[i], (uint8_t)(-s));
        }
        return s;
    }
    while (m < (NORM_LO >> 8)) { /* whole bytes first: same s, fewer steps */
        m <<= 8;
        s = (int8_t)(s + 8);
    }
    while (m < NORM_LO) {
        m <<= 1;
        s++;
    }
    /* max |out_i| < 2^30: the left shifts are exact */
    for (i = 0u; i < 3u; i++) {
        out[i] = shl_in_range(v[i], (uint8_t)s);
    }
    return s;
}
#endif /* ATT_PORT_NORM3 */

/* |v| from the sum of fx_mul32_q31 squares q = |v|^2 / 2^31 (q < 2^31):
 * |v| = sqrt(2q) * 2^15 = fx_sqrt_u32_q8(2q) * 2^7.  A tiny negative q (the
 * truncation of fx_mul32_q31 on components near 0) counts as 0. */
static int32_t mag_from_sq(int32_t q)
{
    if (q < 0) {
        q = 0;
    }
    return (int32_t)fx_sqrt_u32_q8(2u * (uint32_t)q) * 128;
}

/* Undo a block normalisation by 2^s: round(v / 2^s), saturating. */
static int32_t denorm(int32_t v, int8_t s, uint8_t *sat)
{
    return (s >= 0) ? fx_asr32_rnd(v, (uint8_t)s) : fx_shl32_sat(v, (uint8_t)(-s), sat);
}

void att_compute(const int32_t g[3], const int32_t b[3], att_t *a)
{
    int32_t G[3], B[3], H[3], Gh[3];
    int32_t g2, gmag, h2, hmag, r, cross, doth, num, den, gdotb, c2, cmag, b2, bmag;
    int8_t sg, sb, sh;
    uint8_t sat = 0u;
    uint16_t flags = 0u;

    sg = att_norm3(g, G);
    sb = att_norm3(b, B);
    if (G[0] == 0 && G[1] == 0 && G[2] == 0) {
        flags |= ATT_F_ZERO_GRAVITY;
    }
    if (B[0] == 0 && B[1] == 0 && B[2] == 0) {
        flags |= ATT_F_ZERO_FIELD;
    }
    /* the cross-axial pair normalised on its own: H = (Gx, Gy, 0) * 2^sh keeps
     * full relative precision near vertical, where Gx, Gy << Gz */
    Gh[0] = G[0];
    Gh[1] = G[1];
    Gh[2] = 0;
    sh = att_norm3(Gh, H);

    /* every |component| <= 2^30: each product is at most 2^29 in magnitude
     * and no sum of three reaches 2^31, so the dot products do not saturate
     * and are the plain sums */
    g2 = fx_dot3_q31(G, G, &sat);
    gmag = mag_from_sq(g2);
    h2 = fx_dot3_q31(H, H, &sat); /* H[2] = 0 */
    hmag = mag_from_sq(h2);       /* |H| <= 2^30.5 */
    /* r = |(Gx, Gy)| / 2 in G units (sh >= -1), against Gz / 2 */
    r = fx_asr32_rnd(hmag, (uint8_t)(sh + 1));
    a->inc = fx_atan2_q16(r, fx_asr32_rnd(G[2], 1u));
    a->gtf = fx_atan2_q16(G[1], -G[0]);

    /* azimuth, both terms multiplied by 2^sh (> 0):
     *   num = |G| (Hx By - Hy Bx)
     *   den = Bz |H|^2 2^-sh - Gz (Hx Bx + Hy By) */
    cross = fx_mul32_q31(H[0], B[1], &sat) - fx_mul32_q31(H[1], B[0], &sat);
    doth = fx_dot3_q31(H, B, &sat); /* H[2] = 0 */
    num = fx_mul32_q31(gmag, cross, &sat);
    den = fx_asr32_rnd(fx_mul32_q31(B[2], h2, &sat), (uint8_t)(sh + 1)) -
          fx_asr32_rnd(fx_mul32_q31(G[2], doth, &sat), 1u);
    a->azi = fx_atan2_q16(fx_asr32_rnd(num, 1u), den);
    a->mtf = fx_atan2_q16(-B[1], B[0]);

    /* dip = atan2(G.B, |G x B|) with |G x B|^2 = |G|^2 |B|^2 - (G.B)^2, both
     * terms of the difference scaled by 2^-93 (g2 b2 <= 9 * 2^27, gdotb^2 <=
     * 2.25 * 2^29); |G x B| then comes out scaled by 2^-31, as G.B */
    gdotb = fx_dot3_q31(G, B, &sat);
    b2 = fx_dot3_q31(B, B, &sat);
    c2 = fx_mul32_q31(g2, b2, &sat) - fx_mul32_q31(gdotb, gdotb, &sat);
    cmag = mag_from_sq(c2);
    a->dip = fx_atan2_q16(gdotb, cmag);
    if (a->dip > FX_DEG(180)) {
        a->dip -= FX_DEG(360);
    }

    bmag = mag_from_sq(b2);
    a->gt = denorm(gmag, sg, &sat);
    a->bt = denorm(bmag, sb, &sat);

    if (a->inc < ATT_NEAR_VERTICAL_Q16 || a->inc > FX_DEG(180) - ATT_NEAR_VERTICAL_Q16) {
        flags |= ATT_F_NEAR_VERTICAL;
    }
    if (sat != 0u) {
        flags |= ATT_F_ARITH_SATURATED;
    }
    a->flags = flags;
}
