/* fuzz_boot.c - libFuzzer target: the serial bootloader's record and command
 * handling (firmware/src/boot.c) on a RAM model of the MC9S12XEP100 P-Flash
 * behind the HAL: arbitrary bytes or CRC-correct framed requests into
 * boot_rx / boot_idle, arbitrary application descriptors into
 * boot_app_check, optional power failure at the n-th flash command.  Built
 * with -fsanitize=fuzzer,address,undefined by tests/test_fuzz.py;
 * docs/fuzzing.md has a longer run's figures.
 *
 * Input layout: byte 0 = flags, byte 1 = parameter, the rest = data.
 *   bit 7  the data is a list of requests {seq, cmd, len, payload[len]}
 *          framed with a correct CRC (else: the raw line, cut into reads of
 *          (byte 1 | 1) bytes, each followed by a line silence);
 *   bit 6  the flash starts with a valid application (2 KiB at 0x7C0000);
 *   bit 5  the power fails at flash command number byte 1 (every later
 *          command and read fails, as on the emulated board);
 *   bit 4  the first 120 data bytes are written over the descriptor's
 *          header before boot_init (bit 3: with a correct header CRC and
 *          commit phrase, so that the range checks are reached).
 * Byte 1 bit 7 clear: the data sectors hold a valid identity record.
 *
 * Invariants, each a trap when broken: the bootloader area and the data
 * sectors never change; no phrase is ever programmed over different
 * non-erased bits (cumulative programming damages the part); no answer is
 * longer than the largest frame; a valid application reported by the
 * command layer is valid in flash, with every range in the application
 * area. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "inclino/boot.h"
#include "inclino/crc16.h"
#include "inclino/crc32.h"
#include "inclino/hal.h"
#include "inclino/probe.h"

#define FLASH_SIZE (BOOT_FLASH_END - BOOT_FLASH_START)

static uint8_t mem[FLASH_SIZE];
static uint8_t loader0[BOOT_LOADER_END - BOOT_LOADER_START];
static uint8_t data0[BOOT_DATA_END - BOOT_DATA_START];
static unsigned ops, fail_at;
static int dead;

/* ---- the HAL: a RAM P-Flash with the part's rules ------------------------- */
void hal_init(void)
{
}

uint32_t hal_millis(void)
{
    return 0;
}

int16_t hal_sci_getc(void)
{
    return -1;
}

uint8_t hal_sci_putc(uint8_t byte)
{
    (void)byte;
    return 1;
}

uint8_t hal_flash_read(uint32_t addr, uint8_t *dst, uint16_t n)
{
    if (dead) {
        return HAL_FLASH_E_TIMEOUT;
    }
    if (addr < BOOT_FLASH_START || addr > BOOT_FLASH_END || n > BOOT_FLASH_END - addr) {
        return HAL_FLASH_E_ACCESS;
    }
    memcpy(dst, mem + (addr - BOOT_FLASH_START), n);
    return HAL_FLASH_OK;
}

static int count_op(void)
{
    ops++;
    if (fail_at != 0 && ops >= fail_at) {
        dead = 1;
    }
    return dead;
}

static int protected_area(uint32_t start, uint32_t end)
{
    return start < BOOT_LOADER_END && BOOT_LOADER_START < end; /* FPROT */
}

uint8_t hal_flash_program(uint32_t addr, const uint8_t *data)
{
    uint8_t *p;
    int erased = 1, same = 1, i;
    if (dead || count_op()) {
        return HAL_FLASH_E_TIMEOUT;
    }
    if (addr < BOOT_FLASH_START || addr >= BOOT_FLASH_END || addr % 8u != 0u) {
        return HAL_FLASH_E_ACCESS;
    }
    if (protected_area(addr, addr + 8u)) {
        return HAL_FLASH_E_PROTECT;
    }
    p = mem + (addr - BOOT_FLASH_START);
    for (i = 0; i < 8; i++) {
        erased &= p[i] == 0xFFu;
        same &= p[i] == data[i];
    }
    if (!erased && !same) {
        __builtin_trap(); /* the bootloader programmed over old bits */
    }
    for (i = 0; i < 8; i++) {
        p[i] &= data[i];
    }
    return HAL_FLASH_OK;
}

uint8_t hal_flash_erase(uint32_t addr)
{
    uint32_t s;
    if (dead || count_op()) {
        return HAL_FLASH_E_TIMEOUT;
    }
    if (addr < BOOT_FLASH_START || addr >= BOOT_FLASH_END || addr % 8u != 0u) {
        return HAL_FLASH_E_ACCESS;
    }
    s = addr - addr % BOOT_SECTOR;
    if (protected_area(s, s + BOOT_SECTOR)) {
        return HAL_FLASH_E_PROTECT;
    }
    memset(mem + (s - BOOT_FLASH_START), 0xFF, BOOT_SECTOR);
    return HAL_FLASH_OK;
}

/* ---- answers ---------------------------------------------------------------- */
static void send(const uint8_t *d, uint16_t n)
{
    (void)d;
    if (n > PROTO_MAX_PAYLOAD + PROTO_OVERHEAD) {
        __builtin_trap(); /* no answer (or console line) is that long */
    }
}

/* ---- the starting flash ------------------------------------------------------- */
static void fill(uint32_t addr, uint32_t n, uint32_t k)
{
    uint32_t i;
    for (i = 0; i < n; i++) {
        mem[addr - BOOT_FLASH_START + i] = (uint8_t)(i * k + 11u);
    }
}

