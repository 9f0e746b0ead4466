#!/usr/bin/env python3
"""The firmware's MAVLink 2 codec (firmware/src/mavlink.rs) checked by pymavlink.

Run by the firmware's host tests (firmware/src/mavlink/pymavlink.rs), not by hand:

  mavlink_check.py check FRAMES.bin EXPECTED.json
      Decodes FRAMES.bin with pymavlink's `common` dialect (MAVLink 2), strictly: a bad CRC
      (pymavlink checks the CRC with each message's CRC extra), a bad length, bytes left over
      or a MAVLink 1 frame fails. Then compares every message, in order, with EXPECTED.json:
      a list of {"name", "seq", "src_system", "src_component", "fields": {name: value}} and
      optionally "crc_extra" (the CRC extra our crate used, compared with pymavlink's).
      Floats are compared as float32 (what the frame carries), exactly; lists element-wise;
      char arrays as the strings pymavlink makes of them (up to the first NUL).

  mavlink_check.py make VALUES.json OUT.bin
      Encodes messages with pymavlink's `ardupilotmega` dialect (MAVLink 2; it has AOA_SSA)
      into OUT.bin: VALUES.json is {"src_system", "src_component", "messages":
      [{"name", "fields": {...}}]}, each encoded by the dialect's `<name>_encode(**fields)`
      (a string given for a char-array field, such as PARAM_VALUE's param_id, as ASCII bytes).

Exit status 0 on success; 1 with the reasons on stderr; 2 when pymavlink is missing
(`pip install pymavlink`).
"""

import io
import json
import os
import struct
import sys

os.environ["MAVLINK20"] = "1"
try:
    from pymavlink.dialects.v20 import ardupilotmega
    from pymavlink.dialects.v20 import common as mavlink2
except ImportError as e:  # pragma: no cover - the Rust test says how to install it
    print(f"pymavlink is not installed ({e}): pip install pymavlink", file=sys.stderr)
    sys.exit(2)


def f32(v):
    """v rounded to float32, as a frame carries it."""
    return struct.unpack("<f", struct.pack("<f", v))[0]


def same(got, want):
    """Whether a decoded field equals the expected value (floats as float32, exactly)."""
    if isinstance(want, list):
        return isinstance(got, list) and len(got) == len(want) and all(
            same(g, w) for g, w in zip(got, want)
        )
    if isinstance(want, float) or isinstance(got, float):
        return f32(float(got)) == f32(float(want))
    return got == want


def check(frames_path, expected_path):
    data = open(frames_path, "rb").read()
    expected = json.load(open(expected_path))
    mav = mavlink2.MAVLink(None)
    mav.robust_parsing = False  # raise on a bad CRC or length instead of skipping
    errors = []
    try:
        msgs = mav.parse_buffer(data) or []
    except mavlink2.MAVError as e:
        print(f"pymavlink refused the stream: {e}", file=sys.stderr)
        return 1
    if mav.buf_len() != 0:
        errors.append(f"{mav.buf_len()} bytes left over after the last frame")
    if len(msgs) != len(expected):
        errors.append(f"{len(msgs)} messages decoded, {len(expected)} expected")
    for i, (m, want) in enumerate(zip(msgs, expected)):
        h = m.get_header()
        buf = m.get_msgbuf()
        where = f"message {i} ({m.get_type()})"
        if m.get_type() == "BAD_DATA":
            errors.append(f"{where}: bad data: {m.reason}")
            continue
        if buf[0] != 0xFD:
            errors.append(f"{where}: not a MAVLink 2 frame (start byte {buf[0]:#x})")
        if m.get_type() != want["name"]:
            errors.append(f"{where}: expected {want['name']}")
        if m.get_msgId() != getattr(mavlink2, "MAVLINK_MSG_ID_" + want["name"]):
            errors.append(f"{where}: message id {m.get_msgId()}")
        got_hdr = (h.srcSystem, h.srcComponent, h.seq)
        want_hdr = (want["src_system"], want["src_component"], want["seq"])
        if got_hdr != want_hdr:
            errors.append(f"{where}: header (sys, comp, seq) {got_hdr} != {want_hdr}")
        # The CRC pymavlink accepted, recomputed over the frame with the CRC extra.
        crc = mavlink2.x25crc(bytes(buf[1:-2]))
        crc.accumulate(struct.pack("B", m.crc_extra))
        if crc.crc != struct.unpack("<H", bytes(buf[-2:]))[0]:
            errors.append(f"{where}: CRC {crc.crc:#06x} does not match the frame's")
        if "crc_extra" in want and m.crc_extra != want["crc_extra"]:
            errors.append(f"{where}: CRC extra {m.crc_extra}, ours {want['crc_extra']}")
        fields = m.to_dict()
        for name, value in want["fields"].items():
            if name not in fields:
                errors.append(f"{where}: no field {name}")
            elif not same(fields[name], value):
                errors.append(f"{where}: {name} = {fields[name]!r}, expected {value!r}")
    for e in errors:
        print(e, file=sys.stderr)
    print(f"pymavlink: {len(msgs)} messages checked, {len(errors)} errors")
    return 1 if errors else 0


def make(values_path, out_path):
    values = json.load(open(values_path))
    out = io.BytesIO()
    mav = ardupilotmega.MAVLink(
        out, srcSystem=values["src_system"], srcComponent=values["src_component"]
    )
    for m in values["messages"]:
        encode = getattr(mav, m["name"].lower() + "_encode")
        cls = ardupilotmega.mavlink_map[getattr(ardupilotmega, "MAVLINK_MSG_ID_" + m["name"])]
        types = dict(zip(cls.fieldnames, cls.fieldtypes))
        fields = {
            k: v.encode("ascii") if types.get(k) == "char" and isinstance(v, str) else v
            for k, v in m["fields"].items()
        }
        mav.send(encode(**fields))
    open(out_path, "wb").write(out.getvalue())
    print(f"pymavlink: {len(values['messages'])} messages, {len(out.getvalue())} bytes")
    return 0


def main(argv):
    if len(argv) == 4 and argv[1] == "check":
        return check(argv[2], argv[3])
    if len(argv) == 4 and argv[1] == "make":
        return make(argv[2], argv[3])
    print(__doc__, file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
