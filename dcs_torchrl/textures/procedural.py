"""The stand-in textures: 20 training and 5 held-out surface textures made procedurally (no download).

No texture set (e.g. the Describable Textures Dataset) ships with the package, so the default
set is made here: ten families of surface a texture dataset has, two training textures each (in two
styles) and a held-out one in a third style for every other family, each drawn with its own parameters
and colours —

- ``grain``: fine fractal noise with flecks (sand, concrete, granite, terrazzo);
- ``stripes``: bands at an angle, straight, wavy or zigzag (striped fabric, banded rock);
- ``stones``: rounded cells with grout between them (cobblestones, pebbles, scales);
- ``woven``: threads over and under each other (plain weave, twill, basketry);
- ``marble``: turbulent veins across clouded stone;
- ``wood``: boards with growth lines and seams;
- ``dots``: studs or dots on a square or staggered grid (polka dots, studded rubber);
- ``bricks``: bricks or tiles in mortar, each its own tone (brick walls, chequered tiles);
- ``cracked``: plates split by thin cracks (dried mud, crackle glaze);
- ``blotchy``: patches of two or three colours (lichen on stone, stains, camouflage).

Texture ``index`` of a split is a function of (split, index) only: its family, its parameters and
its random fields come from a ``np.random.Generator`` seeded with :func:`texture_seed`, and every
pixel is arithmetic on numpy arrays (only ``+ - * /``, ``sqrt``, ``floor`` and comparisons, which
IEEE 754 makes bit-identical on every machine, as :mod:`dcs_torchrl.videos.procedural`; no sums over
pixels), so a texture is the same bits everywhere for a given numpy version. The random fields do not depend on the size: a texture is
drawn straight at the requested size (no upscaling) and shows the same pattern at every size, details
finer than a pixel fading out. Every texture tiles: its right edge continues into its left edge and
its bottom edge into its top.
"""
from __future__ import annotations

import numpy as np

from dcs_torchrl.videos.procedural import F32, hsv, mix, uniform, wave

# The version of the stand-ins: bump it whenever a texture's bytes change (results computed on
# different versions are not comparable).
STANDIN_VERSION = 1
STANDINS = {"train": 20, "val": 5}
FAMILIES = ("grain", "stripes", "stones", "woven", "marble", "wood", "dots", "bricks", "cracked", "blotchy")
_SPLIT_IDS = {"train": 0, "val": 1}


def texture_seed(split: str, index: int) -> list[int]:
    """The seed of stand-in texture ``index`` of ``split`` (train and val never share one)."""
    return [0x7E7, _SPLIT_IDS[split], int(index)]


def family_of(split: str, index: int) -> str:
    """The family of stand-in texture ``index``: training cycles through the ten families (each twice),
    the held-out textures take every other family (each a family's new member, not a new family)."""
    return FAMILIES[index % len(FAMILIES)] if split == "train" else FAMILIES[(2 * index + 1) % len(FAMILIES)]


# ---------------------------------------------------------------------------------------------------------
# Fields over the unit square, periodic: coordinates y, x in texture units ([0, 1) over the image).


def _smooth(t):
    return t * t * (F32(3) - F32(2) * t)


def _noise(grid: np.ndarray, y, x):
    """Value noise in [0, 1]: the [cy, cx] ``grid`` of random values, smoothly interpolated, tiling the
    unit square (row ``cy`` is row 0 again)."""
    cy, cx = grid.shape
    gy, gx = y * F32(cy), x * F32(cx)
    fy, fx = np.floor(gy), np.floor(gx)
    ty, tx = _smooth(gy - fy), _smooth(gx - fx)
    iy, ix = fy.astype(np.intp) % cy, fx.astype(np.intp) % cx
    iy1, ix1 = (iy + 1) % cy, (ix + 1) % cx
    top = grid[iy, ix] + (grid[iy, ix1] - grid[iy, ix]) * tx
    bottom = grid[iy1, ix] + (grid[iy1, ix1] - grid[iy1, ix]) * tx
    return top + (bottom - top) * ty


