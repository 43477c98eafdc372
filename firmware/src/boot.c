/* boot.c - the serial bootloader's core; contract in boot.h, design and
 * power-cut argument in docs/bootloader.md, commands in docs/protocol.md. */
#include "inclino/boot.h"
#include "inclino/be_bytes.h"
#include "inclino/crc32.h"
#include "inclino/hal.h"
#include "inclino/id_record.h"
#include "inclino/proto_cmd.h"
#include "inclino/proto_dispatch.h"
#include "inclino/text_fmt.h"

#define CHUNK 128u    /* bytes per flash read */
#define TEXT_MAX 64u  /* console answer line */
#define HDR_FIXED 16u /* descriptor bytes before the ranges */

/* ------------------------------------------------------------ CRC-32 of flash */
uint8_t boot_crc32_flash(uint32_t addr, uint32_t len, uint32_t *crc)
{
    uint8_t buf[CHUNK];
    uint32_t c = 0u;
    uint32_t left = len;
    uint32_t k;
    if (boot_area(addr, len) == BOOT_AREA_OUTSIDE) {
        return HAL_FLASH_E_ACCESS;
    }
    /* at most 1 MiB / CHUNK = 8192 passes: the range lies inside the P-Flash */
    for (k = 0u; k < (BOOT_FLASH_END - BOOT_FLASH_START) / CHUNK && left != 0u; k++) {
        uint16_t n = (left > CHUNK) ? (uint16_t)CHUNK : (uint16_t)left;
        uint8_t st = hal_flash_read(addr, buf, n);
        if (st != HAL_FLASH_OK) {
            return st;
        }
        c = crc32_update(c, buf, n);
        addr += n;
        left -= n;
    }
    *crc = c;
    return HAL_FLASH_OK;
}

/* ------------------------------------------------------------ flash map */
static uint8_t overlaps(uint32_t addr, uint32_t len, uint32_t start, uint32_t end)
{
    /* [addr, addr+len) and [start, end) share a byte; addr+len cannot wrap
     * (the caller checked it lies inside the P-Flash) */
    return (uint8_t)(addr < end && start < addr + len);
}

uint8_t boot_area(uint32_t addr, uint32_t len)
{
    if (len == 0u || addr < BOOT_FLASH_START || addr >= BOOT_FLASH_END ||
        len > BOOT_FLASH_END - addr) {
        return BOOT_AREA_OUTSIDE;
    }
    if (overlaps(addr, len, BOOT_DATA_START, BOOT_DATA_END) ||
        overlaps(addr, len, BOOT_DESC_ADDR, BOOT_LOADER_END)) {
        return BOOT_AREA_PROTECTED;
    }
    return BOOT_AREA_APP;
}

/* ------------------------------------------------------------ descriptor */
static uint16_t hdr_len(uint8_t count)
{
    return (uint16_t)(HDR_FIXED + 12u * (uint16_t)count + 4u);
}

uint16_t boot_desc_build(boot_app_t *app, uint8_t out[BOOT_DESC_MAX], uint8_t commit[8])
{
    uint16_t i, n, padded;
    uint32_t total = 0u;
    if (app->count == 0u || app->count > BOOT_MAX_RANGES) {
        return 0u;
    }
    for (i = 0u; i < BOOT_DESC_MAX; i++) {
        out[i] = 0xFFu;
    }
    be_put_u32(out, BOOT_DESC_MAGIC);
    out[4] = BOOT_DESC_VERSION;
    out[5] = app->count;
    be_put_u32(out + 8, app->entry);
    for (i = 0u; i < app->count; i++) {
        uint8_t *r = out + HDR_FIXED + 12u * i;
        be_put_u32(r, app->range[i].addr);
        be_put_u32(r + 4, app->range[i].len);
        be_put_u32(r + 8, app->range[i].crc);
        total += app->range[i].len;
    }
    app->total = total;
    be_put_u32(out + 12, total);
    n = (uint16_t)(hdr_len(app->count) - 4u);
    app->hdr_crc = crc32_update(0u, out, n);
    be_put_u32(out + n, app->hdr_crc);
    be_put_u32(commit, BOOT_COMMIT_MAGIC);
    be_put_u32(commit + 4, app->hdr_crc);
    padded = (uint16_t)((hdr_len(app->count) + BOOT_PHRASE - 1u) / BOOT_PHRASE * BOOT_PHRASE);
    return padded;
}

