/*
 * boot.h - the serial bootloader's core (docs/bootloader.md): the flash map
 * it enforces, the application descriptor that decides whether the
 * application may run, CRC-32, and the command layer it speaks over the
 * SCI framing of proto_frame.h (commands in docs/protocol.md, section
 * "Bootloader").  In the spirit of NXP's AN4258 S12(X) serial bootloader:
 * the loader lives in the protected top of block 0 and never erases or
 * programs it; unlike AN4258 it takes framed binary commands (the host
 * reads the S-record file) and keeps a descriptor with the image's ranges
 * and CRCs, so that it never starts a half-programmed application.
 *
 * Flash goes through the HAL only (hal_flash_read / _program / _erase);
 * the same C runs on the probe and in the emulator.  Rules as for all the
 * firmware: C99, integers only, no heap, no recursion, every loop bounded.
 *
 * Power cuts: the descriptor sector is erased before the first erase or
 * program of the application area and its commit phrase is the very last
 * program of a flash, so at any cut the probe holds either the complete,
 * checked old application, or no valid application and boots into the
 * bootloader (docs/bootloader.md has the argument).
 */
#ifndef INCLINO_BOOT_H
#define INCLINO_BOOT_H

#include <stdint.h>

#include "inclino/proto_frame.h"

#define BOOT_VERSION_MAJOR 1u
#define BOOT_VERSION_MINOR 0u
#define BOOT_PRODUCT "INCLINO-BOOT"

/* ---- flash map (MC9S12XEP100 global addresses) ---------------------------- */
#define BOOT_FLASH_START 0x700000UL /* P-Flash */
#define BOOT_FLASH_END 0x800000UL   /* exclusive */
/* the bootloader itself, the vectors and the flash configuration field: the
 * top 4 KiB of block 0 (local 0xF000-0xFFFF as in AN4258), protected by
 * FPROT on the part; the loader refuses to touch it */
#define BOOT_LOADER_START 0x7FF000UL
#define BOOT_LOADER_END 0x800000UL
/* the application descriptor: one sector just below the bootloader, written
 * only by COMMIT, erased only by the loader itself */
#define BOOT_DESC_ADDR 0x7FEC00UL
/* probe data (identity, calibration A/B, QC reference A/B, spare): never
 * touched by a firmware update */
#define BOOT_DATA_START 0x7A0000UL
#define BOOT_DATA_END 0x7A2000UL

#define BOOT_PHRASE 8u
#define BOOT_SECTOR 1024u

/* boot_area results */
#define BOOT_AREA_APP 0u       /* inside the P-Flash, outside every refused area */
#define BOOT_AREA_OUTSIDE 1u   /* leaves the P-Flash (or empty) */
#define BOOT_AREA_PROTECTED 2u /* touches the bootloader, the descriptor or the data area */

/* ---- the application descriptor (sector BOOT_DESC_ADDR) ------------------
 * offset  size   content (big-endian)
 *   0       4    magic 0x49415050 "IAPP"
 *   4       1    format version 1
 *   5       1    range count n, 1..BOOT_MAX_RANGES
 *   6       2    0xFFFF
 *   8       4    entry point (the S-record's start address; 0xFFFFFFFF: none)
 *  12       4    total bytes (sum of the range lengths)
 *  16    12*n    ranges: address, length, CRC-32 of the flash bytes
 * 16+12n    4    CRC-32 of bytes 0 .. 16+12n-1 (the header CRC)
 *  ...           0xFF up to a whole phrase
 * 0x3F8     8    commit phrase: magic 0x49434D54 "ICMT", the header CRC again
 * Ranges: phrase-aligned address and length, ascending, not overlapping,
 * each inside the application area (BOOT_AREA_APP). */
#define BOOT_DESC_MAGIC 0x49415050UL
#define BOOT_DESC_VERSION 1u
#define BOOT_COMMIT_MAGIC 0x49434D54UL
#define BOOT_COMMIT_OFFSET 0x3F8u
#define BOOT_MAX_RANGES 8u
#define BOOT_DESC_MAX 120u /* header of 8 ranges, 116 bytes, padded to 15 phrases */
#define BOOT_NO_ENTRY 0xFFFFFFFFUL

typedef struct {
    uint32_t addr;
    uint32_t len;
    uint32_t crc; /* CRC-32 of the flash bytes addr .. addr+len-1 */
} boot_range_t;

typedef struct {
    uint32_t entry;
    uint32_t total;
    uint32_t hdr_crc;
    uint8_t count;
    boot_range_t range[BOOT_MAX_RANGES];
} boot_app_t;

/* boot_app_check results: why the application may not run */
#define BOOT_OK 0u
#define BOOT_E_NO_COMMIT 1u /* no commit phrase: no application, or a flash not finished */
#define BOOT_E_HEADER 2u    /* descriptor header: magic, version, count or header CRC */
#define BOOT_E_RANGES 3u    /* a range misaligned, outside the application area, unordered */
#define BOOT_E_IMAGE 4u     /* a range's flash bytes do not have their CRC */
#define BOOT_E_READ 5u      /* the flash could not be read */

