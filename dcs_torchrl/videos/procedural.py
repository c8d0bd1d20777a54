"""Building blocks of the embedded clips: noise, smooth paths, colours, shaded sprites.

Everything is arithmetic on numpy arrays (no ``sin``/``exp``: only ``+ - * /``, ``sqrt``
and ``floor``, which IEEE 754 makes bit-identical on every machine) driven by a
``np.random.Generator``, so a clip is the same bits everywhere for a given numpy version.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

F32 = np.float32


def uniform(rng: np.random.Generator, low: float, high: float) -> float:
    """One float in [low, high)."""
    return low + (high - low) * float(rng.random())


def smoothstep(t):
    """3t² - 2t³ of ``t`` clipped to [0, 1]."""
    t = np.clip(t, 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def wave(phase):
    """A sine-like periodic function of ``phase`` (in cycles), in [-1, 1], made of polynomials."""
    p = np.asarray(phase, dtype=np.float64)
    tri = 4.0 * np.abs(p - np.floor(p) - 0.5) - 1.0  # triangle wave, 1 at integer phases
    return tri * (1.5 - 0.5 * tri * tri)


def bezier(points, t):
    """A cubic Bézier curve through 4 control values (or vectors) at times ``t`` in [0, 1]."""
    p0, p1, p2, p3 = (np.asarray(p, dtype=np.float64) for p in points)
    t = np.asarray(t, dtype=np.float64)[..., None] if p0.ndim else np.asarray(t, dtype=np.float64)
    s = 1.0 - t
    return s * s * s * p0 + 3.0 * s * s * t * p1 + 3.0 * s * t * t * p2 + t * t * t * p3


def _axis(n_px: int, n_cells: int):
    position = (np.arange(n_px, dtype=np.float64) + 0.5) * (n_cells / n_px)
    index = np.minimum(np.floor(position).astype(np.intp), n_cells - 1)
    return index, smoothstep(position - index).astype(F32)


def value_noise(grid: np.ndarray, height: int, width: int) -> np.ndarray:
    """Smoothly interpolates a (gh + 1, gw + 1) grid of random values to [height, width]."""
    iy, fy = _axis(height, grid.shape[0] - 1)
    ix, fx = _axis(width, grid.shape[1] - 1)
    fy = fy[:, None]
    rows = grid[iy] * (1 - fy) + grid[iy + 1] * fy
    return rows[:, ix] * (1 - fx) + rows[:, ix + 1] * fx


def fbm(
    rng, height: int, width: int, cells: tuple[int, int], octaves: int = 5, gain: float = 0.5, periodic: bool = False
) -> np.ndarray:
    """Fractal value noise [height, width] in about [-1, 1], ``cells`` = (rows, cols) of the coarsest grid.

    The random grids do not depend on the pixel size, so a clip looks the same at every
    resolution; octaves finer than 2 pixels are skipped. ``periodic`` noise tiles.
    """
    total = np.zeros((height, width), F32)
    amplitude, norm = 1.0, 0.0
    for k in range(octaves):
        gy, gx = cells[0] << k, cells[1] << k
        grid = rng.random((gy + 1, gx + 1), dtype=F32) * F32(2) - F32(1)
        if periodic:
            grid[-1], grid[:, -1] = grid[0], grid[:, 0]
        if height >= 2 * gy and width >= 2 * gx:
            total += F32(amplitude) * value_noise(grid, height, width)
        norm += amplitude
        amplitude *= gain
    return total * F32(1.6 / norm)


def fbm1d(rng, length: int, cells: int, octaves: int = 5, gain: float = 0.5) -> np.ndarray:
    """Fractal value noise along one axis, [length] in about [-1, 1]."""
    total = np.zeros(length, F32)
    amplitude, norm = 1.0, 0.0
    for k in range(octaves):
        grid = rng.random((2, (cells << k) + 1), dtype=F32) * F32(2) - F32(1)
        if length >= 2 * (cells << k):
            total += F32(amplitude) * value_noise(grid, 1, length)[0]
        norm += amplitude
        amplitude *= gain
    return total * F32(1.6 / norm)


def sample_wrapped(texture: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Bilinear lookup of a tiling [h, w] texture at float pixel coordinates (rows ``v``, columns ``u``)."""
    h, w = texture.shape
    v, u = v - F32(0.5), u - F32(0.5)
    v0, u0 = np.floor(v), np.floor(u)
    fv, fu = v - v0, u - u0
    v0, u0 = v0.astype(np.intp) % h, u0.astype(np.intp) % w
    v1, u1 = (v0 + 1) % h, (u0 + 1) % w
    top = texture[v0, u0] * (1 - fu) + texture[v0, u1] * fu
    bottom = texture[v1, u0] * (1 - fu) + texture[v1, u1] * fu
    return top * (1 - fv) + bottom * fv