def _fbm(rng, y, x, cells: tuple[int, int], octaves: int = 5, gain: float = 0.5, pixel: float = 0.0):
    """Fractal value noise in about [-1, 1]; the coarsest grid has ``cells`` (rows, columns).

    The grids are drawn whatever the size; an octave whose cells are under 2 pixels (``pixel``:
    one pixel in texture units) is left out of the sum.
    """
    total = np.zeros(np.shape(y), F32)
    amplitude, norm = 1.0, 0.0
    for k in range(octaves):
        grid = rng.random((cells[0] << k, cells[1] << k), dtype=F32)
        if 1.0 / max(cells[0] << k, cells[1] << k) >= 2 * pixel:
            total += F32(2 * amplitude) * _noise(grid, y, x) - F32(amplitude)
        norm += amplitude
        amplitude *= gain
    return total * F32(1.7 / norm)


def _cells(points: np.ndarray, y, x, stretch: float = 1.0):
    """Cellular (Worley) noise over an [n, n] grid with one point per cell at ``points`` [n, n, 2] (the
    point's place in its cell, in [0, 1)): (distance to the nearest point, to the second nearest, flat
    index of the nearest cell), distances in cells, x distances times ``stretch``."""
    n = points.shape[0]
    gy, gx = y * F32(n), x * F32(n)
    cy, cx = np.floor(gy), np.floor(gx)
    first = np.full(np.shape(y), F32(9))
    second = np.full(np.shape(y), F32(9))
    nearest = np.zeros(np.shape(y), np.intp)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            ny, nx = cy + F32(dy), cx + F32(dx)
            iy, ix = ny.astype(np.intp) % n, nx.astype(np.intp) % n
            ddy = ny + points[iy, ix, 0] - gy
            ddx = (nx + points[iy, ix, 1] - gx) * F32(stretch)
            d = np.sqrt(ddy * ddy + ddx * ddx)
            closer = d < first
            second = np.where(closer, first, np.minimum(second, d))
            nearest = np.where(closer, iy * n + ix, nearest)
            first = np.where(closer, d, first)
    return first, second, nearest


def _edge(d, width):
    """Coverage in [0, 1] of the side d > 0 of an edge, soft over ``width`` (a pixel or more)."""
    return np.clip(d / F32(width) + F32(0.5), F32(0), F32(1))


def _frac(t):
    return t - np.floor(t)


def _relief(rgb, height, pixel: float, strength: float):
    """``rgb`` lit from the upper left over the tiling ``height`` field (in texture units)."""
    slope_x = (np.roll(height, -1, axis=1) - np.roll(height, 1, axis=1)) * F32(0.5 / pixel)
    slope_y = (np.roll(height, -1, axis=0) - np.roll(height, 1, axis=0)) * F32(0.5 / pixel)
    light = np.clip(F32(1) - F32(strength) * (slope_x + slope_y), F32(0.45), F32(1.45))
    return rgb * light[..., None]


def _weathered(rng, rgb, y, x, pixel: float, amount: float = 0.1):
    """``rgb`` under uneven light and fine grain, as a photographed surface."""
    light = _fbm(rng, y, x, (2, 2), 3, 0.5, pixel)
    grain = _fbm(rng, y, x, (48, 48), 2, 0.5, pixel)
    return rgb * (F32(1) + F32(amount) * light + F32(amount * 0.4) * grain)[..., None]


# ---------------------------------------------------------------------------------------------------------
# Colours of materials: (hue, saturation, value) ranges, hue in turns.