/* Ranges as a descriptor or a COMMIT gives them: aligned, ascending, apart,
 * in the application area.  Returns BOOT_OK or BOOT_E_RANGES. */
static uint8_t check_ranges(const boot_app_t *app)
{
    uint8_t i;
    uint32_t next = BOOT_FLASH_START;
    for (i = 0u; i < app->count; i++) {
        const boot_range_t *r = &app->range[i];
        if ((r->addr % BOOT_PHRASE) != 0u || (r->len % BOOT_PHRASE) != 0u ||
            boot_area(r->addr, r->len) != BOOT_AREA_APP || r->addr < next) {
            return BOOT_E_RANGES;
        }
        next = r->addr + r->len;
    }
    return BOOT_OK;
}

/* The entry point lies inside one of the ranges (the bootloader jumps
 * there after every reset: never into itself, the descriptor, the data
 * sectors or bytes no range describes).  1 if so, else 0. */
static uint8_t entry_ok(const boot_app_t *app)
{
    uint8_t i;
    for (i = 0u; i < app->count; i++) {
        if (app->entry >= app->range[i].addr &&
            app->entry - app->range[i].addr < app->range[i].len) {
            return 1u;
        }
    }
    return 0u;
}

static uint8_t check_images(const boot_app_t *app, uint8_t *bad)
{
    uint8_t i;
    for (i = 0u; i < app->count; i++) {
        uint32_t c = 0u;
        if (boot_crc32_flash(app->range[i].addr, app->range[i].len, &c) != HAL_FLASH_OK) {
            *bad = i;
            return BOOT_E_READ;
        }
        if (c != app->range[i].crc) {
            *bad = i;
            return BOOT_E_IMAGE;
        }
    }
    return BOOT_OK;
}

uint8_t boot_app_check(boot_app_t *app)
{
    uint8_t hdr[BOOT_DESC_MAX];
    uint8_t commit[8];
    uint8_t i, bad = 0u;
    uint16_t n;
    uint32_t total = 0u;
    if (hal_flash_read(BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET, commit, 8u) != HAL_FLASH_OK ||
        hal_flash_read(BOOT_DESC_ADDR, hdr, HDR_FIXED) != HAL_FLASH_OK) {
        return BOOT_E_READ;
    }
    if (be_get_u32(commit) != BOOT_COMMIT_MAGIC) {
        return BOOT_E_NO_COMMIT;
    }
    if (be_get_u32(hdr) != BOOT_DESC_MAGIC || hdr[4] != BOOT_DESC_VERSION || hdr[5] == 0u ||
        hdr[5] > BOOT_MAX_RANGES) {
        return BOOT_E_HEADER;
    }
    app->count = hdr[5];
    n = (uint16_t)(hdr_len(app->count) - 4u);
    if (hal_flash_read(BOOT_DESC_ADDR + HDR_FIXED, hdr + HDR_FIXED,
                       (uint16_t)(n + 4u - HDR_FIXED)) != HAL_FLASH_OK) {
        return BOOT_E_READ;
    }
    app->hdr_crc = be_get_u32(hdr + n);
    if (crc32_update(0u, hdr, n) != app->hdr_crc || be_get_u32(commit + 4) != app->hdr_crc) {
        return BOOT_E_HEADER;
    }
    app->entry = be_get_u32(hdr + 8);
    app->total = be_get_u32(hdr + 12);
    for (i = 0u; i < app->count; i++) {
        const uint8_t *r = hdr + HDR_FIXED + 12u * i;
        app->range[i].addr = be_get_u32(r);
        app->range[i].len = be_get_u32(r + 4);
        app->range[i].crc = be_get_u32(r + 8);
        if (app->range[i].len > BOOT_FLASH_END - BOOT_FLASH_START) {
            return BOOT_E_RANGES;
        }
        total += app->range[i].len; /* at most 8 MiB: no wrap */
    }
    if (check_ranges(app) != BOOT_OK || total != app->total || entry_ok(app) == 0u) {
        return BOOT_E_RANGES;
    }
    return check_images(app, &bad);
}

uint8_t boot_select(uint8_t request)
{
    boot_app_t app;
    if (request != 0u) {
        return BOOT_SEL_LOADER;
    }
    return (uint8_t)((boot_app_check(&app) == BOOT_OK) ? BOOT_SEL_APP : BOOT_SEL_LOADER);
}