def hsv(h: float, s: float, v: float) -> np.ndarray:
    """An RGB colour in [0, 1] (float32 [3]) from hue in turns, saturation and value."""
    h = (h % 1.0) * 6.0
    i = int(h)
    f = h - i
    p, q, t = v * (1 - s), v * (1 - s * f), v * (1 - s * (1 - f))
    return np.array([(v, t, p), (q, v, p), (p, v, t), (p, q, v), (t, p, v), (v, p, q)][i % 6], F32)


def mix(a, b, t):
    """Linear interpolation a + (b - a) t, broadcasting t over colour channels if needed."""
    t = np.asarray(t, F32)
    if t.ndim == 2:
        t = t[..., None]
    out = np.subtract(b, a, dtype=F32) * t
    out += a  # in place: these are whole images
    return out


@dataclass
class Part:
    """An ellipse (or rounded box) of a sprite, in sprite units (the object is ~1 tall).

    ``cos``/``sin`` rotate it; ``shade`` in [0, 1] is how much light direction darkens it.
    ``pattern`` paints ``pattern_color`` over it in the part's own coordinates (so the
    pattern moves and turns with the part): ``STRIPES`` across its width, ``BANDS``
    along its length, ``SPOTS`` or ``CHECKS``, ``freq`` of them across the part. Every
    part gets a dark rim about a pixel wide (a contour, as objects in footage have).
    """

    x: float
    y: float
    rx: float
    ry: float
    color: np.ndarray
    cos: float = 1.0
    sin: float = 0.0
    shade: float = 0.7
    alpha: float = 1.0
    box: bool = False
    pattern: int = 0
    pattern_color: np.ndarray | None = None
    freq: float = 3.0


PLAIN, STRIPES, BANDS, SPOTS, CHECKS = range(5)


def pattern_mask(kind: int, u, v, freq: float, pixels: float):
    """Coverage in [0, 1] of a part's pattern at part coordinates (u, v) in [-1, 1].

    ``pixels`` is the part's half size in pixels: pattern edges are about a pixel soft.
    """
    sharp = F32(max(pixels / (2.0 * freq), 1.0))  # pixels per half period: antialiasing
    if kind == STRIPES or kind == BANDS:
        x = (u if kind == STRIPES else v) * F32(freq / 2)
        tri = np.abs(x - np.floor(x) - F32(0.5)) * F32(4) - F32(1)  # [-1, 1], period 1
        return np.clip(tri * sharp + F32(0.5), 0, 1)
    if kind == SPOTS:
        x, y = (u + F32(1)) * F32(freq / 2), (v + F32(1)) * F32(freq / 2)
        fx, fy = x - np.floor(x) - F32(0.5), y - np.floor(y) - F32(0.5)
        return np.clip((F32(0.3) - np.sqrt(fx * fx + fy * fy)) * sharp * F32(4) + F32(0.5), 0, 1)
    if kind == CHECKS:
        a = pattern_mask(STRIPES, u, v, freq, pixels) * F32(2) - F32(1)
        b = pattern_mask(BANDS, u, v, freq, pixels) * F32(2) - F32(1)
        return a * b * F32(0.5) + F32(0.5)
    return None


def rotation(t: float) -> tuple[float, float]:
    """(cos, sin) of the angle 2·atan(t), exactly rational: a rotation without trigonometry."""
    return (1 - t * t) / (1 + t * t), 2 * t / (1 + t * t)


LIGHT = np.array([-0.45, -0.6, 0.66])  # from the upper left, towards the viewer


@dataclass
class Sprite:
    """A rendered object: coverage in 0..256, colour (0..255) times coverage, and its anchor pixel."""

    color: np.ndarray  # uint16 [h, w, 3], colour * cover
    cover: np.ndarray  # uint16 [h, w, 1], 0..256
    anchor: tuple[int, int]  # (x, y) of the object's origin inside the sprite


def extent(p: Part) -> tuple[float, float]:
    """Half width and half height of the box around a (turned) part."""
    return abs(p.cos) * p.rx + abs(p.sin) * p.ry, abs(p.sin) * p.rx + abs(p.cos) * p.ry


