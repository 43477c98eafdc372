/*
 * memcpy_s08.c - SDCC's struct-copy helper __memcpy, built with the image's
 * own flags.
 *
 * SDCC compiles a structure assignment (calimg_parse's `*cal = c`, 96 bytes)
 * into a call of its library helper __memcpy.  The s08.lib that Debian ships
 * holds the non-reentrant build, which takes its second and third arguments
 * from static locations (___memcpy_PARM_2, _PARM_3), while a --stack-auto
 * caller pushes them on the stack: the copy would read garbage without a
 * link error (the trap of docs/mcu.md).  This definition, compiled with
 * --stack-auto like the rest of the image, is linked before the library, so
 * the library's module is never pulled in (mcu.build() refuses an image that
 * links it).  Same contract as the library's: copy n bytes from src to dst
 * (no overlap), return dst.
 */
#if defined(__SDCC_s08) || defined(__SDCC_hc08)

#include <stddef.h>
#include <stdint.h>

#ifndef __SDCC_STACK_AUTO
#error "built with --stack-auto only: the shipped library helper serves other builds"
#endif

void *__memcpy(void *dst, const void *src, size_t n)
{
    uint8_t *d = (uint8_t *)dst;
    const uint8_t *s = (const uint8_t *)src;
    while (n != 0u) {
        *d = *s;
        d++;
        s++;
        n--;
    }
    return dst;
}

#else

/* Other compilers have their own memcpy. */
typedef int memcpy_s08_unused_t;

#endif