static void put_u32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

static void identity_record(void)
{
    uint8_t *r = mem + (PROBE_ID_ADDR - BOOT_FLASH_START);
    uint16_t crc;
    put_u32(r, PROBE_ID_MAGIC);
    put_u32(r + 4, 123456u);
    r[8] = 0;
    r[9] = 1;
    memset(r + 10, 0xFF, 4);
    crc = crc16_update(CRC16_INIT, r, 14u);
    r[14] = (uint8_t)(crc >> 8);
    r[15] = (uint8_t)crc;
}

static void valid_app(void)
{
    boot_app_t app;
    uint8_t hdr[BOOT_DESC_MAX], commit[8];
    uint16_t n;
    fill(0x7C0000UL, 2048u, 37u);
    memset(&app, 0, sizeof app);
    app.entry = 0x7C0000UL;
    app.count = 1;
    app.range[0].addr = 0x7C0000UL;
    app.range[0].len = 2048u;
    app.range[0].crc = crc32_update(0u, mem + (0x7C0000UL - BOOT_FLASH_START), 2048u);
    n = boot_desc_build(&app, hdr, commit);
    memcpy(mem + (BOOT_DESC_ADDR - BOOT_FLASH_START), hdr, n);
    memcpy(mem + (BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET - BOOT_FLASH_START), commit, 8);
}

static void forced_descriptor(const uint8_t *data, size_t size, int fix)
{
    uint8_t *d = mem + (BOOT_DESC_ADDR - BOOT_FLASH_START);
    size_t n = size < BOOT_DESC_MAX ? size : BOOT_DESC_MAX;
    memcpy(d, data, n);
    if (fix) { /* magic, version and a correct header CRC + commit: the ranges decide */
        uint8_t count = (uint8_t)(d[5] % BOOT_MAX_RANGES + 1u);
        uint16_t hl = (uint16_t)(16u + 12u * count);
        uint32_t crc;
        put_u32(d, BOOT_DESC_MAGIC);
        d[4] = BOOT_DESC_VERSION;
        d[5] = count;
        crc = crc32_update(0u, d, hl);
        put_u32(d + hl, crc);
        put_u32(d + BOOT_COMMIT_OFFSET, BOOT_COMMIT_MAGIC);
        put_u32(d + BOOT_COMMIT_OFFSET + 4u, crc);
    }
}

static void framed(boot_t *b, const uint8_t *data, size_t size)
{
    static uint8_t frame[PROTO_MAX_PAYLOAD + PROTO_OVERHEAD];
    size_t i = 0;
    while (i + 3 <= size && boot_after(b) == BOOT_AFTER_NONE) {
        uint8_t seq = data[i], cmd = data[i + 1];
        size_t len = data[i + 2];
        uint16_t n;
        i += 3;
        if (len > size - i) {
            len = size - i;
        }
        n = proto_frame_encode(seq, cmd, data + i, (uint16_t)len, frame, (uint16_t)sizeof frame);
        if (n == 0u) {
            boot_rx(b, data + i, (uint16_t)len);
        } else {
            boot_rx(b, frame, n);
        }
        i += len;
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static boot_t b;
    boot_app_t app;
    uint8_t flags, param;
    size_t i, start;
    if (size < 2) {
        return 0;
    }
    flags = data[0];
    param = data[1];
    data += 2;
    size -= 2;
    memset(mem, 0xFF, sizeof mem);
    fill(BOOT_LOADER_START, sizeof loader0, 101u);
    fill(BOOT_DATA_START + 0x400u, 64u, 7u); /* a calibration's first bytes */
    if ((param & 0x80u) == 0u) {
        identity_record();
    }
    memcpy(loader0, mem + (BOOT_LOADER_START - BOOT_FLASH_START), sizeof loader0);
    memcpy(data0, mem + (BOOT_DATA_START - BOOT_FLASH_START), sizeof data0);
    ops = 0;
    dead = 0;
    fail_at = (flags & 0x20u) ? (unsigned)param + 1u : 0u;
    if (flags & 0x40u) {
        valid_app();
    }
    if (flags & 0x10u) {
        forced_descriptor(data, size, (flags & 0x08u) != 0);
        (void)boot_app_check(&app);
        (void)boot_select(0u);
        (void)boot_select(1u);
    }
    boot_init(&b, send);
    if (flags & 0x80u) {
        framed(&b, data, size);
    } else {
        uint8_t cut = (uint8_t)(param | 1u);
        start = 0;
        for (i = 0; i <= size; i++) {
            if (i == size || (i - start) == cut) {
                boot_rx(&b, data + start, (uint16_t)(i - start));
                boot_idle(&b);
                start = i;
            }
        }
    }
    if (memcmp(loader0, mem + (BOOT_LOADER_START - BOOT_FLASH_START), sizeof loader0) != 0 ||
        memcmp(data0, mem + (BOOT_DATA_START - BOOT_FLASH_START), sizeof data0) != 0) {
        __builtin_trap(); /* a protected area changed */
    }
    if (!dead && b.app_status == BOOT_OK) {
        uint8_t k;
        if (boot_app_check(&app) != BOOT_OK) {
            __builtin_trap(); /* the command layer believes in an application the flash lacks */
        }
        for (k = 0; k < app.count; k++) {
            if (boot_area(app.range[k].addr, app.range[k].len) != BOOT_AREA_APP) {
                __builtin_trap();
            }
        }
    }
    return 0;
}
