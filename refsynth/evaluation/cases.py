"""The experiments' cases: a scene at a size, a sampling, a method and a seed (§3.3).

A *case* is one fill to score. Cases are named compactly, as on the command
line (``python -m refsynth evaluate``), and every spec here has a parser that
validates it and returns its canonical form:

- scenes: ``synthetic`` (the synthetic room of seed 0; ``synthetic-N`` for
  seed N), ``motorcycle`` (the Middlebury 2014 pair of scikit-image),
  ``motorcycle-crop`` (its centred 6:5 crop: columns 70:670, 600 × 500,
  the disparity in the pair's own pixels), or a path pair ``IMAGE:DISPARITY`` (PNG/PFM/NPY, see
  :func:`refsynth.scenes.load_middlebury`), ``IMAGE:DISPARITY@SCALE`` for a PNG disparity
  stored as ``disparity × SCALE`` (0 = unknown; Middlebury 2005's half-size PNGs: ``@2``);
- sizes: ``128`` (square), ``450x375`` (width × height, as the paper
  writes it), or ``native`` (a path pair or the Motorcycle as stored);
- samplings: ``gRW_XW`` (the paper's grid stripes, known width RW, unknown
  width XW, Table 1), ``xNN`` (vertical stripes, NN % unknown, Table 4),
  ``distance`` or ``distanceNN`` (Fig. 2's distance-driven columns, 60 % or
  NN % unknown);
- methods: ``np``, ``np-noedges``, ``np-noisophotes``, ``np-onion``, ``bp``,
  ``bp-noedges``, ``bp-fig6`` (Fig. 6 as printed: ``readings="paper"``), ``np-copy`` and
  ``bp-copy`` (the default readings but ``gaps="copy"`` and ``median=0``: every pixel as
  filled), ``bp-obs-np`` (BP's
  observations completed by NP's fill, an option), and the baselines of
  :mod:`refsynth.evaluation.baselines` by name (``nearest``, ``linear``,
  ``harmonic``, ``colorization``, ``joint-bilateral``).

Numbers in specs are ASCII digits only (``synthetic-٣`` is not room 3).
:func:`scene_label` names a scene as the result tables do
(``synthetic-room-3``, ``motorcycle-128x128``), and :func:`case_memory`
estimates the memory one case needs, so that a command can refuse an absurd
size before it starts.

:func:`build_cases` and :func:`grid_cases` expand lists of specs into cases
(NP and BP on NP's fill, which draw at random, over several seeds); :func:`load_scene` and
:func:`known_mask` turn a case's specs into the scene and the known-range
mask that :mod:`refsynth.evaluation.runner` fills and scores.

References
----------
L. A. Torres-Méndez and G. Dudek, "Inter-Image Statistics for 3D Environment
Modeling", IJCV 79:137–158 (2008), §3.3 (Tables 1–4, Fig. 2),
doi:10.1007/s11263-007-0108-2.
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from refsynth._checks import check_int
from refsynth.acquisition.sampling import distance_driven, stripes, x_stripes_for_fraction
from refsynth.evaluation.baselines import BASELINES
from refsynth.scenes import load_middlebury, motorcycle, synthetic_room
from refsynth.scenes.middlebury import MOTORCYCLE_CROP
from refsynth.synthesis.options import draws_at_random

__all__ = [
    "Case", "SYNTHESIS_METHODS", "DEFAULT_SAMPLINGS", "DISTANCE_KNOWN_FRACTION", "DEFAULT_GRID",
    "QUICK_GRID", "method_names", "scene_label", "size_tuple", "case_memory", "MAX_STRIPE_WIDTH",
    "parse_scene", "parse_size", "parse_sampling", "parse_method", "parse_list", "build_cases",
    "grid_cases", "load_scene", "known_mask",
]

#: The synthesis variants: keyword arguments of :func:`refsynth.synthesize`.
SYNTHESIS_METHODS: dict[str, dict] = {
    "np": {},
    "np-noedges": {"use_edges": False},
    "np-noisophotes": {"use_isophotes": False},
    "np-onion": {"ordering": "onion"},
    "bp": {"method": "bp"},
    "bp-noedges": {"method": "bp", "use_edges": False},
    # Fig. 6 as printed, readings="paper": BP's defaults complete the observations, widen
    # the training disc, shift the copied labels, gate the gaps, take the median after and
    # narrow the window on narrow gaps (departures measured on real data:
    # refsynth.synthesis.readings lists them)
    "bp-fig6": {"method": "bp", "observation": "measured", "training_radius": "fixed",
                "range_copy": "value", "missing_range": "ignore", "tolerance": 0.0,
                "gaps": "copy", "median": 0, "window": "fixed"},
    # refsynth's readings without the post-passes: every pixel as NP or BP filled it
    "np-copy": {"gaps": "copy", "median": 0},
    "bp-copy": {"method": "bp", "gaps": "copy", "median": 0},
    # BP's observations completed by NP's fill, named: the same as "bp" (BP's default)
    "bp-obs-np": {"method": "bp", "observation": "np"},
    # completed by the colorization fill instead (no random choice)
    "bp-obs-colorization": {"method": "bp", "observation": "colorization"},
}
#: Variants the default grid leaves out (a block's methods None), chosen by name with
#: ``--methods``: ``bp-obs-np`` is ``bp`` under another name, ``bp-obs-colorization``
#: BP on the colorization fill.
OPTION_METHODS = ("bp-obs-np", "bp-obs-colorization")

#: Every sampling of the paper's experiments: Table 1's grids, Table 4's
#: x-stripes and Fig. 2's distance-driven columns.
DEFAULT_SAMPLINGS = ("g24_80", "g10_20", "g5_25", "g3_28", "x63", "x78", "x85", "distance")

#: Known fraction of Fig. 2's sampling when the spec gives none: §4 scans
#: 30–50 % of the slices.
DISTANCE_KNOWN_FRACTION = 0.4

#: The widest stripe (RW or XW of ``gRW_XW``) a sampling spec may name, in pixels.
MAX_STRIPE_WIDTH = 100_000
#: The most digits a number in a spec may have (larger numbers name nothing useful).
_MAX_DIGITS = 9


def method_names() -> tuple[str, ...]:
    """Every method name: the synthesis variants, then the baselines.

    The variants are those of §3.3 (NP with and without the edge term and
    isophotes, in the priority order of Eq. 12 or onion order; BP, §3.2);
    the baselines are not in the paper.

    Returns
    -------
    tuple of str
        The names :func:`parse_method` accepts.

    Examples
    --------
    >>> method_names()[:2], "nearest" in method_names()
    (('np', 'np-noedges'), True)
    """
    return (*SYNTHESIS_METHODS, *BASELINES)


#: The default grid, as blocks of (scenes, size, samplings, methods); ``None``
#: for the methods means all of them. Block 1 is Tables 1, 3 and 4 on 128×128
#: scenes; block 2 adds three more rooms at Table 2/3's sampling; block 3 is
#: Table 4 at the paper's Middlebury size, with Fig. 2's distance sampling.
DEFAULT_GRID: tuple[tuple[str, str, str, str | None], ...] = (
    ("synthetic,motorcycle", "128", ",".join(DEFAULT_SAMPLINGS), None),
    ("synthetic-1,synthetic-2,synthetic-3", "128", "g5_25", "np,np-noedges,bp,bp-fig6"),
    ("motorcycle", "450x375", "x63,x78,x85,distance", None),
)

#: A grid of seconds, for smoke tests: a 32×32 room.
QUICK_GRID: tuple[tuple[str, str, str, str | None], ...] = (
    ("synthetic", "32", "g3_8,x78", "np,np-noedges,np-onion,bp,nearest,colorization"),
)


# ----------------------------------------------------------------------------- specs


@dataclass(frozen=True)
class Case:
    """One run: a scene at a size, a sampling, a method and a seed, all as spec strings.

    One cell of the experiments of §3.3 (Tables 1–4).

    Attributes
    ----------
    scene : str
        ``synthetic``, ``synthetic-N``, ``motorcycle`` or ``IMAGE:DISPARITY``
        (absolute paths).
    size : str
        ``WxH`` or ``native``.
    sampling : str
        ``gRW_XW``, ``xNN``, ``distance`` or ``distanceNN``.
    method : str
        A name of :func:`method_names`.
    seed : int
        The synthesis seed (0 for deterministic methods).

    Examples
    --------
    >>> Case("synthetic-0", "16x16", "x20", "nearest", 0).method
    'nearest'
    """

    scene: str
    size: str
    sampling: str
    method: str
    seed: int

    @property
    def label(self) -> str:
        """A one-line description for progress reports, naming the scene as the tables do.

        >>> Case("synthetic-0", "64x64", "x78", "np", 1).label
        'synthetic-room-0 64x64 x78 np seed 1'
        >>> Case("motorcycle", "450x375", "x78", "bp", 0).label
        'motorcycle-450x375 x78 bp seed 0'
        """
        name = scene_label(self.scene, self.size)
        size = "" if name.endswith(self.size) else f" {self.size}"
        return f"{name}{size} {self.sampling} {self.method} seed {self.seed}"


def scene_label(scene: str, size: str | None = None) -> str:
    """A scene spec's name in the result tables (the loaded scene's ``name``).

    Parameters
    ----------
    scene : str
        A canonical spec (:func:`parse_scene`).
    size : str, optional
        A canonical size (:func:`parse_size`); only the Motorcycle's name
        carries it (``motorcycle-450x375``; ``native`` is 741x500).

    Examples
    --------
    >>> scene_label("synthetic-3"), scene_label("motorcycle", "128x128")
    ('synthetic-room-3', 'motorcycle-128x128')
    """
    if scene.startswith("synthetic-"):
        return f"synthetic-room-{scene.split('-', 1)[1]}"
    if scene == "motorcycle":
        if size is None:
            return scene
        return f"motorcycle-{'741x500' if size == 'native' else size}"
    if scene == "motorcycle-crop":
        if size is None:
            return scene
        (r0, r1), (c0, c1) = MOTORCYCLE_CROP
        return (f"motorcycle-{'600x500' if size == 'native' else size}"
                f"-crop{r0}-{r1},{c0}-{c1}-native")
    if ":" in scene:
        image = Path(_split_pair(scene)[0])
        folder = image.parent.name
        return f"{folder}/{image.stem}" if folder else image.stem
    return scene


def _split_scale(text: str) -> tuple[str, float]:
    """``IMAGE:DISPARITY@SCALE`` → (``IMAGE:DISPARITY``, SCALE), else (text, 1.0); an ``@`` in
    a file name that exists counts as part of the name."""
    head, at, tail = text.rpartition("@")
    try:
        scale = float(tail) if at else None
    except ValueError:
        scale = None
    if scale is None or (not Path(head.rpartition(":")[2]).is_file()
                         and Path(text.rpartition(":")[2]).is_file()):
        return text, 1.0
    if not (math.isfinite(scale) and scale > 0):
        raise ValueError(f"scene {text!r}: the disparity scale after '@' must be a finite "
                         f"number > 0, got {tail!r}")
    return head, scale


def _split_pair(text: str) -> tuple[str, str]:
    """Split ``IMAGE:DISPARITY``; with several colons, at the one whose halves exist."""
    parts = text.split(":")
    if len(parts) == 2:
        return parts[0], parts[1]
    for i in range(1, len(parts)):
        image, disparity = ":".join(parts[:i]), ":".join(parts[i:])
        if Path(image).is_file() and Path(disparity).is_file():
            return image, disparity
    raise ValueError(f"scene {text!r}: cannot tell IMAGE from DISPARITY at its colons")


def parse_scene(text: str) -> str:
    """Validate a scene spec and return it in canonical form.

    Parameters
    ----------
    text : str
        ``synthetic`` (room of seed 0), ``synthetic-N``, ``motorcycle``,
        ``motorcycle-crop``, or ``IMAGE:DISPARITY`` (two existing files), optionally with
        ``@SCALE``: the stored PNG integers per unit of disparity (a finite number > 0).

    Returns
    -------
    str
        ``synthetic-N``, ``motorcycle``, ``motorcycle-crop`` or ``IMAGE:DISPARITY`` with absolute
        paths (so that workers elsewhere on the machine find them).

    Raises
    ------
    ValueError
        If the spec is none of these.
    OSError
        If a file of a path pair does not exist.

    Examples
    --------
    >>> parse_scene("synthetic"), parse_scene("synthetic-3"), parse_scene("motorcycle")
    ('synthetic-0', 'synthetic-3', 'motorcycle')
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"scene must be a non-empty string, got {text!r}")
    text = text.strip()
    if text == "synthetic":
        return "synthetic-0"
    match = re.fullmatch(rf"synthetic-([0-9]{{1,{_MAX_DIGITS}}})", text)
    if match:
        return f"synthetic-{int(match.group(1))}"
    if text in ("motorcycle", "motorcycle-crop"):
        return text
    if ":" in text:
        pair, scale = _split_scale(text)
        image, disparity = _split_pair(pair)
        for what, path in (("image", image), ("disparity", disparity)):
            if not path:
                raise ValueError(f"scene {text!r}: the {what} path is empty")
            if not Path(path).is_file():
                raise FileNotFoundError(f"scene {text!r}: {what} file not found: {path}")
        suffix = "" if scale == 1.0 else f"@{scale!r}"
        return f"{Path(image).resolve()}:{Path(disparity).resolve()}{suffix}"
    raise ValueError(
        f"unknown scene {text!r}: expected synthetic, synthetic-N, motorcycle, motorcycle-crop "
        "or IMAGE:DISPARITY"
    )


