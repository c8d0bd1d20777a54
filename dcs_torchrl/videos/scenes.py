"""Backgrounds of the embedded clips: sky, hills, ground, water, forest, city, arena.

A painter takes ``(rng, height, width, horizon)`` (pixels; the horizon may lie above the
image) and returns a float32 RGB image in [0, 1]. Sizes are relative to the height, so
a scene looks the same at every resolution.
"""
from __future__ import annotations

import numpy as np

from dcs_torchrl.videos.procedural import F32, fbm, fbm1d, hsv, mix, sample_wrapped, smoothstep, uniform


def rows(height: int) -> np.ndarray:
    return np.arange(height, dtype=F32)[:, None] + F32(0.5)


def sky(rng, height: int, width: int, horizon: float) -> tuple[np.ndarray, np.ndarray]:
    """A sky gradient with clouds; returns (image, the colour at the horizon, used as haze)."""
    mood = int(rng.integers(4))
    if mood == 0:  # clear day
        top, low = hsv(uniform(rng, 0.56, 0.62), uniform(rng, 0.5, 0.75), uniform(rng, 0.6, 0.85)), hsv(
            uniform(rng, 0.54, 0.6), uniform(rng, 0.12, 0.3), uniform(rng, 0.85, 0.97))
        cloud, cover = hsv(0.6, 0.03, 0.98), uniform(rng, 0.0, 0.45)
    elif mood == 1:  # overcast
        grey = uniform(rng, 0.55, 0.8)
        top, low = hsv(0.6, 0.2, grey - 0.1), hsv(0.6, 0.1, grey + 0.1)
        cloud, cover = hsv(0.6, 0.04, grey + 0.12), uniform(rng, 0.4, 0.8)
    elif mood == 2:  # sunset
        top, low = hsv(uniform(rng, 0.62, 0.75), uniform(rng, 0.35, 0.55), uniform(rng, 0.35, 0.55)), hsv(
            uniform(rng, 0.02, 0.11), uniform(rng, 0.45, 0.7), uniform(rng, 0.9, 1.0))
        cloud, cover = hsv(uniform(rng, 0.95, 1.05), 0.35, 0.85), uniform(rng, 0.1, 0.5)
    else:  # hazy
        top, low = hsv(uniform(rng, 0.5, 0.6), uniform(rng, 0.2, 0.35), uniform(rng, 0.7, 0.85)), hsv(
            uniform(rng, 0.1, 0.15), uniform(rng, 0.05, 0.15), uniform(rng, 0.88, 0.97))
        cloud, cover = hsv(0.1, 0.05, 0.95), uniform(rng, 0.0, 0.3)
    t = smoothstep(rows(height) / F32(max(horizon, 1.0)))
    image = mix(top, low, np.broadcast_to(t, (height, width)))
    n = fbm(rng, height, width, (3, 4), octaves=6)
    shade = fbm(rng, height, width, (4, 6), octaves=4)
    amount = smoothstep((n - F32(0.55 - cover)) / F32(0.5)) * (F32(1) - t * F32(0.6))
    cloud_color = mix(cloud * F32(0.72), cloud, smoothstep(shade * F32(0.8) + F32(0.6)))
    return mix(image, cloud_color, amount), low


def ridge(image, rng, horizon: float, rise: float, bumps: int, color, haze, haze_amount, jag: float = 0.5):
    """Paints a hill/mountain/treeline silhouette whose foot is at the horizon."""
    height, width = image.shape[:2]
    profile = fbm1d(rng, width, bumps, octaves=6, gain=jag) * F32(0.5) + F32(0.5)
    top = F32(horizon) - F32(rise) * (F32(0.35) + F32(0.65) * profile)
    alpha = np.clip(rows(height) - top[None, :], 0, 1)
    texture = fbm(rng, height, width, (6, 10), octaves=5)
    depth = smoothstep((rows(height) - top[None, :]) / F32(max(rise, 1.0)))
    shaded = color * (F32(0.85) + F32(0.3) * texture[..., None] - F32(0.15) * depth[..., None])
    return mix(image, mix(shaded, haze, F32(haze_amount)), alpha)


