"""Calibration image: the firmware's checker (C through cffi) and the host's
packer agree byte for byte, and no single corrupted byte gets through."""
import binascii
import struct

import numpy as np
import pytest

from inclino.engines import firmware as core
from inclino.engines._core import ffi, lib
from inclino.formats.calfile import Calibration
from inclino.formats.calimage import SIZE, SIZE_V1, CalImage
from inclino.errors import CalibrationError

C_CODES = {0: "ok", 1: "length", 2: "magic", 3: "version", 4: "crc", 5: "range"}
BLOCK = {"t_ref_c": 25.0, "order": 2, "span_c": [-5.0, 55.0], "applied_by_firmware": True,
         "acc": {"bias": [[2e-5, -1.5e-5, 3e-5], [2e-7, -1e-7, 0.0]], "scale_ppm": [[30, -20, 25], [0.3, -0.2, 0.1]]},
         "mag": {"bias": [[2.0, -1.5, 3.0], [0.02, 0.01, -0.02]], "scale_ppm": [[50, 40, -30], [0.3, 0.1, -0.3]]}}


def _img(temp=False):
    cal = Calibration(acc_m=[[1.01, 0.002, -0.003], [0.0, 0.99, 0.01], [0.004, 0.0, 1.02]],
                      acc_b=[0.01, -0.02, 0.005], mag_m=[[1.05, 0.01, 0.0], [0.0, 0.97, 0.0], [0.02, 0.0, 1.0]],
                      mag_b=[350.0, -120.5, 80.25], temperature=dict(BLOCK) if temp else None)
    return CalImage(cal.to_fixed(), serial=123456, time=1795000000, method="joint")


def c_parse(data: bytes):
    buf = ffi.new("uint8_t[]", data)
    cal = ffi.new("corr_cal_t *")
    info = ffi.new("calimg_info_t *")
    rc = lib.calimg_parse(buf, len(data), cal, info)
    return C_CODES[rc], cal, info


def test_crc_is_ccitt_false():
    data = b"123456789"
    assert lib.crc16_update(0xFFFF, ffi.new("uint8_t[]", data), len(data)) == 0x29B1
    rng = np.random.default_rng(5)
    for n in (0, 1, 7, 64, 300):
        d = rng.integers(0, 256, n, dtype=np.uint8).tobytes()
        assert lib.crc16_update(0xFFFF, ffi.new("uint8_t[]", d or b"\0"), n) == binascii.crc_hqx(d, 0xFFFF)


@pytest.mark.parametrize("temp", [False, True], ids=["v1", "v2"])
def test_host_pack_is_firmware_build_and_parse(temp):
    im = _img(temp)
    data = im.pack()
    assert len(data) == (SIZE if temp else SIZE_V1)
    rc, cal, info = c_parse(data)
    assert rc == "ok" and info.serial == 123456 and info.time == 1795000000 and info.method == 4
    assert list(cal.acc.m) == list(im.cal.acc_m) and list(cal.mag.bias) == list(im.cal.mag_b)
    if temp:
        t = im.cal.temp
        assert (cal.t_order, cal.t_ref) == (2, 25 * 128)
        assert list(cal.acc_tc.c1) == list(t.acc_c1) and list(cal.mag_tc.r2) == list(t.mag_r2)
        assert list(cal.mag_tc.c2) == list(t.mag_c2) and list(cal.acc_tc.r1) == list(t.acc_r1)
    else:  # a version 1 image still loads: no temperature terms
        assert cal.t_order == 0 and im.cal.temp is None
    out = ffi.new("uint8_t[192]")
    n = lib.calimg_build(cal, info, out)
    assert bytes(out)[:n] == data
    assert CalImage.unpack(data) == im


def _v2_with(mutate):
    """A version 2 image with one field changed and a good CRC."""
    data = bytearray(_img(True).pack())
    mutate(data)
    struct.pack_into(">H", data, 188, binascii.crc_hqx(bytes(data[:188]), 0xFFFF))
    return bytes(data)


@pytest.mark.parametrize("what,mutate", [
    ("order 3", lambda d: d.__setitem__(17, 3)),
    ("t_ref 126 degC", lambda d: struct.pack_into(">h", d, 18, 126 * 128)),
    ("t_ref -41 degC", lambda d: struct.pack_into(">h", d, 18, -41 * 128)),
    ("acc c1 beyond 2^30", lambda d: struct.pack_into(">i", d, 116, -(2**30) - 1)),
    ("mag r1 beyond 2^30", lambda d: struct.pack_into(">i", d, 152 + 18, 2**30 + 1)),
    ("mag r2 INT16_MIN", lambda d: struct.pack_into(">h", d, 152 + 30, -(2**15))),
    ("order 1 with a second-order term", lambda d: d.__setitem__(17, 1)),
    ("order 0 with terms", lambda d: d.__setitem__(17, 0)),
    ("version 1 with 192 bytes", lambda d: struct.pack_into(">H", d, 4, 1)),
])
def test_v2_range_checks_agree(what, mutate):
    data = _v2_with(mutate)
    rc = c_parse(data)[0]
    assert rc in ("range", "version"), what
    with pytest.raises(CalibrationError):
        CalImage.unpack(data)


