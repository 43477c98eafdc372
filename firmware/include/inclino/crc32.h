/*
 * crc32.h - CRC-32 (IEEE 802.3, reflected, polynomial 0xEDB88320, initial
 * and final XOR 0xFFFFFFFF; zlib's crc32, check value of "123456789" =
 * 0xCBF43926): the bootloader's image and descriptor checks
 * (docs/bootloader.md).  The host computes the same CRC with zlib.crc32.
 */
#ifndef INCLINO_CRC32_H
#define INCLINO_CRC32_H

#include <stdint.h>

/* crc32_update - continue the CRC `crc` (0 to start) over n bytes.  Nibble
 * table: 64 bytes of constants, two table steps per byte. */
uint32_t crc32_update(uint32_t crc, const uint8_t *data, uint16_t n);

#endif /* INCLINO_CRC32_H */