def perspective(rng, height: int, width: int, horizon: float, scale: tuple[float, float], cells=(4, 4), octaves=6):
    """Tiling fractal noise laid on a ground plane below ``horizon``: big near, small far."""
    texture = fbm(rng, 128, 128, cells, octaves=octaves, periodic=True)
    below = np.maximum(rows(height) - F32(horizon), F32(0)) / F32(height) + F32(0.02)
    depth = F32(1) / below  # ~1 at the bottom of the image, large at the horizon
    x = (np.arange(width, dtype=F32)[None, :] - F32(width / 2)) / F32(height)
    offset = F32(uniform(rng, 0, 128))
    u = x * depth * F32(scale[0] * 128) + offset
    v = np.broadcast_to(depth * F32(scale[1] * 128), u.shape)
    return sample_wrapped(texture, v, u), depth


GROUNDS = {
    "grass": ((0.2, 0.3), (0.4, 0.7), (0.3, 0.55), (0.1, 0.16), (0.35, 0.55), (0.45, 0.65)),
    "savanna": ((0.1, 0.15), (0.35, 0.6), (0.55, 0.75), (0.2, 0.27), (0.3, 0.5), (0.35, 0.5)),
    "sand": ((0.08, 0.12), (0.25, 0.45), (0.7, 0.88), (0.06, 0.1), (0.3, 0.5), (0.55, 0.7)),
    "snow": ((0.55, 0.62), (0.08, 0.15), (0.85, 0.95), (0.58, 0.64), (0.2, 0.35), (0.65, 0.8)),
    "dirt": ((0.05, 0.09), (0.3, 0.55), (0.35, 0.55), (0.08, 0.12), (0.2, 0.4), (0.55, 0.7)),
    "rock": ((0.05, 0.12), (0.2, 0.4), (0.35, 0.6), (0.55, 0.62), (0.15, 0.3), (0.5, 0.7)),
}


GROUND_MIX = ("grass", "grass", "grass", "grass", "savanna", "savanna", "sand", "snow", "dirt", "rock")


def ground_colors(rng, kind: str):
    h1, s1, v1, h2, s2, v2 = GROUNDS[kind]
    first = hsv(uniform(rng, *h1), uniform(rng, *s1), uniform(rng, *v1))
    second = hsv(uniform(rng, *h2), uniform(rng, *s2), uniform(rng, *v2))
    return first, second


def land(image, rng, horizon: float, kind: str, haze) -> np.ndarray:
    """A textured ground plane (grass, sand, snow, ...) with patches, fading into haze far away."""
    height, width = image.shape[:2]
    first, second = ground_colors(rng, kind)
    patches = fbm(rng, height, width, (2, 3), octaves=5)
    detail, depth = perspective(rng, height, width, horizon, (uniform(rng, 0.3, 0.8), uniform(rng, 0.3, 0.8)))
    fine, _ = perspective(rng, height, width, horizon, (3.0, 3.0), cells=(8, 8), octaves=4)
    base = mix(first, second, smoothstep(patches * F32(1.5) + F32(0.5)))
    contrast = F32(0.15 if kind == "snow" else 0.45)
    ground = base * (F32(0.8) + contrast * detail[..., None] + contrast * F32(0.4) * fine[..., None])
    ground = mix(ground, haze, smoothstep((depth - F32(6)) / F32(30)) * F32(0.7))
    return mix(image, ground, np.clip(rows(height) - F32(horizon), 0, 1))


def water(image, rng, horizon: float, haze) -> np.ndarray:
    """A lake or sea: stretched ripples, the sky's colour far away, glints."""
    height, width = image.shape[:2]
    deep = hsv(uniform(rng, 0.45, 0.62), uniform(rng, 0.4, 0.8), uniform(rng, 0.25, 0.5))
    ripples, depth = perspective(rng, height, width, horizon, (0.5, 0.9), cells=(8, 4), octaves=5)
    chop, _ = perspective(rng, height, width, horizon, (1.7, 3.1), cells=(8, 4), octaves=3)
    ripples = ripples * F32(0.7) + chop * F32(0.4)
    swell = fbm(rng, height, width, (2, 3), octaves=4)
    color = deep * (F32(0.85) + F32(0.3) * ripples[..., None] + F32(0.2) * swell[..., None])
    color = mix(color, haze, smoothstep((depth - F32(1.5)) / F32(20)) * F32(0.85))
    glint = smoothstep((ripples - F32(0.45)) / F32(0.3)) * F32(uniform(rng, 0.1, 0.5))
    color = mix(color, np.ones(3, F32), glint)
    return mix(image, color, np.clip(rows(height) - F32(horizon), 0, 1))