MATERIALS = {
    "wood": ((0.045, 0.1), (0.45, 0.75), (0.5, 0.85)),
    "stone": ((0.06, 0.14), (0.08, 0.25), (0.5, 0.8)),
    "slate": ((0.52, 0.64), (0.08, 0.25), (0.38, 0.65)),
    "sand": ((0.09, 0.14), (0.28, 0.52), (0.62, 0.88)),
    "brick": ((0.0, 0.055), (0.5, 0.75), (0.45, 0.72)),
    "moss": ((0.17, 0.3), (0.4, 0.7), (0.35, 0.65)),
    "mud": ((0.06, 0.11), (0.32, 0.58), (0.4, 0.66)),
    "straw": ((0.1, 0.15), (0.38, 0.62), (0.62, 0.88)),
    "marble": ((0.05, 0.12), (0.02, 0.12), (0.78, 0.93)),
    "fabric": ((0.0, 1.0), (0.35, 0.75), (0.4, 0.85)),
}


def _colour(rng, material: str) -> tuple[float, float, float]:
    (h0, h1), (s0, s1), (v0, v1) = MATERIALS[material]
    return uniform(rng, h0, h1), uniform(rng, s0, s1), uniform(rng, v0, v1)


def _palette(rng, material: str, depth: tuple[float, float] = (0.35, 0.55)):
    """(dark, light) RGB float32 [3] of one material: the same hue, the dark one deeper."""
    h, s, v = _colour(rng, material)
    dark = hsv(h + uniform(rng, -0.02, 0.02), min(1.0, s * 1.2 + 0.05), v * uniform(rng, *depth))
    return dark, hsv(h, s * 0.85, v)


def _pick(rng, options):
    return options[int(rng.integers(len(options)))]


# Directions with whole numbers of cycles across the square, so that bands at an angle still tile.
DIRECTIONS = ((1, 0), (0, 1), (1, 1), (1, -1), (2, 1), (1, 2), (2, -1), (1, -2), (3, 1), (1, 3), (3, -1))


# ---------------------------------------------------------------------------------------------------------
# The families: each (rng, y, x, pixel, member) -> float32 RGB [S, S, 3], about [0, 1]. ``member`` is the
# texture's place among its family's (0 and 1: the two training ones, 2: the held-out one) and picks its
# style, so the three members of a family always look different.


def grain(rng, y, x, pixel, member):
    """Sand, granite, concrete: fractal noise of one material with flecks of two others."""
    material, cells, dense, size = (("sand", 28, 0.3, 0.25), ("slate", 20, 0.7, 0.4), ("stone", 36, 0.35, 0.3))[member]
    dark, light = _palette(rng, material)
    flecks = (hsv(*_colour(rng, "slate")) * F32(0.45), hsv(*_colour(rng, _pick(rng, ("marble", "brick", "sand")))))
    base = _fbm(rng, y, x, (3, 3), 4, 0.55, pixel)
    fine = _fbm(rng, y, x, (24, 24), 3, 0.7, pixel)
    rgb = mix(dark, light, np.clip(F32(0.55) + F32(0.4) * base + F32(0.35) * fine, F32(0), F32(1)))
    n = cells + int(rng.integers(-4, 5))
    points = rng.random((n, n, 2), dtype=F32)
    radius = (F32(0.4) + F32(0.6) * rng.random((n, n), dtype=F32)) * F32(size)
    kind = rng.random((n, n), dtype=F32)
    near, _, cell = _cells(points, y, x, stretch=uniform(rng, 0.8, 1.3))
    cover = _edge(radius.ravel()[cell] - near, pixel * n) * (kind.ravel()[cell] < F32(dense))
    fleck = np.where((kind.ravel()[cell] < F32(dense / 2))[..., None], flecks[0], flecks[1])
    return _weathered(rng, rgb + (fleck - rgb) * (cover * F32(0.85))[..., None], y, x, pixel)