def _normalised(text: str, what: str) -> str:
    """The spec stripped and lower-cased; ValueError naming ``what`` if it is not a string."""
    if not isinstance(text, str):
        raise ValueError(f"{what} must be a string, got {text!r}")
    return text.strip().lower()


def parse_size(text: str) -> str:
    """Validate a size spec: ``128`` (square), ``450x375`` (W×H) or ``native``.

    Parameters
    ----------
    text : str
        The spec; width and height must be at least 16 pixels.

    Returns
    -------
    str
        ``WxH`` or ``native``.

    Examples
    --------
    >>> parse_size("128"), parse_size("450x375"), parse_size("native")
    ('128x128', '450x375', 'native')
    """
    text = _normalised(text, "size")
    if text == "native":
        return text
    match = re.fullmatch(rf"([0-9]{{1,{_MAX_DIGITS}}})(?:x([0-9]{{1,{_MAX_DIGITS}}}))?", text)
    if not match:
        raise ValueError(f"bad size {text!r}: expected N (square), WxH such as 450x375, or native "
                         f"(at most {_MAX_DIGITS} ASCII digits each)")
    width = int(match.group(1))
    height = int(match.group(2)) if match.group(2) else width
    if width < 16 or height < 16:
        raise ValueError(f"bad size {text!r}: width and height must be at least 16 pixels")
    return f"{width}x{height}"


