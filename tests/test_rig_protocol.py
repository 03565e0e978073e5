"""The rig's wire protocols as pure functions: round trips, hand-made bytes, hostile bytes."""

import binascii

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from refsynth.acquisition.errors import ProtocolError
from refsynth.acquisition.pan_protocol import (
    PanReply,
    encode_pan_command,
    format_pan_error,
    format_pan_reply,
    pan_reply_kind,
    parse_pan_command,
    parse_pan_reply,
)
from refsynth.acquisition.rangefinder_protocol import (
    LINE_WIDTH,
    STATUS,
    crc16,
    decode_samples,
    encode_rangefinder_command,
    encode_rangefinder_reply,
    encode_samples,
    parse_rangefinder_command,
    parse_rangefinder_reply,
    rangefinder_reply_length,
)

# ----------------------------------------------------------------------------- strategies


@st.composite
def slice_samples(draw, max_count: int = 40):
    """A GS request and the samples of its reply (short, so that shrinking stays readable)."""
    count = draw(st.integers(1, max_count))
    seq = draw(st.integers(0, 2000 - count))
    average = draw(st.integers(1, 99))
    tag = draw(st.none() | st.text("0123456789ABCDEFabcxyz", min_size=1, max_size=16))
    range_mm = np.array(draw(st.lists(st.integers(0, 0xFFFF), min_size=count, max_size=count)))
    amplitude = np.array(draw(st.lists(st.integers(0, 0xFF), min_size=count, max_size=count)))
    command = encode_rangefinder_command("GS", seq=seq, count=count, average=average, tag=tag)
    return command, range_mm, amplitude


def valid_gs_reply(command, range_mm, amplitude) -> bytes:
    """The device's reply to a GS command."""
    return encode_rangefinder_reply(command, 0, encode_samples(range_mm, amplitude))


# ----------------------------------------------------------------------------- CRC and samples


def test_crc16_is_ccitt_false():
    assert crc16(b"123456789") == 0x29B1  # the catalogued check value of CRC-16/CCITT-FALSE
    assert crc16(b"") == 0xFFFF
    assert crc16(b"abc") == binascii.crc_hqx(b"abc", 0xFFFF)


def test_samples_by_hand():
    payload = encode_samples(np.array([3898, 0, 65535]), np.array([124, 0, 255]))
    assert payload == b"0F3A7C000000FFFFFF"
    range_mm, amplitude = decode_samples(payload, 3)
    assert range_mm.dtype == np.uint16 and amplitude.dtype == np.uint8
    assert range_mm.tolist() == [3898, 0, 65535] and amplitude.tolist() == [124, 0, 255]


@given(slice_samples())
def test_samples_round_trip(case):
    _, range_mm, amplitude = case
    got_range, got_amplitude = decode_samples(encode_samples(range_mm, amplitude), len(range_mm))
    np.testing.assert_array_equal(got_range, range_mm)
    np.testing.assert_array_equal(got_amplitude, amplitude)


@pytest.mark.parametrize(
    ("payload", "count", "match"),
    [(b"0F3A7C", 2, "expected 2 samples"), (b"0f3a7c", 1, "upper-case hex"),
     (b"0F3A7G", 1, "upper-case hex")],
)
def test_decode_samples_rejects(payload, count, match):
    with pytest.raises(ProtocolError, match=match):
        decode_samples(payload, count)


@pytest.mark.parametrize(
    ("range_mm", "amplitude"),
    [([70000], [1]), ([1], [256]), ([-1], [0]), ([1.5], [0]), ([1, 2], [1])],
)
def test_encode_samples_rejects(range_mm, amplitude):
    with pytest.raises(ValueError):
        encode_samples(np.array(range_mm), np.array(amplitude))


# ----------------------------------------------------------------------------- pan unit


def test_pan_commands_by_hand():
    assert encode_pan_command("PP", 250) == b"PP250 "
    assert encode_pan_command("PP") == b"PP "
    assert encode_pan_command("PS", 1000) == b"PS1000 "
    assert encode_pan_command("C") == b"C "
    assert parse_pan_command(b"PP250") == ("PP", 250)
    assert parse_pan_command(b"A") == ("A", None)
    for bad in (b"XX", b"A5", b"PP12a", b"", b"pp1"):
        with pytest.raises(ProtocolError):
            parse_pan_command(bad)
    with pytest.raises(ValueError, match="takes no argument"):
        encode_pan_command("A", 3)
    with pytest.raises(ValueError, match="must be one of"):
        encode_pan_command("ZZ")
    with pytest.raises(TypeError):
        encode_pan_command("PP", 2.5)


@given(st.sampled_from(["PR", "PN", "PX", "PP", "PS", "A", "R", "V", "C"]),
       st.integers(-999_999, 999_999))
def test_pan_command_round_trip(name, value):
    takes = name in ("PP", "PS")
    command = encode_pan_command(name, value if takes else None)
    assert command.endswith(b" ")
    assert parse_pan_command(command[:-1]) == (name, value if takes else None)


