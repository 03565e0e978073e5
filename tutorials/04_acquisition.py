# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # Tutorial 4 — acquiring partial range: the rig, its protocols, scans that lose nothing
#
# Torres-Méndez & Dudek (IJCV 2008), §3.1 and §4.
#
# The paper's robot carries a laser rangefinder (a 45° mirror spinning on a
# 2000-position encoder sweeps one vertical *slice*; each slice the mean of 10
# samples) on a pan unit that turns through 180° in steps of 0.36° — 500 slices —
# and a camera on the same unit that takes a picture every 18°. A complete scan
# took about 20 minutes, so the robot measures only **30–50 % of the slices**,
# chosen by a sampling strategy (§3.1.1, Fig. 2), and synthesizes the rest.
#
# `refsynth.acquisition` holds a serial driver for both devices, a simulator that
# speaks the same protocols on pseudo-terminals, and scans that survive
# corrupted replies, lost replies and unplugged cables. This tutorial shows
# the protocol on the wire, runs a simulated scan with faults, and looks at
# the partial range it produced. The protocol page is
# `refsynth/acquisition/PROTOCOL.md`.
#
# **Before this tutorial**: tutorial 0 (samplings: why the robot measures
# only some slices); bytes and strings in Python; what a serial port is (a
# pipe of bytes with no message boundaries).
#
# **After it** you can read a request and a reply of the rangefinder's
# protocol byte by byte and check its CRC, say why a corrupted reply can
# never be taken for data, drive the simulated rig with pyserial, run a scan
# with faults and interruptions and check that nothing was lost, and turn
# the scan into the partial range and pictures that tutorial 3 registers.
#
# Open this file as a notebook, build it with
# `python -m refsynth notebooks --out notebooks --only 04`, or run it as
# plain Python (`python tutorials/04_acquisition.py`); figures go to
# `tutorial-output/` (or `$REFSYNTH_TUTORIAL_OUT`), the scan folders to
# `04_scans/` beside them. It needs pseudo-terminals (Linux, macOS).

# %%
import shutil
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import serial
from _course import OUT, save

from refsynth.acquisition import (
    PanUnit,
    ProtocolError,
    Rangefinder,
    RigSimulator,
    RoomRig,
    ScanSettings,
    load_scan,
    run_scan,
)
from refsynth.acquisition.geometry import (
    FOCAL_PX,
    IMAGE_HEIGHT,
    IMAGE_WIDTH,
    PAN_SLICES,
    SLICE_COUNT,
    SLICE_START,
    camera_indices,
    pan_angle,
    polar_angle,
)
from refsynth.acquisition.rangefinder_protocol import (
    crc16,
    encode_rangefinder_command,
    encode_rangefinder_reply,
    encode_samples,
    parse_rangefinder_reply,
)

WORK = OUT / "04_scans"  # the scan folders, to look at afterwards
shutil.rmtree(WORK, ignore_errors=True)  # a new run starts new scans
SEED = 0


def hexdump(data: bytes, width: int = 16) -> str:
    lines = []
    for start in range(0, len(data), width):
        chunk = data[start : start + width]
        text = "".join(chr(b) if 32 <= b < 127 else "." for b in chunk)
        lines.append(f"  {start:04x}  {chunk.hex(' '):<{3 * width}} {text}")
    return "\n".join(lines)


# %% [markdown]
# ## 1. Angles
#
# Pan index `i` ↦ `φ = (i − 250) · 0.36°`; encoder position `p` ↦ polar angle
# `θ = p · 0.18°` from the vertical (Eq. 19's θ: 90° is horizontal). Scans
# request positions 379…621 of each slice, which cover the camera's vertical
# field of view: the camera has `f = 300` px (App. A.2) and 128 × 240 pixels,
# so pictures every 18° overlap by 25 % (the paper: 10–30 %).

# %%
print(f"pan: index 0 → {np.degrees(pan_angle(0)):.2f}°, 499 → {np.degrees(pan_angle(499)):.2f}°")
theta = np.degrees(polar_angle([SLICE_START, SLICE_START + SLICE_COUNT - 1]))
print(f"slice: encoder {SLICE_START}…{SLICE_START + SLICE_COUNT - 1} → θ {theta[0]:.2f}°…"
      f"{theta[1]:.2f}°")
fov = np.degrees(2 * np.arctan([IMAGE_WIDTH / 2 / FOCAL_PX, IMAGE_HEIGHT / 2 / FOCAL_PX]))
print(f"camera: {IMAGE_WIDTH}x{IMAGE_HEIGHT} px, f = {FOCAL_PX:g} px, field of view "
      f"{fov[0]:.1f}° x {fov[1]:.1f}°, pictures at pan indices {camera_indices().tolist()}")