def size_tuple(size: str) -> tuple[int, int] | None:
    """``"450x375"`` → ``(450, 375)`` (width, height); ``"native"`` → None.

    Parameters
    ----------
    size : str
        A spec in the canonical form :func:`parse_size` returns.

    Returns
    -------
    tuple of (int, int) or None
        ``(width, height)``, or None for ``native``.

    Examples
    --------
    >>> size_tuple("450x375"), size_tuple("native")
    ((450, 375), None)
    """
    if size == "native":
        return None
    width, height = size.split("x")
    return int(width), int(height)


#: Peak memory of one fill per pixel, in bytes, by method family: measured with
#: tracemalloc on the synthetic room at 64–256 px (NP about 1.2 kB, BP 7.5 kB,
#: the baselines 0.4–0.7 kB, the scene included), with a margin.
_BYTES_PER_PIXEL = {"np": 2_000, "bp": 10_000, "baseline": 1_000}
#: The Motorcycle as stored (width, height).
_MOTORCYCLE_NATIVE = (741, 500)


def case_memory(case: Case) -> int | None:
    """A rough peak memory of one case in bytes (pixels × a method's bytes per pixel).

    Parameters
    ----------
    case : Case
        The case: its size (the Motorcycle's stored size for ``native``) and its
        method set the estimate.

    Returns
    -------
    int or None
        None for a path pair at its native size (the files set the size).

    Examples
    --------
    >>> case_memory(Case("synthetic-0", "100x100", "x78", "bp", 0))
    100000000
    """
    dims = size_tuple(case.size)
    if dims is None:
        if case.scene not in ("motorcycle", "motorcycle-crop"):
            return None
        dims = _MOTORCYCLE_NATIVE
    family = case.method.split("-")[0] if case.method in SYNTHESIS_METHODS else "baseline"
    return dims[0] * dims[1] * _BYTES_PER_PIXEL[family]