def trees(image, rng, horizon: float, count: int) -> np.ndarray:
    """Trunks standing on the ground, thicker when nearer, in front of a canopy."""
    height, width = image.shape[:2]
    bark = hsv(uniform(rng, 0.05, 0.1), uniform(rng, 0.3, 0.5), uniform(rng, 0.18, 0.35))
    grain = fbm(rng, height, width, (4, 24), octaves=3)
    for _ in range(count):
        near = uniform(rng, 0.0, 1.0)
        foot = horizon + (height - horizon) * (0.05 + 0.4 * near)
        half = height * (0.012 + 0.03 * near)
        centre = uniform(rng, 0, width)
        c0, c1 = max(int(centre - half) - 1, 0), min(int(centre + half) + 2, width)
        r1 = min(max(int(np.ceil(foot)), 0), height)
        if c1 <= c0 or r1 == 0:
            continue
        across = (np.arange(c0, c1, dtype=F32)[None, :] + F32(0.5 - centre)) / F32(half)
        alpha = np.broadcast_to(np.clip((F32(1) - np.abs(across)) * F32(half) + F32(0.5), 0, 1), (r1, c1 - c0))
        light = F32(0.6) + F32(0.4) * np.clip(-across, -1, 1) + F32(0.25) * grain[:r1, c0:c1]
        image[:r1, c0:c1] = mix(image[:r1, c0:c1], bark * light[..., None] * F32(0.6 + 0.4 * near), alpha)
    return image


def buildings(image, rng, horizon: float, haze) -> np.ndarray:
    """A row of buildings with window grids standing on the horizon."""
    height, width = image.shape[:2]
    x = 0.0
    while x < width:
        w = height * uniform(rng, 0.12, 0.4)
        top = horizon - height * uniform(rng, 0.15, 0.7)
        wall = hsv(uniform(rng, 0.0, 0.15) if rng.random() < 0.5 else uniform(rng, 0, 1), uniform(rng, 0.2, 0.75),
                   uniform(rng, 0.35, 0.9))
        glass = hsv(uniform(rng, 0.5, 0.65), uniform(rng, 0.2, 0.6), uniform(rng, 0.1, 0.5))
        lit = hsv(uniform(rng, 0.1, 0.15), uniform(rng, 0.3, 0.7), 0.95)  # lit windows, shop fronts
        awning = hsv(uniform(rng, 0, 1), uniform(rng, 0.6, 1.0), uniform(rng, 0.6, 1.0))
        pitch_x, pitch_y = height * uniform(rng, 0.025, 0.05), height * uniform(rng, 0.035, 0.06)
        c0, c1 = int(np.ceil(x - 0.5)), min(int(np.ceil(x + w - 0.5)), width)
        r0, r1 = max(int(np.ceil(top - 0.5)), 0), min(int(np.ceil(horizon + 0.5)), height)
        if c1 > c0 and r1 > r0:
            xs = (np.arange(c0, c1, dtype=F32)[None, :] + F32(0.5) - F32(x)) / F32(pitch_x)
            ys = (np.arange(r0, r1, dtype=F32)[:, None] + F32(0.5) - F32(top)) / F32(pitch_y)
            windows = (xs - np.floor(xs) > F32(0.35)) & (ys - np.floor(ys) > F32(0.4)) & (ys > F32(0.8))
            side = F32(0.85) + F32(0.15) * xs * F32(pitch_x / w)
            color = np.where(windows[..., None], glass, wall * side[..., None])
            on = rng.random((int(np.ceil((r1 - top) / pitch_y)) + 2, int(np.ceil(w / pitch_x)) + 2)) < 0.3
            on = on[np.floor(ys[:, 0]).astype(np.intp).clip(0)][:, np.floor(xs[0]).astype(np.intp).clip(0)]
            color = np.where((windows & on)[..., None], lit, color)
            shop = np.broadcast_to(ys > F32((horizon - top) / pitch_y - 3.0), windows.shape)  # street level
            stripes = (xs * F32(2) - np.floor(xs * F32(2))) < F32(0.5)
            color = np.where((shop & stripes)[..., None], awning, np.where(shop[..., None], awning * F32(0.3), color))
            image[r0:r1, c0:c1] = mix(color, haze, F32(0.15))
        x += w + height * uniform(rng, 0.0, 0.05)
    return image


