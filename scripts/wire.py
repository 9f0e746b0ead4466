#!/usr/bin/env python3
"""Decoder and encoder of the flight computer's serial link, written from docs/interface.md
alone (Python 3.11, standard library only).

It reads the document's machine-readable parts at start: the constants, the frame kinds with
their bodies, and the layout tables (every container's fields or variants, in wire order),
and implements the encodings the document states in prose: COBS framing with a terminating
zero, version and kind bytes, CRC-32C (Castagnoli, reflected, init and xorout 0xFFFFFFFF)
little-endian, and postcard bodies (LEB128 varints, zigzag for signed integers, f32 as four
little-endian bytes, bool and u8 as one byte, options as a tag byte, enums as a varint
index, fixed arrays without a length, strings and vectors with a varint length).

    python3 scripts/wire.py decode < capture.bin     # one JSON line per frame
    python3 scripts/wire.py encode < messages.jsonl  # the frames, one after the other

A decoded frame is {"kind": "M", "body": ...} (the kind's letter; an empty body is null), or
{"error": NAME} for a rejected one (cobs, oversize, too_short, crc, version, kind,
malformed). Values take the document's canonical form: a struct an object of its fields, a
newtype its content, an array or tuple a list, an option null or its content, a variant
without content its name and one with content {name: content}, an f32 the string of its bits
"0x%08x" (NaN payloads and signs kept; the encoder also takes a number), an integer a number.
"""

import argparse
import json
import re
import struct
import sys
from pathlib import Path

DEFAULT_DOC = Path(__file__).resolve().parent.parent / "docs" / "interface.md"


class WireError(Exception):
    """A rejected frame or value, named as the document names the rejections."""

    def __init__(self, name, detail=""):
        super().__init__(f"{name}: {detail}" if detail else name)
        self.name = name


# ---------------------------------------------------------------------------------------
# The document's tables.


def region(doc, name):
    begin = f"<!-- {name}:begin -->\n"
    end = f"<!-- {name}:end -->"
    a = doc.index(begin) + len(begin)
    return doc[a:doc.index(end, a)]


def cells(line):
    out = []
    for c in line.strip().strip("|").split(" | "):
        c = c.strip()
        if len(c) >= 2 and c.startswith("`") and c.endswith("`"):
            c = c[1:-1]
        out.append(c)
    return out


def table_rows(lines):
    rows, started = [], False
    for line in lines:
        if line.startswith("|"):
            started = True
            rows.append(line)
        elif started:
            break
    return [cells(r) for r in rows[2:]]


PRIMITIVES = {"u8", "u16", "u32", "u64", "i8", "i16", "i32", "i64", "f32", "f64", "bool", "()"}


def parse_type(text):
    """A type string of the layout tables, as a tree: ("prim", name), ("str", cap),
    ("option", t), ("array", t, n), ("vec", t, cap), ("tuple", [t...]), ("name", n)."""
    t, rest = _parse(text.strip())
    if rest.strip():
        raise ValueError(f"type {text!r}: {rest!r} left over")
    return t


def _parse(s):
    if s.startswith("()"):
        return ("prim", "()"), s[2:]
    if s.startswith("Option<"):
        t, rest = _parse(s[len("Option<"):])
        return ("option", t), _expect(rest, ">")
    if s.startswith("Vec<"):
        t, rest = _parse(s[len("Vec<"):])
        m = re.match(r",\s*<=(\d+)>", rest)
        if not m:
            raise ValueError(f"Vec capacity in {s!r}")
        return ("vec", t, int(m.group(1))), rest[m.end():]
    if s.startswith("["):
        t, rest = _parse(s[1:])
        m = re.match(r";\s*(\d+)\]", rest)
        if not m:
            raise ValueError(f"array length in {s!r}")
        return ("array", t, int(m.group(1))), rest[m.end():]
    if s.startswith("("):
        items, rest = [], s[1:]
        while True:
            t, rest = _parse(rest.lstrip())
            items.append(t)
            rest = rest.lstrip()
            if rest.startswith(","):
                rest = rest[1:]
                continue
            return ("tuple", items), _expect(rest, ")")
    m = re.match(r"str<=(\d+)", s)
    if m:
        return ("str", int(m.group(1))), s[m.end():]
    m = re.match(r"[A-Za-z_][A-Za-z0-9_]*", s)
    if not m:
        raise ValueError(f"a type at {s!r}")
    word = m.group(0)
    return (("prim", word) if word in PRIMITIVES else ("name", word)), s[m.end():]