def test_pan_reply_kinds():
    assert pan_reply_kind("PR") == "float"
    assert pan_reply_kind("V") == "text"
    assert [pan_reply_kind(n) for n in ("PN", "PX", "C", "PP", "PS")] == ["int"] * 5
    assert pan_reply_kind("PP", 3) == pan_reply_kind("PS", 3) == pan_reply_kind("A") == "none"


@pytest.mark.parametrize(
    ("raw", "kind", "expected"),
    [
        (b"*\r\n", "none", PanReply(True)),
        (b"* 250\r\n", "int", PanReply(True, 250)),
        (b"* -3\r\n", "int", PanReply(True, -3)),
        (b"* 1296.0000\r\n", "float", PanReply(True, 1296.0)),
        (b"* refsynth pan 1.0\r\n", "text", PanReply(True, "refsynth pan 1.0")),
        (b"! Maximum allowable pan position exceeded\r\n", "none",
         PanReply(False, message="Maximum allowable pan position exceeded")),
    ],
)
def test_pan_replies_by_hand(raw, kind, expected):
    assert parse_pan_reply(raw, kind) == expected


@pytest.mark.parametrize(
    ("raw", "kind"),
    [(b"* 250\r\n", "none"), (b"*\r\n", "int"), (b"* 25x\r\n", "int"), (b"* 250\n", "int"),
     (b"*\r", "none"), (b"!\r\n", "none"), (b"* 12\r\n", "float"), (b"xx*\r\n", "none"),
     (b"", "none"), (b"*\r\n*\r\n", "none")],
)
def test_pan_reply_rejects(raw, kind):
    with pytest.raises(ProtocolError):
        parse_pan_reply(raw, kind)


@given(st.one_of(st.none(), st.integers(0, 99999), st.floats(0, 1e5, allow_nan=False),
                 st.text("abcXYZ019 .-", min_size=1, max_size=40).filter(lambda t: t[0] != " ")))
def test_pan_reply_round_trip(value):
    if value is None:
        kind = "none"
    elif isinstance(value, float):
        kind, value = "float", round(value, 4)
    elif isinstance(value, int):
        kind = "int"
    else:
        kind = "text"
    reply = parse_pan_reply(format_pan_reply(value), kind)
    assert reply.ok and reply.value == value


@settings(deadline=None)
@given(st.binary(max_size=80), st.sampled_from(["none", "int", "float", "text"]))
def test_pan_reply_parser_never_crashes(raw, kind):
    try:
        reply = parse_pan_reply(raw, kind)
    except ProtocolError:
        return
    assert raw.endswith(b"\r\n")
    assert isinstance(reply, PanReply)


def test_pan_error_replies_are_reported():
    reply = parse_pan_reply(format_pan_error("Illegal command"), "int")
    assert not reply.ok and reply.message == "Illegal command"


def test_every_single_byte_corruption_of_a_bare_pan_ack_is_rejected_or_an_error():
    # the pan protocol has no checksum: only replies without a value can be fully checked
    for raw in (b"*\r\n", format_pan_error("Busy")):
        for position in range(len(raw)):
            for byte in range(256):
                if byte == raw[position]:
                    continue
                corrupt = bytearray(raw)
                corrupt[position] = byte
                try:
                    reply = parse_pan_reply(bytes(corrupt), "none")
                except ProtocolError:
                    continue
                assert not reply.ok


# ----------------------------------------------------------------------------- rangefinder


def test_rangefinder_commands_by_hand():
    assert encode_rangefinder_command("GS", seq=379, count=243, average=10) == b"GS0379024310\n"
    assert encode_rangefinder_command("BM", tag="7") == b"BM;7\n"
    assert parse_rangefinder_command(b"GS0379024310;002A").tag == "002A"
    assert parse_rangefinder_command(b"VV").name == "VV"
    for bad in (b"GS037902431", b"GS0379024310;", b"XX", b"BM;a-b", b"GS0379024310;" + b"1" * 17):
        with pytest.raises(ProtocolError):
            parse_rangefinder_command(bad)


@pytest.mark.parametrize(
    ("kwargs", "error"),
    [({"seq": 1999, "count": 2, "average": 1}, ValueError),
     ({"seq": 0, "count": 0, "average": 1}, ValueError),
     ({"seq": 0, "count": 1, "average": 100}, ValueError),
     ({"seq": 0.5, "count": 1, "average": 1}, TypeError),
     ({"seq": 0, "count": 1, "average": 1, "tag": "a;b"}, ValueError)],
)
def test_rangefinder_command_validation(kwargs, error):
    with pytest.raises(error):
        encode_rangefinder_command("GS", **kwargs)


def test_rangefinder_reply_by_hand():
    command = encode_rangefinder_command("GS", seq=500, count=2, average=10, tag="1")
    payload = encode_samples(np.array([3898, 0]), np.array([124, 0]))
    block = payload + b"\n"
    reply = encode_rangefinder_reply(command, 0, payload)
    crc = f"{crc16(block):04X}".encode()
    assert reply == b"GS0500000210;1\n00\n0F3A7C000000\n=" + crc + b"\n\n"
    assert len(reply) == rangefinder_reply_length(command)
    parsed = parse_rangefinder_reply(reply, command)
    assert parsed.ok and parsed.payload == payload
    assert encode_rangefinder_reply(b"BM\n") == b"BM\n00\n=FFFF\n\n"
    error = parse_rangefinder_reply(encode_rangefinder_reply(command, 2), command)
    assert error.status == 2 and not error.ok and error.lines == ()