def road(image, rng, horizon: float, haze) -> np.ndarray:
    """An asphalt road plane with dashed lane markings."""
    height, width = image.shape[:2]
    tone = uniform(rng, 0.25, 0.45)
    asphalt = hsv(uniform(rng, 0, 1), uniform(rng, 0.05, 0.3), tone)
    grit, depth = perspective(rng, height, width, horizon, (2.0, 2.0), cells=(8, 8), octaves=4)
    color = asphalt * (F32(0.92) + F32(0.14) * grit[..., None])
    x = (np.arange(width, dtype=F32)[None, :] - F32(width * uniform(rng, 0.3, 0.7))) / F32(height)
    lane = np.abs(x * depth) < F32(0.02)
    dashes = (depth * F32(0.6)) - np.floor(depth * F32(0.6)) < F32(0.5)
    color = np.where((lane & dashes)[..., None], hsv(0.15, uniform(rng, 0.0, 0.6), 0.9), color)
    color = mix(color, haze, smoothstep((depth - F32(6)) / F32(30)) * F32(0.6))
    return mix(image, color, np.clip(rows(height) - F32(horizon), 0, 1))


def arena(rng, height: int, width: int, horizon: float) -> np.ndarray:
    """Indoors or a court: a wall with a stripe, and a wooden, painted or tiled floor."""
    wall = hsv(uniform(rng, 0, 1), uniform(rng, 0.3, 0.8), uniform(rng, 0.4, 0.9))
    plaster = fbm(rng, height, width, (3, 4), octaves=6)
    light = F32(0.8) + F32(0.2) * rows(height)[..., None] / F32(height)
    image = wall * (F32(0.9) + F32(0.15) * plaster[..., None]) * light
    # stands of spectators above the wall: a mosaic of clothes colours and faces, row by row
    seat = height * uniform(rng, 0.025, 0.045)
    stand_top, stand_bottom = horizon - height * uniform(rng, 0.35, 0.6), horizon - height * 0.12
    r0, r1 = max(int(stand_top), 0), max(int(stand_bottom), 0)
    if r1 > r0:
        ny, nx = int((r1 - r0) / seat) + 2, int(width / seat) + 2
        crowd = np.stack([hsv(float(h), float(sat), float(v)) for h, sat, v in
                          rng.random((ny * nx, 3)) * np.array([1.0, 0.8, 0.75]) + np.array([0.0, 0.2, 0.2])])
        ys = (np.arange(r0, r1, dtype=F32) + F32(0.5) - F32(r0)) / F32(seat)
        xs = (np.arange(width, dtype=F32) + F32(0.5)) / F32(seat) + (np.floor(ys)[:, None] % 2) * F32(0.5)
        cell = np.floor(ys).astype(np.intp)[:, None] * nx + np.floor(xs).astype(np.intp)
        fy, fx = (ys - np.floor(ys))[:, None], xs - np.floor(xs)
        head = (fx - F32(0.5)) ** 2 + (fy - F32(0.3)) ** 2 < F32(0.04)
        body = (fy > F32(0.5)) & (np.abs(fx - F32(0.5)) < F32(0.4))
        skin = hsv(0.07, 0.45, 0.75)
        people = np.where(head[..., None], skin, np.where(body[..., None], crowd[cell], crowd[cell] * F32(0.25)))
        image[r0:r1] = people
    stripe = (rows(height) > F32(horizon - height * 0.12)) & (rows(height) < F32(horizon - height * 0.08))
    image = np.where(stripe[..., None], hsv(uniform(rng, 0, 1), 0.8, 0.6), image)
    style = int(rng.integers(3))  # wood, painted court, tiles
    floor = [hsv(uniform(rng, 0.05, 0.11), uniform(rng, 0.35, 0.6), uniform(rng, 0.45, 0.75)),
             hsv(uniform(rng, 0, 1), uniform(rng, 0.4, 0.8), uniform(rng, 0.35, 0.7)),
             hsv(uniform(rng, 0, 1), uniform(rng, 0.2, 0.6), uniform(rng, 0.5, 0.9))][style]
    stretch = (0.5, 4.0) if style == 0 else (1.0, 1.0)  # wood grain runs along the planks
    grain, depth = perspective(rng, height, width, horizon, stretch, cells=(12, 2), octaves=4)
    x = (np.arange(width, dtype=F32)[None, :] - F32(width / 2)) / F32(height) * depth * F32(uniform(rng, 3, 9))
    seams = np.abs(x - np.floor(x) - F32(0.5)) > F32(0.47)  # lines running away from the camera
    across = depth * F32(uniform(rng, 1.5, 4))
    if style == 1:  # a few white court lines
        middle = np.abs(x - F32(0.5)) < F32(0.04)
        seams = middle | (np.abs(across - F32(8)) < F32(0.1)) | (np.abs(across - F32(4)) < F32(0.05))
    elif style == 2:
        seams = seams | (np.abs(across - np.floor(across) - F32(0.5)) > F32(0.45))
    color = floor * (F32(0.88) + F32(0.25 if style == 0 else 0.1) * grain[..., None])
    lined = color * F32(0.6) if style != 1 else np.broadcast_to(hsv(0, 0, 0.95), color.shape)
    fade = F32(1) - smoothstep((depth - F32(4)) / F32(12))  # far seams would only alias
    color = mix(color, lined, seams * fade)
    return mix(image, color, np.clip(rows(height) - F32(horizon), 0, 1))


