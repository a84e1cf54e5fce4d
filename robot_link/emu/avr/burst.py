#!/usr/bin/env python3
"""Writes N odolink frames with a wrong CRC back to back on a serial port, in
one write: a line-rate stress of everything between the host and the
firmware's frame decoder. Each frame is 20 bytes on the wire (delimiter
included) and draws no reply; the robot counts each one in its crc_errors
counter (odocal robot info: link_crc_errors), so after a burst of N the
counter must have grown by exactly N: a lost byte merges two frames or cuts
one short and shows up as a different count.

usage: burst.py PORT [N]   (default N = 100: 2000 bytes)
"""
import os
import sys
import termios
import time
import tty


def crc16_ccitt_false(data):
    crc = 0xFFFF
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def cobs_encode(data):
    out = bytearray([0])
    code_at, code = 0, 1
    for b in data:
        if b == 0:
            out[code_at] = code
            code_at, code = len(out), 1
            out.append(0)
        else:
            out.append(b)
            code += 1
            if code == 0xFF:
                out[code_at] = code
                code_at, code = len(out), 1
                out.append(0)
    out[code_at] = code
    return bytes(out)


def bad_frame(seq):
    body = bytes((0x30 + (seq + i) % 64) for i in range(11))
    payload = bytes([1, 0x01, seq & 0xFF, (seq >> 8) & 0xFF, len(body)]) + body
    crc = crc16_ccitt_false(payload) ^ 0x5A5A  # wrong on purpose
    framed = cobs_encode(payload + bytes([crc >> 8, crc & 0xFF])) + b"\0"
    assert len(framed) == 20 and framed.count(0) == 1
    return framed


def main():
    port = sys.argv[1]
    n = int(sys.argv[2]) if len(sys.argv) > 2 else 100
    data = b"".join(bad_frame(0x1000 + i) for i in range(n))
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    try:
        tty.setraw(fd)
        attrs = termios.tcgetattr(fd)
        attrs[4] = attrs[5] = termios.B115200
        termios.tcsetattr(fd, termios.TCSANOW, attrs)
        t0 = time.monotonic()
        written = 0
        while written < len(data):
            written += os.write(fd, data[written:])
        termios.tcdrain(fd)
        # At 115200 baud (11 bits a byte on simavr's UART) 2000 bytes take
        # about 0.19 s to reach the firmware; give it that and a margin.
        time.sleep(len(data) * 11 / 115200 + 0.3)
        print(f"wrote {len(data)} bytes ({n} frames) in one write, {time.monotonic() - t0:.2f} s")
    finally:
        os.close(fd)


if __name__ == "__main__":
    main()
