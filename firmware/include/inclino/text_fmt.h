/*
 * text_fmt.h - the few text operations of the probe's terminal console
 * (application and bootloader): copy a string, write an unsigned decimal,
 * upper-case an ASCII letter.  No printf, no heap, no float.  The caller
 * owns a buffer large enough for what it writes (a u32 is at most 10
 * digits); the functions return the position after what they wrote and do
 * not terminate the string.
 */
#ifndef INCLINO_TEXT_FMT_H
#define INCLINO_TEXT_FMT_H

#include <stdint.h>

static inline char *txt_put_str(char *o, const char *s)
{
    while (*s != '\0') {
        *o++ = *s++;
    }
    return o;
}

static inline char *txt_put_uint(char *o, uint32_t v)
{
    char tmp[10];
    uint8_t n = 0u;
    do {
        tmp[n++] = (char)('0' + (v % 10u));
        v /= 10u;
    } while (v != 0u);
    while (n != 0u) {
        *o++ = tmp[--n];
    }
    return o;
}

static inline uint8_t txt_upper(uint8_t c)
{
    return (c >= (uint8_t)'a' && c <= (uint8_t)'z') ? (uint8_t)(c - 32u) : c;
}

#endif /* INCLINO_TEXT_FMT_H */