# %% [markdown]
# ## 2. The rangefinder's protocol, byte by byte
#
# A request is one line: `GS` + first encoder position (4 digits) + count (4)
# + samples averaged (2), and a tag the device echoes. The reply: the echo, a
# status line (`00` = ok), data lines of at most 64 characters — per sample 4
# hex digits of range in millimetres (0 = no return) and 2 of amplitude — a
# CRC-16 line over the data (`binascii.crc_hqx(data, 0xFFFF)`), a blank line.
# Here is a real slice of three positions straight ahead, as the simulator
# computes it.

# %%
rig = RoomRig(seed=SEED)
command = encode_rangefinder_command("GS", seq=499, count=3, average=10, tag="0001")
range_mm, amplitude = rig.measure(250, 499, 3, 10)
reply = encode_rangefinder_reply(command, 0, encode_samples(range_mm, amplitude))
print("request:")
print(hexdump(command))
print("reply:")
print(hexdump(reply))
data_line = reply.split(b"\n")[2] + b"\n"
print(f"samples: {range_mm.tolist()} mm, amplitudes {amplitude.tolist()}; "
      f"CRC of the data line {crc16(data_line):04X}")
parsed = parse_rangefinder_reply(reply, command)
print(f"parsed: status {parsed.status:02d}, payload {parsed.payload!r}")

# %% [markdown]
# Every single-byte corruption of a valid reply is rejected (the CRC covers
# the data, the echo must match the request, the status line and the lengths
# are checked); the test suite tries all of them. For instance:

# %%
for position, value in [(20, ord("7")), (1, ord("X")), (len(reply) - 1, ord("x"))]:
    broken = bytearray(reply)
    broken[position] = value
    try:
        parse_rangefinder_reply(bytes(broken), command)
        print("accepted?!")
    except ProtocolError as error:
        print(f"byte {position} → {chr(value)!r}: rejected ({error})")

# %% [markdown]
# ## 3. A live exchange over a pseudo-terminal
#
# The simulator serves both devices on pseudo-terminals; any serial program
# can talk to them. The pan unit speaks PTU-style ASCII: `PP<n>` moves
# (absolutely), `A` waits for the move, `PP` asks where it is, `C` takes a
# picture. Here with plain pyserial:

# %%
with RigSimulator(seed=SEED, camera_dir=WORK / "demo-images") as sim:
    with serial.serial_for_url(sim.pan_port, timeout=1) as port:
        for request in (b"PR ", b"PP125 ", b"A ", b"PP ", b"C ", b"PP600 "):
            port.write(request)
            answer = port.read_until(b"\n")
            print(f"  {request!r:>10} → {answer!r}")
    with serial.serial_for_url(sim.laser_port, timeout=1) as port:
        for request in (b"GS0379000310;1\n", b"BM;2\n", b"GS0379000310;3\n"):
            port.write(request)
            answer = port.read_until(b"\n\n")
            print(f"  {request!r:>22} → {answer!r}")

# %% [markdown]
# ## 4. A scan with faults
#
# `run_scan` drives the two devices through a plan of slices. The simulator
# corrupts 5 % of its replies (a flipped byte, garbage before the reply, or a
# reply cut short), drops 2 %, refuses 1 % as busy, and unplugs the
# rangefinder once. The drivers reject what is wrong, drain the port, retry
# (moves are absolute, so retries are safe), reopen the lost port with
# backoff and re-initialise the device. Each validated slice is written at
# once (temporary file + `os.replace`); the slice files hold only data, so the
# faulty scan must save exactly the bytes of a fault-free one.


# %%
def simulated_scan(folder, settings, faults=None, resume=False):
    with RigSimulator(seed=SEED, faults=faults, camera_dir=Path(folder) / "images",
                      reconnect_delay=0.05) as sim, \
            PanUnit(sim.pan_port, timeout=0.5) as pan, \
            Rangefinder(sim.laser_port, timeout=0.5) as laser:
        return run_scan(folder, pan, laser, settings, resume=resume,
                        source={"simulated": True, "seed": SEED})


stripes = ScanSettings("stripes", fraction=0.4)
start = time.perf_counter()
noisy = simulated_scan(WORK / "noisy", stripes,
                       faults="corrupt=0.05,drop=0.02,error=0.01,disconnect=1")
print(f"with faults: {noisy}")
clean = simulated_scan(WORK / "clean", stripes)
print(f"fault-free:  {clean}")


def folder_bytes(folder):
    return {p.name: p.read_bytes() for p in sorted((Path(folder) / "slices").iterdir())}


same = folder_bytes(WORK / "noisy") == folder_bytes(WORK / "clean")
print(f"identical slices: {same} ({len(folder_bytes(WORK / 'clean'))} files)")

