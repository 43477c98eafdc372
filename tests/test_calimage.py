"""Calibration image: the firmware's checker (C through cffi) and the host's
packer agree byte for byte, and no single corrupted byte gets through."""
import binascii

import numpy as np
import pytest

from inclino.engines import firmware as core
from inclino.engines._core import ffi, lib
from inclino.formats.calfile import Calibration
from inclino.formats.calimage import SIZE, CalImage
from inclino.errors import CalibrationError

C_CODES = {0: "ok", 1: "length", 2: "magic", 3: "version", 4: "crc", 5: "range"}


def _img():
    cal = Calibration(acc_m=[[1.01, 0.002, -0.003], [0.0, 0.99, 0.01], [0.004, 0.0, 1.02]],
                      acc_b=[0.01, -0.02, 0.005], mag_m=[[1.05, 0.01, 0.0], [0.0, 0.97, 0.0], [0.02, 0.0, 1.0]],
                      mag_b=[350.0, -120.5, 80.25])
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


def test_host_pack_is_firmware_build_and_parse():
    im = _img()
    data = im.pack()
    assert len(data) == SIZE
    rc, cal, info = c_parse(data)
    assert rc == "ok" and info.serial == 123456 and info.time == 1795000000 and info.method == 4
    assert list(cal.acc.m) == list(im.cal.acc_m) and list(cal.mag.bias) == list(im.cal.mag_b)
    out = ffi.new("uint8_t[120]")
    lib.calimg_build(cal, info, out)
    assert bytes(out) == data
    assert CalImage.unpack(data) == im


def test_every_single_byte_corruption_is_refused_by_both():
    data = bytearray(_img().pack())
    for i in range(118):  # the last two bytes are padding, outside the CRC
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