/* ------------------------------------------------------------ flash helpers */
static uint8_t is_blank(uint32_t addr, uint16_t len)
{
    uint8_t buf[CHUNK];
    uint16_t done = 0u, i;
    while (done < len) { /* len / CHUNK passes */
        uint16_t n = (uint16_t)(len - done);
        if (n > CHUNK) {
            n = CHUNK;
        }
        if (hal_flash_read(addr + done, buf, n) != HAL_FLASH_OK) {
            return 0u;
        }
        for (i = 0u; i < n; i++) {
            if (buf[i] != 0xFFu) {
                return 0u;
            }
        }
        done = (uint16_t)(done + n);
    }
    return 1u;
}

/* Erase one sector and check it reads erased.  Returns 0 or a HAL code. */
static uint8_t erase_checked(uint32_t addr)
{
    uint8_t st = hal_flash_erase(addr);
    if (st != HAL_FLASH_OK) {
        return st;
    }
    return is_blank(addr, BOOT_SECTOR) ? HAL_FLASH_OK : HAL_FLASH_E_VERIFY;
}

/* Program one phrase and read it back.  Returns 0 or a HAL code. */
static uint8_t program_checked(uint32_t addr, const uint8_t *data)
{
    uint8_t back[BOOT_PHRASE];
    uint8_t i;
    uint8_t st = hal_flash_program(addr, data);
    if (st != HAL_FLASH_OK) {
        return st;
    }
    st = hal_flash_read(addr, back, BOOT_PHRASE);
    if (st != HAL_FLASH_OK) {
        return st;
    }
    for (i = 0u; i < BOOT_PHRASE; i++) {
        if (back[i] != data[i]) {
            return HAL_FLASH_E_VERIFY;
        }
    }
    return HAL_FLASH_OK;
}

/* Before the first change of the application area: erase the descriptor, so
 * the old application stops being valid before any of its bytes change. */
static uint8_t invalidate(boot_t *b)
{
    uint8_t st;
    if (b->desc_blank) {
        return HAL_FLASH_OK;
    }
    b->app_status = BOOT_E_NO_COMMIT;
    st = erase_checked(BOOT_DESC_ADDR);
    if (st == HAL_FLASH_OK) {
        b->desc_blank = 1u;
    }
    return st;
}

/* ------------------------------------------------------------ commands */
/* Handlers (proto_dispatch.h): 0 and the answer in out, or a PERR_* code
 * with the NAK's detail byte in the high byte. */
#define REFUSE(code, detail) ((uint16_t)((uint16_t)(code) | ((uint16_t)(detail) << 8)))

/* Refusal code for a target range: 0 when it is in the application area. */
static uint8_t target_error(uint32_t addr, uint32_t len)
{
    uint8_t a = boot_area(addr, len);
    if (a == BOOT_AREA_OUTSIDE) {
        return PERR_ARGUMENT;
    }
    return (a == BOOT_AREA_PROTECTED) ? BOOT_E_PROTECTED : 0u;
}

static uint16_t c_identify(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                           uint16_t *out_len)
{
    static const char prod[] = BOOT_PRODUCT;
    boot_t *b = (boot_t *)ctx;
    uint8_t i;
    uint8_t valid = (uint8_t)(b->app_status == BOOT_OK);
    (void)cmd;
    for (i = 0u; i < 16u; i++) {
        out[i] = (i < (uint8_t)(sizeof prod - 1u)) ? (uint8_t)prod[i] : 0u;
    }
    out[16] = BOOT_VERSION_MAJOR;
    out[17] = BOOT_VERSION_MINOR;
    out[18] = PROTO_VERSION;
    out[19] = b->app_status;
    be_put_u32(out + 20, b->serial);
    be_put_u32(out + 24, BOOT_FLASH_START);
    be_put_u32(out + 28, BOOT_FLASH_END);
    be_put_u16(out + 32, BOOT_PHRASE);
    be_put_u16(out + 34, BOOT_SECTOR);
    be_put_u16(out + 36, BOOT_MAX_DATA);
    be_put_u32(out + 38, BOOT_LOADER_START);
    be_put_u32(out + 42, BOOT_LOADER_END);
    be_put_u32(out + 46, BOOT_DESC_ADDR);
    be_put_u32(out + 50, BOOT_DATA_START);
    be_put_u32(out + 54, BOOT_DATA_END);
    be_put_u32(out + 58, valid ? b->app.entry : BOOT_NO_ENTRY);
    be_put_u32(out + 62, valid ? b->app.total : 0u);
    be_put_u32(out + 66, valid ? b->app.hdr_crc : 0u);
    be_put_u32(out + 70, b->executed);
    be_put_u32(out + 74, b->mark);
    if (len == 4u) {
        b->mark = be_get_u32(pl); /* reported by the next IDENTIFY unless the probe restarts */
    }
    *out_len = BOOT_IDENTITY_LEN;
    return 0u;
}