def parse_sampling(text: str) -> str:
    """Validate a sampling spec: ``gRW_XW``, ``xNN``, ``distance`` or ``distanceNN``.

    The samplings of §3.3 (see :func:`known_mask`): ``gRW_XW`` is a grid of
    known stripes RW pixels wide and unknown stripes XW wide along both
    axes, ``xNN`` vertical stripes leaving NN % of the range unknown
    (Table 4), ``distance`` the distance-driven sampling of Fig. 2.

    Parameters
    ----------
    text : str
        The spec (leading zeros allowed).

    Returns
    -------
    str
        The spec in canonical form (no leading zeros).

    Raises
    ------
    ValueError
        If the spec is malformed or out of range: RW, XW in 1 …
        :data:`MAX_STRIPE_WIDTH`; NN in 1 … 99.

    Examples
    --------
    >>> parse_sampling("g5_25"), parse_sampling("x078"), parse_sampling("distance")
    ('g5_25', 'x78', 'distance')
    """
    text = _normalised(text, "sampling")
    match = re.fullmatch(r"g([0-9]+)_([0-9]+)", text)
    if match:
        rw, xw = int(match.group(1)), int(match.group(2))
        if not (1 <= rw <= MAX_STRIPE_WIDTH and 1 <= xw <= MAX_STRIPE_WIDTH):
            raise ValueError(f"bad sampling {text!r}: gRW_XW needs RW >= 1 and XW >= 1, "
                             f"both at most {MAX_STRIPE_WIDTH}")
        return f"g{rw}_{xw}"
    match = re.fullmatch(r"(x|distance)([0-9]+)", text)
    if match:
        percent = int(match.group(2))
        if not 1 <= percent <= 99:
            raise ValueError(f"bad sampling {text!r}: the unknown percentage must be in 1..99")
        return f"{match.group(1)}{percent}"
    if text == "distance":
        return text
    raise ValueError(
        f"unknown sampling {text!r}: expected gRW_XW (grid stripes, e.g. g5_25), "
        "xNN (x-stripes, NN % unknown, e.g. x78), distance or distanceNN"
    )


