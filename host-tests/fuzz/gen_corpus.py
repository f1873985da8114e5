#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets: corpus/frame_xml/, corpus/read_paths/ and
corpus/field_input/.

The seeds are the sample messages of the vendor's protocol document (V1.0.12, every Type,
request and response, as printed there, quirks included), plus the variations real traffic
shows (docs/protocol.md, "Beyond the document") and the stream situations the frame
decoder must handle; and for field_input, what the field hands the settings: console
sessions, settings forms and flash blobs (the store's layout, built here by hand too).
Frames are built here by hand, independently of the crate's encoder.

Each frame_xml input is a mode byte, read sizes, then the byte stream (see the comment at
the top of fuzz_targets/frame_xml.rs); each read_paths input is one bare body. Run it from
anywhere:

    python3 host-tests/fuzz/gen_corpus.py

It replaces the files it generated before (seed-* and regress-*) and leaves any other
corpus entries alone.
"""

import struct
from pathlib import Path

OUT = Path(__file__).resolve().parent / "corpus" / "frame_xml"
OUT_BODIES = Path(__file__).resolve().parent / "corpus" / "read_paths"
OUT_FIELD = Path(__file__).resolve().parent / "corpus" / "field_input"
SYNC = b"\xEB\x90\xEB\x90"


def frame(body, message_id=0, reserved=b"\0" * 8, length=None):
    if isinstance(body, str):
        body = body.encode()
    length = len(body) if length is None else length
    return SYNC + struct.pack("<HH", length, message_id) + reserved + body


def doc(type_, command, time, items, decl='<?xml version="1.0" encoding="UTF-8"?>', indent="  "):
    """A document in the vendor's layout; items is None for <Items/>, else (name, text) pairs."""
    lines = [decl] if decl else []
    lines += ["<PatrolDevice>", f"{indent}<Type>{type_}</Type>", f"{indent}<Command>{command}</Command>",
              f"{indent}<Time>{time}</Time>"]
    if items is None:
        lines.append(f"{indent}<Items/>")
    else:
        lines.append(f"{indent}<Items>")
        lines += [f"{indent * 2}<{k}>{v}</{k}>" for k, v in items]
        lines.append(f"{indent}</Items>")
    lines.append("</PatrolDevice>")
    return "\n".join(lines) + "\n"


DQ = '<?xml version="1.0" encoding="UTF-8"?>'
DQ_SPACE = '<?xml version="1.0" encoding="UTF-8" ?>'
SQ = "<?xml version='1.0' encoding='utf-8'?>"
T0 = "2023-01-01 00:00:00"
T1 = "2023-01-01 00:00:01"

STATUS_ITEMS = [("MotionState", "0"), ("PosX", "0.0"), ("PosY", "0.0"), ("PosZ", "0.0"), ("Roll", "0.0"),
                ("Pitch", "0.0"), ("Yaw", "0.0"), ("Speed", "0.0"), ("CurOdom", "0.0"), ("SumOdom", "0.0"),
                ("Res", "0.0"), ("X0", "0.0"), ("Y0", "0.0"), ("H", "1000"), ("Electricity", "50"),
                ("Location", "0"), ("GaitState", "0"), ("MotorState", "0"), ("ChargeState", "0"),
                ("ControlMode", "0"), ("OnDockState", "0")]
NAV_ITEMS = [("Value", "100"), ("MapID", "1"), ("PosX", "0.0"), ("PosY", "0.0"), ("PosZ", "0.0"),
             ("AngleYaw", "0.0"), ("PointInfo", "0"), ("Gait", "0"), ("Speed", "0"), ("Manner", "0"),
             ("ObsMode", "0"), ("NavMode", "0"), ("Terrain", "0"), ("Posture", "0")]
MOTORS = ["LeftFrontSway", "LeftFrontHip", "LeftFrontKnee", "RightFrontSway", "RightFrontHip", "RightFrontKnee",
          "LeftBackSway", "LeftBackHip", "LeftBackKnee", "RightBackSway", "RightBackHip", "RightBackKnee"]

# The vendor document's samples, Type by Type (docs/protocol.md, "Type 0: request error" to
# "Type 2101: relocalisation").
VENDOR = {
    "req-1002-status": doc(1002, 1, T0, None, DQ_SPACE),
    "resp-0000-request-error": doc(0, 0, "0000-00-00 00:00:00", [("ErrorCode", "0")], DQ, "    "),
    "resp-1002-status": doc(1002, 1, T1, STATUS_ITEMS),
    "req-1003-nav-task": doc(1003, 1, T0, NAV_ITEMS, DQ, "    "),
    "resp-1003-nav-result": doc(1003, 1, T1, [("Value", "100"), ("ErrorCode", "0"), ("ErrorStatus", "0")]),
    "req-1004-cancel": doc(1004, 1, T0, None, DQ, "    "),
    "resp-1004-cancel": doc(1004, 1, T1, [("ErrorCode", "0")], DQ, "    "),
    "req-1007-nav-status": doc(1007, 1, T0, None),
    "resp-1007-nav-status": doc(1007, 1, T1, [("Value", "0"), ("Status", "0"), ("ErrorCode", "0")]),
    "req-0002-forward": doc(2, 1, T0, [("Value", "-1")], DQ, "    "),
    "resp-0002-forward": doc(2, 1, T0, [("Value", "-1"), ("ErrorCode", "0")], DQ, "    "),
    "req-2001-battery": doc(2001, 1, T0, None, SQ, "    "),
    "resp-2001-battery": doc(2001, 1, T0, [("Voltage", "82"), ("Current", "653"), ("RemainingCapacity", "1947"),
                                           ("NominalCapacity", "2004"), ("Cycles", "12"), ("ProtectedState", "0"),
                                           ("BatteryLevel", "97"), ("BatteryTemperature", "0")], SQ),
    "req-2002-perception": doc(2002, 1, T0, None, SQ),
    "resp-2002-perception": doc(2002, 1, T0, [("ObsState", "0")], SQ),
    # The document's light sample has non-integer and negative values (not valid:
    # docs/protocol.md, "Type 1101: indicator light").
    "req-1101-light-vendor-sample": doc(1101, 1, T0, [("Red", "0"), ("Green", "3.847"), ("Blue", "-6.127"),
                                                      ("PER", "0.082"), ("LUM", "3.109")], SQ, "    "),
    "req-1101-light": doc(1101, 1, T0, [("Red", "255"), ("Green", "128"), ("Blue", "0"), ("PER", "1"),
                                        ("LUM", "100")], SQ, "    "),
    "resp-1101-light": doc(1101, 1, T0, [("ErrorCode", "0")], SQ, "    "),
    "req-2101-relocalize": doc(2101, 1, T0, [("PosX", "0.0"), ("PosY", "0.0"), ("PosZ", "0.0"), ("Yaw", "0.0")], SQ),
    "resp-2101-relocalize": doc(2101, 1, T0, [("ErrorCode", "0")], SQ),
    "req-1008-motor-temperatures": doc(1008, 1, T0, None, SQ),
    "resp-1008-motor-temperatures": doc(1008, 1, T0, [(m, "0") for m in MOTORS], SQ, "    "),
}

# Other Type 2 commands (docs/protocol.md, "Type 2: motion control"), including the vendor
# extensions 16–22 ("Vendor extensions").
MOTION = {
    "req-0002-switch-gait": doc(2, 20, T0, [("Value", "4")]),
    "resp-0002-switch-gait": doc(2, 20, T0, [("Value", "4"), ("ErrorCode", "0")]),
    "req-0002-turn-left": doc(2, 3, T0, [("Value", "0.35")]),
    "req-0002-body-height": doc(2, 19, T0, [("Value", "-0.05")]),
    "req-0002-go-charging": doc(2, 21, T0, [("Value", "-1")]),
}

# What real robots and clients send (docs/protocol.md, "Beyond the document").
REAL = {
    "resp-1002-status-extra-items": doc(1002, 1, "2024-11-19 10:42:07", [
        ("MotionState", "4"), ("PosX", "12.345678"), ("PosY", "-3.0712891"), ("PosZ", "0.21"),
        ("Roll", "-0.00023393621"), ("Pitch", "0.0123"), ("Yaw", "1.5707964"), ("AngleYaw", "1.5707964"),
        ("Speed", "0.5"), ("CurOdom", "0.731"), ("SumOdom", "1287.5"), ("CurRuntime", "3600"),
        ("SumRuntime", "987654"), ("Res", "0.05"), ("X0", "-25.6"), ("Y0", "-12.8"), ("H", "1024"),
        ("Electricity", "87"), ("Location", "0"), ("RTKState", "4"), ("GaitState", "6"),
        ("MapUpdateState", "0"), ("MotorState", "0"), ("ChargeState", "0"), ("ControlMode", "1"),
        ("OnDockState", "0")]),
    # A robot that does not know its pose prints C's words for NaN and infinity.
    "resp-1002-status-unknown-pose": doc(1002, 1, "2024-11-19 10:42:07", [
        ("MotionState", "1"), ("PosX", "nan"), ("PosY", "-nan"), ("PosZ", "inf"), ("Roll", "-inf"),
        ("Pitch", "NaN"), ("Yaw", "Infinity"), ("Speed", "0"), ("CurOdom", "0"), ("SumOdom", "1287.5"),
        ("Res", "0.05"), ("X0", "-25.6"), ("Y0", "-12.8"), ("H", "1024"), ("Electricity", "87"),
        ("Location", "1"), ("GaitState", "0"), ("MotorState", "0"), ("ChargeState", "0"),
        ("ControlMode", "1"), ("OnDockState", "0")]),
    # A robot that reports less than the document lists: MotionState alone.
    "resp-1002-status-sparse": doc(1002, 1, "2024-11-19 10:42:07", [("MotionState", "6")]),
    # A robot under a locale with a decimal comma, and other readings that cannot be read:
    # each optional item counts as left out.
    "resp-1002-status-unreadable": doc(1002, 1, "2024-11-19 10:42:07", [
        ("MotionState", "6"), ("PosX", "12,345678"), ("PosY", "-nan(ind)"), ("PosZ", ""),
        ("H", "4294967295"), ("Electricity", "87"), ("GaitState", "0x1")]),
    "req-1003-two-blocks-mapid": (
        DQ + "\n<PatrolDevice>\n  <Type>1003</Type>\n  <Command>1</Command>\n  <Time>2024-11-19 10:42:07</Time>\n"
        + "".join("  <Items>\n" + "".join(f"    <{k}>{v}</{k}>\n" for k, v in items) + "  </Items>\n"
                  for items in (
                      [("Value", "1"), ("MapId", "2"), ("PosX", "1.5"), ("PosY", "-2.25"), ("PosZ", "0"),
                       ("AngleYaw", "3.1415927"), ("PointInfo", "0"), ("Gait", "0"), ("Speed", "1"),
                       ("Manner", "0"), ("ObsMode", "0"), ("NavMode", "1"), ("Terrain", "0")],
                      [("Value", "2"), ("MapId", "2"), ("PosX", "7.125"), ("PosY", "0.5"), ("PosZ", "0"),
                       ("AngleYaw", "-1.5707964"), ("PointInfo", "1"), ("Gait", "6"), ("Speed", "0"),
                       ("Manner", "1"), ("ObsMode", "1"), ("NavMode", "0"), ("Terrain", "3"), ("Posture", "0")],
                  ))
        + "</PatrolDevice>\n"),
    "req-2101-tabs-no-declaration-comment": (
        "<PatrolDevice>\n\t<Type>2101</Type>\n\t<Command>1</Command>\n\t<Time>2024-11-19 10:42:07</Time>\n"
        "\t<Items>\n\t\t<!-- pose from the operator's map click -->\n\t\t<PosX>1.25</PosX>\n\t\t<PosY>-0.5</PosY>\n"
        "\t\t<PosZ>0</PosZ>\n\t\t<Yaw>0.785</Yaw>\n\t</Items>\n</PatrolDevice>\n"),
    "req-0002-compact-single-quotes": (
        "<?xml version='1.0' encoding='utf-8'?><PatrolDevice><Items><Value>0.5</Value></Items>"
        "<Time>2024-11-19 10:42:07</Time><Command>1</Command><Type>2</Type></PatrolDevice>"),
    "resp-1003-old-robot-no-errorstatus": doc(1003, 1, T1, [("Value", "100"), ("ErrorCode", "2")]),
    "resp-2001-battery-crlf-bom": "\ufeff" + doc(2001, 1, T0, [
        ("Voltage", "54"), ("Current", "-1200"), ("RemainingCapacity", "1500"), ("NominalCapacity", "2004"),
        ("Cycles", "140"), ("ProtectedState", "1"), ("BatteryLevel", "74"),
        ("BatteryTemperature", "31.5")]).replace("\n", "\r\n"),
    # Number forms a peer may send (up to 8-9 significant digits, exponents, signs:
    # docs/protocol.md, "Numbers, times and codes" and "Extra items").
    "req-2101-number-forms": doc(2101, 1, T0, [("PosX", "1.5e3"), ("PosY", "-2.5E-4"), ("PosZ", "+0.0"),
                                               ("Yaw", " 7e+0 ")]),
    "resp-1008-long-floats": doc(1008, 1, T0, list(zip(MOTORS, [
        "-0.00023393621", "0.000000000000000000000000000000000000000000001", "340282350000000000000000000000000000000",
        "36.600002", "1e-45", "3.4028235e38", "-0", ".5", "5.", "0.1000000000000000055511151231257827",
        "16777217", "-1.17549435e-38"]))),
    "resp-1002-unavailable-entities": doc(1002, 1, T1, STATUS_ITEMS).replace(
        "<Items>", '<Items note="&quot;x&#33;&amp;">'),
}


def seeds():
    one_read = b"\x00"
    for name, body in {**VENDOR, **MOTION, **REAL}.items():
        yield name, one_read + frame(body, message_id=7)

    status = frame(VENDOR["req-1002-status"], 1)
    answer = frame(VENDOR["resp-1002-status"], 1)
    nav = frame(VENDOR["req-1003-nav-task"], 2)
    yield "stream-two-frames-merged", one_read + status + answer
    # Read sizes 7, 1, 64 in turn, through feed(); then the same through spare()/commit().
    yield "stream-two-frames-small-reads", b"\x03\x06\x00\x3f" + answer + nav
    yield "stream-two-frames-spare-commit", b"\x0b\x06\x00\x3f" + status + nav
    yield "stream-garbage-then-frame", one_read + b"GET / HTTP/1.1\r\n\xeb\x90\xeb\x00\xeb" + answer
    yield "stream-oversized-then-frame", one_read + frame(b"x" * 2100, 3) + status
    yield "stream-declared-too-long-then-frame", one_read + SYNC + struct.pack("<HH", 65535, 4) + b"\0" * 8 + status
    yield "stream-bad-reserved-then-frame", one_read + frame(VENDOR["req-1004-cancel"], 5, reserved=b"\0\0\0\x01\0\0\0\0") + status
    # Mode bit 4: a client's decoder, which reads frames whose reserved bytes are set; the
    # second follows half a sync sequence, read 5 bytes at a time.
    set_bytes = b"\xeb\x90\xeb\x90\x01\xff\x00\x80"
    yield "stream-reserved-ignored", b"\x11\x04" + frame(VENDOR["resp-1002-status"], 1, reserved=set_bytes) + b"\xeb\x90" + frame(VENDOR["req-1004-cancel"], 5, reserved=set_bytes)
    yield "stream-truncated-frame", one_read + answer[: len(answer) // 2]
    yield "stream-empty-body", one_read + frame(b"", 9) + status


# Minimised crash inputs the fuzzer found, kept so every run replays them first.
REGRESSIONS = {
    # number.rs scan_exponent: `value * 10 + d` overflows i32 for an exponent of ten or more
    # digits (the saturation to EXPONENT_CAP comes after the arithmetic): "attempt to add with
    # overflow" at src/proto/xml/number.rs (scan_exponent). The fuzzer's own find was
    # "0.0000000000000000000000!DOCTYPE000004000000001", split at the E of DOCTYPE.
    "number-exponent-overflow": "<PatrolDevice><Type>2</Type><Command>1</Command>"
                                "<Items><Value>1e2147483648</Value></Items></PatrolDevice>",
}


def blob(entries):
    """A settings blob: magic, layout version 1, then (key id, value) entries."""
    out = b"X30S\x01"
    for key_id, value in entries:
        value = value.encode()
        out += bytes([key_id, len(value)]) + value
    return out


# field_input: the first byte is the way in (0 flash, 1 console, 2 form); a console input
# then has the robot's pose (four little-endian f32s: x, y, z, yaw).
POSE = struct.pack("<4f", 1.5, -2.0, 0.1, 0.5)
FIELD = {
    "flash-every-kind": b"\x00" + blob([
        (1, "10.0.0.2:30001"), (2, "0"), (3, "192.168.1.50/24"), (4, "192.168.1.1"),
        (5, "0.8"), (7, "default"), (11, "0000FF:20,FF0000:100:breathing"),
        (12, "1,1,2.5,-1,0,1.5707964"), (13, "250"), (17, "300"), (19, "nc"), (20, "1234"),
        (64, "1,1,0,0,0,0,task"), (64, "2,1,3.5,-1.25,0,1.57,transition")]),
    "flash-unknown-and-invalid": b"\x00" + blob([(99, "x"), (5, "9"), (18, "0")]),
    "console-session": b"\x01" + POSE + (
        "help\r\nshow\r\nset speed-forward 0.8\r\nset lights 00FF00:50,FF0000:100:breathing\r\n"
        "dock here 1 3\r\nroute add here task\r\nroute add 3.5 -1.25 0 1.57 transition\r\n"
        "route show\r\nset dhcp 0\r\nset ip 10.0.0.9/24\r\nsave\r\nunset speed-forward\r\n"
        "route clear\r\nstatus\r\nset robot 10.0.0.2\r\nsave\r\n").encode(),
    "console-editing": b"\x01" + POSE + b"set rep\x7feat-ms 3\x08300\x1b[A\x1b[D\r\nsave\n",
    "form-speeds": b"\x02" + b"speed-forward=0.8&speed-backward=&repeat-ms=300&lights=00FF00%3A50",
    "form-dock-escaped": b"\x02" + b"dock=1%2C1%2C2.5%2C-1%2C0%2C1.5707964&web-pin=****&robot=10.0.0.2%3A30000",
}


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    for old in [*OUT.glob("seed-*"), *OUT.glob("regress-*")]:
        old.unlink()
    count = 0
    for name, data in seeds():
        (OUT / f"seed-{name}").write_bytes(data)
        count += 1
    for name, body in REGRESSIONS.items():
        (OUT / f"regress-{name}").write_bytes(b"\x00" + frame(body))
        count += 1
    print(f"wrote {count} inputs to {OUT}")
    OUT_BODIES.mkdir(parents=True, exist_ok=True)
    for old in [*OUT_BODIES.glob("seed-*"), *OUT_BODIES.glob("regress-*")]:
        old.unlink()
    bodies = {**VENDOR, **MOTION, **REAL}
    for name, body in bodies.items():
        (OUT_BODIES / f"seed-{name}").write_bytes(body.encode() if isinstance(body, str) else body)
    for name, body in REGRESSIONS.items():
        (OUT_BODIES / f"regress-{name}").write_bytes(body.encode())
    print(f"wrote {len(bodies) + len(REGRESSIONS)} inputs to {OUT_BODIES}")
    OUT_FIELD.mkdir(parents=True, exist_ok=True)
    for old in OUT_FIELD.glob("seed-*"):
        old.unlink()
    for name, data in FIELD.items():
        (OUT_FIELD / f"seed-{name}").write_bytes(data)
    print(f"wrote {len(FIELD)} inputs to {OUT_FIELD}")


if __name__ == "__main__":
    main()