/* ---- commands (docs/protocol.md, "Bootloader") --------------------------- */
#define BCMD_IDENTIFY 0x40u
#define BCMD_ERASE 0x41u
#define BCMD_PROGRAM 0x42u
#define BCMD_READ 0x43u
#define BCMD_CRC 0x44u
#define BCMD_COMMIT 0x45u
#define BCMD_RUN 0x46u

#define BOOT_E_PROTECTED 12u /* negative answer code: the range is protected */
#define BOOT_MAX_DATA 192u   /* data bytes per PROGRAM / READ: 24 phrases */
#define BOOT_IDENTITY_LEN 78u

/* ---- the bootloader's states ----------------------------------------------
 * What the descriptor sector holds decides what runs after a reset
 * (boot_select) and what the commands do; boot_t keeps it as desc_blank and
 * app_status (boot_app_check of the flash as it is).
 *
 * state   descriptor sector              app_status  boots into   RUN      ERASE, PROGRAM
 * VALID   header, commit phrase, CRCs    BOOT_OK     application  runs it  erase it first: OPEN
 * OPEN    erased (desc_blank 1)          NO_COMMIT   bootloader   E_STATE  as asked
 * BROKEN  anything else (cut, bad CRC)   BOOT_E_*    bootloader   E_STATE  erase it first: OPEN
 *
 * COMMIT: the flash must hold the images the host names (else refused, state
 * unchanged); a descriptor equal to the one it would write is left as it is
 * (a retried COMMIT); else the sector is erased (OPEN), the header
 * programmed and the commit phrase last (VALID).  A failed program leaves
 * BROKEN.  After an answered RESET or RUN, boot_after() says which and
 * boot_rx() takes no more bytes until boot_init().
 */

/* boot_after / boot_main_restart_requested */
#define BOOT_AFTER_NONE 0u
#define BOOT_AFTER_RESET 1u /* RESET answered: restart, the selection decides */
#define BOOT_AFTER_RUN 2u   /* RUN answered: start the (valid) application */

/* boot_select results */
#define BOOT_SEL_APP 0u
#define BOOT_SEL_LOADER 1u

typedef struct {
    proto_parser_t parser;
    void (*send)(const uint8_t *data, uint16_t n);
    proto_reply_t reply; /* the last answer, for retries */
    uint8_t desc_blank;  /* the descriptor sector is known to be erased */
    uint8_t app_status;  /* boot_app_check of the flash as it is now */
    boot_app_t app;
    uint32_t serial;   /* probe serial from the identity record, 0 if none */
    uint32_t executed; /* requests executed since boot_init (retries not counted) */
    uint32_t mark;     /* the host's mark (IDENTIFY), 0 after boot_init: tells a restart */
    uint8_t after;
} boot_t;

/*
 * boot_crc32_flash - CRC-32 (crc32.h) of the flash bytes addr .. addr+len-1 (len >= 1,
 *   inside the P-Flash).  Returns HAL_FLASH_OK or the failing read's code
 *   (HAL_FLASH_E_ACCESS for a range outside the P-Flash).
 */
uint8_t boot_crc32_flash(uint32_t addr, uint32_t len, uint32_t *crc);

/* boot_area - BOOT_AREA_* of the len bytes at addr (len 0: OUTSIDE). */
uint8_t boot_area(uint32_t addr, uint32_t len);

/*
 * boot_desc_build - the descriptor header of `app` (entry, count, ranges
 *   with their CRCs; total and hdr_crc are computed and stored into app)
 *   into out[BOOT_DESC_MAX], padded with 0xFF to whole phrases, and the
 *   commit phrase into commit[8].  Returns the header's length in bytes (a
 *   multiple of 8), 0 when count is 0 or above BOOT_MAX_RANGES.
 */
uint16_t boot_desc_build(boot_app_t *app, uint8_t out[BOOT_DESC_MAX], uint8_t commit[8]);

/*
 * boot_app_check - read the descriptor and check it: commit phrase, header,
 *   ranges, and the CRC-32 of every range's flash bytes.  Returns BOOT_OK
 *   (app filled) or the first BOOT_E_* found.  Reads only.
 */
uint8_t boot_app_check(boot_app_t *app);

/*
 * boot_select - what runs after a reset: BOOT_SEL_LOADER when `request` is
 *   not 0 (the application answered BOOTLOADER) or the application is not
 *   valid (boot_app_check), else BOOT_SEL_APP.  Reads only.
 */
uint8_t boot_select(uint8_t request);

/*
 * boot_init - reset the command layer; `send` takes every answer byte.
 *   Reads the identity record and the descriptor (the application's
 *   status; whether the descriptor sector is erased).
 */
void boot_init(boot_t *b, void (*send)(const uint8_t *data, uint16_t n));

/*
 * boot_rx - feed received bytes; answers go out through b->send before it
 *   returns.  A request equal (same SEQ, same CRC) to the last executed one
 *   is answered from the cached answer without running again.  After a
 *   RESET or RUN was answered the remaining bytes are dropped and
 *   boot_after() reports it.
 */
void boot_rx(boot_t *b, const uint8_t *data, uint16_t n);

/* boot_idle - the line was silent for PROTO_IDLE_MS: drop a partial frame. */
void boot_idle(boot_t *b);

/* boot_after - BOOT_AFTER_* requested by the last answered command. */
uint8_t boot_after(const boot_t *b);

#endif /* INCLINO_BOOT_H */