def parse_method(text: str) -> str:
    """Validate a method name (see :func:`method_names`).

    Parameters
    ----------
    text : str
        The name, exactly as :func:`method_names` spells it.

    Returns
    -------
    str
        ``text``.

    Raises
    ------
    ValueError
        If ``text`` is not a method name.

    Examples
    --------
    >>> parse_method("np-onion"), parse_method("colorization")
    ('np-onion', 'colorization')
    """
    if not isinstance(text, str) or text.strip().lower() not in method_names():
        raise ValueError(f"unknown method {text!r}: choose from {', '.join(method_names())}")
    return text.strip().lower()


def parse_list(text: str, parse: Callable[[str], str], what: str) -> list[str]:
    """Parse a comma-separated list with ``parse``, dropping duplicates, keeping order.

    Parameters
    ----------
    text : str
        Comma-separated items.
    parse : callable
        ``parse(item) -> str``, e.g. :func:`parse_sampling`; raises
        ``ValueError`` on a bad item.
    what : str
        What an item is, for the error message (``"sampling"``).

    Returns
    -------
    list of str
        The parsed items, each once, in order of first appearance.

    Raises
    ------
    ValueError
        If the list or one of its items is empty, or an item does not parse.

    Examples
    --------
    >>> parse_list("x78,g5_25,x78", parse_sampling, "sampling")
    ['x78', 'g5_25']
    """
    if not isinstance(text, str) or not text.strip():
        raise ValueError(f"empty {what} list")
    items = [item.strip() for item in text.split(",")]
    if any(not item for item in items):
        raise ValueError(f"empty item in the {what} list {text!r}")
    return list(dict.fromkeys(parse(item) for item in items))


