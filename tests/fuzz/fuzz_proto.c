/* fuzz_proto.c - libFuzzer target: arbitrary bytes on the SCI line into the
 * firmware's frame parser and command layer (proto_rx, proto_idle,
 * proto_tick), and arbitrary CALIMG_SIZE-byte blocks into the calibration
 * image checker (version 1 or 2, as their length field says).  Built with -fsanitize=fuzzer,address,undefined by
 * tests/test_fuzz.py; docs/fuzzing.md has a longer run's figures.
 *
 * Input layout: byte 0 selects the mode.  Bit 7 clear: the rest is the raw
 * line, cut into reads of (byte 0 | 1) bytes, each followed by a 20 ms
 * silence (proto_idle) and a stream tick.  Bit 7 set: the rest is a list of
 * requests {seq, cmd, len, payload[len]} that the target frames with a
 * correct CRC first, so that the fuzzer reaches every command rather than
 * stopping at the CRC.  Bit 6 set: the bytes given to calimg_parse get a
 * correct CRC too, where the length field puts it (120: version 1, 192:
 * version 2; else at version 2's place).  The application below answers every command like a
 * probe would, checking images with calimg_parse. */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "inclino/calimg.h"
#include "inclino/crc16.h"
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
static uint8_t survey_raw(uint8_t *out) { return ok_fill(out, PROTO_SURVEY_RAW_LEN); }
static uint8_t qcref_read(uint8_t *out) { return ok_fill(out, PROTO_QCREF_LEN); }
static uint8_t qcref_write(const uint8_t *in)
{
    return (uint8_t)(in[0] == 0xFFu ? PERR_ARGUMENT : 0u);
}
static uint8_t set_average(uint8_t n) { return (uint8_t)((n == 0u || n > 64u) ? PERR_ARGUMENT : 0u); }
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

static const proto_app_t app = {identity, survey, survey_raw, raw, qcref_read, qcref_write, set_average, cal_read,
                                cal_write, cal_activate, nothing, nothing, text, text, send};

static void framed_requests(proto_t *p, const uint8_t *data, size_t size)
{
    static uint8_t frame[PROTO_MAX_PAYLOAD + PROTO_OVERHEAD];
    size_t i = 0;
    uint32_t t = 0;
    while (i + 3 <= size) {
        uint8_t seq = data[i], cmd = data[i + 1];
        size_t len = data[i + 2];
        uint16_t n;
        i += 3;
        if (len > size - i) {
            len = size - i;
        }
        n = proto_frame_encode(seq, cmd, data + i, (uint16_t)len, frame, (uint16_t)sizeof frame);
        if (n == 0u) { /* longer than PROTO_MAX_PAYLOAD: send it unframed */
            proto_rx(p, data + i, (uint16_t)len);
        } else {
            proto_rx(p, frame, n);
        }
        i += len;
        t += 7u;
        proto_tick(p, t);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static proto_t p;
    size_t i, start = 1;
    uint8_t cut;
    if (size < 1) {
        return 0;
    }
    proto_init(&p, &app);
    if ((data[0] & 0x80u) != 0u) {
        framed_requests(&p, data + 1, size - 1);
    } else {
        cut = (uint8_t)(data[0] | 1u);
        for (i = 1; i <= size; i++) {
            if (i == size || (i - start) == cut) {
                proto_rx(&p, data + start, (uint16_t)(i - start));
                proto_tick(&p, (uint32_t)i);
                proto_idle(&p);
                start = i;
            }
        }
    }
    if (size >= 1 + CALIMG_SIZE) {
        static uint8_t img[CALIMG_SIZE];
        corr_cal_t cal;
        calimg_info_t info;
        memcpy(img, data + 1, CALIMG_SIZE);
        if ((data[0] & 0x40u) != 0u) {
            uint16_t n = calimg_length(img);
            uint16_t off = (n != 0u) ? (uint16_t)(n - 4u) : CALIMG_CRC_OFFSET;
            uint16_t crc = crc16_update(CRC16_INIT, img, off);
            img[off] = (uint8_t)(crc >> 8);
            img[off + 1u] = (uint8_t)crc;
        }
        (void)calimg_parse(img, CALIMG_SIZE, &cal, &info);
    }
    return 0;
}