def _expect(rest, token):
    rest = rest.lstrip()
    if not rest.startswith(token):
        raise ValueError(f"expected {token!r} at {rest!r}")
    return rest[len(token):]


def parse_content(text):
    """A variant's content: None (no content), ("struct", [(name, type)...]) or a type."""
    text = text.strip()
    if text == "-":
        return None
    if text.startswith("{"):
        fields, rest = [], text[1:]
        while True:
            m = re.match(r"\s*(\w+)\s*:\s*", rest)
            if not m:
                raise ValueError(f"a field name at {rest!r} in {text!r}")
            t, rest = _parse(rest[m.end():])
            fields.append((m.group(1), t))
            rest = rest.lstrip()
            if rest.startswith(","):
                rest = rest[1:]
                continue
            if rest.strip() != "}":
                raise ValueError(f"{rest!r} left over in {text!r}")
            return ("struct", fields)
    return parse_type(text)


class Layout:
    """Everything the document states about the link, read from its tables."""

    def __init__(self, doc):
        consts = {c[0]: int(c[1].replace(",", "")) for c in table_rows(region(doc, "constants").splitlines())}
        self.version = consts["PROTOCOL_VERSION"]
        self.max_frame = consts["MAX_FRAME_LEN"]
        self.max_payload = consts["MAX_PAYLOAD_LEN"]
        self.kinds = {}  # letter -> body type name, or None for an empty body
        for c in table_rows(region(doc, "sizes").splitlines()):
            letter = c[1].split("`")[1] if "`" in c[1] else c[1][0]
            self.kinds[letter] = None if c[3] == "()" else c[3]
        self.containers = {}
        lines = region(doc, "layout").splitlines()
        heads = [i for i, l in enumerate(lines) if l.startswith("### ")]
        for k, i in enumerate(heads):
            end = heads[k + 1] if k + 1 < len(heads) else len(lines)
            m = re.match(r"### `(\w+)` \(([a-z ]+)\)", lines[i])
            if not m:
                raise ValueError(f"heading {lines[i]!r}")
            name, kind = m.group(1), m.group(2)
            rows = table_rows(lines[i + 1:end])
            if kind == "enum":
                variants = {int(r[0]): (r[1], parse_content(r[2])) for r in rows}
                self.containers[name] = ("enum", variants)
            else:
                self.containers[name] = (kind, [(r[0], parse_type(r[1])) for r in rows])


# ---------------------------------------------------------------------------------------
# Primitives.


def crc32c(data):
    crc = 0xFFFFFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ (0x82F63B78 if crc & 1 else 0)
    return crc ^ 0xFFFFFFFF


def cobs_encode(data):
    out, block = bytearray(), bytearray()
    for i, b in enumerate(data):
        if b == 0:
            out.append(len(block) + 1)
            out += block
            block = bytearray()
            continue
        block.append(b)
        if len(block) == 254 and i + 1 < len(data):
            out.append(255)
            out += block
            block = bytearray()
    out.append(len(block) + 1)
    out += block
    return bytes(out)


def cobs_decode(enc):
    out, i = bytearray(), 0
    while i < len(enc):
        code = enc[i]
        if code == 0 or i + code > len(enc):
            raise WireError("cobs", "a block runs past the frame's end")
        out += enc[i + 1:i + code]
        i += code
        if code != 255 and i < len(enc):
            out.append(0)
    return bytes(out)


