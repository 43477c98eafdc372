/* fuzz_proto.c - libFuzzer target: arbitrary bytes on the SCI line into the
 * firmware's frame parser and command layer (proto_rx, proto_idle,
 * proto_tick), and arbitrary 120-byte blocks into the calibration image
 * checker.  Built with -fsanitize=fuzzer,address,undefined by
 * tests/test_fuzz.py; docs/fuzzing.md has a longer run's figures.
 *
 * Input layout: byte 0 selects how the rest is cut into reads (each cut is
 * followed by a 20 ms silence, proto_idle); the rest is the line.  The
 * application below answers every command like a probe would, checking
 * images with calimg_parse. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "inclino/calimg.h"
#include "inclino/proto_cmd.h"

static uint8_t sink[4096];
static size_t sink_len;

static uint8_t ok_fill(uint8_t *out, size_t n)
{
    memset(out, 0x5A, n);
    return 0;
}
static uint8_t identity(uint8_t *out) { return ok_fill(out, PROTO_IDENTITY_LEN); }
static uint8_t survey(uint8_t *out) { return ok_fill(out, PROTO_SURVEY_LEN); }
static uint8_t raw(uint8_t *out) { return ok_fill(out, PROTO_RAW_LEN); }
static uint8_t qcref_read(uint8_t *out) { return ok_fill(out, PROTO_QCREF_LEN); }
static uint8_t qcref_write(const uint8_t *in)
{
    return (uint8_t)(in[0] == 0xFFu ? PERR_ARGUMENT : 0u);
}
static uint8_t cal_read(uint8_t slot, uint8_t *out)
{
    out[0] = slot;
    return ok_fill(out + 1, 125);
}
static uint16_t cal_write(const uint8_t *image, uint8_t force, uint8_t *out)
{
    corr_cal_t cal;
    calimg_info_t info;
    uint8_t rc = calimg_parse(image, CALIMG_SIZE, &cal, &info);
    (void)force;
    if (rc != CALIMG_OK) {
        return (uint16_t)(PERR_IMAGE | ((uint16_t)rc << 8));
    }
    return ok_fill(out, 7);
}
static uint8_t cal_activate(uint8_t slot, uint32_t seq, uint8_t *out)
{
    (void)seq;
    if (slot > 1u) {
        return PERR_ARGUMENT;
    }
    return ok_fill(out, 5);
}
static void nothing(void) {}
static void text(char *out) { strcpy(out, "TEXT"); }
static void send(const uint8_t *data, uint16_t n)
{
    if (n > PROTO_MAX_PAYLOAD + PROTO_OVERHEAD + 2u) {
        __builtin_trap(); /* no answer is ever longer than the largest frame */
    }
    if (sink_len + n > sizeof sink) {
        sink_len = 0;
    }
    memcpy(sink + sink_len, data, n);
    sink_len += n;
}

static const proto_app_t app = {identity, survey, raw, qcref_read, qcref_write, cal_read,
                                cal_write, cal_activate, nothing, nothing, text, text, send};

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static proto_t p;
    size_t i, start = 1;
    uint8_t cut;
    if (size < 1) {
        return 0;
    }
    proto_init(&p, &app);
    cut = (uint8_t)(data[0] | 1u);
    for (i = 1; i <= size; i++) {
        if (i == size || (i - start) == cut) {
            proto_rx(&p, data + start, (uint16_t)(i - start));
            proto_tick(&p, (uint32_t)i);
            proto_idle(&p);
            start = i;
        }
    }
    if (size >= 1 + CALIMG_SIZE) {
        corr_cal_t cal;
        calimg_info_t info;
        (void)calimg_parse(data + 1, CALIMG_SIZE, &cal, &info);
    }
    return 0;
}