static uint16_t c_erase(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                        uint16_t *out_len)
{
    uint32_t addr = be_get_u32(pl);
    uint8_t st = target_error(addr, BOOT_SECTOR);
    (void)cmd;
    (void)len;
    if (st == 0u && (addr % BOOT_SECTOR) != 0u) {
        st = PERR_ARGUMENT;
    }
    if (st != 0u) {
        return st;
    }
    st = invalidate((boot_t *)ctx);
    if (st == HAL_FLASH_OK) {
        st = erase_checked(addr);
    }
    if (st != HAL_FLASH_OK) {
        return REFUSE(PERR_FLASH, st);
    }
    be_put_u32(out, addr);
    *out_len = 4u;
    return 0u;
}

static uint16_t c_program(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                          uint16_t *out_len)
{
    uint8_t cur[BOOT_PHRASE];
    uint32_t addr;
    uint16_t n, off;
    uint8_t st, i;
    (void)cmd;
    if (len < 4u + BOOT_PHRASE || len > 4u + BOOT_MAX_DATA || ((len - 4u) % BOOT_PHRASE) != 0u) {
        return PERR_LENGTH;
    }
    addr = be_get_u32(pl);
    n = (uint16_t)(len - 4u);
    st = target_error(addr, n);
    if (st == 0u && (addr % BOOT_PHRASE) != 0u) {
        st = PERR_ARGUMENT;
    }
    if (st != 0u) {
        return st;
    }
    st = invalidate((boot_t *)ctx);
    if (st != HAL_FLASH_OK) {
        return REFUSE(PERR_FLASH, st);
    }
    for (off = 0u; off < n; off = (uint16_t)(off + BOOT_PHRASE)) {
        const uint8_t *d = pl + 4u + off;
        uint8_t same = 1u, blank = 1u;
        st = hal_flash_read(addr + off, cur, BOOT_PHRASE);
        if (st != HAL_FLASH_OK) {
            return REFUSE(PERR_FLASH, st);
        }
        for (i = 0u; i < BOOT_PHRASE; i++) {
            same = (uint8_t)(same && cur[i] == d[i]);
            blank = (uint8_t)(blank && cur[i] == 0xFFu);
        }
        if (same) {
            continue; /* already there (a retry after a lost answer): nothing to do */
        }
        if (!blank) { /* programming over old bits would damage the phrase: erase first */
            return REFUSE(PERR_STATE, 1u + off / BOOT_PHRASE);
        }
        st = program_checked(addr + off, d);
        if (st != HAL_FLASH_OK) {
            return REFUSE(PERR_FLASH, st);
        }
    }
    be_put_u32(out, addr);
    be_put_u16(out + 4, n);
    *out_len = 6u;
    return 0u;
}

static uint16_t c_read(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                       uint16_t *out_len)
{
    uint32_t addr = be_get_u32(pl);
    uint16_t n = be_get_u16(pl + 4);
    uint8_t st;
    (void)ctx;
    (void)cmd;
    (void)len;
    if (n == 0u || n > BOOT_MAX_DATA || boot_area(addr, n) == BOOT_AREA_OUTSIDE) {
        return PERR_ARGUMENT;
    }
    st = hal_flash_read(addr, out + 4, n); /* 4 + BOOT_MAX_DATA <= PROTO_MAX_PAYLOAD */
    if (st != HAL_FLASH_OK) {
        return REFUSE(PERR_FLASH, st);
    }
    be_put_u32(out, addr);
    *out_len = (uint16_t)(4u + n);
    return 0u;
}

static uint16_t c_crc(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                      uint16_t *out_len)
{
    uint32_t addr = be_get_u32(pl);
    uint32_t n = be_get_u32(pl + 4);
    uint32_t c = 0u;
    uint8_t st;
    (void)ctx;
    (void)cmd;
    (void)len;
    if (boot_area(addr, n) == BOOT_AREA_OUTSIDE) {
        return PERR_ARGUMENT;
    }
    st = boot_crc32_flash(addr, n, &c);
    if (st != HAL_FLASH_OK) {
        return REFUSE(PERR_FLASH, st);
    }
    be_put_u32(out, addr);
    be_put_u32(out + 4, n);
    be_put_u32(out + 8, c);
    *out_len = 12u;
    return 0u;
}