def render(parts: list[Part], scale: float) -> Sprite:
    """Rasterises parts (painter's order) at ``scale`` pixels per unit, antialiased and shaded."""
    margin = 2
    reach = [extent(p) for p in parts]
    x0 = min(p.x - r[0] for p, r in zip(parts, reach)) * scale - margin
    y0 = min(p.y - r[1] for p, r in zip(parts, reach)) * scale - margin
    x1 = max(p.x + r[0] for p, r in zip(parts, reach)) * scale + margin
    y1 = max(p.y + r[1] for p, r in zip(parts, reach)) * scale + margin
    ox, oy = int(np.floor(x0)), int(np.floor(y0))
    w, h = int(np.ceil(x1)) - ox, int(np.ceil(y1)) - oy
    color = np.zeros((h, w, 3), F32)
    cover = np.zeros((h, w), F32)
    for p in parts:
        rx, ry = max(p.rx * scale, 0.5), max(p.ry * scale, 0.5)
        px, py = p.x * scale - ox, p.y * scale - oy
        reach_x, reach_y = (r * scale + 1 for r in extent(p))
        r0, r1 = max(int(py - reach_y), 0), min(int(py + reach_y) + 2, h)
        c0, c1 = max(int(px - reach_x), 0), min(int(px + reach_x) + 2, w)
        dy = (np.arange(r0, r1, dtype=F32) + F32(0.5) - F32(py))[:, None]
        dx = (np.arange(c0, c1, dtype=F32) + F32(0.5) - F32(px))[None, :]
        u = (F32(p.cos) * dx + F32(p.sin) * dy) / F32(rx)
        v = (F32(p.cos) * dy - F32(p.sin) * dx) / F32(ry)
        if p.box:
            d = np.maximum(np.abs(u), np.abs(v))
            light = F32(0.75) - F32(0.35) * v + F32(0.1) * u * F32(LIGHT[0])
        else:
            d2 = u * u + v * v
            d = np.sqrt(d2)
            nz = np.sqrt(np.maximum(F32(1) - d2, F32(0)))
            nx, ny = F32(p.cos) * u - F32(p.sin) * v, F32(p.sin) * u + F32(p.cos) * v
            light = np.maximum(nx * F32(LIGHT[0]) + ny * F32(LIGHT[1]) + nz * F32(LIGHT[2]), F32(0))
        inside = (F32(1) - d) * F32(min(rx, ry))  # ~pixels from the outline
        a = np.clip(inside + F32(0.5), F32(0), F32(1)) * F32(p.alpha)
        lum = F32(1 - p.shade) + F32(p.shade) * (F32(0.25) + F32(0.95) * light)
        if p.shade > 0:
            lum = lum * (F32(0.45) + F32(0.55) * np.clip(inside * F32(0.7), F32(0), F32(1)))  # the rim
        base = np.asarray(p.color, F32)
        if p.pattern:
            m = pattern_mask(p.pattern, u, v, p.freq, min(rx, ry))
            base = base + (np.asarray(p.pattern_color, F32) - base) * m[..., None]
        shaded = base * lum[..., None]
        region, covered = color[r0:r1, c0:c1], cover[r0:r1, c0:c1]
        region += (shaded - region) * a[..., None]
        covered += (F32(1) - covered) * a
    cover256 = np.floor(cover * F32(256) + F32(0.5))[..., None]  # `color` is already premultiplied by cover
    color = np.minimum(np.floor(color * F32(255 * 256) + F32(0.5)), cover256 * F32(255))
    return Sprite(color=color.astype(np.uint16), cover=cover256.astype(np.uint16), anchor=(-ox, -oy))


def paste(canvas: np.ndarray, sprite: Sprite, x: float, y: float) -> None:
    """Composites ``sprite`` over the uint8 ``canvas`` with its anchor at pixel (x, y); clips at edges."""
    h, w = sprite.cover.shape[:2]
    left, top = int(np.floor(x + 0.5)) - sprite.anchor[0], int(np.floor(y + 0.5)) - sprite.anchor[1]
    a0, b0 = max(0, -top), max(0, -left)
    a1, b1 = min(h, canvas.shape[0] - top), min(w, canvas.shape[1] - left)
    if a1 <= a0 or b1 <= b0:
        return
    region = canvas[top + a0 : top + a1, left + b0 : left + b1]
    cover = sprite.cover[a0:a1, b0:b1]
    region[...] = (region * (256 - cover) + sprite.color[a0:a1, b0:b1] + 128) >> 8