def _is_stochastic(method: str) -> bool:
    """NP draws from the Eq. 5 set, and so does BP on NP's fill (its default);
    BP on another fill and the baselines do not."""
    options = SYNTHESIS_METHODS.get(method)
    return options is not None and draws_at_random(options)   # None: a baseline


def build_cases(
    scenes: Sequence[str],
    sizes: Sequence[str],
    samplings: Sequence[str],
    methods: Sequence[str],
    seeds: int = 3,
) -> list[Case]:
    """The product scenes × sizes × samplings × methods (× seeds if it draws), in that order.

    The grid of experiments of §3.3 (Tables 1–4), as :class:`Case` objects.

    Parameters
    ----------
    scenes, sizes, samplings, methods : sequence of str
        Specs, parsed with :func:`parse_scene` etc.
    seeds : int, default 3
        NP's variants and BP's on NP's fill run with seeds ``0 … seeds − 1``; the
        others once (seed 0).

    Returns
    -------
    list of Case

    Examples
    --------
    >>> cases = build_cases(["synthetic"], ["16"], ["x20"], ["np", "nearest"], seeds=2)
    >>> [(case.method, case.seed) for case in cases]
    [('np', 0), ('np', 1), ('nearest', 0)]
    """
    seeds = check_int("seeds", seeds, minimum=1)
    scenes = [parse_scene(s) for s in scenes]
    sizes = [parse_size(s) for s in sizes]
    samplings = [parse_sampling(s) for s in samplings]
    methods = [parse_method(m) for m in methods]
    cases = []
    for scene in scenes:
        for size in sizes:
            if size == "native" and scene.startswith("synthetic"):
                raise ValueError(f"scene {scene!r} has no native size: give --size, e.g. 128")
            for sampling in samplings:
                for method in methods:
                    for seed in range(seeds if _is_stochastic(method) else 1):
                        cases.append(Case(scene, size, sampling, method, seed))
    return cases