def test_v2_at_the_range_limits_loads():
    def edge(d):
        struct.pack_into(">h", d, 18, 125 * 128)
        struct.pack_into(">i", d, 116, -(2**30))
        struct.pack_into(">i", d, 152 + 18, 2**30)
        struct.pack_into(">h", d, 152 + 30, -(2**15) + 1)
    data = _v2_with(edge)
    assert c_parse(data)[0] == "ok"
    assert CalImage.unpack(data).cal.temp.t_ref == 125 * 128


def test_frame_length_must_match_the_image_length():
    """A version 2 image cut to version 1's length (or the reverse) is
    refused by the length check, before any byte past it is read."""
    v2 = _img(True).pack()
    assert c_parse(v2[:SIZE_V1])[0] == "length"
    assert c_parse(v2[:SIZE - 1])[0] == "length"


@pytest.mark.parametrize("temp", [False, True], ids=["v1", "v2"])
def test_every_single_byte_corruption_is_refused_by_both(temp):
    data = bytearray(_img(temp).pack())
    for i in range(len(data) - 2):  # the last two bytes are padding, outside the CRC
        for flip in (0x01, 0x80, 0xFF):
            bad = bytearray(data)
            bad[i] ^= flip
            rc, _, _ = c_parse(bytes(bad))
            assert rc != "ok", (i, flip)
            with pytest.raises(CalibrationError):
                CalImage.unpack(bytes(bad))


def test_erased_truncated_and_out_of_range():
    assert c_parse(b"\xff" * SIZE)[0] in ("length", "magic")
    assert c_parse(_img().pack()[:100])[0] == "length"
    fc = _img().cal
    neg = core.FixedCal((-(2**29),) + fc.acc_m[1:], fc.acc_b, fc.mag_m, fc.mag_b)  # x axis reversed
    data = CalImage(neg, 1, 2, "joint").pack()
    assert c_parse(data)[0] == "range"
    with pytest.raises(CalibrationError, match="out of range"):
        CalImage.unpack(data)


def test_parse_leaves_outputs_untouched_on_error():
    buf = bytearray(_img().pack())
    buf[30] ^= 1
    cal = ffi.new("corr_cal_t *")
    cal.acc.m[0] = 777
    info = ffi.new("calimg_info_t *")
    assert lib.calimg_parse(ffi.new("uint8_t[]", bytes(buf)), SIZE, cal, info) == 4
    assert cal.acc.m[0] == 777 and info.serial == 0


@pytest.mark.parametrize("temp", [False, True])
def test_coefficient_limits_are_inclusive_where_documented(temp):
    """The image's coefficient checks at their edges, on both triads and
    every axis (calimage.unpack, calimg.c): |bias| < 2^30 (2^30 - 1 read,
    2^30 refused either sign), each diagonal of M >= 2^27 (2^27 read,
    2^27 - 1 refused), in images of version 1 and 2."""
    from dataclasses import replace

    from inclino.formats.calimage import BIAS_LIMIT, DIAG_MIN

    assert (BIAS_LIMIT, DIAG_MIN) == (2**30, 2**27)
    base = core.FixedCal.identity()
    if temp:
        base = replace(base, temp=core.FixedTemp(t_ref=25 * 128, order=1, acc_c1=(5, 0, 0), acc_c2=(0, 0, 0),
                                                 acc_r1=(0, 0, 0), acc_r2=(0, 0, 0), mag_c1=(0, 0, 0),
                                                 mag_c2=(0, 0, 0), mag_r1=(0, 0, 0), mag_r2=(0, 0, 0)))
    for tri in ("acc", "mag"):
        for i in range(3):
            for b, ok in ((2**30 - 1, True), (-(2**30 - 1), True), (2**30, False), (-(2**30), False)):
                bias = [0, 0, 0]
                bias[i] = b
                img = CalImage(replace(base, **{f"{tri}_b": tuple(bias)}), 7, 1, "joint").pack()
                if ok:
                    assert getattr(CalImage.unpack(img).cal, f"{tri}_b") == tuple(bias)
                else:
                    with pytest.raises(CalibrationError, match="coefficient out of range"):
                        CalImage.unpack(img)
            for d, ok in ((2**27, True), (2**27 - 1, False)):
                m = list(getattr(base, f"{tri}_m"))
                m[4 * i] = d
                img = CalImage(replace(base, **{f"{tri}_m": tuple(m)}), 7, 1, "joint").pack()
                if ok:
                    assert getattr(CalImage.unpack(img).cal, f"{tri}_m") == tuple(m)
                else:
                    with pytest.raises(CalibrationError, match="coefficient out of range"):
                        CalImage.unpack(img)


def test_image_version_must_match_its_length():
    """A version-2 header on a version-1-sized image (and the reverse) is
    refused: the length field decides the layout, the version must agree."""
    img1 = CalImage(core.FixedCal.identity(), 7, 1, "joint").pack()
    assert len(img1) == SIZE_V1
    bad = bytearray(img1)
    bad[4:6] = struct.pack(">H", 2)
    bad[SIZE_V1 - 4:SIZE_V1 - 2] = struct.pack(">H", binascii.crc_hqx(bytes(bad[:SIZE_V1 - 4]), 0xFFFF))
    with pytest.raises(CalibrationError, match="format 2 with"):
        CalImage.unpack(bytes(bad))
    longer = img1 + bytes(8)  # trailing bytes beyond the stated length are not part of the image
    assert CalImage.unpack(longer).cal == CalImage.unpack(img1).cal
