"""Solutions to the exercises of tutorial 4 (acquisition: the rig and its protocols).

Run as ``python tutorials/solutions/04_acquisition.py``; the test suite runs
it too. Each exercise prints its numbers and asserts the claims its answer
makes, so a change in refsynth that breaks an answer fails a test.
"""

import binascii

import numpy as np

from refsynth.acquisition import ProtocolError, RoomRig, ScanSettings, plan_slices
from refsynth.acquisition.geometry import PAN_SLICES, SLICE_COUNT, SLICE_START
from refsynth.acquisition.rangefinder_protocol import (
    crc16,
    encode_rangefinder_command,
    encode_rangefinder_reply,
    encode_samples,
    parse_rangefinder_reply,
)


def a_reply():
    """The tutorial's request and reply: three positions straight ahead."""
    rig = RoomRig(seed=0)
    command = encode_rangefinder_command("GS", seq=499, count=3, average=10, tag="0001")
    range_mm, amplitude = rig.measure(250, 499, 3, 10)
    return command, encode_rangefinder_reply(command, 0, encode_samples(range_mm, amplitude))


def exercise_1() -> None:
    """Every single-byte corruption is rejected.

    Each of the reply's bytes is replaced by each of the 255 other values
    and parsed: none is accepted. A corrupted echo fails the echo check, a
    corrupted status line the status check, a corrupted data or CRC line the
    CRC (CRC-16 detects every error confined to 16 consecutive bits), and a
    corrupted newline breaks the framing or the line lengths.
    """
    command, reply = a_reply()
    accepted = tried = 0
    for position in range(len(reply)):
        for value in range(256):
            if value == reply[position]:
                continue
            broken = bytearray(reply)
            broken[position] = value
            tried += 1
            try:
                parse_rangefinder_reply(bytes(broken), command)
                accepted += 1
            except ProtocolError:
                pass
    print(f"1. {tried} single-byte corruptions of a {len(reply)}-byte reply: {accepted} accepted")
    assert tried == 255 * len(reply) and accepted == 0


def crc16_by_hand(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT (polynomial 0x1021, most significant bit first), bit by bit."""
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
            crc &= 0xFFFF
    return crc


def exercise_2() -> None:
    """The CRC by hand.

    Eight shifts per byte, XOR-ing in the polynomial 0x1021 whenever a 1
    falls off the top, starting from 0xFFFF: the same number as
    ``binascii.crc_hqx(data, 0xFFFF)`` and the driver's ``crc16``. Swapping
    two characters of the data line changes the CRC, though the characters
    are the same: the CRC depends on their order, not only their sum.
    """
    _, reply = a_reply()
    data_line = reply.split(b"\n")[2] + b"\n"
    mine, theirs = crc16_by_hand(data_line), crc16(data_line)
    swapped = data_line[1:2] + data_line[0:1] + data_line[2:]
    print(f"2. data line {data_line!r}: CRC by hand {mine:04X}, refsynth {theirs:04X}, "
          f"binascii {binascii.crc_hqx(data_line, 0xFFFF):04X}; first two characters "
          f"swapped: {crc16_by_hand(swapped):04X}")
    assert mine == theirs == binascii.crc_hqx(data_line, 0xFFFF)
    assert crc16_by_hand(swapped) != mine


def exercise_3() -> None:
    """Where does Fig. 2's rule spend its slices?

    With each slice's median true range as the coarse pass, the
    distance-driven plan at 40 % takes a larger share of the slices where
    the room is far than where it is near: the far half of the slices (by
    distance) gets more of them than the near half.
    """
    rig = RoomRig(seed=0)
    coarse = np.array([np.nanmedian(rig.truth(i, SLICE_START, SLICE_COUNT))
                       for i in range(PAN_SLICES)])
    plan = plan_slices(ScanSettings("distance", fraction=0.4), coarse)
    taken = np.zeros(PAN_SLICES, dtype=bool)
    taken[plan] = True
    far = coarse > np.median(coarse)
    print(f"3. {len(plan)} slices; where the room is far (median range > "
          f"{np.median(coarse):.2f} m): {taken[far].sum()} of {far.sum()}; where near: "
          f"{taken[~far].sum()} of {(~far).sum()}")
    assert taken[far].sum() > taken[~far].sum()


if __name__ == "__main__":
    exercise_1()
    exercise_2()
    exercise_3()
