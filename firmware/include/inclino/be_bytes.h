/*
 * be_bytes.h - big-endian byte order (the HCS12X's, and the order of every
 * record on the SCI and in flash): read and write 16- and 32-bit fields of a
 * byte buffer.  Portable: no pointer casts, no dependence on the host's
 * byte order or on the width of int; the signed read converts without an
 * implementation-defined conversion.
 */
#ifndef INCLINO_BE_BYTES_H
#define INCLINO_BE_BYTES_H

#include <stdint.h>

static inline uint16_t be_get_u16(const uint8_t *p)
{
    return (uint16_t)(((uint16_t)p[0] << 8) | (uint16_t)p[1]);
}

static inline uint32_t be_get_u32(const uint8_t *p)
{
    return ((uint32_t)p[0] << 24) | ((uint32_t)p[1] << 16) | ((uint32_t)p[2] << 8) |
           (uint32_t)p[3];
}

/* two's complement without an implementation-defined conversion */
static inline int32_t be_get_i32(const uint8_t *p)
{
    uint32_t u = be_get_u32(p);
    return (u & 0x80000000UL) ? -(int32_t)(~u) - 1 : (int32_t)u;
}

static inline void be_put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v >> 8);
    p[1] = (uint8_t)v;
}

static inline void be_put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

#endif /* INCLINO_BE_BYTES_H */