def grid_cases(
    blocks: Iterable[tuple[str, str, str, str | None]], seeds: int = 3,
    methods: str | None = None,
) -> list[Case]:
    """The cases of a grid given as blocks ``(scenes, sizes, samplings, methods)`` of lists.

    Parameters
    ----------
    blocks : iterable of (str, str, str, str or None)
        Each ``(scenes, sizes, samplings, methods)`` as comma-separated
        lists (see :func:`parse_list`); a block's methods None means every
        name of :func:`method_names` but :data:`OPTION_METHODS`.
    seeds : int, default 3
        As in :func:`build_cases`.
    methods : str or None, default None
        A comma-separated list that replaces every block's methods.

    Returns
    -------
    list of Case
        The cases of :func:`build_cases` for each block, in order, each once.

    Examples
    --------
    >>> blocks = [("synthetic", "16", "x20,x40", "nearest")]
    >>> [case.sampling for case in grid_cases(blocks)]
    ['x20', 'x40']
    >>> [case.method for case in grid_cases(blocks, methods="linear")]
    ['linear', 'linear']
    """
    cases: list[Case] = []
    for scenes, sizes, samplings, block_methods in blocks:
        chosen = methods or block_methods or ",".join(
            name for name in method_names() if name not in OPTION_METHODS)
        cases += build_cases(
            parse_list(scenes, parse_scene, "scene"), parse_list(sizes, parse_size, "size"),
            parse_list(samplings, parse_sampling, "sampling"),
            parse_list(chosen, parse_method, "method"), seeds,
        )
    return list(dict.fromkeys(cases))


# ----------------------------------------------------------------------------- scenes and masks


@functools.lru_cache(maxsize=8)
def load_scene(scene: str, size: str):
    """Load a scene spec at a size spec (cached per process).

    Returns
    -------
    refsynth.scenes.Scene
    """
    dims = size_tuple(size)
    if scene.startswith("synthetic-"):
        if dims is None:
            raise ValueError(f"scene {scene!r} has no native size: give a size, e.g. 128")
        return synthetic_room((dims[1], dims[0]), seed=int(scene.split("-")[1]))
    if scene == "motorcycle":
        return motorcycle(dims if dims is not None else (741, 500))
    if scene == "motorcycle-crop":
        return motorcycle(dims if dims is not None else (600, 500), crop=MOTORCYCLE_CROP,
                          units="native")
    pair, scale = _split_scale(scene)
    image, disparity = _split_pair(pair)
    return load_middlebury(image, disparity, size=dims, disparity_scale=scale)


def known_mask(scene, sampling: str) -> np.ndarray:
    """The known-range mask of a sampling spec on a scene, without pixels that lack truth.

    Pixels without ground truth are never given to the synthesis (there is
    no range to give) and never scored (:func:`refsynth.evaluation.metrics.evaluate`
    skips them).

    Parameters
    ----------
    scene : refsynth.scenes.Scene
        The scene (its range image, the ground truth, gives the shape).
    sampling : str
        A spec of :func:`parse_sampling`.

    Returns
    -------
    ndarray of shape (H, W), bool
        ``True`` where the range is known.

    Notes
    -----
    ``distance`` uses the ground truth's per-column median as the coarse
    range of Fig. 2 (for disparity, its inverse, which grows with
    distance), standing in for the rig's coarse pass.

    Examples
    --------
    >>> from refsynth.scenes import synthetic_room
    >>> mask = known_mask(synthetic_room(shape=(16, 16)), "x20")
    >>> mask.shape, mask.dtype
    ((16, 16), dtype('bool'))
    """
    sampling = parse_sampling(sampling)
    shape = scene.range.shape
    if sampling.startswith("g"):
        rw, xw = (int(v) for v in sampling[1:].split("_"))
        mask = stripes(shape, rw, xw, axes="xy")
    elif sampling.startswith("x"):
        mask = x_stripes_for_fraction(shape, int(sampling[1:]) / 100.0)
    else:
        percent = sampling[len("distance"):]
        known_fraction = 1.0 - int(percent) / 100.0 if percent else DISTANCE_KNOWN_FRACTION
        truth = scene.range
        if scene.units.startswith("disparity"):
            with np.errstate(divide="ignore"):
                truth = np.where(truth > 0, 1.0 / truth, np.nan)
        mask = distance_driven(truth, known_fraction=known_fraction)
    return mask & scene.has_truth