# %% [markdown]
# A scan interrupted at any point — here by an exception after 30 slices,
# the tests use SIGKILL — resumes from its slice files and acquires only what
# is missing.


# %%
class Interrupted(Exception):
    pass


def stop_at_30(done, total, index):
    if done == 30:
        raise Interrupted


try:
    with RigSimulator(seed=SEED, camera_dir=WORK / "resumed" / "images") as sim, \
            PanUnit(sim.pan_port, timeout=0.5) as pan, \
            Rangefinder(sim.laser_port, timeout=0.5) as laser:
        run_scan(WORK / "resumed", pan, laser, stripes, progress=stop_at_30)
except Interrupted:
    print(f"interrupted with {len(list((WORK / 'resumed' / 'slices').iterdir()))} slices saved")
resumed = simulated_scan(WORK / "resumed", None, resume=True)
print(f"resumed: {resumed}")
print(f"identical to the uninterrupted scan: "
      f"{folder_bytes(WORK / 'resumed') == folder_bytes(WORK / 'clean')}")

# %% [markdown]
# ## 5. The partial range
#
# `load_scan` returns the scan as spherical samples `(r, θ, φ)` — ready for
# the laser–camera registration of App. A.2 — and as a range image whose
# columns are the 500 pan positions, NaN where no slice was taken. The Fig. 2
# rule (`distance`) first scans every 10th slice, then spends the rest of the
# budget where the scene is far.

# %%
distance = simulated_scan(WORK / "distance", ScanSettings("distance", fraction=0.4))
scans = {"stripes, 40 %": load_scan(WORK / "clean"),
         "distance-driven (Fig. 2), 40 %": load_scan(WORK / "distance")}
truth = np.stack([rig.truth(i, SLICE_START, SLICE_COUNT) for i in range(PAN_SLICES)], axis=1)
for label, scan in scans.items():
    image = scan.range_image()
    known = np.isfinite(image)
    error = np.abs(image[known] - truth[known])
    print(f"{label}: {scan.known_slices.sum()} slices, {100 * known.mean():.1f} % of the "
          f"range known, median error {1000 * np.median(error):.1f} mm")

# elevation = 90° − θ: the first encoder position (top row) looks highest
extent = [-90, 89.64, 90 - float(np.degrees(polar_angle(SLICE_START + SLICE_COUNT - 1))),
          90 - float(np.degrees(polar_angle(SLICE_START)))]
fig, axes = plt.subplots(3, 1, figsize=(10, 8.4), sharex=True)
vmin, vmax = np.nanmin(truth), np.nanmax(truth)
panels = [("complete scan (500 slices)", truth)] + [
    (label, scan.range_image()) for label, scan in scans.items()]
for ax, (label, image) in zip(axes, panels):
    shown = ax.imshow(image, cmap="turbo", vmin=vmin, vmax=vmax, extent=extent, aspect="auto",
                      interpolation="nearest")
    ax.set_title(label)
    ax.set_ylabel("elevation (°)")
axes[-1].set_xlabel("pan angle φ (°)")
fig.colorbar(shown, ax=axes, label="range (m)", fraction=0.025)
save(fig, "04_partial_range.png")

# %% [markdown]
# The ten pictures, each 24° wide, taken every 18° while the scan went by:

# %%
fig, axes = plt.subplots(1, 10, figsize=(12, 3))
for ax, picture in zip(axes, scans["stripes, 40 %"].images):
    ax.imshow(plt.imread(picture.path), cmap="gray", vmin=0, vmax=1)
    ax.set_title(f"{np.degrees(picture.pan_angle):.0f}°", fontsize=9)
    ax.set_axis_off()
save(fig, "04_pictures.png")
print(f"{time.perf_counter() - start:.1f} s for the scans; figures written to {OUT}/")

# %% [markdown]
# ## Exercises
#
# Solutions: `tutorials/solutions/04_acquisition.py` (the test suite runs
# it).
#
# 1. **Every single-byte corruption.** Replace each byte of the reply of
#    section 2 by each of the 255 other values and parse it. How many are
#    accepted? Which check catches a corrupted echo, status, data line or
#    newline?
# 2. **The CRC by hand.** Write CRC-16/CCITT bit by bit (start 0xFFFF,
#    polynomial 0x1021, most significant bit first) and compare it with
#    `crc16` and `binascii.crc_hqx`. Does swapping two characters of the data
#    line change it?
# 3. **Where does Fig. 2's rule spend its slices?** Take each slice's median
#    true range (`RoomRig(seed=0).truth(i, SLICE_START, SLICE_COUNT)`) as the
#    coarse pass and plan a distance-driven scan at 40 %
#    (`plan_slices(ScanSettings("distance", fraction=0.4), coarse)`). How many
#    slices fall where the room is far, how many where it is near?
