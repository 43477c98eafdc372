/* attitude.c - attitude from corrected vectors; contracts in attitude.h. */
#include "inclino/attitude.h"
#include "inclino/fx_math.h"
#include "inclino/fx_ops.h"

#define NORM_LO ((uint32_t)1u << 29)
#define NORM_HI ((uint32_t)1u << 30)

static uint32_t abs_u32(int32_t v)
{
    return (v < 0) ? (0u - (uint32_t)v) : (uint32_t)v;
}

int8_t att_norm3(const int32_t v[3], int32_t out[3])
{
    uint32_t m = 0u;
    int8_t s = 0;
    uint8_t i;
    uint8_t sat = 0u;

    for (i = 0u; i < 3u; i++) {
        uint32_t a = abs_u32(v[i]);
        if (a > m) {
            m = a;
        }
    }
    if (m == 0u) {
        for (i = 0u; i < 3u; i++) {
            out[i] = 0;
        }
        return 0;
    }
    while (m >= NORM_HI) {
        m >>= 1;
        s--;
    }
    while (m < (NORM_LO >> 8)) { /* whole bytes first: same s, fewer steps */
        m <<= 8;
        s = (int8_t)(s + 8);
    }
    while (m < NORM_LO) {
        m <<= 1;
        s++;
    }
    for (i = 0u; i < 3u; i++) {
        out[i] = (s >= 0) ? fx_shl32_sat(v[i], (uint8_t)s, &sat)
                          : fx_asr32_rnd(v[i], (uint8_t)(-s));
    }
    return s;
}

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
    int32_t g2, gmag, h2, hmag, r, cross, doth, num, den, gdotb, cx, cy, cz, c2, cmag, b2, bmag;
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

    /* |G| <= 2^30 * sqrt(3): every square <= 2^29, every sum < 2^31 */
    g2 = fx_mul32_q31(G[0], G[0], &sat) + fx_mul32_q31(G[1], G[1], &sat) +
         fx_mul32_q31(G[2], G[2], &sat);
    gmag = mag_from_sq(g2);
    h2 = fx_mul32_q31(H[0], H[0], &sat) + fx_mul32_q31(H[1], H[1], &sat);
    hmag = mag_from_sq(h2); /* |H| <= 2^30.5 */
    /* r = |(Gx, Gy)| / 2 in G units (sh >= -1), against Gz / 2 */
    r = fx_asr32_rnd(hmag, (uint8_t)(sh + 1));
    a->inc = fx_atan2_q16(r, fx_asr32_rnd(G[2], 1u));
    a->gtf = fx_atan2_q16(G[1], -G[0]);

    /* azimuth, both terms multiplied by 2^sh (> 0):
     *   num = |G| (Hx By - Hy Bx)
     *   den = Bz |H|^2 2^-sh - Gz (Hx Bx + Hy By) */
    cross = fx_mul32_q31(H[0], B[1], &sat) - fx_mul32_q31(H[1], B[0], &sat);
    doth = fx_mul32_q31(H[0], B[0], &sat) + fx_mul32_q31(H[1], B[1], &sat);
    num = fx_mul32_q31(gmag, cross, &sat);
    den = fx_asr32_rnd(fx_mul32_q31(B[2], h2, &sat), (uint8_t)(sh + 1)) -
          fx_asr32_rnd(fx_mul32_q31(G[2], doth, &sat), 1u);
    a->azi = fx_atan2_q16(fx_asr32_rnd(num, 1u), den);
    a->mtf = fx_atan2_q16(-B[1], B[0]);

    /* dip = atan2(G.B, |G x B|) */
    gdotb = fx_mul32_q31(G[0], B[0], &sat) + fx_mul32_q31(G[1], B[1], &sat) +
            fx_mul32_q31(G[2], B[2], &sat);
    cx = fx_mul32_q31(G[1], B[2], &sat) - fx_mul32_q31(G[2], B[1], &sat);
    cy = fx_mul32_q31(G[2], B[0], &sat) - fx_mul32_q31(G[0], B[2], &sat);
    cz = fx_mul32_q31(G[0], B[1], &sat) - fx_mul32_q31(G[1], B[0], &sat);
    c2 = fx_mul32_q31(cx, cx, &sat) + fx_mul32_q31(cy, cy, &sat) + fx_mul32_q31(cz, cz, &sat);
    cmag = mag_from_sq(c2);
    a->dip = fx_atan2_q16(gdotb, cmag);
    if (a->dip > FX_DEG(180)) {
        a->dip -= FX_DEG(360);
    }

    b2 = fx_mul32_q31(B[0], B[0], &sat) + fx_mul32_q31(B[1], B[1], &sat) +
         fx_mul32_q31(B[2], B[2], &sat);
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