def paint(rng, kind: str, height: int, width: int, horizon: float) -> np.ndarray:
    """The background of one scene ``kind`` as uint8 [height, width, 3]."""
    if kind == "arena":
        image = arena(rng, height, width, horizon)
    else:
        image, haze = sky(rng, height, width, horizon)
        if kind in ("meadow", "coast", "forest"):
            far = hsv(uniform(rng, 0.5, 0.7), uniform(rng, 0.1, 0.35), uniform(rng, 0.45, 0.7))
            image = ridge(image, rng, horizon, height * uniform(rng, 0.05, 0.3), 3, far, haze, 0.45, jag=0.55)
        if kind == "meadow":
            hills = hsv(uniform(rng, 0.15, 0.35), uniform(rng, 0.3, 0.6), uniform(rng, 0.3, 0.55))
            image = ridge(image, rng, horizon, height * uniform(rng, 0.02, 0.1), 2, hills, haze, 0.2, jag=0.4)
            image = land(image, rng, horizon, GROUND_MIX[int(rng.integers(len(GROUND_MIX)))], haze)
        elif kind == "coast":
            image = water(image, rng, horizon, haze)
        elif kind == "forest":
            leaves = hsv(uniform(rng, 0.18, 0.33), uniform(rng, 0.4, 0.7), uniform(rng, 0.2, 0.4))
            image = ridge(image, rng, horizon, height * uniform(rng, 0.3, 0.6), 12, leaves, haze, 0.1, jag=0.65)
            image = land(image, rng, horizon, str(rng.choice(["grass", "dirt", "savanna"])), haze)
            image = trees(image, rng, horizon, int(rng.integers(4, 10)))
        elif kind == "city":
            image = buildings(image, rng, horizon, haze)
            image = road(image, rng, horizon, haze)
    tint = np.array([uniform(rng, 0.92, 1.08) for _ in range(3)], F32)  # a camera's white balance
    contrast = F32(uniform(rng, 0.85, 1.2))
    image = (image * tint - F32(0.5)) * contrast + F32(0.5)
    return np.floor(np.clip(image, 0, 1) * F32(255) + F32(0.5)).astype(np.uint8)


SCENES = ("meadow", "coast", "forest", "city", "arena")