@settings(deadline=None)
@given(slice_samples(max_count=200))
def test_gs_reply_round_trip(case):
    command, range_mm, amplitude = case
    raw = valid_gs_reply(command, range_mm, amplitude)
    assert len(raw) == rangefinder_reply_length(command)
    reply = parse_rangefinder_reply(raw, command)
    lines = reply.lines
    assert all(len(line) == LINE_WIDTH for line in lines[:-1]) and 1 <= len(lines[-1]) <= 64
    got_range, got_amplitude = decode_samples(reply.payload, len(range_mm))
    np.testing.assert_array_equal(got_range, range_mm)
    np.testing.assert_array_equal(got_amplitude, amplitude)


@pytest.mark.parametrize("status", sorted(set(STATUS) - {0}))
def test_error_status_round_trip(status):
    command = b"GS0379024310;5\n"
    assert parse_rangefinder_reply(encode_rangefinder_reply(command, status), command).status \
        == status


@settings(deadline=None)
@given(st.binary(max_size=300))
@example(b"GS0000000101\n00\n\n")
@example(b"GS0000000101\n00\n=FFFF\n\n")
@example(b"GS0000000101\n09\n\n")
@example(b"GS0000000101\n00\n000000\n=1234\n\n")
def test_rangefinder_parser_never_crashes_on_arbitrary_bytes(raw):
    command = b"GS0000000101\n"
    try:
        reply = parse_rangefinder_reply(raw, command)
    except ProtocolError:
        return
    # whatever it accepts is a well-formed reply to this command
    assert raw.startswith(b"GS0000000101\n") and raw.endswith(b"\n\n")
    if reply.ok:
        decode_samples(reply.payload, 1)


@settings(deadline=None)
@given(slice_samples(), st.data())
def test_a_single_corrupted_byte_never_yields_different_data(case, data):
    command, range_mm, amplitude = case
    raw = valid_gs_reply(command, range_mm, amplitude)
    position = data.draw(st.integers(0, len(raw) - 1))
    byte = data.draw(st.integers(0, 255).filter(lambda b: b != raw[position]))
    corrupt = bytearray(raw)
    corrupt[position] = byte
    try:
        reply = parse_rangefinder_reply(bytes(corrupt), command)
    except ProtocolError:
        return
    assert not reply.ok  # reported as an error, never as data


def test_every_single_byte_corruption_of_a_gs_reply_is_rejected_or_an_error():
    # exhaustive over positions and values for a reply of 15 samples (two data lines)
    command = encode_rangefinder_command("GS", seq=379, count=15, average=10, tag="00A1")
    rng = np.random.default_rng(0)
    raw = valid_gs_reply(command, rng.integers(0, 0xFFFF, 15), rng.integers(0, 0xFF, 15))
    accepted = 0
    for position in range(len(raw)):
        for byte in range(256):
            if byte == raw[position]:
                continue
            corrupt = bytearray(raw)
            corrupt[position] = byte
            try:
                reply = parse_rangefinder_reply(bytes(corrupt), command)
            except ProtocolError:
                continue
            accepted += reply.ok
    assert accepted == 0


@pytest.mark.parametrize(
    ("mutate", "match"),
    [
        (lambda r: r.replace(b"GS0379000510", b"GS0379000511", 1), "wrong echo"),
        (lambda r: r[:-1], "blank line"),
        (lambda r: r.replace(b"\n00\n", b"\n0X\n", 1), "status"),
        (lambda r: r.replace(b"\n00\n", b"\n01\n", 1), "with data"),
        (lambda r: r.replace(b"\n00\n", b"\n77\n", 1), "unknown status"),
        (lambda r: r[:-7] + b"=0000\n\n", "CRC"),
        (lambda r: r.replace(b"\n=", b"\n\n=", 1), "empty line"),
    ],
)
def test_rangefinder_rejections_say_why(mutate, match):
    command = encode_rangefinder_command("GS", seq=379, count=5, average=10)
    raw = valid_gs_reply(command, np.arange(5) * 1000, np.arange(5))
    with pytest.raises(ProtocolError, match=match):
        parse_rangefinder_reply(mutate(raw), command)


def test_gs_reply_of_the_wrong_length_is_rejected():
    command = encode_rangefinder_command("GS", seq=379, count=5, average=10)
    other = encode_rangefinder_command("GS", seq=379, count=4, average=10)
    raw = valid_gs_reply(other, np.arange(4), np.arange(4)).replace(other[:-1], command[:-1])
    with pytest.raises(ProtocolError, match="expected 5 samples"):
        parse_rangefinder_reply(raw, command)
    # a line split that is valid framing but not 64-wide is rejected too
    lines = [b"0" * 30, b"0" * 30]
    with pytest.raises(ProtocolError, match="64 characters"):
        parse_rangefinder_reply(encode_rangefinder_reply(command, 0, lines), command)