def stripes(rng, y, x, pixel, member):
    """Bands at an angle, two to four colours a period: straight fabric, wavy banded rock, zigzag knit."""
    style, fabric = (("straight", True), ("wavy", False), ("zigzag", True))[member]
    a, b = _pick(rng, DIRECTIONS)
    repeats = int(rng.integers(3, 9))
    phase = F32(repeats) * (F32(a) * y + F32(b) * x)
    across = F32(int(rng.integers(2, 6))) * (F32(a) * x - F32(b) * y)
    swing = F32(uniform(rng, 0.2, 0.45))
    if style == "zigzag":
        phase = phase + swing * (F32(4) * np.abs(_frac(across) - F32(0.5)))
    elif style == "wavy":
        phase = phase + swing * wave(across).astype(F32) + F32(0.25) * _fbm(rng, y, x, (3, 3), 4, 0.5, pixel)
    phase = phase + F32(0.05) * _fbm(rng, y, x, (4, 4), 3, 0.5, pixel)
    colours = int(rng.integers(2, 5))
    if fabric:
        hues = [hsv(*_colour(rng, "fabric")) for _ in range(2)]
        band = [hues[i % 2] * F32(uniform(rng, 0.55, 1.1)) for i in range(colours)]
    else:
        material = _pick(rng, ("sand", "stone", "mud", "brick"))
        band = [hsv(*_colour(rng, material)) * F32(uniform(rng, 0.5, 1.1)) for _ in range(colours)]
    widths = np.cumsum(rng.random(colours) + 0.4)
    bounds = widths / widths[-1]
    t = _frac(phase)
    width = pixel * repeats * float(np.sqrt(a * a + b * b)) * (1.2 if fabric else 2.5)  # edges: a pixel, in periods
    rgb = np.broadcast_to(band[0], t.shape + (3,)).astype(F32)
    for colour, bound in zip(band[1:], bounds[:-1]):
        rgb = mix(rgb, colour, _edge(t - F32(bound), width) * _edge(F32(bounds[-1]) - t, width))
    threads = _fbm(rng, y, x, (64, 64), 2, 0.5, pixel) if fabric else _fbm(rng, y, x, (8, 8), 4, 0.6, pixel)
    return _weathered(rng, rgb * (F32(1) + F32(0.15) * threads)[..., None], y, x, pixel)


def stones(rng, y, x, pixel, member):
    """Cobblestones, pebbles, flagstones: rounded cells, each its own tone, in grout."""
    material, cells, jitter, gap = (("stone", (4, 8), 0.6, 0.08), ("sand", (6, 11), 1.0, 0.12),
                                    ("slate", (3, 6), 0.9, 0.05))[member]
    dark, light = _palette(rng, material, (0.55, 0.8))
    grout = hsv(*_colour(rng, _pick(rng, ("mud", "sand", "slate")))) * F32(uniform(rng, 0.35, 0.7))
    n = int(rng.integers(*cells))
    points = F32(0.5) + (rng.random((n, n, 2), dtype=F32) - F32(0.5)) * F32(jitter)
    tone = rng.random(n * n, dtype=F32)
    warp = F32(0.12 / n)
    wy, wx = y + warp * _fbm(rng, y, x, (6, 6), 3, 0.5, pixel), x + warp * _fbm(rng, y, x, (6, 6), 3, 0.5, pixel)
    near, second, cell = _cells(points, wy, wx, stretch=uniform(rng, 0.8, 1.25))
    inside = (second - near) * F32(0.5)  # cells to the border
    stone = _edge(inside - F32(gap), pixel * n)
    radial = near / (near + inside - F32(gap) + F32(1e-3))  # 0 at the cell's point, 1 at its rim
    dome = np.sqrt(np.clip(F32(1) - radial * radial, F32(0), F32(1)))
    surface = _fbm(rng, y, x, (16, 16), 3, 0.6, pixel)
    rgb = mix(dark, light, np.clip(F32(0.2) + F32(0.6) * tone[cell] + F32(0.2) * surface, F32(0), F32(1)))
    rgb = rgb * (F32(0.55) + F32(0.45) * dome)[..., None]
    rgb = mix(grout * (F32(0.9) + F32(0.2) * surface)[..., None], rgb, stone)
    rgb = _relief(rgb, dome * F32(0.15 / n), pixel, 1.0)
    return _weathered(rng, rgb, y, x, pixel)