class F32(float):
    """An f32 read from the wire, with its exact bits (a NaN's payload, a sign)."""

    __slots__ = ("bits",)

    def __new__(cls, bits):
        value = struct.unpack("<f", struct.pack("<I", bits))[0]
        obj = super().__new__(cls, value)
        obj.bits = bits
        return obj


class Reader:
    def __init__(self, data):
        self.data, self.at = data, 0

    def take(self, n):
        if self.at + n > len(self.data):
            raise WireError("malformed", "the body ends early")
        b = self.data[self.at:self.at + n]
        self.at += n
        return b

    def varint(self, bits):
        value, shift = 0, 0
        for _ in range((bits + 6) // 7):
            b = self.take(1)[0]
            value |= (b & 0x7F) << shift
            shift += 7
            if not b & 0x80:
                if value >> bits:
                    raise WireError("malformed", f"varint over {bits} bits")
                return value
        raise WireError("malformed", f"varint longer than a u{bits}'s")


def zigzag_decode(n):
    return (n >> 1) ^ -(n & 1)


def zigzag_encode(v, bits):
    return ((v << 1) ^ (v >> (bits - 1))) & ((1 << bits) - 1)


# ---------------------------------------------------------------------------------------
# Bodies.


class Codec:
    def __init__(self, layout):
        self.layout = layout

    # Decoding: bytes to canonical values.

    def read(self, t, r):
        tag = t[0]
        if tag == "prim":
            return self.read_prim(t[1], r)
        if tag == "str":
            n = r.varint(64)
            if n > t[1]:
                raise WireError("malformed", f"a string of {n} bytes, at most {t[1]}")
            try:
                return r.take(n).decode("utf-8")
            except UnicodeDecodeError as e:
                raise WireError("malformed", str(e)) from None
        if tag == "option":
            flag = r.take(1)[0]
            if flag == 0:
                return None
            if flag == 1:
                return self.read(t[1], r)
            raise WireError("malformed", f"option tag {flag}")
        if tag == "array":
            return [self.read(t[1], r) for _ in range(t[2])]
        if tag == "vec":
            n = r.varint(64)
            if n > t[2]:
                raise WireError("malformed", f"{n} elements, at most {t[2]}")
            return [self.read(t[1], r) for _ in range(n)]
        if tag == "tuple":
            return [self.read(x, r) for x in t[1]]
        return self.read_container(t[1], r)

    def read_prim(self, name, r):
        if name == "()":
            return None
        if name == "bool":
            b = r.take(1)[0]
            if b > 1:
                raise WireError("malformed", f"bool {b}")
            return b == 1
        if name == "u8":
            return r.take(1)[0]
        if name == "i8":
            return struct.unpack("<b", r.take(1))[0]
        if name in ("u16", "u32", "u64"):
            return r.varint(int(name[1:]))
        if name in ("i16", "i32", "i64"):
            return zigzag_decode(r.varint(int(name[1:])))
        if name == "f32":
            return F32(struct.unpack("<I", r.take(4))[0])
        if name == "f64":
            return struct.unpack("<d", r.take(8))[0]
        raise ValueError(f"unknown primitive {name}")

    def read_container(self, name, r):
        kind, spec = self.layout.containers[name]
        if kind == "struct":
            return {f: self.read(t, r) for f, t in spec}
        if kind == "newtype":
            return self.read(spec[0][1], r)
        if kind == "tuple struct":
            return [self.read(t, r) for _, t in spec]
        if kind == "unit struct":
            return None
        index = r.varint(32)
        if index not in spec:
            raise WireError("malformed", f"{name}: no variant {index}")
        vname, content = spec[index]
        if content is None:
            return vname
        if content[0] == "struct":
            return {vname: {f: self.read(t, r) for f, t in content[1]}}
        return {vname: self.read(content, r)}

    def body(self, letter, data):
        name = self.layout.kinds[letter]
        if name is None:
            if data:
                raise WireError("malformed", "an empty body expected")
            return None
        r = Reader(data)
        value = self.read_container(name, r)
        if r.at != len(data):
            raise WireError("malformed", f"{len(data) - r.at} bytes left over")
        return value

    # Encoding: canonical values to bytes.

    def write(self, t, v, out, at):
        tag = t[0]
        if tag == "prim":
            return self.write_prim(t[1], v, out, at)
        if tag == "str":
            b = v.encode("utf-8")
            if len(b) > t[1]:
                raise WireError("value", f"{at}: {len(b)} bytes, at most {t[1]}")
            put_varint(out, len(b))
            out += b
            return
        if tag == "option":
            if v is None:
                out.append(0)
            else:
                out.append(1)
                self.write(t[1], v, out, at)
            return
        if tag in ("array", "vec", "tuple"):
            items = t[1] if tag == "tuple" else None
            if not isinstance(v, list):
                raise WireError("value", f"{at}: a list expected")
            if tag == "array" and len(v) != t[2]:
                raise WireError("value", f"{at}: {len(v)} elements, {t[2]} expected")
            if tag == "vec":
                if len(v) > t[2]:
                    raise WireError("value", f"{at}: {len(v)} elements, at most {t[2]}")
                put_varint(out, len(v))
            if tag == "tuple" and len(v) != len(items):
                raise WireError("value", f"{at}: {len(v)} elements, {len(items)} expected")
            for k, x in enumerate(v):
                self.write(items[k] if items else t[1], x, out, f"{at}[{k}]")
            return
        self.write_container(t[1], v, out, at)

    def write_prim(self, name, v, out, at):
        if name == "()":
            if v is not None:
                raise WireError("value", f"{at}: null expected")
            return
        if name == "bool":
            if not isinstance(v, bool):
                raise WireError("value", f"{at}: true or false expected")
            out.append(1 if v else 0)
            return
        if name == "f32":
            if isinstance(v, str):
                bits = int(v, 16)
            else:
                try:
                    bits = struct.unpack("<I", struct.pack("<f", float(v)))[0]
                except OverflowError:
                    raise WireError("value", f"{at}: {v} is out of the f32 range") from None
            out += struct.pack("<I", bits)
            return
        if name == "f64":
            out += struct.pack("<d", float(v))
            return
        if not isinstance(v, int) or isinstance(v, bool):
            raise WireError("value", f"{at}: an integer expected")
        bits = int(name[1:])
        if name[0] == "u":
            if not 0 <= v < (1 << bits):
                raise WireError("value", f"{at}: {v} is out of the {name} range")
            if name == "u8":
                out.append(v)
            else:
                put_varint(out, v)
        else:
            if not -(1 << (bits - 1)) <= v < (1 << (bits - 1)):
                raise WireError("value", f"{at}: {v} is out of the {name} range")
            if name == "i8":
                out += struct.pack("<b", v)
            else:
                put_varint(out, zigzag_encode(v, bits))

    def write_container(self, name, v, out, at):
        kind, spec = self.layout.containers[name]
        if kind == "struct":
            if not isinstance(v, dict) or set(v) != {f for f, _ in spec}:
                raise WireError("value", f"{at}: the fields of {name} expected")
            for f, t in spec:
                self.write(t, v[f], out, f"{at}.{f}")
        elif kind == "newtype":
            self.write(spec[0][1], v, out, at)
        elif kind == "tuple struct":
            for k, (_, t) in enumerate(spec):
                self.write(t, v[k], out, f"{at}.{k}")
        elif kind == "enum":
            if isinstance(v, str):
                vname, inner = v, None
            elif isinstance(v, dict) and len(v) == 1:
                (vname, inner), = v.items()
            else:
                raise WireError("value", f"{at}: a variant of {name} expected")
            found = [(i, c) for i, (n, c) in spec.items() if n == vname]
            if not found:
                raise WireError("value", f"{at}: {name} has no variant {vname}")
            index, content = found[0]
            put_varint(out, index)
            if content is None:
                if inner is not None:
                    raise WireError("value", f"{at}: {vname} carries nothing")
            elif content[0] == "struct":
                self.write_container_fields(content[1], inner, out, f"{at}.{vname}")
            else:
                self.write(content, inner, out, f"{at}.{vname}")

    def write_container_fields(self, fields, v, out, at):
        if not isinstance(v, dict) or set(v) != {f for f, _ in fields}:
            raise WireError("value", f"{at}: its fields expected")
        for f, t in fields:
            self.write(t, v[f], out, f"{at}.{f}")


def put_varint(out, v):
    while True:
        b = v & 0x7F
        v >>= 7
        if v == 0:
            out.append(b)
            return
        out.append(b | 0x80)


# ---------------------------------------------------------------------------------------
# Frames.


def decode_frame(layout, codec, enc):
    """One frame's bytes (without its terminating zero) to (letter, body)."""
    if len(enc) > layout.max_frame - 1:
        raise WireError("oversize")
    payload = cobs_decode(enc)
    if len(payload) > layout.max_payload:
        raise WireError("oversize")
    if len(payload) < 6:
        raise WireError("too_short")
    data, crc = payload[:-4], struct.unpack("<I", payload[-4:])[0]
    if crc32c(data) != crc:
        raise WireError("crc")
    if data[0] != layout.version:
        raise WireError("version", f"version {data[0]}, this document's {layout.version}")
    letter = chr(data[1])
    if letter not in layout.kinds:
        raise WireError("kind", f"kind byte 0x{data[1]:02X}")
    return letter, codec.body(letter, data[2:])


def encode_frame(layout, codec, letter, body):
    if letter not in layout.kinds:
        raise WireError("kind", f"no frame kind {letter!r}")
    name = layout.kinds[letter]
    out = bytearray([layout.version, ord(letter)])
    if name is None:
        if body is not None:
            raise WireError("value", f"a {letter} frame's body is empty (null)")
    else:
        codec.write_container(name, body, out, name)
    out += struct.pack("<I", crc32c(out))
    if len(out) > layout.max_payload:
        raise WireError("oversize", f"a payload of {len(out)} bytes")
    return cobs_encode(bytes(out)) + b"\x00"


def canonical(v):
    """The canonical JSON form of a decoded value (an f32 as its bits)."""
    if isinstance(v, F32):
        return f"0x{v.bits:08x}"
    if isinstance(v, dict):
        return {k: canonical(x) for k, x in v.items()}
    if isinstance(v, list):
        return [canonical(x) for x in v]
    return v


def decode_stream(layout, data):
    codec = Codec(layout)
    for segment in data.split(b"\x00")[:-1]:
        if not segment:
            continue  # idle fill
        try:
            letter, body = decode_frame(layout, codec, segment)
            yield {"kind": letter, "body": canonical(body)}
        except WireError as e:
            yield {"error": e.name, "detail": str(e)}


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--doc", type=Path, default=DEFAULT_DOC, help="the interface document")
    p.add_argument("command", choices=["decode", "encode"])
    args = p.parse_args(argv)
    layout = Layout(args.doc.read_text(encoding="utf-8"))
    if args.command == "decode":
        data = sys.stdin.buffer.read()
        for frame in decode_stream(layout, data):
            # Errors print without their detail, so that a reader can compare lines.
            if "error" in frame:
                print(json.dumps({"error": frame["error"]}))
                print(frame["detail"], file=sys.stderr)
            else:
                print(json.dumps(frame, separators=(",", ":")))
    else:
        codec = Codec(layout)
        out = sys.stdout.buffer
        for n, line in enumerate(sys.stdin, 1):
            if not line.strip():
                continue
            m = json.loads(line)
            try:
                out.write(encode_frame(layout, codec, m["kind"], m["body"]))
            except WireError as e:
                sys.exit(f"line {n}: {e}")
        out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