/* Is the descriptor in flash exactly hdr[0..n) and commit? */
static uint8_t desc_equals(const uint8_t *hdr, uint16_t n, const uint8_t *commit)
{
    uint8_t cur[BOOT_DESC_MAX];
    uint16_t i;
    if (hal_flash_read(BOOT_DESC_ADDR, cur, n) != HAL_FLASH_OK) {
        return 0u;
    }
    for (i = 0u; i < n; i++) {
        if (cur[i] != hdr[i]) {
            return 0u;
        }
    }
    if (hal_flash_read(BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET, cur, 8u) != HAL_FLASH_OK) {
        return 0u;
    }
    for (i = 0u; i < 8u; i++) {
        if (cur[i] != commit[i]) {
            return 0u;
        }
    }
    return 1u;
}

static uint16_t c_commit(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                         uint16_t *out_len)
{
    boot_t *b = (boot_t *)ctx;
    boot_app_t app = {0u, 0u, 0u, 0u, {{0u, 0u, 0u}}};
    uint8_t hdr[BOOT_DESC_MAX];
    uint8_t commit[8];
    uint16_t n;
    uint8_t i, st, bad = 0u;
    (void)cmd;
    if (len < 5u || pl[4] == 0u || pl[4] > BOOT_MAX_RANGES ||
        len != (uint16_t)(5u + 12u * (uint16_t)pl[4])) {
        return PERR_LENGTH;
    }
    app.entry = be_get_u32(pl);
    app.count = pl[4];
    for (i = 0u; i < app.count; i++) {
        const uint8_t *r = pl + 5u + 12u * i;
        app.range[i].addr = be_get_u32(r);
        app.range[i].len = be_get_u32(r + 4);
        app.range[i].crc = be_get_u32(r + 8);
    }
    if (check_ranges(&app) != BOOT_OK || entry_ok(&app) == 0u) {
        return PERR_ARGUMENT;
    }
    st = check_images(&app, &bad);
    if (st != BOOT_OK) { /* the flash does not hold what the host says: no commit */
        return REFUSE((st == BOOT_E_IMAGE) ? PERR_IMAGE : PERR_FLASH, bad + 1u);
    }
    n = boot_desc_build(&app, hdr, commit);
    if (!desc_equals(hdr, n, commit)) {
        st = invalidate(b); /* erases a different descriptor first */
        /* the header first, the commit phrase last of all */
        for (uint16_t off = 0u; off < n && st == HAL_FLASH_OK;
             off = (uint16_t)(off + BOOT_PHRASE)) {
            st = program_checked(BOOT_DESC_ADDR + off, hdr + off);
        }
        if (st == HAL_FLASH_OK) {
            b->desc_blank = 0u;
            st = program_checked(BOOT_DESC_ADDR + BOOT_COMMIT_OFFSET, commit);
        }
        if (st != HAL_FLASH_OK) {
            b->desc_blank = 0u;
            b->app_status = BOOT_E_NO_COMMIT;
            return REFUSE(PERR_FLASH, st);
        }
    }
    b->desc_blank = 0u;
    b->app_status = boot_app_check(&b->app);
    if (b->app_status != BOOT_OK) {
        return REFUSE(PERR_FLASH, HAL_FLASH_E_VERIFY);
    }
    be_put_u32(out, app.hdr_crc);
    be_put_u32(out + 4, app.total);
    *out_len = 8u;
    return 0u;
}

static uint16_t c_run(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                      uint16_t *out_len)
{
    boot_t *b = (boot_t *)ctx;
    (void)cmd;
    (void)pl;
    (void)len;
    (void)out;
    (void)out_len;
    if (b->app_status != BOOT_OK) {
        return REFUSE(PERR_STATE, b->app_status);
    }
    b->after = BOOT_AFTER_RUN;
    return 0u;
}

static uint16_t c_reset(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                        uint16_t *out_len)
{
    (void)cmd;
    (void)pl;
    (void)len;
    (void)out;
    (void)out_len;
    ((boot_t *)ctx)->after = BOOT_AFTER_RESET;
    return 0u;
}

/* BOOTLOADER: already here: answered, nothing else */
static uint16_t c_bootloader(void *ctx, uint8_t cmd, const uint8_t *pl, uint16_t len, uint8_t *out,
                             uint16_t *out_len)
{
    (void)ctx;
    (void)cmd;
    (void)len;
    (void)out;
    (void)out_len;
    return (be_get_u32(pl) != PROTO_BOOT_KEY) ? PERR_ARGUMENT : 0u;
}