def woven(rng, y, x, pixel, member):
    """Threads over and under each other: plain-woven cloth, twill straw, basket weave of thread pairs."""
    material, repeat, pairs = (("fabric", 2, 1), ("straw", 4, 1), ("fabric", 2, 2))[member]
    n = repeat * pairs * int(rng.integers(max(2, 8 // (repeat * pairs)), 24 // (repeat * pairs)))
    warp = hsv(*_colour(rng, material))
    weft = hsv(*_colour(rng, material)) if material == "fabric" else warp * F32(uniform(rng, 0.6, 0.85))
    gy, gx = y * F32(n), x * F32(n)
    row, col = np.floor(gy), np.floor(gx)
    fy, fx = gy - row, gx - col
    block = (np.floor(col / F32(pairs)) + np.floor(row / F32(pairs))).astype(np.intp)
    over = (block % repeat) < max(1, repeat // 2)  # the warp (vertical) thread on top
    thick = uniform(rng, 0.7, 0.92)
    across_warp, across_weft = F32(2) * fx - F32(1), F32(2) * fy - F32(1)
    warp_round = np.sqrt(np.clip(F32(1) - across_warp * across_warp / F32(thick * thick), F32(0), F32(1)))
    weft_round = np.sqrt(np.clip(F32(1) - across_weft * across_weft / F32(thick * thick), F32(0), F32(1)))
    warp_lit = warp_round * (F32(0.55) + F32(0.45) * np.sqrt(F32(1) - across_weft * across_weft))
    weft_lit = weft_round * (F32(0.55) + F32(0.45) * np.sqrt(F32(1) - across_warp * across_warp))
    soft = F32(max(1.0, pixel * n * 8))
    warp_cover = np.clip(warp_round * F32(4) / soft, F32(0), F32(1))
    weft_cover = np.clip(weft_round * F32(4) / soft, F32(0), F32(1))
    fibres_v = _fbm(rng, y, x, (4, 8 * n), 2, 0.5, pixel)
    fibres_h = _fbm(rng, y, x, (8 * n, 4), 2, 0.5, pixel)
    gap = (warp * F32(0.3))[None, None]
    top_warp = np.where(over, warp_cover, warp_cover * (F32(1) - weft_cover))
    top_weft = np.where(over, weft_cover * (F32(1) - warp_cover), weft_cover)
    warp_rgb = warp * (warp_lit * (F32(1) + F32(0.15) * fibres_v))[..., None]
    weft_rgb = weft * (weft_lit * (F32(1) + F32(0.15) * fibres_h))[..., None]
    rgb = gap + (warp_rgb - gap) * top_warp[..., None]
    rgb = rgb + (weft_rgb - rgb) * top_weft[..., None]
    flat = (warp + weft) * F32(0.3)  # about the weave's mean colour, as threads narrow from three pixels to one and a half
    rgb = mix(rgb, flat, np.clip(F32(pixel * n * 3 - 1), F32(0), F32(1)))
    return _weathered(rng, rgb * F32(1.3), y, x, pixel, 0.12)


def marble(rng, y, x, pixel, member):
    """Clouded stone with turbulent veins: dark veins in white marble, light veins in dark or coloured stone."""
    kind = ("marble", _pick(rng, ("slate", "moss")), "brick")[member]
    dark, light = _palette(rng, kind, (0.3, 0.55))
    if member > 0:
        light, dark = dark * F32(1.2), hsv(*_colour(rng, "marble"))  # light veins in dark stone
    a, b = _pick(rng, DIRECTIONS[:4])
    clouds = _fbm(rng, y, x, (3, 3), 5, 0.55, pixel)
    turbulence = _fbm(rng, y, x, (2, 2), 5, 0.5, pixel)
    phase = F32(int(rng.integers(1, 3))) * (F32(a) * y + F32(b) * x) + F32(uniform(rng, 0.4, 0.8)) * turbulence
    core = F32(1) - np.abs(wave(phase).astype(F32))
    halo = core * core * core  # a soft band around each vein ...
    core = halo * halo
    for _ in range(int(rng.integers(0, 3))):  # ... and its core, core ** 6 .. 24: narrower veins
        core = core * core
    fine_phase = F32(2) * (F32(b) * y - F32(a) * x) + F32(1.5) * _fbm(rng, y, x, (3, 3), 5, 0.55, pixel)
    fine = F32(1) - np.abs(wave(fine_phase).astype(F32))
    for _ in range(4):
        fine = fine * fine
    base = mix(light, light * F32(0.75) + dark * F32(0.25), F32(0.5) + F32(0.5) * clouds)
    rgb = mix(base, dark, np.clip(halo * F32(0.3) + core * F32(0.7) + fine * F32(0.2), F32(0), F32(1)))
    return _weathered(rng, rgb, y, x, pixel, 0.05)


def wood(rng, y, x, pixel, member):
    """Boards with growth lines along them, each its own tone and grain, with seams: warm, weathered
    grey or dark."""
    hue, saturation, value = _colour(rng, "wood")
    saturation, value = ((saturation, value), (saturation * 0.25, value * 1.05), (saturation, value * 0.7))[member]
    light = hsv(hue, saturation, min(value, 1.0))
    dark = hsv(hue + uniform(rng, -0.02, 0.0), min(1.0, saturation * 1.2), value * uniform(rng, 0.4, 0.6))
    boards = int(rng.integers(2, 7))
    lines = int(rng.integers(5, 14))
    offset = rng.random(boards, dtype=F32) * F32(lines)
    ends = rng.random(boards, dtype=F32)
    tone = F32(0.75) + F32(0.4) * rng.random(boards, dtype=F32)
    gy = y * F32(boards)
    board = np.floor(gy).astype(np.intp) % boards
    across = gy - np.floor(gy)
    bend = _fbm(rng, y, x, (6, 2), 4, 0.5, pixel)
    knots = _fbm(rng, y, x, (8, 3), 3, 0.5, pixel)
    phase = F32(lines) * across + offset[board] + F32(1.2) * bend + F32(0.6) * knots * knots
    ring = _frac(phase)
    late = np.clip((ring - F32(0.55)) * F32(3), F32(0), F32(1)) * np.clip((F32(1) - ring) * F32(8), F32(0), F32(1))
    fibres = _fbm(rng, y, x, (96, 6), 2, 0.5, pixel)
    rgb = mix(light, dark, np.clip(late * F32(0.85) + F32(0.15) * fibres + F32(0.1), F32(0), F32(1)))
    rgb = rgb * tone[board][..., None]
    seam_width = F32(pixel * boards * 1.5 + 0.004 * boards)
    seam = F32(1) - _edge(np.minimum(across, F32(1) - across) - seam_width, pixel * boards)
    butt = _frac(x + ends[board])
    seam = np.maximum(seam, F32(1) - _edge(np.minimum(butt, F32(1) - butt) - F32(pixel * 1.2 + 0.002), pixel))
    return _weathered(rng, rgb * (F32(1) - F32(0.65) * seam)[..., None], y, x, pixel, 0.08)


def dots(rng, y, x, pixel, member):
    """Dots or studs on a grid: flat polka dots, domed studs of the ground's colour, staggered spots."""
    staggered, domed = ((False, False), (False, True), (True, False))[member]
    n = 2 * int(rng.integers(2, 7))
    ground_dark, ground = _palette(rng, _pick(rng, ("fabric", "slate", "stone", "moss") if member != 1 else ("slate", "brick", "moss")))
    dot = ground * F32(1.1) if domed else hsv(*_colour(rng, _pick(rng, ("fabric", "marble", "brick", "straw"))))
    radius = uniform(rng, 0.16, 0.36)
    gy = y * F32(n)
    row = np.floor(gy)
    gx = x * F32(n) + (row % F32(2)) * F32(0.5 if staggered else 0.0)
    fy, fx = gy - row - F32(0.5), _frac(gx) - F32(0.5)
    d = np.sqrt(fy * fy + fx * fx)
    cover = _edge(F32(radius) - d, pixel * n)
    cloth = _fbm(rng, y, x, (32, 32), 3, 0.6, pixel)
    rgb = mix(ground_dark, ground, F32(0.75) + F32(0.2) * cloth)
    if domed:
        z = np.sqrt(np.clip(F32(1) - d * d / F32(radius * radius), F32(0), F32(1)))
        lit = F32(0.45) + F32(0.55) * np.clip((-fx - fy) / F32(radius) * F32(0.6) + z * F32(0.7), F32(0), F32(1))
        sy, sx = fy - F32(0.06), fx - F32(0.06)
        shadow = F32(1) - F32(0.35) * _edge(F32(radius * 1.25) - np.sqrt(sy * sy + sx * sx), pixel * n * 4)
        rgb = rgb * shadow[..., None]
        top = dot * lit[..., None]
    else:
        top = dot * (F32(0.9) + F32(0.1) * cloth)[..., None]
    return _weathered(rng, mix(rgb, top, cover), y, x, pixel)


def bricks(rng, y, x, pixel, member):
    """Bricks in a running bond, chequered square tiles, or long stone blocks, each its own tone, in mortar."""
    tiles = member == 1
    if tiles:
        rows = per_row = int(rng.integers(3, 9))
        material = _pick(rng, ("slate", "brick", "fabric", "moss"))
    else:
        rows = 2 * int(rng.integers(2, 6)) if member == 0 else 2 * int(rng.integers(2, 4))
        per_row = max(1, rows // 2 + int(rng.integers(-1, 2))) if member == 0 else max(1, rows // 3)
        material = "brick" if member == 0 else _pick(rng, ("stone", "sand", "slate"))
    dark, light = _palette(rng, material, (0.5, 0.75))
    second = hsv(*_colour(rng, _pick(rng, ("marble", "slate")))) if tiles else None
    mortar = hsv(*_colour(rng, _pick(rng, ("stone", "sand", "marble")))) * F32(uniform(rng, 0.5, 1.0))
    tone = rng.random((rows, per_row), dtype=F32)
    gap = F32(uniform(rng, 0.006, 0.02))
    gy = y * F32(rows)
    row = np.floor(gy)
    gx = x * F32(per_row) + (F32(0) if tiles else (row % F32(2)) * F32(0.5))
    col = np.floor(gx)
    fy, fx = gy - row, gx - col
    d = np.minimum(np.minimum(fy, F32(1) - fy) / F32(rows), np.minimum(fx, F32(1) - fx) / F32(per_row))
    solid = _edge(d - gap, pixel)
    r, c = row.astype(np.intp) % rows, col.astype(np.intp) % per_row
    rough = _fbm(rng, y, x, (12, 12), 4, 0.6, pixel)
    rgb = mix(dark, light, np.clip(F32(0.25) + F32(0.55) * tone[r, c] + F32(0.2) * rough, F32(0), F32(1)))
    if second is not None:
        rgb = np.where(((r + c) % 2 == 1)[..., None], second * (F32(0.9) + F32(0.1) * rough)[..., None], rgb)
    sand = _fbm(rng, y, x, (40, 40), 2, 0.5, pixel)
    rgb = mix(mortar * (F32(0.85) + F32(0.2) * sand)[..., None], rgb, solid)
    bevel = np.clip((d - gap) * F32(1 / 0.012), F32(0), F32(1))
    return _weathered(rng, _relief(rgb, bevel * F32(0.008), pixel, 1.0), y, x, pixel)


def cracked(rng, y, x, pixel, member):
    """Plates split by thin dark cracks: dried mud, crazed white glaze, cracked dry clay."""
    material, cells, width = (("mud", (4, 8), (0.002, 0.005)), ("marble", (6, 11), (0.0012, 0.0025)),
                              ("sand", (3, 6), (0.003, 0.007)))[member]
    dark, light = _palette(rng, material, (0.45, 0.7))
    n = int(rng.integers(*cells))
    points = rng.random((n, n, 2), dtype=F32)
    tone = rng.random(n * n, dtype=F32)
    warp = F32(0.35 / n)
    wy = y + warp * _fbm(rng, y, x, (8, 8), 4, 0.55, pixel)
    wx = x + warp * _fbm(rng, y, x, (8, 8), 4, 0.55, pixel)
    near, second, cell = _cells(points, wy, wx, uniform(rng, 0.6, 1.4))
    border = (second - near) * F32(0.5 / n)  # texture units to the crack
    crack = F32(1) - _edge(border - F32(uniform(rng, *width)), pixel)
    curl = np.clip(border * F32(n * 4), F32(0), F32(1))  # plates darker towards their edges
    surface = _fbm(rng, y, x, (10, 10), 4, 0.6, pixel)
    rgb = mix(dark, light, np.clip(F32(0.35) + F32(0.35) * tone[cell] + F32(0.25) * surface, F32(0), F32(1)))
    rgb = rgb * (F32(0.85) + F32(0.15) * curl)[..., None]
    return _weathered(rng, rgb * (F32(1) - F32(0.8) * crack)[..., None], y, x, pixel)


def blotchy(rng, y, x, pixel, member):
    """Patches over a ground: lichen on stone, camouflage of two colours, stains on a pale ground."""
    grounds, blots, count, soft = ((("stone", "slate"), ("moss", "straw"), 1, (0.02, 0.06)),
                                   (("moss", "mud"), ("moss", "mud", "straw", "slate"), 2, (0.01, 0.04)),
                                   (("sand", "marble"), ("mud", "brick", "slate"), 2, (0.08, 0.2)))[member]
    dark, light = _palette(rng, _pick(rng, grounds), (0.55, 0.8))
    patches = [hsv(*_colour(rng, _pick(rng, blots))) for _ in range(count)]
    rgb = mix(dark, light, F32(0.5) + F32(0.5) * _fbm(rng, y, x, (6, 6), 4, 0.6, pixel))
    for patch in patches:
        field = _fbm(rng, y, x, (3, 3), 6, 0.55, pixel)
        cover = np.clip((field - F32(uniform(rng, 0.0, 0.35))) / F32(uniform(rng, *soft)) + F32(0.5), F32(0), F32(1))
        rgb = mix(rgb, patch * (F32(0.85) + F32(0.3) * _fbm(rng, y, x, (20, 20), 2, 0.5, pixel))[..., None], cover)
    return _weathered(rng, rgb, y, x, pixel)


_MAKERS = {
    "grain": grain, "stripes": stripes, "stones": stones, "woven": woven, "marble": marble,
    "wood": wood, "dots": dots, "bricks": bricks, "cracked": cracked, "blotchy": blotchy,
}


def standin(split: str, index: int, size: int) -> np.ndarray:
    """Stand-in texture ``index`` of ``split`` as uint8 RGB [size, size, 3], drawn at that size.

    Args:
        split (str): ``"train"`` or ``"val"``.
        index (int): 0 .. 19 for ``"train"``, 0 .. 4 for ``"val"`` (see :data:`STANDINS`).
        size (int): the side in pixels.

    Examples:
        >>> standin("train", 0, 32).shape
        (32, 32, 3)
    """
    rng = np.random.default_rng(texture_seed(split, index))
    centres = (np.arange(size, dtype=F32) + F32(0.5)) / F32(size)
    y, x = np.meshgrid(centres, centres, indexing="ij")
    member = index // len(FAMILIES) if split == "train" else 2
    rgb = _MAKERS[family_of(split, index)](rng, y, x, 1.0 / size, member)
    return np.floor(np.clip(rgb, F32(0), F32(1)) * F32(255) + F32(0.5)).astype(np.uint8)
