#!/usr/bin/env python3
"""Replays docs/protocol.md's push conversation (the golden bytes of
tests/robot_link/protocol_examples.h) against a robot on PORT and compares
every documented reply byte for byte, then the storage record the commit
wrote (slot A, EEPROM bytes 0..69 of IMAGE) with the documented one.

The robot must be fresh: booted on an erased EEPROM (defaults 72 / 72 / 270
/ 4096, storage empty). HELLO's reply carries the robot's name, so it is
compared with the golden reply re-encoded for NAME (default odocal-avr).

usage: replay_examples.py PORT IMAGE [NAME]
"""
import os
import re
import select
import sys
import termios
import time
import tty

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from burst import cobs_encode, crc16_ccitt_false  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
EXAMPLES = os.path.join(HERE, "..", "..", "..", "tests", "robot_link", "protocol_examples.h")

# (request, documented reply or None), in the conversation's order.
CONVERSATION = [
    ("request type 0x01 seq 1", "reply HELLO"),
    ("request type 0x05 seq 2", "reply STAGE_BEGIN"),
    ("request type 0x06 seq 3", None),
    ("request type 0x06 seq 4", None),
    ("request type 0x06 seq 5", "reply STAGE_PUT"),
    ("request type 0x06 seq 6", None),
    ("request type 0x07 seq 7", "reply PARAMS_READ staged"),
    ("request type 0x08 seq 8", "reply COMMIT wrong checksum"),
    ("request type 0x08 seq 9", "reply COMMIT"),
    ("request type 0x08 seq 9", "reply COMMIT retry (from cache)"),
    ("request type 0x01 seq 10", "reply HELLO version 2"),
    ("request type 0x0c seq 11", "reply TELEMETRY_RATE"),
    ("request type 0x0a seq 12", "reply RUN_START"),
]


def golden():
    text = open(EXAMPLES).read()
    return {name: bytes.fromhex(hexstr) for name, hexstr in
            re.findall(r'\{"([^"]+)",\s*"([0-9a-f ]+)"\}', text)}


def cobs_decode(data):
    out, i = bytearray(), 0
    while i < len(data):
        code = data[i]
        out += data[i + 1:i + code]
        i += code
        if code < 0xFF and i < len(data):
            out.append(0)
    return bytes(out)


def hello_for(name, golden_reply):
    """The golden HELLO reply with the robot name replaced, re-framed."""
    payload = cobs_decode(golden_reply.strip(b"\0"))[:-2]
    header, body = payload[:5], payload[5:]
    # body: type, version, count, table crc u32, set crc u32, boot, name_len, name
    fixed = body[:12]
    new_body = fixed + bytes([len(name)]) + name.encode()
    new_payload = header[:4] + bytes([len(new_body)]) + new_body
    crc = crc16_ccitt_false(new_payload)
    return b"\0" + cobs_encode(new_payload + bytes([crc >> 8, crc & 0xFF])) + b"\0"


def read_frame(fd, timeout=1.0):
    """Bytes up to and including the delimiter that ends the next frame."""
    buf, deadline = bytearray(), time.monotonic() + timeout
    while time.monotonic() < deadline:
        r, _, _ = select.select([fd], [], [], 0.05)
        if not r:
            continue
        buf += os.read(fd, 1)
        if buf[-1] == 0 and any(buf[:-1]):
            return bytes(buf)
    return bytes(buf)


def main():
    port, image = sys.argv[1], sys.argv[2]
    name = sys.argv[3] if len(sys.argv) > 3 else "odocal-avr"
    g = golden()
    fd = os.open(port, os.O_RDWR | os.O_NOCTTY)
    tty.setraw(fd)
    termios.tcflush(fd, termios.TCIOFLUSH)
    failures = 0
    for request, reply in CONVERSATION:
        os.write(fd, g[request])
        got = read_frame(fd)
        if reply is None:
            ok = len(got) > 2
            print(f"{'ok  ' if ok else 'FAIL'} {request}: a reply ({len(got)} bytes)")
        else:
            want = hello_for(name, g[reply]) if reply == "reply HELLO" else g[reply]
            ok = got == want
            label = reply + (f" (name {name})" if reply == "reply HELLO" else "")
            print(f"{'ok  ' if ok else 'FAIL'} {label}: {len(got)} bytes" +
                  ("" if ok else f"\n  want {want.hex(' ')}\n  got  {got.hex(' ')}"))
        failures += not ok
    os.close(fd)
    with open(image, "rb") as f:
        slot_a = f.read(70)
    want = g["storage slot A after commit"]
    ok = slot_a == want
    print(f"{'ok  ' if ok else 'FAIL'} storage slot A after commit: EEPROM bytes 0..69" +
          ("" if ok else f"\n  want {want.hex(' ')}\n  got  {slot_a.hex(' ')}"))
    failures += not ok
    print("PASS" if failures == 0 else f"{failures} FAILED")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