static const proto_command_t commands[] = {
    {BCMD_IDENTIFY, 0u, 4u, c_identify},
    {BCMD_ERASE, 4u, 4u, c_erase},
    {BCMD_PROGRAM, PROTO_LEN_ANY, PROTO_LEN_ANY, c_program},
    {BCMD_READ, 6u, 6u, c_read},
    {BCMD_CRC, 8u, 8u, c_crc},
    {BCMD_COMMIT, PROTO_LEN_ANY, PROTO_LEN_ANY, c_commit},
    {BCMD_RUN, 0u, 0u, c_run},
    {PCMD_RESET, 0u, 0u, c_reset},
    {PCMD_BOOTLOADER, 4u, 4u, c_bootloader},
};

static void execute(boot_t *b, uint8_t seq, uint8_t cmd, const uint8_t *pl, uint16_t len)
{
    if (!proto_dispatch(commands, (uint8_t)(sizeof commands / sizeof commands[0]), b, &b->reply,
                        b->send, seq, cmd, pl, len)) {
        /* the application's commands are not available here */
        b->send(b->reply.buf,
                proto_reply_nak(&b->reply, seq, cmd,
                                (cmd < BCMD_IDENTIFY) ? PERR_STATE : PERR_COMMAND, 0u));
    }
}

/* ------------------------------------------------------------ text console */

static void text_command(boot_t *b)
{
    char buf[TEXT_MAX];
    char *o = buf;
    const uint8_t *line = b->parser.line;
    if (txt_upper(line[0]) == (uint8_t)'I' && txt_upper(line[1]) == (uint8_t)'D' &&
        line[2] == 0u) {
        o = txt_put_str(o, BOOT_PRODUCT " bl ");
        o = txt_put_uint(o, BOOT_VERSION_MAJOR);
        *o++ = '.';
        o = txt_put_uint(o, BOOT_VERSION_MINOR);
        o = txt_put_str(o, " serial ");
        o = txt_put_uint(o, b->serial);
        if (b->app_status == BOOT_OK) {
            o = txt_put_str(o, " app valid");
        } else {
            o = txt_put_str(o, " app none (");
            o = txt_put_uint(o, b->app_status);
            *o++ = ')';
        }
    } else {
        o = txt_put_str(o, "? bootloader: ID, or program with inclino flash");
    }
    o = txt_put_str(o, "\r\n");
    b->send((const uint8_t *)buf, (uint16_t)(o - buf));
}

/* ------------------------------------------------------------ entry points */
void boot_init(boot_t *b, void (*send)(const uint8_t *data, uint16_t n))
{
    uint16_t hw_rev;
    proto_parser_init(&b->parser);
    b->send = send;
    proto_reply_init(&b->reply);
    b->executed = 0u;
    b->mark = 0u;
    b->after = BOOT_AFTER_NONE;
    (void)id_record_read(&b->serial, &hw_rev); /* serial 0 without a valid record */
    b->app_status = boot_app_check(&b->app);
    b->desc_blank = is_blank(BOOT_DESC_ADDR, BOOT_SECTOR);
}

static void on_frame(boot_t *b)
{
    proto_parser_t *f = &b->parser;
    if (proto_reply_is_retry(&b->reply, f)) {
        b->send(b->reply.buf, b->reply.len); /* a retry: answer again, run nothing */
        return;
    }
    if (f->ver != PROTO_VERSION) {
        b->send(b->reply.buf, proto_reply_nak(&b->reply, f->seq, f->cmd, PERR_VERSION, 0u));
    } else {
        execute(b, f->seq, f->cmd, f->payload, f->len);
    }
    b->executed++;
    proto_reply_remember(&b->reply, f);
}

void boot_rx(boot_t *b, const uint8_t *data, uint16_t n)
{
    uint16_t i;
    for (i = 0u; i < n && b->after == BOOT_AFTER_NONE; i++) {
        uint8_t r = proto_frame_feed(&b->parser, data[i]);
        if (r == PF_FRAME) {
            on_frame(b);
        } else if (r == PF_BAD_CRC) {
            proto_nak_bad_crc(&b->parser, b->send);
        } else if (r == PF_LINE) {
            text_command(b);
        }
    }
}

void boot_idle(boot_t *b)
{
    (void)proto_parser_idle(&b->parser);
}

uint8_t boot_after(const boot_t *b)
{
    return b->after;
}
